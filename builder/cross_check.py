"""The FMI Cross-Check deliverable: the project's FMUs with reference results, and FMPy's import of them.

    python build_fmu.py --cross-check DIR

writes the layout of modelica/fmi-cross-check's rules for FMI 2.0 and 3.0, Co-Simulation and Model Exchange,
on this platform, for the scenes in CROSS_CHECK_SCENES:

    DIR/fmus/<2.0|3.0>/<cs|me>/<platform>/mass-spring-lattice/<version>/<Model>/
        <Model>.fmu        the FMU, carrying its reference result and an FMI-LS-REF manifest in
                           extra/org.fmi-standard.fmi-ls-ref/ (as the Reference FMUs do)
        <Model>_ref.csv    at most 10 outputs, the names exactly as in modelDescription.xml
        <Model>_ref.opt    StartTime, StopTime, StepSize, RelTol
        ReadMe.md          the model, how the reference was made, the variable table
    DIR/results/<2.0|3.0>/<cs|me>/<platform>/FMPy/<fmpy version>/mass-spring-lattice/<version>/<Model>/
        passed | failed    FMPy's import, compared with the reference by fmpy.cross_check.validate_result
        <Model>_out.csv, ReadMe.md

The reference is the FMU's own Co-Simulation solver at its default parameters, driven by FMPy over the
cross-check's horizon; the importing tool is FMPy (Co-Simulation in the reference's steps, Model Exchange
with its CVode at the _ref.opt's tolerance). This module simulates; building the FMU never does.
"""

from __future__ import annotations

import importlib.metadata
import shutil
import sys
import tempfile
import tomllib
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from builder.rendering import environment

TOOL = "mass-spring-lattice"
IMPORTER = "FMPy"
EXTRA = "extra/org.fmi-standard.fmi-ls-ref"
MAX_SIGNALS = 10  # the cross-check rules' recommendation for a _ref.csv
# The reference's outputs, in the order they are chosen; an output that stays constant over the run, or
# repeats one already chosen, is left out.
SIGNALS = (
    "backplate_force",
    "peak_backplate_force",
    "kinetic_energy",
    "potential_energy",
    "external_work",
    "dissipated_energy",
    "nonreciprocal_work",
    "ux_left_edge",
    "ux_centre",
    "ux_right_edge",
    "ux_corner",
    "uy_corner",
    "uy_left_edge",
    "uy_centre",
    "uy_right_edge",
)
# A Model Exchange importer's relative tolerance (its solver's, not the FMU's own).
RELATIVE_TOLERANCE = 1e-6
INTERFACES = {"cs": ("CoSimulation", "Co-Simulation"), "me": ("ModelExchange", "Model Exchange")}


@dataclass(frozen=True)
class CrossCheckScene:
    """A scene of scenes/ and the horizon of its cross-check run (s)."""

    scene: str
    stop_time: float


# The 11 x 11 armour over its peak and last contact (both before 1 s), the free 5 x 5 lattice, the two masses.
CROSS_CHECK_SCENES = (
    CrossCheckScene("armour_11x11", 1.0),
    CrossCheckScene("free_5x5", 2.0),
    CrossCheckScene("two_masses_exponential", 2.0),
)
FMI_VERSIONS = ("2.0", "3.0")


@dataclass(frozen=True)
class CrossCheckResult:
    """One FMU of the folder as FMPy imported it: ``problem`` is None when it passed."""

    model: str
    fmi_version: str
    fmi_type: str
    fmu: Path
    signals: tuple[str, ...]
    problem: str | None

    @property
    def verdict(self) -> str:
        return "passed" if self.problem is None else "failed"


def tool_version() -> str:
    """The project's version: the installed distribution's, else the checkout's pyproject.toml."""
    try:
        return importlib.metadata.version(TOOL)
    except importlib.metadata.PackageNotFoundError:
        pyproject = Path(__file__).resolve().parents[1] / "pyproject.toml"
        return tomllib.loads(pyproject.read_text())["project"]["version"]


def write_csv(path: Path, result: np.ndarray, names: tuple[str, ...]) -> None:
    """A CSV by the cross-check rules: quoted names in the first line, the time first, C float literals."""
    columns = ("time",) + names
    lines = [",".join(f'"{name}"' for name in columns)]
    lines += [",".join(repr(float(row[name])) for name in columns) for row in result]
    path.write_text("\n".join(lines) + "\n")


def read_csv(path: Path) -> np.ndarray:
    return np.genfromtxt(path, delimiter=",", names=True, deletechars="")


