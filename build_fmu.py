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

from builder.build import (MODELS_DIR, SOURCE_DIR, build_core_library, build_fmu, compile_shared_library,
                           model_guid, platform_folder)
from builder.component import COMPONENT_MODELS, build_component_fmu
from scenes import DEFAULT_SCENE, SCENE_DIR, Scene

__all__ = ["DEFAULT_SCENE", "MODELS_DIR", "SCENE_DIR", "SOURCE_DIR", "Scene", "build_core_library", "build_fmu",
           "compile_shared_library", "main", "model_guid", "platform_folder"]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--model", default="lattice", choices=("lattice", *COMPONENT_MODELS),
                        help="which model folder of fmu_src/ to build: the lattice (default; the scene options "
                             "apply), or a component of the armour system (docs/model.md section 11): projectile, "
                             "hull")
    parser.add_argument("--system", action="store_true",
                        help="write the armour system instead (docs/model.md section 11): the projectile, lattice "
                             "and hull FMUs (FMI 2) connected port to port in models/ArmourSystem.ssp, or -o")
    parser.add_argument("--scene", default=DEFAULT_SCENE,
                        help=f"a scene name from scenes/ or a path to a scene .json (default {DEFAULT_SCENE})")
    parser.add_argument("--rows", type=int, help="override the scene's number of rows")
    parser.add_argument("--cols", type=int, help="override the scene's number of columns")
    parser.add_argument("--depth", type=int,
                        help="override the scene's number of layers (docs/model.md section 10; 1: one layer)")
    parser.add_argument("--load-patch", type=int, metavar="P",
                        help="the start of parameter load_patch: 0 loads column 1's whole face, an odd P its "
                             "centred P x P patch (P <= min(rows, depth), with odd rows and depth)"),
    parser.add_argument("--materials", metavar="FILE",
                        help="the material table (.csv with the header name,k,k_diag,c,alpha,alpha_diag and "
                             "optionally mass,damping_exponent; .toml or .json with the same fields): its M materials "
                             "are the FMU's; default the scene's")
    parser.add_argument("-o", "--output",
                        help="where to write the .fmu (default models/<identifier>.fmu under the current folder)")
    parser.add_argument("--fmi-version", type=int, choices=(2, 3), default=2,
                        help="2: FMI 2.0 (default); 3: FMI 3.0, written to models/<identifier>-fmi3.fmu")
    parser.add_argument("--platforms", metavar="LIST",
                        help="whose binaries the FMU carries: 'all' or a comma list of x86_64-linux, x86_64-windows, "
                             "aarch64-linux (default: this machine's only). Compilers: cc (this machine's; $CC), "
                             "x86_64-w64-mingw32-gcc (Debian: gcc-mingw-w64-x86-64), aarch64-linux-gnu-gcc (Debian: "
                             "gcc-aarch64-linux-gnu), x86_64-linux-gnu-gcc elsewhere; CC_X86_64_LINUX, "
                             "CC_X86_64_WINDOWS, CC_AARCH64_LINUX override them. FMI 2 names one folder (linux64) for "
                             "both Linux architectures, so there 'all' is x86_64-linux and x86_64-windows, and "
                             "aarch64-linux goes into an FMU of its own")
    parser.add_argument("--werror", action="store_true", help="fail on any compiler warning (CI does)")
    parser.add_argument("--reference", action="store_true",
                        help="build the reference FMU instead (pythonfmu over the numpy/scipy model of reference/): "
                             "models/MassSpringLatticeReference.fmu, or -o")
    parser.add_argument("--cross-check", metavar="DIR", help="write the FMI Cross-Check folder into DIR (builder/"
                        "cross_check.py: three scenes, FMI 2.0 and 3.0, cs and me, references, FMPy's results)")
    args = parser.parse_args(argv)
    if args.cross_check:
        if (args.output or args.rows or args.cols or args.depth or args.load_patch is not None or args.materials or args.reference or args.scene != DEFAULT_SCENE
                or args.fmi_version != 2 or args.platforms):
            parser.error("--cross-check builds its own scenes and versions: give it with --werror only")
        from builder.cross_check import main as cross_check
        return cross_check(args.cross_check, werror=args.werror)
    if args.system:
        given = [name for name, value in {"--model": args.model != "lattice", "--scene": args.scene != DEFAULT_SCENE,
                                           "--rows": args.rows, "--cols": args.cols, "--depth": args.depth,
                                           "--load-patch": args.load_patch is not None, "--materials": args.materials,
                                           "--reference": args.reference, "--fmi-version": args.fmi_version != 2,
                                           "--platforms": args.platforms}.items() if value]
        if given:
            parser.error(f"{', '.join(given)}: --system builds its own three FMI 2 FMUs; give it with -o and "
                         f"--werror only")
        from builder.system import build_system

        print(build_system(args.output, werror=args.werror))
        return 0
    if args.model != "lattice":
        scene_options = {"--scene": args.scene != DEFAULT_SCENE, "--rows": args.rows, "--cols": args.cols,
                         "--depth": args.depth, "--load-patch": args.load_patch is not None,
                         "--materials": args.materials, "--reference": args.reference}
        given = [name for name, value in scene_options.items() if value]
        if given:
            parser.error(f"{', '.join(given)}: only for --model lattice (the {args.model} has no scene)")
        try:
            path = build_component_fmu(args.model, args.output, fmi_version=args.fmi_version,
                                       platforms=args.platforms, werror=args.werror)
        except (ValueError, RuntimeError) as exc:
            print(f"{parser.prog}: error: {exc}", file=sys.stderr)
            return 2
        print(path)
        return 0
    if args.reference:
        from reference.fmu import build_reference_fmu

        print(build_reference_fmu(args.output))
        return 0
    try:
        path = build_fmu(args.scene, args.output, args.rows, args.cols, werror=args.werror,
                         fmi_version=args.fmi_version, materials=args.materials, platforms=args.platforms,
                         depth=args.depth, load_patch=args.load_patch)
    except (ValueError, RuntimeError) as exc:
        print(f"{parser.prog}: error: {exc}", file=sys.stderr)
        return 2
    print(path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
