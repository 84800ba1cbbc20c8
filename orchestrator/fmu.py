"""The FMU a study runs: found, checked, built when needed and instantiated once, before any search.

``prepare_fmu`` is the one place that decides which FMU a run uses: the one given (``--fmu``), or the scene's
in ``models/``, built when it is missing, rebuilt when it was built from other sources (its GUID) or its
binary cannot be instantiated here (a foreign build). Where no C compiler is found, the scene's FMU comes from
the prebuilt ones an installed wheel carries (``orchestrator/prebuilt/``, see setup.py) when one was built
from these sources for this scene; any other scene (a custom lattice, a material table) is refused in one line
naming the compiler to install. It is instantiated once in this process, so a broken
FMU is refused at once with its own log message, not after a whole study. The study receives the result, a
``PreparedFMU``: the file, its hash (how journals and checkpoints identify it, wherever it lies) and what its
model description says (columns, materials, parameters with their types, ranges and enumeration items).
"""

from __future__ import annotations

import os
import platform
import shutil
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .journal import file_sha256
from .simulation import (
    LatticeFMU,
    Parameter,
    SimulationError,
    array_lengths,
    declared_lattice_size,
    declared_parameters,
    material_columns,
    model_description,
)


class FMUError(ValueError):
    """An FMU that cannot be used, with the reason in one line."""


@dataclass(frozen=True)
class PreparedFMU:
    """An FMU checked and instantiated once; what the study needs to know of it."""

    path: Path
    sha256: str
    identifier: str
    guid: str
    rows: int
    columns: int
    materials: int
    parameters: dict[str, Parameter]  # the scalar parameters (array elements are not here)
    outputs: tuple[str, ...]

    @property
    def has_force_limit(self) -> bool:
        return "peak_force_limit" in self.parameters

    @property
    def has_repeat(self) -> bool:
        return "repeat_materials" in self.parameters

    @property
    def description(self):
        return model_description(self.path)

    def start(self, name: str, default: Any = None) -> Any:
        parameter = self.parameters.get(name)
        return default if parameter is None else parameter.start

    def is_default(self, name: str, value: Any) -> bool:
        """Whether ``value`` is what the FMU runs with when ``name`` is not set."""
        parameter = self.parameters.get(name)
        return parameter is not None and value == parameter.start


def describe(path: Path, rows: int) -> PreparedFMU:
    """What the FMU's model description says (no instantiation)."""
    try:
        description = model_description(path)
    except Exception as exc:  # noqa: BLE001 - one line for a file that is not an FMU
        raise FMUError(f"--fmu {path}: not a readable FMU ({type(exc).__name__}: {exc})") from None
    if description.coSimulation is None:
        raise FMUError(f"--fmu {path}: it has no Co-Simulation interface; the study runs Co-Simulation FMUs")
    parameters = {name: parameter for name, parameter in declared_parameters(description).items() if "[" not in name}
    outputs = tuple(v.name for v in description.modelVariables if v.causality == "output")
    materials = array_lengths(description).get("k") or sum(
        1 for v in description.modelVariables if v.name.startswith("k[")
    )
    columns = material_columns(description)
    return PreparedFMU(
        path,
        file_sha256(path),
        description.coSimulation.modelIdentifier,
        description.guid,
        rows,
        columns,
        materials or columns,
        parameters,
        outputs,
    )


def instantiate_once(path: Path) -> None:
    """Instantiates the FMU here and frees it: a broken or foreign binary fails now, with the FMU's message."""
    try:
        LatticeFMU(path, instance_name="check").close()
    except (SimulationError, OSError) as exc:
        raise FMUError(str(exc).splitlines()[0] if str(exc) else type(exc).__name__) from None


def size_text(rows: int, columns: int, depth: int) -> str:
    return f"{rows} x {columns}" + (f" x {depth} (rows x columns x depth)" if depth > 1 else " (rows x columns)")


def scene_state_count(scene) -> int:
    """The continuous states the FMU of ``scene`` declares (the variable table's, for its rows x cols x depth)."""
    from fmu_src.variables import STATE

    return sum(variable.count for variable in scene.interface().exposed if variable.role == STATE)


