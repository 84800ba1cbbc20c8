"""Co-simulation example: the lattice's backplate force drives a second FMU, the body the plate is mounted on.

    python examples/backplate_support.py                         # 2 s, published best order, libcosim master
    python examples/backplate_support.py --order 1,2,3,4,5,6,7,8,9,10,11 --horizon 2 -o results/seq.png

Two FMUs, one master:
- models/MassSpringLattice.fmu (built here if missing): its output `backplate_force`;
- BackplateSupport.fmu, a tiny C FMU built here from examples/support_fmu/support.c: a mass m on a spring k
  and a damper c to the ground, pushed by its input F; outputs x, v and F_support = k x + c v, the force
  passed on to what is behind the plate.
libcosim (the Python package libcosimpy, an FMI 2.0 co-simulation master we did not write) connects
backplate_force -> F and steps both every 0.01 s; each step the support sees the force of the previous
communication point held constant, as any fixed-step master gives it. The coupling is one way: the lattice's
backplate is rigid and has no input, so the support's motion does not act back on the lattice.

Writes a PNG (force on the plate, force passed on, displacement of the support) and prints the peaks.
"""
from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from builder import build as build_fmu
from fmu_src.published import STUDY_BEST_ORDER as PUBLISHED_BEST

SUPPORT_SOURCE = Path(__file__).resolve().parent / "support_fmu" / "support.c"
SUPPORT_GUID = "{b0d1e5a4-5c1b-4d7e-9f00-5a11e5ba0001}"  # the same literal as in support.c
NANOSECONDS = 1_000_000_000
# name: (value reference, causality, start); the value references are support.c's enum
SUPPORT_VARIABLES = {
    "m": (0, "parameter", 20.0, "kg", "Mass of the support"),
    "k": (1, "parameter", 2.0e4, "N/m", "Stiffness of the mounting"),
    "c": (2, "parameter", 200.0, "N.s/m", "Damping of the mounting"),
    "max_substep": (3, "parameter", 1e-3, "s", "Longest RK4 substep inside a communication step"),
    "F": (4, "input", 0.0, "N", "Force on the support (the lattice's backplate force)"),
    "x": (5, "output", None, "m", "Displacement of the support"),
    "v": (6, "output", None, "m/s", "Velocity of the support"),
    "F_support": (7, "output", None, "N", "Force passed on behind the support: k x + c v"),
}


def support_model_description() -> str:
    rows, outputs = [], []
    for index, (name, (vr, causality, start, unit, description)) in enumerate(SUPPORT_VARIABLES.items(), 1):
        if causality == "parameter":
            attributes, real = 'causality="parameter" variability="fixed"', f'start="{start!r}" unit="{unit}"'
        elif causality == "input":
            attributes, real = 'causality="input" variability="continuous"', f'start="{start!r}" unit="{unit}"'
        else:
            attributes, real = 'causality="output" variability="continuous" initial="calculated"', f'unit="{unit}"'
            outputs.append(index)
        rows.append(f'    <ScalarVariable name="{name}" valueReference="{vr}" {attributes} '
                    f'description="{description}">\n      <Real {real}/>\n    </ScalarVariable>')
    units = "\n".join(f'    <Unit name="{u}"/>' for u in sorted({v[3] for v in SUPPORT_VARIABLES.values()}))
    unknowns = "\n".join(f'      <Unknown index="{i}"/>' for i in outputs)
    return f"""<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="2.0" modelName="BackplateSupport" guid="{SUPPORT_GUID}"
  description="A mass on a spring and a damper, pushed by the lattice's backplate force"
  generationTool="examples/backplate_support.py" numberOfEventIndicators="0">
  <CoSimulation modelIdentifier="BackplateSupport" canHandleVariableCommunicationStepSize="true">
    <SourceFiles>
      <File name="support.c"/>
    </SourceFiles>
  </CoSimulation>
  <UnitDefinitions>
{units}
  </UnitDefinitions>
  <DefaultExperiment startTime="0" stopTime="8" stepSize="0.01"/>
  <ModelVariables>
{chr(10).join(rows)}
  </ModelVariables>
  <ModelStructure>
    <Outputs>
{unknowns}
    </Outputs>
    <InitialUnknowns>
{unknowns}
    </InitialUnknowns>
  </ModelStructure>
</fmiModelDescription>
"""


