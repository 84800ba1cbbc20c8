"""The co-design polish's gradients: how far a forward difference of the recorded trace is from the truth.

    python -m bench.codesign_polish            # both rules, five relative steps, both fidelities (about 2 min)
    python -m bench.codesign_polish --quick    # the receiver rule, two steps

Why: the polish (``orchestrator.codesign.polish``) takes each sample's gradient d F_s / d z from forward differences
of the backplate force recorded at every sample (``finite_difference_jacobian``), and holds its first-order measure
against a tolerance of 0.01 (relative to the peak, per unit of scaled factor). An adaptive solver's error, divided
by the step, is noise in that gradient: this page measures it at each fidelity and relative step against central
differences of runs at rtol 1e-11 (the truth), on the study's 11 x 11 lattice at the study's best order with every
column's k, c and mass at the table's values (factor 1, inside the 0.5..2 range: no step meets a bound), at the
sample of the peak. The figure is the largest component of the gradient's error in the polish's units; it must
stay well below the tolerance for the measure to mean what it says.
"""

from __future__ import annotations

import time

import numpy as np

from fmu_src.materials import study_materials
from orchestrator.codesign import (
    RELATIVE_STEP,
    CoDesignObjective,
    TraceJacobian,
    CoDesignSpace,
    finite_difference_jacobian,
    sampled_traces,
    scaled_gradients,
    scaled_parameter_names,
    trace_runs,
)
from orchestrator.design import DesignSpace
from orchestrator.executors import SerialExecutor
from orchestrator.loop import Evaluator
from orchestrator.objective import FULL, SEARCH, SEARCH_RTOL, SEARCH_SOLVER, LatticeObjective, close_instances

from .common import FULL_HORIZON, STUDY_BEST, add_fmu_option, lattice_fmu, order_text
from .measurements import Page, Run, Table, write_page

VARIED = ("k", "c", "mass")
ROWS = 11
TOLERANCE = 1e-2  # the polish's default tolerance of its first-order measure
STEPS = (1e-2, 1e-3, 1e-4, 1e-5, 1e-6)
QUICK_STEPS = (1e-3, 1e-5)
TRUTH = {"rtol": 1e-11, "atol": 1e-13}  # the FMU's own solver, far tighter than either fidelity
TRUTH_STEP = 1e-4  # the truth's central difference: its truncation error is of the order of the step squared
RULES = {"receiver": {}, "mean": {"diagonal_rule": "mean"}}
TIMED = 3  # a fidelity's recorded run is timed this many times: the fastest is shown


def truth_gradient(objective: CoDesignObjective, evaluator, point, names: tuple[str, ...]) -> np.ndarray:
    """d F_s / d parameter by central differences of ``TRUTH_STEP`` at the truth's tolerance, one row per sample."""
    base = objective.space.parameters(point)
    sets = []
    for name in names:
        for sign in (1.0, -1.0):
            sets.append({**base, name: base[name] * (1.0 + sign * TRUTH_STEP)})
    traces = [values for _, values in sampled_traces(objective, evaluator, point.order, sets, FULL)]
    columns = [
        (traces[2 * i] - traces[2 * i + 1]) / (sets[2 * i][name] - sets[2 * i + 1][name])
        for i, name in enumerate(names)
    ]
    return np.column_stack(columns)


def fastest_run(objective: CoDesignObjective, point, fidelity: str) -> float:
    """The fastest of ``TIMED`` recorded runs of the point at ``fidelity`` (s), run directly (no cache)."""
    (run,) = trace_runs(objective, point.order, objective.space.parameters(point), fidelity)
    seconds = []
    for _ in range(TIMED):
        start = time.perf_counter()
        run()
        seconds.append(time.perf_counter() - start)
    return min(seconds)


