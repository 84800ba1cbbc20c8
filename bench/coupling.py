"""Coupling: where the armour system's co-simulation holds and where it fails, measured and predicted.

    python -m bench.coupling            # about 2.5 min: 12 steps x 4 masters x 2 hulls
    python -m bench.coupling --quick    # about 1 min: 6 steps x 2 masters x 2 hulls

The armour system (`python build_fmu.py --system`: projectile -> lattice -> hull, three FMUs) co-simulated over
0.4 s, by which the backplate force has peaked, at communication steps from 1e-5 to 1e-2 s, by each master and
scheme available: libcosim's fixed-step master and FMPy's simulate_ssp (Jacobi: each FMU steps on the others'
values of the last communication point), examples/armour_system.py's own Gauss-Seidel loop over FMPy's FMI 2
API (projectile, lattice, hull in turn, each on the newest values) and libcosim's ECCO (energy-conservation
step control over the two power bonds, started at the step, free to go ten times shorter or longer).

Each run against the one-model reference of the whole system (reference/system.py: projectile, lattice and hull
as one ODE, every switch an event): the relative error of the lattice's sampled peak backplate force, and the
coupling's energy error: the work the projectile's contact force did on the face (its face_work) less the work
the lattice took in through its ports (external_work) less what the hull holds and dissipated (its kinetic and
spring energy and dissipated_energy), over the projectile's kinetic energy at the start. A run that fails, or
whose peak or energy error is more than half, is unstable (its coupling diverged).

Two hulls: the hull FMU's default, and the wall as a hull (one lattice mass on a ground spring as stiff as the
backplate's springs together, no damper). Predicted: explicit coupling of a mass m on a coupled spring k and
damper c held over a step H is stable for H < min(2c/k, 2m/c); at the back port k and c are the backplate's
springs and dampers of the column-C masses in parallel and m the hull's mass (builder.system.port_limits). The
measured limit is bracketed by the largest stable and the smallest unstable step of libcosim's fixed step.
"""

from __future__ import annotations

import math
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

from builder.build import resolve_scene
from builder.system import build_system, port_limits
from fmu_src.component_table import component_table
from scenes import DEFAULT_SCENE

from .measurements import PAGES, Page, Run, Table, write_page

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "examples"))
import armour_system  # noqa: E402

HORIZON = 0.4
STEPS = (1e-5, 2e-5, 5e-5, 1e-4, 2e-4, 5e-4, 1e-3, 1.5e-3, 2e-3, 3e-3, 5e-3, 1e-2)
QUICK_STEPS = (1e-4, 5e-4, 1e-3, 2e-3, 5e-3, 1e-2)
MASTERS = ("libcosim", "fmpy", "gauss-seidel", "libcosim-ecco")
QUICK_MASTERS = ("libcosim", "gauss-seidel")
# ECCO's smallest start step: below it its step control runs the horizon in hundreds of thousands of steps.
ECCO_SMALLEST_START = 1e-4
UNSTABLE_ERROR = 0.5  # a peak or an energy off by more than half: the coupling diverged
REFERENCE_RTOL = 1e-10
CHART = PAGES / "coupling.png"


@dataclass(frozen=True)
class HullCase:
    name: str
    mass: float  # kg
    stiffness: float  # N/m
    damping: float  # N s/m

    @property
    def parameters(self) -> dict[str, float]:
        return {"m": self.mass, "k": self.stiffness, "c": self.damping}


def hull_cases() -> tuple[HullCase, ...]:
    hull = {v.name: v.start for v in component_table("hull").variables}
    interface = resolve_scene(DEFAULT_SCENE).interface()
    starts = {v.name: v.start for v in interface.exposed + interface.fixed}
    face = interface.rows * interface.depth
    lattice_mass = float(starts["mass"][0]) if isinstance(starts.get("mass"), tuple) else float(starts["mass"])
    return (
        HullCase("default hull", hull["m"], hull["k"], hull["c"]),
        HullCase("wall as a hull", lattice_mass, face * float(starts["k_wall"]), 0.0),
    )


@dataclass(frozen=True)
class CouplingPoint:
    """One master's run of one hull at one step (ECCO: its start step)."""

    case: str
    master: str
    step: float
    peak: float | None  # the lattice's sampled peak backplate force (N); None: the run failed
    peak_error: float | None  # relative, against the reference
    energy_error: float | None  # the coupling's, over the projectile's initial kinetic energy
    seconds: float
    failure: str | None = None

    @property
    def stable(self) -> bool:
        return (
            self.failure is None
            and self.peak_error is not None
            and self.peak_error <= UNSTABLE_ERROR
            and self.energy_error <= UNSTABLE_ERROR
        )


