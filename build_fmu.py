"""Build the mass-spring lattice FMU from fmu_src/ with builder/: generate, compile, zip (the command line of
builder.build).

    python build_fmu.py                      # models/MassSpringLattice.fmu, the 11 x 11 armour scene
    python build_fmu.py --scene free_5x5     # a scene from scenes/ (or a path to a scene file)
    python build_fmu.py --rows 7 --cols 9 -o models/Lattice7x9.fmu
    python build_fmu.py --scene plate_11x11x11   # the plate of 11 layers under a 3 x 3 patch (docs/model.md 10)
    python build_fmu.py --rows 5 --cols 5 --depth 5 --load-patch 3   # a 5 x 5 x 5 plate, its patch's start 3
    python build_fmu.py --materials my_materials.csv --cols 5   # M materials of a table over 5 columns
    python build_fmu.py --fmi-version 3      # models/MassSpringLattice-fmi3.fmu
    python build_fmu.py --platforms all --fmi-version 3   # binaries for x86_64-linux, x86_64-windows, aarch64-linux
    python build_fmu.py --model projectile   # models/Projectile.fmu: the projectile of docs/model.md section 11
    python build_fmu.py --model hull --fmi-version 3     # models/Hull-fmi3.fmu: the hull behind the backplate
    python build_fmu.py --system             # models/ArmourSystem.ssp: projectile -> lattice -> hull, one SSP
    lattice-build ...                        # the same, installed as a console script (pip install .)

The scenes are the library module `scenes` (scenes/__init__.py and the JSON files beside it); FMUs are
written to models/ under the current folder unless -o says otherwise. Code that builds FMUs imports
`builder.build` (build_fmu, build_core_library, ...); this script only parses and calls it.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass

from builder.build import (
    MODELS_DIR,
    SOURCE_DIR,
    build_core_library,
    build_fmu,
    compile_shared_library,
    model_guid,
    platform_folder,
)
from builder.component import COMPONENT_MODELS, build_component_fmu
from fmu_src.core import MAX_COLS
from orchestrator.options import EXIT_USAGE, Parser, add_options, config_from, given, integer, option
from scenes import DEFAULT_SCENE, SCENE_DIR, Scene

__all__ = [
    "BuildConfig",
    "DEFAULT_SCENE",
    "MODELS_DIR",
    "SCENE_DIR",
    "SOURCE_DIR",
    "Scene",
    "build_core_library",
    "build_fmu",
    "compile_shared_library",
    "main",
    "model_guid",
    "platform_folder",
]

PLATFORMS_HELP = (
    "whose binaries the FMU carries: 'all' or a comma list of x86_64-linux, x86_64-windows, "
    "aarch64-linux. Compilers: cc (this machine's; $CC), x86_64-w64-mingw32-gcc (Debian: "
    "gcc-mingw-w64-x86-64), aarch64-linux-gnu-gcc (Debian: gcc-aarch64-linux-gnu), x86_64-linux-gnu-gcc "
    "elsewhere; CC_X86_64_LINUX, CC_X86_64_WINDOWS, CC_AARCH64_LINUX override them. FMI 2 names one "
    "folder (linux64) for both Linux architectures, so there 'all' is x86_64-linux and x86_64-windows, "
    "and aarch64-linux goes into an FMU of its own"
)


@dataclass(frozen=True)
class BuildConfig:
    """What to build (a scene and what overrides it) and how: declared with the option rules of the study's
    command line (orchestrator.options), so that a value either builds what it says or is refused in one line."""

    model: str = option(
        "lattice",
        "which model folder of fmu_src/ to build: the lattice (the scene options apply), "
        "or a component of the armour system (docs/model.md section 11): projectile, hull",
        choices=("lattice", *COMPONENT_MODELS),
    )
    system: bool = option(
        False,
        "write the armour system instead (docs/model.md section 11): the projectile, "
        "lattice and hull FMUs (FMI 2) connected port to port in models/ArmourSystem.ssp, or -o",
        action="store_true",
    )
    scene: str = option(DEFAULT_SCENE, "a scene name from scenes/ or a path to a scene .json", path=True)
    rows: int | None = option(
        None, "override the scene's number of rows", type=integer("--rows", 1), show_default="the scene's"
    )
    cols: int | None = option(
        None, "override the scene's number of columns", type=integer("--cols", 1, MAX_COLS), show_default="the scene's"
    )
    depth: int | None = option(
        None,
        "override the scene's masses through the plate's depth (docs/model.md section 10; 1: the 2-D lattice)",
        type=integer("--depth", 1),
        show_default="the scene's",
    )
    load_patch: int | None = option(
        None,
        "the start of parameter load_patch: 0 loads column 1's whole face, an odd "
        "P its centred P x P patch (P <= min(rows, depth), with odd rows and depth)",
        type=integer("--load-patch", 0),
        metavar="P",
        show_default="the scene's",
    )
    materials: str | None = option(
        None,
        "the material table (.csv with the header name,k,k_diag,c,alpha,"
        "alpha_diag; .toml or .json with the same fields): its M materials are the FMU's",
        metavar="FILE",
        path=True,
        show_default="the scene's",
    )
    output: str | None = option(
        None,
        "where to write the .fmu",
        short="-o",
        metavar="OUTPUT",
        path=True,
        show_default="models/<identifier>.fmu under the current folder",
    )
    fmi_version: int = option(
        2, "2: FMI 2.0; 3: FMI 3.0, written to models/<identifier>-fmi3.fmu", type=int, choices=(2, 3)
    )
    fmi3_scalars: bool = option(
        False,
        "FMI 3: declare the parameter arrays (material, k, ..., mass) element by element with FMI 2's "
        "names (material[1] ...), for importers that set no FMI 3 array (OMSimulator 3, fmi-sim 0.7)",
        action="store_true",
    )
    platforms: str | None = option(None, PLATFORMS_HELP, metavar="LIST", show_default="this machine's only")
    werror: bool = option(False, "fail on any compiler warning (CI does)", action="store_true")
    reference: bool = option(
        False,
        "build the reference FMU instead (pythonfmu over the numpy/scipy model of "
        "reference/): models/MassSpringLatticeReference.fmu, or -o",
        action="store_true",
    )
    cross_check: str | None = option(
        None,
        "write the FMI Cross-Check folder into DIR (builder/cross_check.py: three "
        "scenes, FMI 2.0 and 3.0, cs and me, references, FMPy's results)",
        metavar="DIR",
        path=True,
        show_default="none",
    )


def main(argv: list[str] | None = None) -> int:
    parser = Parser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    add_options(parser, BuildConfig, "the build")
    args = parser.parse_args(argv)
    try:
        config = config_from(BuildConfig, args)
    except ValueError as exc:
        parser.error(str(exc))
    if config.cross_check:
        if given(config) - {"cross_check", "werror"}:
            parser.error("--cross-check builds its own scenes and versions: give it with --werror only")
        from builder.cross_check import main as cross_check

        return cross_check(config.cross_check, werror=config.werror)
    if config.system:
        extra = sorted(given(config) - {"system", "output", "werror"})
        if extra:
            parser.error(
                f"{', '.join('--' + name.replace('_', '-') for name in extra)}: --system builds its own "
                "three FMI 2 FMUs; give it with -o and --werror only"
            )
        from builder.system import build_system

        print(build_system(config.output, werror=config.werror))
        return 0
    if config.fmi3_scalars and config.fmi_version != 3:
        parser.error("--fmi3-scalars: only with --fmi-version 3 (FMI 2 declares every array element by element)")
    if config.model != "lattice":
        scene_options = sorted(
            given(config) & {"scene", "rows", "cols", "depth", "load_patch", "materials", "reference", "fmi3_scalars"}
        )
        if scene_options:
            parser.error(
                f"{', '.join('--' + name.replace('_', '-') for name in scene_options)}: only for --model "
                f"lattice (the {config.model} has no scene)"
            )
        try:
            path = build_component_fmu(
                config.model,
                config.output,
                fmi_version=config.fmi_version,
                platforms=config.platforms,
                werror=config.werror,
            )
        except (ValueError, RuntimeError) as exc:
            print(f"{parser.prog}: error: {exc}", file=sys.stderr)
            return EXIT_USAGE
        print(path)
        return 0
    if config.reference:
        from reference.fmu import build_reference_fmu

        print(build_reference_fmu(config.output))
        return 0
    try:
        path = build_fmu(
            config.scene,
            config.output,
            config.rows,
            config.cols,
            werror=config.werror,
            fmi_version=config.fmi_version,
            materials=config.materials,
            platforms=config.platforms,
            depth=config.depth,
            load_patch=config.load_patch,
            fmi3_arrays=not config.fmi3_scalars,
        )
    except (ValueError, RuntimeError) as exc:
        print(f"{parser.prog}: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    print(path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
