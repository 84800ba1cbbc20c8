"""The co-design polish's gradient: forward differences against the FMU's forward sensitivity.

    python -m bench.codesign_gradient            # about 2 min: the 11 x 11 co-design start, 33 parameters
    python -m bench.codesign_gradient --quick    # seconds: the 11 x 3 lattice over 2 s, one pass (a check)

Why: the epigraph polish (orchestrator/codesign.py) needs the Jacobian of the sampled backplate-force trace with
respect to every varied property of every column. Forward differences take one recorded run per parameter beyond
the point's own (``codesign.finite_difference_jacobian``); the FMU's forward sensitivity takes one per parameter,
each integrating the derivative with the state, about twice a run's right-hand sides
(``orchestrator.sensitivity.directional_jacobian``). Which is cheaper at the accuracy the polish needs is what
this measures: at the co-design's start (the certified order at the table's values) and at a point off them
(every factor drawn log-uniformly from [0.8, 1.25]), with k, c and mass of every column varied, the time, the
FMU runs and the right-hand sides (the FMU's own counter, which counts the sensitivity's) of the whole Jacobian
from each source at the search fidelity, at full fidelity and at rtol 1e-10, and its error against a reference:
the directional derivatives with DOP853 at rtol 1e-12, themselves checked against central differences at that
tolerance on a few parameters.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass
import numpy as np

from fmu_src.materials import study_materials
from orchestrator.codesign import (
    CANDIDATE_BAND,
    RELATIVE_STEP,
    CoDesignObjective,
    CoDesignPoint,
    CoDesignSpace,
    TraceJacobian,
    finite_difference_jacobian,
    polish,
    sampled_traces,
    scaled_parameter_names,
)
from orchestrator.design import DesignSpace
from orchestrator.executors import SerialExecutor
from orchestrator.loop import Evaluator
from orchestrator.objective import FULL, SEARCH, SEARCH_RTOL, SEARCH_SOLVER, LatticeObjective, RecordRun
from orchestrator.sensitivity import directional_jacobian

from .common import BEST_KNOWN, FULL_HORIZON, add_fmu_option, default_setting, lattice_fmu
from .measurements import Page, Run, Table, write_page

NAMES = ("k", "c", "mass")
REFERENCE = {"solver": "dop853", "rtol": 1e-12, "atol": 1e-14}
TIGHT = {"solver": "dop853", "rtol": 1e-10, "atol": 1e-12}
FACTOR_SPREAD = 1.25  # the point off the table's values: every factor log-uniform in [1 / spread, spread]
CHECKED_PARAMETERS = 3  # the reference's columns checked against central differences
CENTRAL_STEP = 1e-4  # their step, relative to the parameter
TARGETS = (1e-2, 1e-3, 1e-4, 1e-5)  # the accuracies the page names the cheapest source for
COUNTER = "rhs_evaluations"


class CountingEvaluator:
    """The orchestrator's evaluator, counting the FMU's right-hand sides (its own counter, the sensitivity's
    included) of every run it simulates: a recorded run records the counter too, an evaluation carries it as its
    work."""

    def __init__(self) -> None:
        self.evaluator = Evaluator(SerialExecutor())
        self.rhs_evaluations = 0

    def run(self, items):
        counted = [
            dataclasses.replace(item, outputs=item.outputs + (COUNTER,)) if isinstance(item, RecordRun) else item
            for item in items
        ]
        results = self.evaluator.run(counted)
        for item, result in zip(counted, results):
            if isinstance(item, RecordRun):
                self.rhs_evaluations += int(result.values[COUNTER][-1]) if result.ok else 0
            else:
                self.rhs_evaluations += int(result.work or 0)
        return results

    def state(self):
        return self.evaluator.state()


@dataclass(frozen=True)
class Setting:
    """A source of the Jacobian at a fidelity: its label and how to compute it."""

    source: str
    fidelity: str
    objective_parameters: dict
    relative_step: float | None  # forward differences' step; None for the directional derivatives

    def compute(self, objective: CoDesignObjective, point: CoDesignPoint, names, evaluator) -> TraceJacobian:
        base = objective.base
        objective = dataclasses.replace(
            objective, base=dataclasses.replace(base, parameters={**base.parameters, **self.objective_parameters})
        )
        fidelity = SEARCH if self.fidelity.startswith("search") else FULL
        if self.relative_step is None:
            return directional_jacobian(objective, evaluator, point, names, fidelity)
        return finite_difference_jacobian(objective, evaluator, point, names, fidelity, self.relative_step)


@dataclass(frozen=True)
class Measured:
    setting: Setting
    runs: int
    rhs_evaluations: int
    seconds: float
    peak_error: float  # the peak sample's gradient, relative 2-norm error
    band_error: float  # the samples within CANDIDATE_BAND of the peak: largest row error over the largest row


def settings(default: dict) -> list[Setting]:
    full = f"full ({default['solver']}, rtol {default['rtol']:g})"
    search = f"search ({SEARCH_SOLVER}, rtol {SEARCH_RTOL:g})"
    tight = f"dop853, rtol {TIGHT['rtol']:g}"
    differences = [
        Setting(difference_label(step), fidelity, parameters, step)
        for step, fidelity, parameters in (
            (1e-3, search, {}),
            (1e-3, full, {}),
            (1e-4, search, {}),
            (1e-4, full, {}),
            (1e-4, tight, TIGHT),
            (1e-5, tight, TIGHT),
        )
    ]
    return differences + [
        Setting("directional derivatives", search, {}, None),
        Setting("directional derivatives", full, {}, None),
        Setting("directional derivatives", tight, TIGHT, None),
    ]


def difference_label(step: float) -> str:
    return f"forward differences, step {step:g}" + (" (the polish's)" if step == RELATIVE_STEP else "")


def errors(found: TraceJacobian, reference: TraceJacobian) -> tuple[float, float]:
    """The peak sample's gradient error and the band's (module docstring), against the reference's rows."""
    peak = int(np.argmax(reference.values))
    band = np.flatnonzero(reference.values >= (1.0 - CANDIDATE_BAND) * reference.values[peak])
    difference = found.jacobian - reference.jacobian
    peak_error = float(np.linalg.norm(difference[peak]) / np.linalg.norm(reference.jacobian[peak]))
    band_error = float(
        np.max(np.linalg.norm(difference[band], axis=1)) / np.max(np.linalg.norm(reference.jacobian[band], axis=1))
    )
    return peak_error, band_error