def reference_peak(case: HullCase) -> float:
    from reference.lattice3d import PlateScene
    from reference.system import Hull, Projectile, SystemScene, simulate_system

    start = {v.name: v.start for v in component_table("projectile").variables}
    interface = resolve_scene(DEFAULT_SCENE).interface()
    scene = SystemScene(
        PlateScene(rows=interface.rows, cols=interface.cols, depth=interface.depth),
        load_mode="projectile",
        projectile=Projectile(
            start["projectile_mass"],
            start["projectile_speed"],
            start["contact_stiffness"],
            start["contact_exponent"],
            start["contact_damping"],
        ),
        hull=Hull(case.mass, case.stiffness, case.damping),
    )
    return simulate_system(scene, horizon=HORIZON, rtol=REFERENCE_RTOL, atol=REFERENCE_RTOL * 1e-2).peak_backplate_force


def energy_error(run: armour_system.SystemRun, case: HullCase) -> float:
    start = {v.name: v.start for v in component_table("projectile").variables}
    initial = 0.5 * start["projectile_mass"] * start["projectile_speed"] ** 2
    x, v = run["hull", "x"][-1], run["hull", "v"][-1]
    hull = 0.5 * case.mass * v * v + 0.5 * case.stiffness * x * x + run["hull", "dissipated_energy"][-1]
    return abs(run["projectile", "face_work"][-1] - run["lattice", "external_work"][-1] - hull) / initial


def measure(ssp: Path, case: HullCase, master: str, step: float, reference: float) -> CouplingPoint:
    started = time.perf_counter()
    try:
        if master in armour_system.SCHEMES:
            run = armour_system.run_loop(ssp, HORIZON, step, case.parameters, scheme=master)
        else:
            runner = {
                "libcosim": armour_system.run_libcosim,
                "fmpy": armour_system.run_fmpy,
                "libcosim-ecco": armour_system.run_libcosim_ecco,
            }[master]
            run = runner(ssp, HORIZON, step, case.parameters)
    except Exception as exc:  # a diverging coupling ends in whatever error the FMU or the master raises
        reason = (str(exc).strip().splitlines() or [type(exc).__name__])[0][:120]
        return CouplingPoint(case.name, master, step, None, None, None, time.perf_counter() - started, reason)
    seconds = time.perf_counter() - started
    peak = float(run["lattice", "peak_backplate_force"][-1])
    if not math.isfinite(peak):
        return CouplingPoint(case.name, master, step, None, None, None, seconds, "the peak is not finite")
    return CouplingPoint(
        case.name, master, step, peak, abs(peak - reference) / reference, energy_error(run, case), seconds
    )


def bracket(points: list[CouplingPoint]) -> tuple[float | None, float | None]:
    """(the largest stable step below the smallest unstable one, the smallest unstable step)."""
    unstable = [p.step for p in points if not p.stable]
    first_unstable = min(unstable) if unstable else None
    stable = [p.step for p in points if p.stable and (first_unstable is None or p.step < first_unstable)]
    return (max(stable) if stable else None), first_unstable


def chart(
    points: list[CouplingPoint], cases, predicted: dict[str, float], measured: dict[str, tuple], path: Path
) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, axes = plt.subplots(1, len(cases), figsize=(12, 4.6), sharey=True)
    for axis, case in zip(axes, cases):
        for master in dict.fromkeys(p.master for p in points):
            ours = [p for p in points if p.case == case.name and p.master == master and p.peak_error is not None]
            if ours:
                (line,) = axis.loglog(
                    [p.step for p in ours], [max(p.peak_error, 1e-9) for p in ours], "o-", label=f"{master}: peak"
                )
                axis.loglog(
                    [p.step for p in ours],
                    [max(p.energy_error, 1e-9) for p in ours],
                    "s--",
                    ms=3,
                    color=line.get_color(),
                    alpha=0.6,
                    label=f"{master}: energy",
                )
        axis.axvline(predicted[case.name], color="k", ls=":", label="predicted limit min(2c/k, 2m/c)")
        first_unstable = measured[case.name][1]
        if first_unstable is not None:
            axis.axvspan(first_unstable, max(STEPS), color="tab:red", alpha=0.12, label="unstable (libcosim, measured)")
        axis.set_title(
            f"{case.name}: m = {case.mass:g} kg, k = {case.stiffness:g} N/m, c = {case.damping:g} N s/m", fontsize=9
        )
        axis.set_xlabel("communication step (s)")
        axis.grid(alpha=0.3, which="both")
    axes[0].set_ylabel("relative error against the one-model reference")
    axes[-1].legend(fontsize=7, loc="lower right")
    figure.tight_layout()
    figure.savefig(path, dpi=100)
    plt.close(figure)
    return path


