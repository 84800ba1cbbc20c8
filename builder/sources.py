"""Which C files an FMU is built from: the shared FMI glue of fmu_src/ and one model folder.

A model is a folder (fmu_src/lattice/ by default; fmu_src/projectile/ and fmu_src/hull/ the others) whose C
sources implement the functions the glue calls (fmu_src/common/model_api.h, included by the folder's model.h);
the glue finds model.h through the include path, as the Reference FMUs' CMake passes it.
An FMU carries every file flat in sources/, as the Reference FMUs' do: FMI 2 has no way to name an include
directory, and fmpy compile passes sources/ alone, so the one folder is the include path everywhere.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import fmu_src

FMU_SOURCE_DIR = Path(fmu_src.__file__).resolve().parent  # the glue and the model's C sources: package data
DEFAULT_MODEL_DIR = FMU_SOURCE_DIR / "lattice"
# The glue shared by every model: the instance bookkeeping, then each FMI version's API and its headers.
COMMON_SOURCES = ("common/instance.c",)
COMMON_HEADERS = ("common/instance.h", "common/model_api.h", "common/refused_calls.h", "common/state_masks.h")
# What every component model of the armour system (fmu_src/projectile/, fmu_src/hull/) shares beside the glue: the
# model API functions that do not depend on its physics (common/component_model.h says why not in instance.c).
COMPONENT_SOURCES = ("common/component_model.c",)
COMPONENT_HEADERS = ("common/component_model.h",)
GLUE_SOURCES = {2: ("fmi2/fmi2_glue.c",), 3: ("fmi3/fmi3_glue.c",)}
GLUE_HEADERS = {
    2: ("include/fmi2Functions.h", "include/fmi2FunctionTypes.h", "include/fmi2TypesPlatform.h"),
    3: ("include/fmi3Functions.h", "include/fmi3FunctionTypes.h", "include/fmi3PlatformTypes.h"),
}


@dataclass(frozen=True)
class SourceTree:
    """The files of one FMU's binary: the glue of `fmi_version`, with `component` the code every component model
    shares, and the model folder's *.c and *.h."""

    model_dir: Path = DEFAULT_MODEL_DIR
    fmi_version: int = 2
    component: bool = False

    def sources(self) -> list[Path]:
        shared = GLUE_SOURCES[self.fmi_version] + COMMON_SOURCES + (COMPONENT_SOURCES if self.component else ())
        return [FMU_SOURCE_DIR / name for name in shared] + sorted(Path(self.model_dir).glob("*.c"))

    def headers(self) -> list[Path]:
        shared = GLUE_HEADERS[self.fmi_version] + COMMON_HEADERS + (COMPONENT_HEADERS if self.component else ())
        return [FMU_SOURCE_DIR / name for name in shared] + sorted(Path(self.model_dir).glob("*.h"))

    def files(self) -> list[Path]:
        """Sources then headers; their names are unique, so they can sit side by side in the FMU's sources/."""
        files = self.sources() + self.headers()
        names = [path.name for path in files]
        clashes = sorted({name for name in names if names.count(name) > 1})
        if clashes:
            raise ValueError(
                f"model folder {self.model_dir}: {', '.join(clashes)} clash with the FMI glue's files "
                f"of the same name; rename them in the model folder"
            )
        return files

    def source_names(self) -> list[str]:
        """The sources as the FMU lists them (<SourceFiles>, buildDescription.xml): names in sources/."""
        return [path.name for path in self.sources()]