def build_support_fmu(output: str | Path) -> Path:
    """Compiles support.c and zips BackplateSupport.fmu (binary and source)."""
    output = Path(output)
    folder, suffix = build_fmu.platform_folder()
    with tempfile.TemporaryDirectory(prefix="support_fmu_") as staging_name:
        staging = Path(staging_name)
        sources = staging / "sources"
        sources.mkdir()
        shutil.copy2(SUPPORT_SOURCE, sources / "support.c")
        for header in ("fmi2Functions.h", "fmi2FunctionTypes.h", "fmi2TypesPlatform.h"):
            shutil.copy2(build_fmu.SOURCE_DIR / "include" / header, sources / header)
        (staging / "modelDescription.xml").write_text(support_model_description())
        build_fmu.compile_shared_library([sources / "support.c"], staging / "binaries" / folder /
                                         f"BackplateSupport{suffix}", [sources], werror=True)
        output.parent.mkdir(parents=True, exist_ok=True)
        with zipfile.ZipFile(output, "w", zipfile.ZIP_DEFLATED) as archive:
            for path in sorted(staging.rglob("*")):
                if path.is_file():
                    archive.write(path, path.relative_to(staging).as_posix())
    return output


@dataclass
class Result:
    time: np.ndarray
    backplate_force: np.ndarray  # the lattice's output
    support_input: np.ndarray  # what the support saw over the step ending at each time
    support_force: np.ndarray  # F_support
    support_displacement: np.ndarray  # x
    peak_backplate_force: float  # the lattice's own sampled peak output


def run(lattice_fmu: str | Path, support_fmu: str | Path, order=PUBLISHED_BEST, horizon: float = 8.0,
        step: float = 0.01, support_parameters: dict | None = None) -> Result:
    """Co-simulates both FMUs with libcosim as the master and returns the time series."""
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver
    from libcosimpy.CosimSlave import CosimLocalSlave

    log_output_level(CosimLogLevel.ERROR)
    step_ns = int(round(step * NANOSECONDS))
    steps = int(round(horizon / step))
    execution = CosimExecution.from_step_size(step_size=step_ns)
    lattice = execution.add_local_slave(CosimLocalSlave(fmu_path=str(lattice_fmu), instance_name="lattice"))
    support = execution.add_local_slave(CosimLocalSlave(fmu_path=str(support_fmu), instance_name="support"))
    lattice_vr = {v.name.decode(): v.reference for v in execution.slave_variables(lattice)}
    support_vr = {v.name.decode(): v.reference for v in execution.slave_variables(support)}
    for column, material in enumerate(order, 1):
        execution.integer_initial_value(lattice, lattice_vr[f"material[{column}]"], int(material))
    for name, value in (support_parameters or {}).items():
        if name not in support_vr or SUPPORT_VARIABLES[name][1] != "parameter":
            raise ValueError(f"unknown support parameter {name!r}: allowed "
                             f"{[n for n, v in SUPPORT_VARIABLES.items() if v[1] == 'parameter']}")
        execution.real_initial_value(support, support_vr[name], float(value))
    execution.connect_real_variables(lattice, lattice_vr["backplate_force"], support, support_vr["F"])
    observer = CosimObserver.create_last_value()
    execution.add_observer(observer)

    lattice_out = [lattice_vr["backplate_force"], lattice_vr["peak_backplate_force"]]
    support_out = [support_vr[name] for name in ("F", "F_support", "x")]
    rows = [[0.0, 0.0, 0.0, 0.0, 0.0]]  # everything is at rest at t = 0 (no contact yet)
    peak = 0.0
    for i in range(steps):
        if not execution.step(1):
            raise RuntimeError(f"libcosim failed at t = {i * step:g} s: {execution.status()}")
        force, peak = observer.last_real_values(lattice, lattice_out)
        seen, passed_on, displacement = observer.last_real_values(support, support_out)
        rows.append([(i + 1) * step, force, seen, passed_on, displacement])
    data = np.array(rows)
    return Result(data[:, 0], data[:, 1], data[:, 2], data[:, 3], data[:, 4], float(peak))


