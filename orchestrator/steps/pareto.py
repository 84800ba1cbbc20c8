"""The trade-off between two or three objectives: the Pareto front at full fidelity, its hypervolume, and the
designs a designer would look at first (each objective's best end, and the knee)."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..exhaustive import not_strongly_dominated
from ..objective import FULL
from ..study import Step, StudyContext
from ..types import Order
from .exhaustive import SCREENING_ERROR, Exhaustive, FrontPoint
from .searches import Searches, rule_label


@dataclass(frozen=True)
class ChosenPoint:
    label: str  # "knee", or "lowest <output>"
    order: Order
    values: tuple[float, ...]
    design_file: str


@dataclass(frozen=True)
class Front:
    diagonal_rule: str
    points: tuple[FrontPoint, ...]  # the non-dominated designs at full fidelity, by the first objective
    exact: bool  # from the exhaustive sweep: every design of the space accounted for
    source: str
    hypervolume: float
    reference_point: tuple[float, ...]
    chosen: tuple[ChosenPoint, ...]


@dataclass(frozen=True)
class ParetoResult:
    outputs: tuple[str, ...]
    fronts: tuple[Front, ...]


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
    return tuple(ChosenPoint(name, points[i].order, points[i].values,
                             f"design_{label}_{name.replace('lowest ', '').replace(' ', '_')}.ssp")
                 for i, name in sorted(picks.items(), key=lambda item: item[0]))


class Pareto(Step):
    name = "pareto"
    title = "The trade-off: Pareto front"
    template = "pareto.html.j2"
    chart_file = "pareto.png"

    def applies(self, context: StudyContext) -> bool:
        return len(context.case.outputs) > 1

    def run(self, context: StudyContext) -> ParetoResult:
        from ..search.pareto import hypervolume, non_dominated, reference_point

        searched = context.result(Searches)
        swept = context.result(Exhaustive)
        fronts = []
        for rule in context.rules:
            label = rule_label(rule)
            exact = swept.front_for_rule(label) if swept else None
            if exact is not None:
                points, source, is_exact = exact.front, "exhaustive sweep of the whole space", exact.exact
            else:
                evaluated = {e.order: e for run in (searched.runs_for(label) if searched else ())
                             for e in run.evaluations if e.ok}
                found = list(evaluated.values())
                mask = not_strongly_dominated([e.values for e in found], SCREENING_ERROR) if found else []
                candidates = [e.order for e, k in zip(found, mask) if k]
                full = [e for e in context.objective(rule).evaluate(candidates, context.evaluator, FULL) if e.ok]
                keep = non_dominated([e.values for e in full]) if full else []
                points = tuple(sorted((FrontPoint(e.order, e.values, e.outputs) for e, k in zip(full, keep) if k),
                                      key=lambda p: p.values))
                source, is_exact = f"the searches' {len(evaluated)} designs, verified at full fidelity", False
            if points:
                reference = tuple(float(v) for v in reference_point([p.values for p in points]))
                volume = hypervolume([p.values for p in points], reference)
            else:
                reference, volume = (), 0.0
            fronts.append(Front(label, points, is_exact, source, volume, reference,
                                choose(points, context.case.outputs, label)))
        return ParetoResult(context.case.outputs, tuple(fronts))

    def chart(self, study, path):
        return draw_pareto(study, path)

    def design_files(self, study):
        result = study.steps.get(self.name)
        return [(c.design_file, c.order, f.diagonal_rule) for f in (result.fronts if result else ()) for c in f.chosen]


def draw_pareto(study, path: Path) -> str | None:
    import numpy as np
    from ..report.charts import RULE_COLOURS, plt, save

    result = study.steps.get("pareto")
    if result is None:
        return None
    outputs = study.case.objective.outputs
    units = study.case.objective.units
    figure, axis = plt.subplots(figsize=(8, 5.5))
    searches = study.steps.get("searches")
    for front, colour in zip(result.fronts, RULE_COLOURS):
        evaluated = [e.values for run in (searches.runs if searches else ()) if run.label == front.diagonal_rule
                     for e in run.evaluations if e.ok and len(e.values) >= 2]
        if evaluated:
            points = np.array(evaluated)
            axis.plot(points[:, 0], points[:, 1], ".", color=colour, alpha=0.15, ms=3,
                      label=f"every design the searches evaluated ({front.diagonal_rule} rule, search fidelity)")
        if front.points:
            values = np.array(sorted(p.values for p in front.points))
            axis.plot(values[:, 0], values[:, 1], "o-", color=colour, ms=4,
                      label=f"non-dominated set, full fidelity ({front.diagonal_rule} rule)")
            for chosen in front.chosen:
                axis.annotate(chosen.label, chosen.values[:2], fontsize=7, textcoords="offset points",
                              xytext=(5, 5))
    axis.set_xlabel(f"{outputs[0]} ({units[0]})")
    axis.set_ylabel(f"{outputs[1]} ({units[1]})")
    axis.set_title("The trade-off: each point a design; lower is better on both axes", fontsize=9)
    axis.grid(alpha=0.3)
    if axis.get_legend_handles_labels()[0]:
        axis.legend(fontsize=7)
    return save(figure, path)


__all__ = ["ChosenPoint", "Front", "Pareto", "ParetoResult", "choose", "knee"]
