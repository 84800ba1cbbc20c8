"""Co-simulation example: a projectile strikes the armour, the armour pushes the hull it is mounted on.

    python examples/armour_system.py                         # models/ArmourSystem.ssp in libcosim, 1 s
    python examples/armour_system.py --master fmpy --step 1e-3 --hull-mass 200 -o results/armour_fmpy.png

Three FMUs, one master, the system file `python build_fmu.py --system` writes (built here if missing):
- Projectile.fmu (fmu_src/projectile/): a rigid body with Hunt-Crossley contact; its step-averaged contact force
  pushes the lattice's front port (F_front), and it reads the face's motion (x_front, v_front);
- MassSpringLattice.fmu in load_mode input: it passes its backplate force to the hull and reads the hull's
  motion (x_back, v_back) as its backplate's;
- Hull.fmu (fmu_src/hull/): a mass on a spring and a damper to the ground.
The master (libcosim, or FMPy's simulate_ssp) steps the three side by side and exchanges the ports' values at
every communication step: each FMU sees the others' values of the previous communication point (Jacobi). Such
explicit coupling is stable only below a step each port predicts; the example prints it beside the step it uses.
`--master jacobi` and `--master gauss-seidel` run the example's own loop over FMPy's FMI 2 API (Gauss-Seidel:
projectile, lattice, hull in turn, each on the newest values); `--master libcosim-ecco` libcosim's ECCO
algorithm, which adapts the step to the energy the two power bonds exchange (its outputs at the end only).

Writes a PNG (contact force and backplate force; the hull's displacement) and prints the peaks.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from lxml import etree

from builder.build import MODELS_DIR
from builder.system import (
    COMPONENTS,
    CONNECTIONS,
    ECCO_STEP_RANGE,
    LATTICE_PARAMETER_SET,
    OSP_NAME,
    RECORDED_OUTPUTS,
    SSD_NAME,
    SYSTEM,
    build_system,
    port_limits,
)

NANOSECONDS = 1_000_000_000
SCHEMES = ("jacobi", "gauss-seidel")  # this example's own master loop (run_loop)
MASTERS = ("libcosim", "fmpy", "libcosim-ecco", *SCHEMES)
# ECCO's power bonds: (component, its output, its input) at either end, velocity against force.
POWER_BONDS = (
    (("lattice", "v_front", "F_front"), ("projectile", "contact_force", "v_front")),
    (("lattice", "backplate_force", "v_back"), ("hull", "v", "F")),
)
HULL_PARAMETERS = ("m", "k", "c")
OBSERVED = RECORDED_OUTPUTS


@dataclass(frozen=True)
class SystemRun:
    """The observed outputs at every communication point after the start, by component and name."""

    master: str
    step: float
    time: np.ndarray
    outputs: dict[tuple[str, str], np.ndarray]

    def __getitem__(self, key: tuple[str, str]) -> np.ndarray:
        return self.outputs[key]

    @property
    def peak_backplate_force(self) -> float:
        return float(self.outputs["lattice", "backplate_force"].max())


def system_step(ssp: str | Path) -> float:
    """The communication step the system file sets (its libcosim annotation)."""
    with zipfile.ZipFile(ssp) as archive:
        root = etree.fromstring(archive.read(SSD_NAME))
    (algorithm,) = root.iter("{https://opensimulationplatform.com/SSP/1.0}FixedStepAlgorithm")
    return float(algorithm.get("baseStepSize"))


def run_libcosim(
    ssp: str | Path, horizon: float, step: float | None = None, hull: dict[str, float] | None = None
) -> SystemRun:
    """The system in libcosim (its fixed-step master, from the SSP); `step` None: the system file's."""
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver

    log_output_level(CosimLogLevel.ERROR)
    step = system_step(ssp) if step is None else step
    execution = CosimExecution.from_ssp_file(str(ssp), step_size=round(step * NANOSECONDS))
    observer = CosimObserver.create_last_value()
    execution.add_observer(observer)
    indices = {name: execution.slave_index_from_instance_name(name) for name in OBSERVED}
    references = {
        name: {v.name.decode(): v.reference for v in execution.slave_variables(index)}
        for name, index in indices.items()
    }
    for name, value in (hull or {}).items():
        execution.real_initial_value(indices["hull"], references["hull"][name], float(value))
    rows = []
    for i in range(1, round(horizon / step) + 1):
        if not execution.step(1):
            raise RuntimeError(f"libcosim failed at t = {i * step:g} s: {execution.status()}")
        row = [i * step]
        for name, outputs in OBSERVED.items():
            row += observer.last_real_values(indices[name], [references[name][o] for o in outputs])
        rows.append(row)
    return _run("libcosim", step, rows)