def main(argv=None) -> int:
    run = Run.start(__file__, argv)
    parser = run.parser(__doc__, quick="the receiver rule only, relative steps 1e-3 and 1e-5")
    add_fmu_option(parser)
    args = parser.parse_args(argv)
    steps = sorted({*(QUICK_STEPS if args.quick else STEPS), RELATIVE_STEP}, reverse=True)  # the polish's own too
    rules = {"receiver": RULES["receiver"]} if args.quick else RULES
    table = study_materials(ROWS)
    space = CoDesignSpace(DesignSpace.permutations(ROWS), table, VARIED, 0.5, 2.0, ROWS)
    point = space.unit_point(STUDY_BEST)
    names = scaled_parameter_names(space, point.order)
    rows = []
    timings = []
    worst_full = 0.0
    with lattice_fmu(args.fmu) as fmu:
        for rule, parameters in rules.items():
            lattice = LatticeObjective(str(fmu), space.space, FULL_HORIZON, parameters=parameters)
            objective = CoDesignObjective(lattice, space)
            exact = CoDesignObjective(lattice.with_parameters(**TRUTH), space)
            evaluator = Evaluator(SerialExecutor())
            ((_, values),) = sampled_traces(exact, evaluator, point.order, [space.parameters(point)], FULL)
            peak_sample = int(np.argmax(values))
            peak = float(values[peak_sample])
            truth_jacobian = TraceJacobian((), values, truth_gradient(exact, evaluator, point, names), names, 0)
            truth = scaled_gradients(space, point, truth_jacobian)[peak_sample] / peak
            for fidelity in (FULL, SEARCH):
                for step in steps:
                    found = finite_difference_jacobian(objective, evaluator, point, names, fidelity, step)
                    gradient = scaled_gradients(space, point, found)[peak_sample] / peak
                    error = float(np.max(np.abs(gradient - truth)))
                    if fidelity == FULL and step == RELATIVE_STEP:
                        worst_full = max(worst_full, error)
                    rows.append(
                        (
                            rule,
                            fidelity_text(fidelity),
                            f"{step:g}",
                            f"{error:.1e}",
                            f"{error / TOLERANCE:.1e}",
                            f"{float(np.max(np.abs(truth))):.3f}",
                        )
                    )
                timings.append((rule, fidelity_text(fidelity), f"{fastest_run(objective, point, fidelity) * 1e3:.0f}"))
    close_instances()
    page = Page(
        name=run.name,
        title="Co-design polish: the noise of its gradients",
        headline=(
            f"the polish's forward differences at full fidelity and a relative step of {RELATIVE_STEP:g}: largest "
            f"gradient error "
            f"{worst_full:.1e} against its first-order tolerance of {TOLERANCE:g} (relative to the peak, per unit of "
            "scaled factor)"
        ),
        summary=(
            f"The study's 11 x 11 lattice, order {order_text(STUDY_BEST)} with each column's {', '.join(VARIED)} at "
            "the table's values. Per rule, fidelity and relative step: the largest component, over the 33 scaled "
            "factors, of the difference between the forward-difference gradient of the peak's sample "
            "(``finite_difference_jacobian``, chained to the scaled coordinates, relative to the peak) and the truth, "
            f"central differences of {TRUTH_STEP:g} at rtol {TRUTH['rtol']:g}, atol {TRUTH['atol']:g}. Full fidelity "
            "is the FMU's default solver at its default tolerance over 8 s; the search fidelity is "
            f"{SEARCH_SOLVER} at rtol {SEARCH_RTOL:g}, recorded over the full horizon."
        ),
        tables=(
            Table(
                (
                    "rule",
                    "fidelity",
                    "relative step",
                    "largest gradient error",
                    "/ tolerance",
                    "largest gradient component (truth)",
                ),
                tuple(rows),
            ),
            Table(
                ("rule", "fidelity", "one recorded run, fastest of 3 (ms)"),
                tuple(timings),
                caption="One recorded run of the trace (801 samples every 0.01 s), called directly",
            ),
        ),
        notes=(
            "A forward difference's error is its truncation (of the order of the step) plus the solver's error "
            "divided by the step: a step too small amplifies the solver's noise, one too large the curvature.",
        ),
    )
    write_page(run, page)
    return 0


def fidelity_text(fidelity: str) -> str:
    return "full" if fidelity == FULL else "search"


if __name__ == "__main__":
    raise SystemExit(main())