def measure(setting: Setting, objective, point, names, reference: TraceJacobian, repeats: int) -> Measured:
    seconds = math.inf
    found = None
    counter = CountingEvaluator()
    for _ in range(repeats):  # a fresh evaluator each time: nothing comes from its cache
        counter = CountingEvaluator()
        start = time.perf_counter()
        found = setting.compute(objective, point, names, counter)
        seconds = min(seconds, time.perf_counter() - start)
    assert found is not None
    peak_error, band_error = errors(found, reference)
    return Measured(setting, found.evaluations, counter.rhs_evaluations, seconds, peak_error, band_error)


@dataclass(frozen=True)
class Polished:
    source: str
    seconds: float
    runs: int
    rhs_evaluations: int
    iterations: int
    converged: bool
    start_value: float
    end_value: float
    residual: float
    tolerance: float


def polish_with(source: str, jacobian, objective: CoDesignObjective, point: CoDesignPoint, budget: float) -> Polished:
    """The epigraph polish at full fidelity from ``point`` with ``jacobian`` as its gradients' source, on a fresh
    evaluator."""
    counter = CountingEvaluator()
    start = time.perf_counter()
    result = polish(objective, counter, point, budget, FULL, jacobian=jacobian)
    return Polished(
        source,
        time.perf_counter() - start,
        result.evaluations,
        counter.rhs_evaluations,
        result.iterations,
        result.converged,
        result.start_value,
        result.end_value,
        result.kkt_residual,
        result.tolerance,
    )