def run_fmpy(
    ssp: str | Path, horizon: float, step: float | None = None, hull: dict[str, float] | None = None
) -> SystemRun:
    """The system in FMPy's simulate_ssp, which applies no parameter binding: the lattice's parameter set (and
    the hull's parameters) go in as its parameter_set, named from the system."""
    from fmpy.ssp.simulation import simulate_ssp
    from fmpy.ssp.ssd import Parameter, read_ssv

    step = system_step(ssp) if step is None else step
    parameters = read_ssv(str(ssp), resource=LATTICE_PARAMETER_SET)
    for parameter in parameters.parameters:
        parameter.name = "lattice." + parameter.name
    for name, value in (hull or {}).items():
        parameter = Parameter()
        parameter.name, parameter.type, parameter.value = f"hull.{name}", "Real", float(value)
        parameters.parameters.append(parameter)
    result = simulate_ssp(str(ssp), stop_time=horizon + step / 2, step_size=step, parameter_set=parameters)
    # simulate_ssp records each step's outputs (its connectors' values) at the step's start time
    missing = [
        f"{name}.{o}" for name, outputs in OBSERVED.items() for o in outputs if f"{name}.{o}" not in result.dtype.names
    ]
    if missing:
        raise ValueError(f"the system file declares no connector for {', '.join(missing)}")
    rows = [
        [record["time"] + step] + [record[f"{name}.{o}"] for name, outputs in OBSERVED.items() for o in outputs]
        for record in result
    ]
    return _run("fmpy", step, rows[: round(horizon / step)])


def _parameter_values(ssp: str | Path, hull: dict[str, float] | None) -> dict[str, dict[str, float]]:
    """Each component's parameters as the system file binds them (the lattice's set), with the hull's given."""
    from fmpy.ssp.ssd import read_ssv

    lattice = {p.name: p.value for p in read_ssv(str(ssp), resource=LATTICE_PARAMETER_SET).parameters}
    return {"lattice": lattice, "hull": dict(hull or {}), "projectile": {}}


