"""The trade-off between two or three objectives: the Pareto front at full fidelity, its hypervolume, and the
designs a designer would look at first (each objective's best end, and the knee)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..charts import RULE_COLOURS, legend_below, plt, save
from ..exhaustive import SWEEP_METHOD, not_strongly_dominated
from ..known_optima import known_ends
from ..loop import run_search
from ..objective import FULL
from ..search import make_search
from ..search.pareto import dominated_by, hypervolume, non_dominated, reference_point
from ..study import SILENT, Step, StudyContext, Verdict
from ..types import Order
from .final_descent import MAX_DESCENT
from .exhaustive import SCREENING_ERROR, Exhaustive, FrontPoint
from .searches import Searches, multi_objective, rule_label


@dataclass(frozen=True)
class ChosenPoint:
    label: str  # "knee", or "lowest <output>"
    order: Order
    values: tuple[float, ...]
    design_file: str


BEST_DESIGN_FILE = "best_design.ssp"
AGREEMENT = 0.999  # a run agrees with the best known front when its own front covers this share of its hypervolume


@dataclass(frozen=True)
class KnownEnd:
    """A known optimum of one objective alone (orchestrator/known_optima.json): an end of the true front."""

    output: str
    order: Order
    certified: bool
    values: tuple[float, ...] | None  # every objective at full fidelity; None: its evaluation failed
    on_front: bool  # the reported front holds it (or a design equal to it on every objective)


@dataclass(frozen=True)
class FrontSureness:
    """How far to trust a front: exact from a sweep; otherwise how closely the runs agree, and what settles it."""

    exact: bool
    runs: int  # runs of a multi-objective search under the rule (the baselines not counted)
    runs_agreeing: int  # runs whose own front covers ``agreement`` of the best known front's hypervolume
    agreement: float
    coverage: tuple[float, ...]  # per run: its front's hypervolume / the best known front's (search fidelity)
    known_ends: tuple[KnownEnd, ...]
    settle: str  # what would settle the front, with its cost; "" when it is exact


@dataclass(frozen=True)
class DescendedEnd:
    """A descent on one objective alone from the front's end on it, by single moves until none improves: the
    single-objective answer next to that end, which the multi-objective search may have stopped short of."""

    output: str
    start: Order
    order: Order  # where it stopped: a local optimum of that objective alone at the search fidelity
    evaluations: int


@dataclass(frozen=True)
class Front:
    diagonal_rule: str
    points: tuple[FrontPoint, ...]  # the non-dominated designs at full fidelity, by the first objective
    exact: bool  # from the exhaustive sweep: every design of the space accounted for
    source: str
    hypervolume: float
    reference_point: tuple[float, ...]
    chosen: tuple[ChosenPoint, ...]
    sureness: FrontSureness
    descended: tuple[DescendedEnd, ...] = ()  # each objective's end, descended on that objective alone


@dataclass(frozen=True)
class ParetoResult:
    outputs: tuple[str, ...]
    fronts: tuple[Front, ...]


def undominated(evaluations) -> tuple[FrontPoint, ...]:
    """The evaluations no other one dominates, as front points sorted by the objectives: never a point that a
    design of ``evaluations`` (every design evaluated at full fidelity, the known optima among them) dominates."""
    evaluations = list(evaluations)
    if not evaluations:
        return ()
    values = [e.values for e in evaluations]
    beaten = dominated_by(values, values)
    return tuple(
        sorted(
            (FrontPoint(e.order, e.values, e.outputs) for e, out in zip(evaluations, beaten) if not out),
            key=lambda p: (p.values, p.order),
        )
    )


def run_fronts(runs) -> list[list[tuple[float, ...]]]:
    """Each run's own non-dominated set, at the search fidelity it was told."""
    fronts = []
    for run in runs:
        values = [e.values for e in run.evaluations if e.ok and e.values]
        fronts.append([v for v, k in zip(values, non_dominated(values)) if k] if values else [])
    return fronts


