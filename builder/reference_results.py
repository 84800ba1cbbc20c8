"""The FMU's reference results, carried the way the Reference FMUs carry theirs: the FMI-LS-REF layered standard.

    extra/org.fmi-standard.fmi-ls-ref/fmi-ls-manifest.xml      <fmiReferences> with one <Related> per result
    extra/org.fmi-standard.fmi-ls-ref/<Model>_out.csv          the default experiment (the sequential order)
    extra/org.fmi-standard.fmi-ls-ref/<Model>_study_best_out.csv  the study's best order

Each CSV is the FMU's Co-Simulation outputs every communication step over the default experiment (0 to 8 s),
at its default parameters but `material[1..11]`, which is the published order the file is named after: the
orders and conditions of fmu_src/published.py, whose peaks the last row's peak_backplate_force reproduces.
They hold for the armour scene as the study defined it (11 x 11, the study's materials, the scene's defaults);
an FMU of another scene, size or material table carries none (it has no published result to carry).

Building never simulates: the CSVs are recorded once from the sources and kept beside them (as the Reference
FMUs keep their <Model>_out.csv in their source tree); the build copies them.

    python -m builder.reference_results     # records them again from today's sources (this machine's FMU)

tests/test_reference_results.py checks that today's FMU still gives them and that the manifest is what
FMI-LS-REF and FMI 3's layered-standard manifest schema ask for.
"""

from __future__ import annotations

import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

from builder.rendering import environment
from fmu_src.published import PUBLISHED_PEAKS, SEQUENTIAL_ORDER, STUDY_BEST_ORDER

EXTRA = "extra/org.fmi-standard.fmi-ls-ref"
MANIFEST = "fmi-ls-manifest.xml"
RESULTS_DIR = Path(__file__).resolve().parent / "reference_results"
LS_NAME = "org.fmi-standard.fmi-ls-ref"
LS_VERSION = "1.0.0-alpha.1"  # the version the Reference FMUs' manifests declare
LS_DESCRIPTION = "Layered standard providing information on related files included in an FMU"
# The outputs recorded, in this order (time first); all change over the default experiment.
SIGNALS = (
    "backplate_force",
    "peak_backplate_force",
    "peak_backplate_force_continuous",
    "kinetic_energy",
    "potential_energy",
    "external_work",
    "dissipated_energy",
    "ux_left_edge",
    "ux_centre",
    "ux_right_edge",
)


@dataclass(frozen=True)
class ReferenceResult:
    """One reference result of the armour FMU: a published order and the file that holds its run."""

    label: str
    order: tuple[int, ...]
    suffix: str  # <Model><suffix>.csv

    def file_name(self, identifier: str) -> str:
        return f"{identifier}{self.suffix}.csv"

    def description(self) -> str:
        order = " ".join(map(str, self.order))
        return (
            f"Outputs of the default experiment with material = {order} ({self.label}; other parameters at "
            f"their defaults); its final peak_backplate_force is the published {PUBLISHED_PEAKS[self.order]!r} N"
        )


REFERENCE_RESULTS = (
    ReferenceResult("the sequential order, the FMU's default", SEQUENTIAL_ORDER, "_out"),
    ReferenceResult("the study's best order", STUDY_BEST_ORDER, "_study_best_out"),
)


def carries_reference_results(scene) -> bool:
    """Whether an FMU of ``scene`` (resolved: size and table applied) is the one the published results hold for."""
    from scenes import is_study_scene

    return is_study_scene(scene)


def manifest_xml(identifier: str) -> str:
    return (
        environment()
        .get_template("fmi_ls_ref_manifest.xml")
        .render(
            ls_name=LS_NAME,
            ls_version=LS_VERSION,
            ls_description=LS_DESCRIPTION,
            related=[{"source": r.file_name(identifier), "description": r.description()} for r in REFERENCE_RESULTS],
        )
    )


def extra_files(identifier: str) -> dict[str, bytes]:
    """The FMI-LS-REF files: path in the FMU -> content. FileNotFoundError (one line) if a recorded
    result is missing from the sources."""
    files = {f"{EXTRA}/{MANIFEST}": manifest_xml(identifier).encode()}
    for result in REFERENCE_RESULTS:
        recorded = RESULTS_DIR / result.file_name(identifier)
        if not recorded.is_file():
            raise FileNotFoundError(
                f"reference result {recorded} is missing: python -m builder.reference_results records it"
            )
        files[f"{EXTRA}/{recorded.name}"] = recorded.read_bytes()
    return files


def simulate(fmu: Path, order: tuple[int, ...]):
    """The FMU's Co-Simulation over its default experiment with ``material`` = order (FMPy drives it)."""
    from fmpy import simulate_fmu

    start = {f"material[{index}]": material for index, material in enumerate(order, start=1)}
    return simulate_fmu(str(fmu), fmi_type="CoSimulation", start_values=start, output=list(SIGNALS))


def write_csv(path: Path, result) -> None:
    """The Reference FMUs' CSV: the names in the first line, time first, every value as Python's repr."""
    columns = ("time",) + SIGNALS
    lines = [",".join(columns)] + [",".join(repr(float(row[name])) for name in columns) for row in result]
    path.write_text("\n".join(lines) + "\n")


def record(out_dir: Path = RESULTS_DIR) -> list[Path]:
    """Builds the armour FMU here and records its reference results into ``out_dir``."""
    from builder.build import build_fmu

    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    with tempfile.TemporaryDirectory(prefix="reference_results_") as folder:
        fmu = build_fmu(output=Path(folder) / "MassSpringLattice.fmu", reference_results=False)
        for result in REFERENCE_RESULTS:
            run = simulate(fmu, result.order)
            path = out_dir / result.file_name("MassSpringLattice")
            write_csv(path, run)
            written.append(path)
    return written


if __name__ == "__main__":
    for written_path in record():
        print(written_path)
    sys.exit(0)