def run_loop(
    ssp: str | Path,
    horizon: float,
    step: float | None = None,
    hull: dict[str, float] | None = None,
    scheme: str = "jacobi",
) -> SystemRun:
    """The system under a master loop of this example's over FMPy's FMI 2 Co-Simulation API, with the values
    exchanged once after initialisation: Jacobi (every FMU steps on the others' values of the last
    communication point, as libcosim and simulate_ssp do) or Gauss-Seidel (projectile, lattice, hull in turn,
    each on the newest values: the lattice gets the projectile's mean force over the same step)."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave
    from fmpy.ssp.ssd import read_ssd

    if scheme not in SCHEMES:
        raise ValueError(f"scheme {scheme!r}: allowed {', '.join(SCHEMES)}")
    step = system_step(ssp) if step is None else step
    parameters = _parameter_values(ssp, hull)
    system = read_ssd(str(ssp)).system
    with tempfile.TemporaryDirectory(prefix="armour_system_") as folder:
        with zipfile.ZipFile(ssp) as archive:
            archive.extractall(folder)
        slaves, references = {}, {}
        try:
            for component in system.elements:
                fmu = str(Path(folder) / component.source)
                description = read_model_description(fmu)
                slave = FMU2Slave(
                    guid=description.guid,
                    modelIdentifier=description.coSimulation.modelIdentifier,
                    unzipDirectory=extract(fmu, str(Path(folder) / component.name)),
                    instanceName=component.name,
                )
                slave.instantiate()
                slaves[component.name] = slave
                variables = {v.name: v for v in description.modelVariables}
                references[component.name] = {name: v.valueReference for name, v in variables.items()}
                slave.setupExperiment(startTime=0.0)
                for name, value in parameters[component.name].items():
                    if variables[name].type in ("Integer", "Enumeration"):
                        slave.setInteger([variables[name].valueReference], [int(value)])
                    else:
                        slave.setReal([variables[name].valueReference], [float(value)])
                slave.enterInitializationMode()
                slave.exitInitializationMode()

            def get(name, variable):
                return slaves[name].getReal([references[name][variable]])[0]

            def feed(name):
                for c in CONNECTIONS:
                    if c.target_component == name:
                        slaves[name].setReal(
                            [references[name][c.target_variable]], [get(c.source_component, c.source_variable)]
                        )

            rows = []
            for i in range(round(horizon / step)):
                if scheme == "jacobi":
                    values = {
                        (c.source_component, c.source_variable): get(c.source_component, c.source_variable)
                        for c in CONNECTIONS
                    }
                    for c in CONNECTIONS:
                        slaves[c.target_component].setReal(
                            [references[c.target_component][c.target_variable]],
                            [values[c.source_component, c.source_variable]],
                        )
                    for name in COMPONENTS:
                        slaves[name].doStep(i * step, step)
                else:
                    for name in COMPONENTS:
                        feed(name)
                        slaves[name].doStep(i * step, step)
                rows.append([(i + 1) * step] + [get(name, o) for name, outputs in OBSERVED.items() for o in outputs])
        finally:
            for slave in slaves.values():
                slave.terminate()
                slave.freeInstance()
    return _run(scheme, step, rows)


def run_libcosim_ecco(
    ssp: str | Path, horizon: float, step: float | None = None, hull: dict[str, float] | None = None
) -> SystemRun:
    """The system in libcosim under its ECCO algorithm (energy-conservation-based step control over the two
    power bonds: the front port's F_front and v_front, the back port's backplate force and v_back), built here
    as the system file's OspSystemStructure.xml sets it up, starting from `step` (None: the system's); the
    outputs at the end only, since its steps are its own."""
    from fmpy.ssp.ssd import read_ssd
    from libcosimpy.CosimAlgorithm import CosimAlgorithm, EccoParams
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver
    from libcosimpy.CosimSlave import CosimLocalSlave

    log_output_level(CosimLogLevel.ERROR)
    step = system_step(ssp) if step is None else step
    parameters = _parameter_values(ssp, hull)
    system = read_ssd(str(ssp)).system
    with tempfile.TemporaryDirectory(prefix="armour_system_") as folder:
        with zipfile.ZipFile(ssp) as archive:
            archive.extractall(folder)
        algorithm = CosimAlgorithm.create_ecco_algorithm(
            EccoParams(step_size=step, min_step_size=step / ECCO_STEP_RANGE, max_step_size=step * ECCO_STEP_RANGE)
        )
        execution = CosimExecution.from_algorithm(algorithm)
        indices, references = {}, {}
        for component in system.elements:
            indices[component.name] = execution.add_local_slave(
                CosimLocalSlave(fmu_path=str(Path(folder) / component.source), instance_name=component.name)
            )
            references[component.name] = {
                v.name.decode(): v.reference for v in execution.slave_variables(indices[component.name])
            }
        for name, values in parameters.items():
            for variable, value in values.items():
                if name == "lattice":
                    execution.integer_initial_value(indices[name], references[name][variable], int(value))
                else:
                    execution.real_initial_value(indices[name], references[name][variable], float(value))
        for c in CONNECTIONS:
            execution.connect_real_variables(
                indices[c.source_component],
                references[c.source_component][c.source_variable],
                indices[c.target_component],
                references[c.target_component][c.target_variable],
            )
        for (a, a_out, a_in), (b, b_out, b_in) in POWER_BONDS:
            algorithm.add_power_bond(
                indices[a],
                references[a][a_out],
                references[a][a_in],
                indices[b],
                references[b][b_out],
                references[b][b_in],
            )
        observer = CosimObserver.create_last_value()
        execution.add_observer(observer)
        if not execution.simulate_until(target_time=round(horizon * NANOSECONDS)):
            raise RuntimeError(f"libcosim's ECCO failed before t = {horizon:g} s: {execution.status()}")
        row = [horizon]
        for name, outputs in OBSERVED.items():
            row += observer.last_real_values(indices[name], [references[name][o] for o in outputs])
    return _run("libcosim-ecco", step, [row])


def run_libcosim_ecco_from_osp(ssp: str | Path, horizon: float, hull: dict[str, float] | None = None) -> SystemRun:
    """The system under libcosim's ECCO as libcosim reads it from its own system structure, the system file's
    OspSystemStructure.xml. libcosimpy 0.0.6's parser refuses a system of two power bonds ("The number of
    powerbonds (1) is not equal to the number of unique power bond names (2)", a check libcosim made inside its
    loop over the bonds): run_libcosim_ecco builds the same execution through the API."""
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver

    log_output_level(CosimLogLevel.ERROR)
    with tempfile.TemporaryDirectory(prefix="armour_system_") as folder:
        with zipfile.ZipFile(ssp) as archive:
            archive.extractall(folder)
        execution = CosimExecution.from_osp_config_file(str(Path(folder) / OSP_NAME))
        indices = {name: execution.slave_index_from_instance_name(name) for name in OBSERVED}
        references = {
            name: {v.name.decode(): v.reference for v in execution.slave_variables(index)}
            for name, index in indices.items()
        }
        for name, value in (hull or {}).items():
            execution.real_initial_value(indices["hull"], references["hull"][name], float(value))
        observer = CosimObserver.create_last_value()
        execution.add_observer(observer)
        if not execution.simulate_until(target_time=round(horizon * NANOSECONDS)):
            raise RuntimeError(f"libcosim's ECCO failed before t = {horizon:g} s: {execution.status()}")
        row = [horizon]
        for name, outputs in OBSERVED.items():
            row += observer.last_real_values(indices[name], [references[name][o] for o in outputs])
    return _run("libcosim-ecco", system_step(ssp), [row])


def _run(master: str, step: float, rows: list[list[float]]) -> SystemRun:
    data = np.array(rows)
    keys = [(name, output) for name, outputs in OBSERVED.items() for output in outputs]
    return SystemRun(master, step, data[:, 0], {key: data[:, i + 1] for i, key in enumerate(keys)})


def plot(run: SystemRun, output: str | Path, title: str) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    output = Path(output)
    output.parent.mkdir(parents=True, exist_ok=True)
    figure, (forces, motion) = plt.subplots(2, 1, figsize=(9, 6.5), sharex=True)
    forces.plot(
        run.time, run["projectile", "contact_force"], label="contact force on the face (projectile FMU)", lw=1.4
    )
    forces.plot(run.time, run["lattice", "backplate_force"], label="force on the backplate (lattice FMU)", lw=1.4)
    forces.set_ylabel("force (N)")
    forces.legend(loc="upper right", fontsize=9)
    forces.grid(alpha=0.3)
    forces.set_title(title, fontsize=10)
    motion.plot(run.time, 1000.0 * run["hull", "x"], color="tab:green", lw=1.4)
    motion.set_ylabel("hull displacement (mm)")
    motion.set_xlabel("time (s)")
    motion.grid(alpha=0.3)
    figure.tight_layout()
    figure.savefig(output, dpi=110)
    plt.close(figure)
    return output


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--ssp",
        default=str(MODELS_DIR / f"{SYSTEM}.ssp"),
        help="the system file (built with build_fmu.py --system when missing)",
    )
    parser.add_argument("--master", choices=MASTERS, default="libcosim", help="the co-simulation master")
    parser.add_argument("--horizon", type=float, default=1.0, help="seconds to simulate (default 1)")
    parser.add_argument("--step", type=float, help="communication step in s (default: the system file's)")
    parser.add_argument("--hull-mass", type=float, help="hull mass m in kg (default: the hull FMU's)")
    parser.add_argument("--hull-stiffness", type=float, help="hull stiffness k in N/m (default: the hull FMU's)")
    parser.add_argument("--hull-damping", type=float, help="hull damping c in N s/m (default: the hull FMU's)")
    parser.add_argument(
        "-o",
        "--output",
        default=str(Path("results") / "armour_system.png"),
        help="where to write the picture (default results/armour_system.png)",
    )
    args = parser.parse_args(argv)
    if not args.horizon > 0:
        parser.error(f"--horizon {args.horizon}: allowed a number of seconds > 0")
    if args.step is not None and not 0 < args.step <= args.horizon:
        parser.error(f"--step {args.step}: allowed 0 < step <= horizon ({args.horizon:g} s)")
    hull = {
        name: value
        for name, value in zip(HULL_PARAMETERS, (args.hull_mass, args.hull_stiffness, args.hull_damping))
        if value is not None
    }
    ssp = Path(args.ssp)
    if not ssp.is_file():
        print(f"{ssp} not found: building it", file=sys.stderr)
        ssp = build_system(ssp)
    step = system_step(ssp) if args.step is None else args.step
    for limit in port_limits(hull.get("m")):
        verdict = "stable" if step < limit.limit else "UNSTABLE"
        print(
            f"{limit.port} port ({limit.what}): predicted limit min(2c/k, 2m/c) = {limit.limit:.3g} s; "
            f"step {step:g} s: {verdict}"
        )
    if args.master in SCHEMES:
        run = run_loop(ssp, args.horizon, step, hull, scheme=args.master)
    else:
        runner = {"libcosim": run_libcosim, "fmpy": run_fmpy, "libcosim-ecco": run_libcosim_ecco}[args.master]
        run = runner(ssp, args.horizon, step, hull)
    print(
        f"peak force on the backplate:   {run['lattice', 'peak_backplate_force'][-1]:.3f} N "
        f"(the lattice's sampled peak)"
    )
    if len(run.time) < 2:
        print("libcosim's ECCO chooses its own steps: no time series, no picture")
        return 0
    title = f"projectile -> lattice -> hull ({SYSTEM}.ssp); master: {args.master}, {step:g} s steps" + (
        f"; hull {', '.join(f'{k} = {v:g}' for k, v in hull.items())}" if hull else ""
    )
    picture = plot(run, args.output, title)
    print(f"peak contact force:            {run['projectile', 'contact_force'].max():.3f} N")
    print(f"peak hull displacement:        {1000 * np.abs(run['hull', 'x']).max():.3f} mm")
    print(f"picture: {picture}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