def prepare_fmu(scene, fmu: str | None = None) -> PreparedFMU:
    """The FMU of ``scene`` (a ``scenes.Scene``): ``fmu`` when given (checked, never rebuilt), else the
    scene's FMU in models/, built or rebuilt as needed."""
    if fmu:
        path = Path(fmu)
        if not path.is_file():
            raise FMUError(f"--fmu {fmu}: no such file (build one with `python build_fmu.py`)")
        prepared = describe(path, scene.rows)
        if prepared.columns < 2:
            raise FMUError(
                f"--fmu {fmu}: {prepared.columns} column(s) with a material parameter: there is no "
                "material order to search (give a scene with a material per column)"
            )
        shape = declared_lattice_size(path)
        if shape and shape != scene.size():
            rows, columns, depth = shape
            raise FMUError(
                f"--fmu {fmu}: its lattice is {size_text(*shape)}, scene {scene.name}'s "
                f"{size_text(scene.rows, scene.cols, scene.depth)}; give the FMU's --scene"
                + (f" or --cols {columns} --depth {depth}" if rows == scene.rows else f" (a scene of {rows} rows)")
            )
        if prepared.columns != scene.cols:
            raise FMUError(
                f"--fmu {fmu}: its lattice has {prepared.columns} columns, scene {scene.name} "
                f"{scene.cols}; give the FMU's --scene or --cols {prepared.columns}"
            )
        states, scene_states = len(prepared.description.derivatives), scene_state_count(scene)
        if states and states != scene_states:
            raise FMUError(
                f"--fmu {fmu}: it has {states} continuous states, scene {scene.name}'s {scene.rows} x "
                f"{scene.cols} x {scene.depth} lattice {scene_states}; give the FMU's --scene, --cols or "
                f"--depth"
            )
        try:
            instantiate_once(path)
        except FMUError as exc:
            raise FMUError(f"--fmu {fmu}: {exc}") from None
        return prepared
    from builder import build

    path = build.MODELS_DIR / f"{scene.model_identifier}.fmu"
    expected = build.model_guid(scene.interface(), scene.model_identifier)
    reason = None
    if not path.is_file():
        reason = f"building {path} (scene {scene.name}) ..."
    elif _guid(path) != expected:
        reason = f"rebuilding {path}: it was built from other sources or for another scene"
    if reason:
        _build_or_copy_prebuilt(scene, path, expected, reason)
    try:
        instantiate_once(path)
    except FMUError as exc:
        _build_or_copy_prebuilt(
            scene,
            path,
            expected,
            f"rebuilding {path}: its binary cannot be instantiated here ({exc})",
            foreign=str(exc),
        )
        try:
            instantiate_once(path)
        except FMUError as again:
            raise FMUError(f"{path} was rebuilt but still cannot be instantiated: {again}") from None
    return describe(path, scene.rows)


PREBUILT_DIR = Path(__file__).resolve().parent / "prebuilt"  # filled by setup.py in a wheel; absent in a checkout


def compiler_found() -> bool:
    """Whether the C compiler the build would call (``$CC``, else ``cc``) is there to call."""
    from builder import build

    return shutil.which(build.compiler_command()[0]) is not None


def compiler_hint() -> str:
    """What to install on this platform so that ``builder.build`` finds a C compiler (gcc-style flags)."""
    system = platform.system()
    if system == "Windows":
        return "install MinGW-w64 gcc (for example MSYS2's mingw-w64-ucrt-x86_64-gcc) and set CC=gcc"
    if system == "Darwin":
        return "install Apple's command line tools: xcode-select --install"
    return "install gcc (Debian, Ubuntu: apt-get install gcc; Fedora: dnf install gcc)"


def _build_or_copy_prebuilt(scene, path: Path, expected: str, reason: str, foreign: str | None = None) -> None:
    """Builds the scene's FMU at ``path``; without a compiler, copies the wheel's prebuilt FMU of this scene
    there, or refuses in one line. ``foreign``: why the FMU at ``path`` could not be instantiated."""
    from builder import build

    if compiler_found():
        print(reason, file=sys.stderr)
        build.build_fmu(scene, path)
        return
    compiler = os.environ.get("CC") or "cc"
    prebuilt = PREBUILT_DIR / path.name
    usable = prebuilt.is_file() and _guid(prebuilt) == expected
    if usable and not (foreign is not None and _same_file(prebuilt, path)):
        print(
            f"no C compiler ({compiler}) found: using the prebuilt {path.name} this installation carries",
            file=sys.stderr,
        )
        path.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(prebuilt, path)
        return
    if foreign is not None:
        what = f"{path} cannot be instantiated on this machine ({platform.system()} {platform.machine()}: {foreign})"
    else:
        what = (
            f"{path.name} (scene {scene.name}, {scene.rows} x {scene.cols}, with its material table) must be "
            "built from C, no prebuilt FMU matches it"
        )
    raise FMUError(
        f"{what}, and no C compiler was found (CC={compiler}): {compiler_hint()}; or give a built FMU with --fmu"
    )


def _same_file(a: Path, b: Path) -> bool:
    return b.is_file() and a.read_bytes() == b.read_bytes()


def _guid(path: Path) -> str | None:
    try:
        return model_description(path).guid
    except Exception:  # noqa: BLE001 - unreadable: rebuilt
        return None


__all__ = [
    "FMUError",
    "PREBUILT_DIR",
    "Parameter",
    "PreparedFMU",
    "compiler_found",
    "compiler_hint",
    "describe",
    "instantiate_once",
    "prepare_fmu",
]