def coverage(fronts: list[list[tuple[float, ...]]]) -> tuple[float, ...]:
    """Each front's hypervolume against the best known front's (their union's), with one reference point."""
    union = [v for front in fronts for v in front]
    if not union:
        return tuple(0.0 for _ in fronts)
    best = [v for v, k in zip(union, non_dominated(union)) if k]
    reference = reference_point(best)
    total = hypervolume(best, reference)
    return tuple(hypervolume(front, reference) / total if total > 0 and front else 0.0 for front in fronts)


def settle_advice(context: StudyContext, runs, agreeing: int) -> str:
    """What would settle the front, with its cost at the rate the searches measured."""
    budget = context.config(Searches).budget
    seconds = [e.seconds for run in runs for e in run.evaluations]
    rate = sum(seconds) / len(seconds) if seconds else None
    size = context.case.space.size
    sweep = f"--method {SWEEP_METHOD} sweeps all {size:,} designs and gives the exact front" + (
        f" (about {size * rate / 3600:.2g} core-hours at this run's rate)" if rate else ""
    )
    if not runs:
        return f"no multi-objective search ran (only baselines): add --method nsga2, or {sweep}"
    if agreeing == len(runs):
        return f"every run reached the same front; {sweep}"
    more = (
        f"--budget {2 * budget} (about {len(runs) * budget * rate:.0f} more core-seconds over the {len(runs)} runs)"
        if rate
        else f"--budget {2 * budget}"
    )
    return f"{agreeing} of {len(runs)} runs reached it: raise {more} until the runs agree, or {sweep}"


def knee(values: np.ndarray) -> int:
    """The point of the front farthest from the straight line (the plane) through its ends, each objective
    scaled to [0, 1]: where one objective stops being cheap in the other."""
    low, high = values.min(axis=0), values.max(axis=0)
    scaled = (values - low) / np.where(high > low, high - low, 1.0)
    return int(np.argmin(scaled.sum(axis=1)))


def choose(points: tuple[FrontPoint, ...], outputs: tuple[str, ...], label: str) -> tuple[ChosenPoint, ...]:
    if not points:
        return ()
    values = np.array([p.values for p in points])
    picks: dict[int, str] = {}
    for k, output in enumerate(outputs):
        picks.setdefault(int(np.argmin(values[:, k])), f"lowest {output}")
    picks.setdefault(knee(values), "knee")
    return tuple(
        ChosenPoint(
            name,
            points[i].order,
            points[i].values,
            f"design_{label}_{name.replace('lowest ', '').replace(' ', '_')}.ssp",
        )
        for i, name in sorted(picks.items(), key=lambda item: item[0])
    )


