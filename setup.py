"""The wheel carries the FMUs build_fmu.py left in models/, so a machine without a C compiler runs the default scene.

Everything else about the package is in pyproject.toml. ``python build_fmu.py [--platforms ...]`` (and
``--fmi-version 3``) first, then ``python -m build``: the build copies ``models/MassSpringLattice.fmu`` and
``models/MassSpringLattice-fmi3.fmu``, whichever exist, as they are (with every platform's binary they hold),
into the package ``orchestrator/prebuilt/``; ``orchestrator.fmu.prepare_fmu`` uses the first where no compiler
is found and its GUID says it was built from these sources. An editable install carries none: it runs from
the checkout, where models/ is. Why a build_py step of our own: setuptools' package data can only take files
from inside a package folder, and the FMU is built outside any.
"""

from __future__ import annotations

import shutil
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

MODELS = Path(__file__).resolve().parent / "models"
PREBUILT = ("MassSpringLattice.fmu", "MassSpringLattice-fmi3.fmu")


class BuildPyWithPrebuiltFMU(build_py):
    def run(self):
        super().run()
        if self.editable_mode:
            return
        target = Path(self.build_lib) / "orchestrator" / "prebuilt"
        found = [MODELS / name for name in PREBUILT if (MODELS / name).is_file()]
        for fmu in found:
            target.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(fmu, target / fmu.name)
            print(f"prebuilt FMU: {fmu.name} carried as orchestrator/prebuilt/{fmu.name}")
        if not found:
            print(
                "prebuilt FMU: none in models/ (run python build_fmu.py first); a machine without a C compiler "
                "will not run this build"
            )


setup(cmdclass={"build_py": BuildPyWithPrebuiltFMU})