def plot(result: Result, output: str | Path, title: str) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    output = Path(output)
    output.parent.mkdir(parents=True, exist_ok=True)
    figure, (forces, motion) = plt.subplots(2, 1, figsize=(9, 6.5), sharex=True)
    forces.plot(result.time, result.backplate_force, label="on the backplate (lattice FMU output)", lw=1.4)
    forces.plot(result.time, result.support_force, label="passed on behind the support (k x + c v)", lw=1.4)
    forces.axhline(result.peak_backplate_force, color="grey", ls=":", lw=1,
                   label=f"lattice peak {result.peak_backplate_force:.1f} N")
    forces.set_ylabel("force (N)")
    forces.legend(loc="upper right", fontsize=9)
    forces.grid(alpha=0.3)
    forces.set_title(title, fontsize=10)
    motion.plot(result.time, 1000.0 * result.support_displacement, color="tab:green", lw=1.4)
    motion.set_ylabel("support displacement (mm)")
    motion.set_xlabel("time (s)")
    motion.grid(alpha=0.3)
    figure.tight_layout()
    figure.savefig(output, dpi=110)
    plt.close(figure)
    return output


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--order", default=",".join(map(str, PUBLISHED_BEST)),
                        help="material order, comma-separated (default: the published best)")
    parser.add_argument("--horizon", type=float, default=2.0,
                        help="seconds to simulate (default 2: the impact is over by then; the study used 8)")
    parser.add_argument("--step", type=float, default=0.01, help="communication step in s (default 0.01)")
    parser.add_argument("--lattice-fmu", default=str(build_fmu.MODELS_DIR / "MassSpringLattice.fmu"),
                        help="the lattice FMU (built with build_fmu.py when missing)")
    parser.add_argument("--mass", type=float, default=20.0, help="support mass m in kg (default 20)")
    parser.add_argument("--stiffness", type=float, default=2.0e4, help="support stiffness k in N/m (default 2e4)")
    parser.add_argument("--damping", type=float, default=200.0, help="support damping c in N s/m (default 200)")
    parser.add_argument("-o", "--output", default=str(Path("results") / "backplate_support.png"),
                        help="where to write the picture (default results/backplate_support.png)")
    args = parser.parse_args(argv)
    try:
        order = tuple(int(m) for m in args.order.split(","))
    except ValueError:
        parser.error(f"--order {args.order!r}: give integers separated by commas, e.g. 1,2,3,4,5,6,7,8,9,10,11")
    lattice_fmu = Path(args.lattice_fmu)
    if not lattice_fmu.is_file():
        print(f"{lattice_fmu} not found: building it", file=sys.stderr)
        lattice_fmu = build_fmu.build_fmu(output=lattice_fmu)
    with tempfile.TemporaryDirectory(prefix="backplate_support_") as work:
        support_fmu = build_support_fmu(Path(work) / "BackplateSupport.fmu")
        result = run(lattice_fmu, support_fmu, order, args.horizon, args.step,
                     {"m": args.mass, "k": args.stiffness, "c": args.damping})
    title = (f"lattice FMU (order {list(order)}) -> BackplateSupport FMU\n"
             f"support m = {args.mass:g} kg, k = {args.stiffness:g} N/m, c = {args.damping:g} N s/m; "
             f"master: libcosim, {args.step:g} s steps")
    picture = plot(result, args.output, title)
    print(f"peak force on the backplate:   {result.backplate_force.max():.3f} N "
          f"(the lattice's sampled peak output: {result.peak_backplate_force:.3f} N)")
    print(f"peak force passed on:          {np.abs(result.support_force).max():.3f} N")
    print(f"peak support displacement:     {1000 * np.abs(result.support_displacement).max():.3f} mm")
    print(f"picture: {picture}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