def chosen_signals(result: np.ndarray, outputs: list[str]) -> tuple[str, ...]:
    """Up to MAX_SIGNALS of SIGNALS that the FMU outputs and that change over the run."""
    chosen: list[str] = []
    for name in SIGNALS:
        if name not in outputs or len(chosen) == MAX_SIGNALS:
            continue
        values = result[name]
        if np.ptp(values) == 0.0 or any(np.array_equal(values, result[other]) for other in chosen):
            continue
        chosen.append(name)
    return tuple(chosen)


def reference_result(fmu: Path, stop_time: float, step_size: float) -> tuple[np.ndarray, tuple[str, ...]]:
    """The FMU's Co-Simulation outputs every step_size from 0 to stop_time, and the signals chosen of them."""
    from fmpy import read_model_description, simulate_fmu

    outputs = [
        v.name
        for v in read_model_description(str(fmu)).modelVariables
        if v.causality == "output" and v.type in ("Real", "Float64")
    ]
    result = simulate_fmu(
        str(fmu),
        fmi_type="CoSimulation",
        stop_time=stop_time,
        step_size=step_size,
        output_interval=step_size,
        output=outputs,
    )
    return result, chosen_signals(result, outputs)


def with_reference(fmu: Path, target: Path, reference_csv: Path, stop_time: float, step_size: float) -> None:
    """A copy of ``fmu`` at ``target`` with the reference result and its FMI-LS-REF manifest in extra/."""
    from builder.reference_results import LS_DESCRIPTION, LS_NAME, LS_VERSION

    description = (
        f"Outputs from 0 to {stop_time!r} s every {step_size!r} s, by the FMU's Co-Simulation at its default parameters"
    )
    manifest = (
        environment()
        .get_template("fmi_ls_ref_manifest.xml")
        .render(
            ls_name=LS_NAME,
            ls_version=LS_VERSION,
            ls_description=LS_DESCRIPTION,
            related=[{"source": reference_csv.name, "description": description}],
        )
    )
    partial = target.with_name(target.name + ".partial")
    with zipfile.ZipFile(fmu) as source, zipfile.ZipFile(partial, "w", zipfile.ZIP_DEFLATED) as archive:
        for item in source.infolist():
            if not item.filename.startswith("extra/"):
                archive.writestr(item, source.read(item))
        archive.writestr(f"{EXTRA}/fmi-ls-manifest.xml", manifest)
        archive.write(reference_csv, f"{EXTRA}/{reference_csv.name}")
    partial.replace(target)


def import_with_fmpy(fmu: Path, fmi_type: str, stop_time: float, step_size: float) -> tuple[np.ndarray, str]:
    """FMPy's run of one interface, and the settings it used (for the ReadMe)."""
    from fmpy import simulate_fmu

    if fmi_type == "cs":
        settings = {"step_size": step_size, "output_interval": step_size}
    else:
        settings = {"solver": "CVode", "relative_tolerance": RELATIVE_TOLERANCE, "output_interval": step_size}
    result = simulate_fmu(str(fmu), fmi_type=INTERFACES[fmi_type][0], stop_time=stop_time, **settings)
    return result, ", ".join(f"{key}={value!r}" for key, value in settings.items())


def variable_rows(description) -> list[dict]:
    return [
        {
            "name": v.name,
            "causality": v.causality,
            "type": v.type,
            "start": v.start,
            "unit": v.unit,
            "description": v.description,
        }
        for v in description.modelVariables
        if v.causality in ("parameter", "output", "input")
    ]