class Pareto(Step):
    name = "pareto"
    title = "The trade-off: Pareto front"
    template = "pareto.html.j2"
    chart_file = "pareto.png"

    def applies(self, context: StudyContext) -> bool:
        return len(context.case.outputs) > 1

    def verdict(self, result: ParetoResult | None, study) -> Verdict:
        """The fronts are the answer of a study of several objectives; none without a point is no answer."""
        if result is None:
            return SILENT
        if not any(front.points for front in result.fronts):
            return Verdict.no_answer(f"no design was evaluated successfully: {study.failure_summary()}")
        return Verdict.answer()

    def run(self, context: StudyContext) -> ParetoResult:
        searched = context.result(Searches)
        swept = context.result(Exhaustive)
        fronts = []
        for rule in context.rules:
            label = rule_label(rule)
            objective = context.objective(rule)
            runs = [r for r in (searched.runs_for(label) if searched else ()) if multi_objective(r.method)]
            ends = known_ends(context.case, rule or context.case.rule_default)
            end_values = {
                e.order: e for e in objective.evaluate([k.order for k in ends], context.evaluator, FULL) if e.ok
            }
            exact = swept.front_for_rule(label) if swept else None
            descended: list[DescendedEnd] = []
            if exact is not None:
                points, source, is_exact = exact.front, "exhaustive sweep of the whole space", exact.exact
            else:
                evaluated = {
                    e.order: e
                    for run in (searched.runs_for(label) if searched else ())
                    for e in run.evaluations
                    if e.ok
                }
                found = list(evaluated.values())
                mask = not_strongly_dominated([e.values for e in found], SCREENING_ERROR) if found else []
                candidates = [e.order for e, k in zip(found, mask) if k]
                full = [e for e in objective.evaluate(candidates, context.evaluator, FULL) if e.ok]
                pool = {e.order: e for e in full + list(end_values.values()) + self.evaluated(context, objective)}
                descended = self.descend_ends(context, rule, undominated(pool.values()))
                pool.update(
                    {
                        e.order: e
                        for e in objective.evaluate([d.order for d in descended], context.evaluator, FULL)
                        if e.ok
                    }
                )
                points = undominated(pool.values())
                source = (
                    f"the searches' {len(evaluated)} designs"
                    + (
                        f", the known optimum of {len(ends)} objective{'s' if len(ends) > 1 else ''} alone"
                        if ends
                        else ""
                    )
                    + " and a descent from each end on its own objective, verified at "
                    "full fidelity"
                )
                is_exact = False
            if points:
                reference = tuple(float(v) for v in reference_point([p.values for p in points]))
                volume = hypervolume([p.values for p in points], reference)
            else:
                reference, volume = (), 0.0
            fronts.append(
                Front(
                    label,
                    points,
                    is_exact,
                    source,
                    volume,
                    reference,
                    choose(points, context.case.outputs, label),
                    self.sureness(context, runs, points, is_exact, ends, end_values),
                    tuple(descended),
                )
            )
        return ParetoResult(context.case.outputs, tuple(fronts))

    @staticmethod
    def descend_ends(context: StudyContext, rule, points) -> list[DescendedEnd]:
        """From the front's end on each objective, a descent on that objective alone (the study's final descent,
        at the search fidelity): an end a search of several objectives left one move short of its objective's
        local optimum moves there."""
        if not points:
            return []
        seed = context.config(Searches).seed
        descended: list[DescendedEnd] = []
        for k, output in enumerate(context.case.outputs):
            start = min(points, key=lambda p: (p.values[k], p.values)).order
            alone = context.objective(rule).with_outputs((output,))
            run = run_search(
                make_search("local", context.case.space, seed, start=start, kicks=0),
                alone,
                MAX_DESCENT,
                context.evaluator,
                method_name="local",
                seed=seed,
                label=rule_label(rule),
            )
            descended.append(DescendedEnd(output, start, run.best_order or start, run.n_evaluations))
        return descended

    @staticmethod
    def evaluated(context: StudyContext, objective) -> list:
        """Every design this run evaluated at full fidelity on these objectives (one load case: the FMU run's
        own results; several: the combined values are not kept, so none)."""
        if len(context.case.cases) != 1:
            return []
        (task,) = objective.with_cases(None).tasks(FULL)
        return [e for e in context.evaluator.known(task) if e.ok and len(e.values) == len(context.case.outputs)]

    @staticmethod
    def sureness(context: StudyContext, runs, points, is_exact: bool, ends, end_values) -> FrontSureness:
        on_front = {p.order for p in points}
        front_values = {tuple(p.values) for p in points}
        known = tuple(
            KnownEnd(
                k.objective,
                k.order,
                k.certified,
                tuple(end_values[k.order].values) if k.order in end_values else None,
                k.order in on_front or (k.order in end_values and tuple(end_values[k.order].values) in front_values),
            )
            for k in ends
        )
        shares = coverage(run_fronts(runs))
        agreeing = sum(1 for share in shares if share >= AGREEMENT)
        return FrontSureness(
            is_exact,
            len(runs),
            agreeing,
            AGREEMENT,
            shares,
            known,
            "" if is_exact else settle_advice(context, runs, agreeing),
        )

    def cost_note(self, context: StudyContext) -> str:
        return (
            "the front at full fidelity, and each objective's end descended on that objective alone until no "
            "single move improves it: not bounded by --budget"
        )

    def chart(self, study, path):
        return draw_pareto(study, path)

    def design_files(self, study):
        result = study.result(type(self))
        files = [(c.design_file, c.order, f.diagonal_rule) for f in (result.fronts if result else ()) for c in f.chosen]
        best = best_design(study)
        return ([(BEST_DESIGN_FILE, best.order, best.diagonal_rule)] if best else []) + files


