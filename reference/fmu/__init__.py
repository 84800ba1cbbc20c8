"""The reference FMU: the numpy/scipy model of ``reference/`` as an FMI 2.0 co-simulation FMU (pythonfmu).

    python build_fmu.py --reference          # models/MassSpringLatticeReference.fmu
    from reference.fmu import build_reference_fmu; build_reference_fmu("out/Ref.fmu")

The FMU bundles the slave (:mod:`reference.fmu.mass_spring_lattice_reference`), the whole ``reference``
package, ``fmu_src.materials`` (the study's table), ``fmu_src.published`` (the study's orders, which ``reference``
names) and pythonfmu's Python side; pythonfmu's binary runs it
inside a Python interpreter, which must have numpy and scipy.  Same variable names as the C FMU, so the same
fmpy code path (``orchestrator.simulation.LatticeFMU``) drives both: that is how the two are compared in the tests.
Nothing is done at import (pythonfmu is imported only when building).
"""

from __future__ import annotations

from pathlib import Path

HERE = Path(__file__).resolve().parent
REFERENCE_DIR = HERE.parent
SLAVE_SCRIPT = HERE / "mass_spring_lattice_reference.py"
MODEL_IDENTIFIER = "MassSpringLatticeReference"
DEFAULT_OUTPUT = Path("models") / f"{MODEL_IDENTIFIER}.fmu"  # under the current folder, as build_fmu.py's
# the two modules of fmu_src the reference imports; both need nothing but the standard library
FMU_SRC_MODULES = (REFERENCE_DIR.parent / "fmu_src" / "materials.py", REFERENCE_DIR.parent / "fmu_src" / "published.py")


def build_reference_fmu(output: str | Path | None = None) -> Path:
    """Build the reference FMU (default ``models/MassSpringLatticeReference.fmu`` under the current folder) and
    return its path."""
    import shutil
    import tempfile

    from pythonfmu.builder import FmuBuilder

    output = Path(output) if output else DEFAULT_OUTPUT
    output.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="reference_fmu_") as staging:
        # a clean copy of the package: no caches, no build leftovers, nothing of the 3-D reference or the armour
        # system (other models)
        package = Path(staging) / "reference"
        shutil.copytree(
            REFERENCE_DIR,
            package,
            ignore=shutil.ignore_patterns("__pycache__", "*.pyc", "lattice3d.py", "system.py", "*.json", "README.md"),
        )
        # the study's material table and orders come from fmu_src, the one place each is written: the FMU carries
        # those modules as a package of its own
        materials = Path(staging) / "fmu_src"
        materials.mkdir()
        (materials / "__init__.py").write_text(
            '"""fmu_src.materials and fmu_src.published alone, for the reference model."""\n'
        )
        for module in FMU_SRC_MODULES:
            shutil.copy2(module, materials / module.name)
        built = FmuBuilder.build_FMU(
            SLAVE_SCRIPT, dest=Path(staging) / f"{MODEL_IDENTIFIER}.fmu", project_files=[package, materials]
        )
        partial = output.with_suffix(".fmu.partial")
        shutil.copyfile(built, partial)
        partial.replace(output)  # never leave a half-written FMU where an importer could load it
    return output


__all__ = ["build_reference_fmu", "MODEL_IDENTIFIER", "DEFAULT_OUTPUT", "SLAVE_SCRIPT"]