def off_table_point(space: CoDesignSpace, order, seed: int) -> CoDesignPoint:
    rng = np.random.default_rng(seed)
    flat = np.exp(rng.uniform(-math.log(FACTOR_SPREAD), math.log(FACTOR_SPREAD), space.columns * len(space.names)))
    return space.with_factors(order, [float(f) for f in flat])


def central_check(objective: CoDesignObjective, point, names, reference: TraceJacobian) -> list[tuple]:
    """The reference's first columns against central differences of traces at its own tolerance."""
    rows = []
    tight = dataclasses.replace(
        objective, base=dataclasses.replace(objective.base, parameters={**objective.base.parameters, **REFERENCE})
    )
    evaluator = Evaluator(SerialExecutor())
    base = objective.space.parameters(point)
    for column, name in enumerate(names[:CHECKED_PARAMETERS]):
        h = CENTRAL_STEP * base[name]
        (_, plus), (_, minus) = sampled_traces(
            tight, evaluator, point.order, [{**base, name: base[name] + h}, {**base, name: base[name] - h}], FULL
        )
        central = (plus - minus) / (2.0 * h)
        scale = float(np.max(np.abs(central)))
        rows.append(
            (name, f"{scale:.4g}", f"{float(np.max(np.abs(central - reference.jacobian[:, column]))) / scale:.1e}")
        )
    return rows


def cheapest(measured: list[Measured], source: str, target: float) -> Measured | None:
    within = [m for m in measured if m.setting.source.startswith(source) and m.band_error <= target]
    return min(within, key=lambda m: m.rhs_evaluations) if within else None


def headline(measured: list[Measured], polished: list[Polished], parameters: int, columns: int) -> str:
    """What a reader comes for, at the table's values: each source at the search fidelity, the cheapest of each
    within the finest accuracy asked, and the polish with each."""
    search = {
        m.setting.source.split(",")[0]: m
        for m in measured
        if m.setting.fidelity.startswith("search") and m.setting.relative_step in (None, RELATIVE_STEP)
    }
    differences, directional = search["forward differences"], search["directional derivatives"]
    parts = [
        f"{parameters} parameters at the 11 x {columns} co-design start: at the search fidelity forward differences "
        f"(the polish's step {RELATIVE_STEP:g}) take {differences.rhs_evaluations} right-hand sides to an error of "
        f"{differences.band_error:.0e}, the FMU's directional derivatives {directional.rhs_evaluations} to "
        f"{directional.band_error:.0e}"
    ]
    finest = TARGETS[-1]
    tight_differences = cheapest(measured, "forward differences", finest)
    tight_directional = cheapest(measured, "directional derivatives", finest)
    if tight_directional and not tight_differences:
        parts.append(
            f"within {finest:g} only the directional derivatives, {tight_directional.rhs_evaluations} right-hand sides "
            f"at {tight_directional.setting.fidelity.split(' (')[0]} fidelity"
        )
    elif tight_differences and tight_directional:
        parts.append(
            f"within {finest:g}, {tight_differences.rhs_evaluations} against {tight_directional.rhs_evaluations}"
        )
    if len(polished) == 2:
        ratio = polished[1].rhs_evaluations / polished[0].rhs_evaluations
        parts.append(
            f"the polish ends {'within' if all(p.converged for p in polished) else 'at'} its tolerance with either, "
            f"the directional derivatives at {ratio:.1f} times forward differences' right-hand sides"
        )
    return "; ".join(parts)