@dataclass(frozen=True)
class BestDesign:
    """The design a two-objective run writes as best_design.ssp: the knee of the first rule's front."""

    diagonal_rule: str
    order: Order
    values: tuple[float, ...]


def best_design(study) -> BestDesign | None:
    """best_design.ssp of a run of several objectives (which has no single answer): the knee of the first rule's
    front (the balanced design, as every run writes the design to build as best_design.ssp); None for one
    objective (the answer writes it) or without a front."""
    result = study.result(Pareto)
    if len(study.case.objective.outputs) < 2 or result is None or not result.fronts or not result.fronts[0].points:
        return None
    front = result.fronts[0]
    point = front.points[knee(np.array([p.values for p in front.points]))]
    return BestDesign(front.diagonal_rule, point.order, point.values)


def draw_pareto(study, path: Path) -> str | None:
    result = study.result(Pareto)
    if result is None:
        return None
    outputs = study.case.objective.outputs
    units = study.case.objective.units
    figure, axis = plt.subplots(figsize=(8, 5.5))
    searches = study.result(Searches)
    labels = []
    for front, colour in zip(result.fronts, RULE_COLOURS):
        evaluated = [
            e.values
            for run in (searches.runs if searches else ())
            if run.label == front.diagonal_rule
            for e in run.evaluations
            if e.ok and len(e.values) >= 2
        ]
        if evaluated:
            points = np.array(evaluated)
            axis.plot(
                points[:, 0],
                points[:, 1],
                ".",
                color=colour,
                alpha=0.15,
                ms=3,
                label=f"every design the searches evaluated ({front.diagonal_rule} rule, search fidelity)",
            )
        if front.points:
            values = np.array(sorted(p.values for p in front.points))
            axis.plot(
                values[:, 0],
                values[:, 1],
                "o-",
                color=colour,
                ms=4,
                label=f"non-dominated set, full fidelity ({front.diagonal_rule} rule)",
            )
            labels += [
                axis.annotate(chosen.label, chosen.values[:2], fontsize=7, textcoords="offset points", xytext=(5, 5))
                for chosen in front.chosen
            ]
        for end in front.sureness.known_ends:
            if end.values:
                axis.plot(
                    [end.values[0]],
                    [end.values[1]],
                    "*",
                    color=colour,
                    ms=12,
                    mec="black",
                    mew=0.6,
                    label=f"{'certified' if end.certified else 'known'} optimum of {end.output} alone "
                    f"({front.diagonal_rule} rule)",
                )
    axis.set_xlabel(f"{outputs[0]} ({units[0]})")
    axis.set_ylabel(f"{outputs[1]} ({units[1]})")
    axis.set_title("The trade-off: each point a design; lower is better on both axes", fontsize=9)
    axis.grid(alpha=0.3)
    if axis.get_legend_handles_labels()[0]:
        legend_below(axis)
    return save(figure, path, labels=labels)


__all__ = [
    "BEST_DESIGN_FILE",
    "BestDesign",
    "ChosenPoint",
    "DescendedEnd",
    "Front",
    "Pareto",
    "ParetoResult",
    "best_design",
    "choose",
    "knee",
]