def main(argv=None) -> int:
    run = Run.start(__file__, argv)
    parser = run.parser(
        __doc__, quick=f"steps {', '.join(f'{s:g}' for s in QUICK_STEPS)} s; masters {', '.join(QUICK_MASTERS)}"
    )
    args = parser.parse_args(argv)
    steps, masters = (QUICK_STEPS, QUICK_MASTERS) if args.quick else (STEPS, MASTERS)
    cases = hull_cases()
    points = []
    with tempfile.TemporaryDirectory(prefix="bench_coupling_") as folder:
        ssp = build_system(Path(folder) / "ArmourSystem.ssp")
        default_step = armour_system.system_step(ssp)
        references = {case.name: reference_peak(case) for case in cases}
        for case in cases:
            for master in masters:
                for step in steps:
                    if master == "libcosim-ecco" and step < ECCO_SMALLEST_START:
                        continue
                    point = measure(ssp, case, master, step, references[case.name])
                    print(
                        f"{case.name}, {master}, {step:g} s: "
                        + (
                            f"peak error {point.peak_error:.2e}, energy error {point.energy_error:.2e}"
                            if point.peak_error is not None
                            else f"failed: {point.failure}"
                        )
                        + f" ({point.seconds:.1f} s)",
                        flush=True,
                    )
                    points.append(point)
    predicted = {case.name: next(p for p in port_limits(case.mass) if p.port == "back") for case in cases}
    front = next(p for p in port_limits() if p.port == "front")
    limits = {name: limit.limit for name, limit in predicted.items()}
    measured = {
        case.name: bracket([p for p in points if p.case == case.name and p.master == "libcosim"]) for case in cases
    }
    chart(points, cases, limits, measured, CHART)

    def bracket_text(name):
        low, high = measured[name]
        if high is None:
            return f"stable at every step up to {max(steps):g} s"
        return f"between {low:g} and {high:g} s" if low is not None else f"below {high:g} s"

    wall = cases[1].name
    low, high = measured[wall]
    ratio = (
        f"; the predicted {limits[wall] * 1e3:.3g} ms is within a factor 2 of both ends"
        if low is not None and high is not None and limits[wall] / 2 <= low and high <= 2 * limits[wall]
        else ""
    )
    at_default = {p.case: p for p in points if p.master == "libcosim" and p.step == default_step}
    rows = tuple(
        (
            p.case,
            p.master,
            f"{p.step:g}",
            "" if p.peak is None else f"{p.peak:.3f}",
            "" if p.peak_error is None else f"{p.peak_error:.2e}",
            "" if p.energy_error is None else f"{p.energy_error:.2e}",
            "stable" if p.stable else f"**unstable**{': ' + p.failure if p.failure else ''}",
            f"{p.seconds:.1f}",
        )
        for p in points
    )
    limit_rows = tuple(
        (
            case.name,
            f"{case.mass:g}",
            f"{predicted[case.name].stiffness:g}",
            f"{predicted[case.name].damping:g}",
            f"{limits[case.name] * 1e3:.3g}",
            bracket_text(case.name),
            f"{references[case.name]:.3f}",
        )
        for case in cases
    )
    page = Page(
        name=run.name,
        title="Coupling: where the armour system holds and where it fails",
        headline=(
            f"the wall as a hull: explicit coupling measured unstable {bracket_text(wall)} against the "
            f"predicted min(2c/k, 2m/c) = {limits[wall] * 1e3:.3g} ms{ratio}"
            + (
                f"; at the system's default step {default_step:g} s libcosim's peak is "
                f"{at_default[cases[0].name].peak_error:.1e} off the one-model reference"
                if cases[0].name in at_default and at_default[cases[0].name].peak_error is not None
                else ""
            )
        ),
        summary=(
            __doc__.split("\n\n", 2)[2].strip()
            + "\n\n"
            + f"The system's default step (`python build_fmu.py --system`): {default_step:g} s. The chart: the "
            "relative error of the sampled peak (solid) and the energy error (dashed) against the step, the "
            "predicted limit dotted, the steps at which libcosim's fixed step diverged shaded.\n\n"
            "![error against communication step](coupling.png)"
        ),
        notes=(
            f"The front port's predicted limit ({front.what}: m = {front.mass:.3g} kg, k = {front.stiffness:.3g} "
            f"N/m, c = {front.damping:.3g} N s/m) is {front.limit * 1e3:.3g} ms, above every step here: "
            "the back port bounds the system's step.",
            "FMPy's communication times are sums (0.3400000000000002 where libcosim has 0.34): the "
            "lattice takes those samples from inside its steps, through its dense output, and gives the same "
            "peak (tests/test_armour_system.py).",
        ),
        tables=(
            Table(
                (
                    "hull",
                    "m (kg)",
                    "k at the back port (N/m)",
                    "c at the back port (N s/m)",
                    "predicted limit (ms)",
                    "measured limit (libcosim)",
                    "reference peak (N)",
                ),
                limit_rows,
                caption="**Stability limits:**",
            ),
            Table(
                ("hull", "master", "step (s)", "peak (N)", "peak error", "energy error", "coupling", "wall s"),
                rows,
                caption="**Every run:**",
            ),
        ),
    )
    write_page(run, page)
    return 0


if __name__ == "__main__":
    sys.exit(main())