def verdict(measured: list[Measured], polished: list[Polished]) -> str:
    """Which source is cheaper, at which accuracy, from the figures (at the table's values)."""
    sources = ("forward differences", "directional derivatives")
    cheaper = []
    for target in TARGETS:
        best = {source: cheapest(measured, source, target) for source in sources}
        reached = {source: found for source, found in best.items() if found is not None}
        if reached:
            winner = min(reached, key=lambda source: reached[source].rhs_evaluations)
            cheaper.append(f"within {target:g}: {winner}")
    text = (
        "Which source is cheaper, in right-hand sides, at the table's values: " + "; ".join(cheaper) + ". The "
        "polish's trace at each iterate is a run of its own, which is forward differences' run of the point (the "
        "evaluator's cache gives it once): in the polish both take one run per parameter and iterate, and a "
        "directional derivative's run costs about two."
    )
    if len(polished) == 2:
        faster = min(polished, key=lambda p: p.rhs_evaluations)
        text += (
            f" The polish itself is the cheaper with {faster.source}; `codesign.polish(..., jacobian=...)` takes "
            "either source."
        )
    return text


def main(argv=None) -> int:
    run = Run.start(__file__, argv)
    parser = run.parser(__doc__, quick="the 11 x 3 lattice over 2 s, one pass")
    add_fmu_option(parser)
    parser.add_argument("--repeats", type=int, default=3, help="timed passes per setting (the fastest counts)")
    parser.add_argument("--seed", type=int, default=36, help="seed of the point off the table's values")
    parser.add_argument(
        "--print-only", action="store_true", help="print the tables and write no page (what the tests run)"
    )
    parser.add_argument("--no-polish", action="store_true", help="measure the Jacobians only, not the polish")
    args = parser.parse_args(argv)
    columns, horizon = (3, 2.0) if args.quick else (11, FULL_HORIZON)
    repeats = 1 if args.quick else args.repeats
    order = BEST_KNOWN if columns == 11 else (2, 3, 1)
    table = study_materials(columns)
    space = CoDesignSpace(DesignSpace.permutations(columns), table, NAMES, 0.5, 2.0, 11)
    rows, check_rows, cheapest_rows = [], [], []
    findings: dict[str, list[Measured]] = {}
    polished: list[Polished] = []
    with lattice_fmu(args.fmu, cols=None if columns == 11 else columns) as path:
        default = default_setting(path)
        objective = CoDesignObjective(LatticeObjective(path, space.space, horizon), space)
        points = {"the table's values": space.unit_point(order), "off them": off_table_point(space, order, args.seed)}
        for label, point in points.items():
            names = scaled_parameter_names(space, point.order)
            reference = Setting("reference", "reference", REFERENCE, None).compute(
                objective, point, names, Evaluator(SerialExecutor())
            )
            check_rows += [(label, *row) for row in central_check(objective, point, names, reference)]
            measured = [measure(s, objective, point, names, reference, repeats) for s in settings(default)]
            for m in measured:
                rows.append(
                    (
                        label,
                        m.setting.source,
                        m.setting.fidelity,
                        m.runs,
                        m.rhs_evaluations,
                        f"{m.seconds:.2f}",
                        f"{m.peak_error:.1e}",
                        f"{m.band_error:.1e}",
                    )
                )
            for target in TARGETS:
                within = [m for m in measured if m.band_error <= target]
                for source in ("forward differences", "directional derivatives"):
                    mine = [m for m in within if m.setting.source.startswith(source)]
                    best = min(mine, key=lambda m: m.rhs_evaluations) if mine else None
                    cheapest_rows.append(
                        (
                            label,
                            f"{target:g}",
                            source,
                            "none of these" if best is None else f"{best.setting.source}, {best.setting.fidelity}",
                            "" if best is None else best.rhs_evaluations,
                            "" if best is None else f"{best.seconds:.2f}",
                        )
                    )
            findings[label] = measured
        polish_rows = []
        if not args.no_polish:
            start = points["the table's values"]
            budget = space.budget_for(order)
            for source, jacobian in (
                ("forward differences", finite_difference_jacobian),
                ("directional derivatives", directional_jacobian),
            ):
                p = polish_with(source, jacobian, objective, start, budget)
                polished.append(p)
                polish_rows.append(
                    (
                        p.source,
                        p.runs,
                        p.rhs_evaluations,
                        f"{p.seconds:.1f}",
                        p.iterations,
                        f"{p.start_value:.6f}",
                        f"{p.end_value:.6f}",
                        f"{p.residual:.1e} ({'within' if p.converged else 'above'} {p.tolerance:g})",
                    )
                )
    parameters = len(scaled_parameter_names(space, order))
    caption = (
        "**Each source's whole Jacobian** (FMU runs, right-hand sides, the fastest of "
        f"{repeats} pass(es) in seconds) and its error against the reference: at the peak's sample (the relative "
        f"2-norm of its gradient's error) and over the samples within {CANDIDATE_BAND:g} of the peak (the "
        "epigraph's constraints: the largest gradient error over the largest gradient):"
    )
    page = Page(
        name=run.name,
        title="The co-design polish's gradient: finite differences against the FMU's sensitivity",
        headline=headline(findings["the table's values"], polished, parameters, columns),
        summary=(
            f"The Jacobian of the sampled backplate-force trace (every {0.01:g} s over {horizon:g} s) of the "
            f"{11} x {columns} lattice with respect to k, c and mass of every column ({parameters} parameters, "
            f"receiver rule), at the order {list(order)} with its table's values and at a point off them (each "
            f"factor log-uniform in [1/{FACTOR_SPREAD:g}, {FACTOR_SPREAD:g}], seed {args.seed}), through the "
            "orchestrator's evaluator: `codesign.finite_difference_jacobian` (forward differences, one run per "
            "parameter and one for the point) and `sensitivity.directional_jacobian` (the FMU's forward "
            "sensitivity, one run per parameter). The search fidelity is the searches' solver and tolerance over "
            "the whole horizon (the trace's), full fidelity the FMU's default. Reference: the directional "
            f"derivatives with DOP853 at rtol {REFERENCE['rtol']:g}, atol {REFERENCE['atol']:g}."
        ),
        tables=(
            Table(
                ("point", "source", "fidelity", "FMU runs", "right-hand sides", "seconds", "peak error", "band error"),
                tuple(rows),
                caption=caption,
            ),
            Table(
                ("point", "band error at most", "source", "cheapest setting within it", "right-hand sides", "seconds"),
                tuple(cheapest_rows),
                caption="**The cheapest setting of each source within an accuracy** (fewest right-hand sides):",
            ),
            Table(
                (
                    "gradients",
                    "FMU runs",
                    "right-hand sides",
                    "seconds",
                    "SLSQP iterations",
                    "start peak (N)",
                    "end peak (N)",
                    "first-order measure",
                ),
                tuple(polish_rows),
                caption=(
                    "**The epigraph polish at full fidelity** from the table's values, within the order's own mass, "
                    "with each source of gradients (`codesign.polish`, its default tolerance):"
                ),
            ),
            Table(
                ("point", "parameter", "largest derivative", "reference's error, relative to it"),
                tuple(check_rows),
                caption=(
                    f"**The reference against central differences** (step {CENTRAL_STEP:g} of the parameter, runs "
                    f"at rtol {REFERENCE['rtol']:g}):"
                ),
            ),
        ),
        notes=(
            verdict(findings["the table's values"], polished),
            "A forward difference of the sampled trace errs most where a column-C mass meets the plate near a "
            "sample: the trace's samples bend hardest there (the damper's force switches on), and the step's "
            "truncation error is of first order; at a loose tolerance its runs' noise over the step adds to it. "
            "The directional derivative differentiates the run itself, with the run's own steps, to its quotient's "
            "error (docs/fmu-reference.md).",
        ),
    )
    if args.print_only:
        for table_ in page.tables:
            print(table_.caption)
            print(" | ".join(table_.columns))
            for row in table_.rows:
                print(" | ".join(str(cell) for cell in row))
        for note in page.notes:
            print(note)
        print(page.headline)
        return 0
    write_page(run, page)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