def write_model(
    out_dir: Path, fmu: Path, fmi_version: str, stop_time: float, step_size: float, platform: str
) -> list[CrossCheckResult]:
    """The fmus/ and results/ folders of one FMU, for each interface it has."""
    from fmpy import __version__ as fmpy_version
    from fmpy import read_model_description
    from fmpy.cross_check import validate_result

    description = read_model_description(str(fmu))
    model = description.coSimulation.modelIdentifier
    version = tool_version()
    options = {
        "StartTime": 0.0,
        "StopTime": float(stop_time),
        "StepSize": float(step_size),
        "RelTol": RELATIVE_TOLERANCE,
    }
    results = []
    with tempfile.TemporaryDirectory(prefix="cross_check_") as staging_name:
        staging = Path(staging_name)
        reference, signals = reference_result(fmu, stop_time, step_size)
        reference_csv = staging / f"{model}_ref.csv"
        write_csv(reference_csv, reference, signals)
        carried = staging / f"{model}.fmu"
        with_reference(fmu, carried, reference_csv, stop_time, step_size)
        reference = read_csv(reference_csv)
        for fmi_type, (_, type_name) in INTERFACES.items():
            if (description.coSimulation if fmi_type == "cs" else description.modelExchange) is None:
                continue
            folder = out_dir / "fmus" / fmi_version / fmi_type / platform / TOOL / version / model
            shutil.rmtree(folder, ignore_errors=True)
            folder.mkdir(parents=True)
            shutil.copy2(carried, folder / carried.name)
            shutil.copy2(reference_csv, folder / reference_csv.name)
            (folder / f"{model}_ref.opt").write_text("".join(f"{key}, {value!r}\n" for key, value in options.items()))
            (folder / "ReadMe.md").write_text(
                environment()
                .get_template("cross_check_fmu_readme.md")
                .render(
                    model=model,
                    description=description.description,
                    fmi_version=fmi_version,
                    fmi_type_name=type_name,
                    platform=platform,
                    tool=TOOL,
                    tool_version=version,
                    signals=signals,
                    stop_time=stop_time,
                    step_size=step_size,
                    fmpy_version=fmpy_version,
                    options=[f"{key} {value!r}" for key, value in options.items()],
                    variables=variable_rows(description),
                )
            )
            try:
                result, settings = import_with_fmpy(folder / carried.name, fmi_type, stop_time, step_size)
                out_csv = staging / f"{model}_out.csv"
                write_csv(out_csv, result, signals)
                problem = validate_result(
                    result=read_csv(out_csv), reference=reference, t_start=0.0, t_stop=float(stop_time)
                )
            except Exception as error:  # the importer's failure is the result to report, in one line
                result, settings, problem = None, "", f"{type(error).__name__}: {str(error).splitlines()[0]}"
            verdict_folder = (
                out_dir
                / "results"
                / fmi_version
                / fmi_type
                / platform
                / IMPORTER
                / fmpy_version
                / TOOL
                / version
                / model
            )
            shutil.rmtree(verdict_folder, ignore_errors=True)
            verdict_folder.mkdir(parents=True)
            entry = CrossCheckResult(model, fmi_version, fmi_type, folder / carried.name, signals, problem)
            (verdict_folder / entry.verdict).write_text("")
            if result is not None:
                shutil.copy2(out_csv, verdict_folder / out_csv.name)
            (verdict_folder / "ReadMe.md").write_text(
                environment()
                .get_template("cross_check_result_readme.md")
                .render(
                    model=model,
                    verdict=entry.verdict,
                    fmpy_version=fmpy_version,
                    fmi_type_name=INTERFACES[fmi_type][0],
                    stop_time=stop_time,
                    settings=settings,
                    problem=problem,
                )
            )
            results.append(entry)
    return results


def write_cross_check(
    out_dir: str | Path,
    scenes=CROSS_CHECK_SCENES,
    fmi_versions=FMI_VERSIONS,
    *,
    werror: bool = False,
    fmus: dict | None = None,
) -> list[CrossCheckResult]:
    """Builds each scene's FMU for each FMI version (or takes ``fmus[(scene, fmi_version)]``, an FMU already
    built from that scene) and writes its cross-check folders into ``out_dir``."""
    from scenes import Scene

    from .build import build_fmu, platform_folder

    out_dir = Path(out_dir)
    platform = platform_folder()[0]
    results = []
    for entry in scenes:
        scene = Scene.load(entry.scene)
        for fmi_version in fmi_versions:
            if fmi_version not in FMI_VERSIONS:
                raise ValueError(f"fmi_version {fmi_version!r} is not allowed: allowed values are {FMI_VERSIONS}")
            given = (fmus or {}).get((entry.scene, fmi_version))
            if given is not None:
                results += write_model(
                    out_dir, Path(given), fmi_version, entry.stop_time, scene.communication_step, platform
                )
                continue
            with tempfile.TemporaryDirectory(prefix="cross_check_build_") as build_dir:
                fmu = build_fmu(
                    Scene.load(entry.scene),
                    Path(build_dir) / f"{scene.model_identifier}.fmu",
                    werror=werror,
                    fmi_version=int(fmi_version[0]),
                )
                results += write_model(out_dir, fmu, fmi_version, entry.stop_time, scene.communication_step, platform)
    return results


def main(out_dir: str, werror: bool = False) -> int:
    """The CLI of `build_fmu.py --cross-check DIR`: one line per FMU and interface; exit 1 if any failed."""
    results = write_cross_check(out_dir, werror=werror)
    for entry in results:
        print(
            f"{entry.verdict:6s} {entry.fmi_version} {entry.fmi_type} {entry.model}"
            + (f": {entry.problem}" if entry.problem else "")
        )
    print(
        f"{sum(e.problem is None for e in results)} of {len(results)} passed; folder {Path(out_dir).resolve()}",
        file=sys.stderr,
    )
    return 0 if all(e.problem is None for e in results) else 1


__all__ = ["CROSS_CHECK_SCENES", "CrossCheckResult", "CrossCheckScene", "main", "write_cross_check"]
