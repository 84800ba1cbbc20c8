"""The finalists: each run's best designs, the baselines, the sweep's optimum and the case's known optimum (with
its runner-up), at full fidelity."""

from __future__ import annotations

from dataclasses import dataclass

from fmu_src.published import STUDY_BEST_ORDER
from fmu_src.materials import study_materials

from ..known_optima import known_optimum
from ..loop import SearchRun
from ..objective import FULL
from ..options import check_options, integer, option
from ..study import Step, StudyContext
from ..types import Evaluation, Order
from .exhaustive import Exhaustive
from .searches import Searches, rule_label
from .starting_designs import starting_designs


@dataclass(frozen=True)
class FinalistsConfig:
    per_run: int = option(
        3,
        "best designs of each run re-evaluated at full fidelity",
        flag="--finalists",
        metavar="FINALISTS",
        type=integer("--finalists", 1, 1000),
    )

    def __post_init__(self):
        check_options(self)


@dataclass(frozen=True)
class Disagreement:
    """A run whose finalists the full fidelity ranks otherwise than the search fidelity did."""

    method: str
    seed: int
    search_ranking: tuple[Order, ...]
    full_ranking: tuple[Order, ...]
    largest_relative_difference: float


@dataclass(frozen=True)
class RuleFinalists:
    diagonal_rule: str
    evaluations: tuple[Evaluation, ...]  # every finalist at full fidelity, failures included
    best: Evaluation | None
    disagreements: tuple[Disagreement, ...]
    baselines: dict[str, Order]  # label -> design, evaluated among the finalists

    def value_of(self, order: Order) -> Evaluation | None:
        return next((e for e in self.evaluations if e.order == order), None)


@dataclass(frozen=True)
class FinalistsResult:
    rules: tuple[RuleFinalists, ...]

    def for_rule(self, label: str) -> RuleFinalists | None:
        return next((r for r in self.rules if r.diagonal_rule == label), None)


def finalist_orders(run: SearchRun, count: int) -> list[Order]:
    """The run's best ``count`` distinct designs by their search value."""
    good = sorted((e for e in run.evaluations if e.ok), key=lambda e: e.ok_value)
    return list(dict.fromkeys(e.order for e in good))[:count]


def baselines(context: StudyContext) -> dict[str, Order]:
    """The designs every answer is compared with: the baseline order, and the study's published best on the
    study's own lattice and materials."""
    space = context.case.space
    found = {"sequential": space.baseline()}
    if (
        space.kind == "permutation"
        and space.columns == len(STUDY_BEST_ORDER)
        and context.case.materials == study_materials(space.materials)
    ):
        found["study's best"] = STUDY_BEST_ORDER
    for index, design in enumerate(starting_designs(context), start=1):  # the answer is never worse than one
        found[f"starting design {index}"] = design
    return found


def best_of(evaluations) -> Evaluation | None:
    good = [e for e in evaluations if e.ok]
    return min(good, key=lambda e: e.value) if good else None


class Finalists(Step):
    name = "finalists"
    title = "Finalists at full fidelity"
    template = "finalists.html.j2"
    Config = FinalistsConfig

    def applies(self, context: StudyContext) -> bool:
        return len(context.case.outputs) == 1

    def run(self, context: StudyContext) -> FinalistsResult:
        count = self.config.per_run
        searched = context.result(Searches)
        swept = context.result(Exhaustive)
        known = baselines(context)
        rules = []
        for rule in context.rules:
            label = rule_label(rule)
            runs = searched.runs_for(label) if searched else []
            orders = [o for run in runs for o in finalist_orders(run, count)] + list(known.values())
            sweep = swept.for_rule(label) if swept else None
            if sweep and sweep.certificate.optimum:
                orders.append(sweep.certificate.optimum.order)
            recorded = known_optimum(context.case, rule or context.case.rule_default)
            if recorded is not None:  # a recorded optimum and its runner-up are designs like any other: evaluated
                orders += [recorded.order] + ([recorded.runner_up] if recorded.runner_up else [])
            orders = list(dict.fromkeys(orders))
            evaluations = context.objective(rule).evaluate(orders, context.evaluator, FULL)
            full = dict(zip(orders, evaluations))
            rules.append(
                RuleFinalists(
                    label, tuple(evaluations), best_of(evaluations), tuple(disagreements(runs, full, count)), known
                )
            )
        return FinalistsResult(tuple(rules))

    def cost_note(self, context: StudyContext) -> str:
        return (
            f"each run's {self.config.per_run} best designs, the baselines and any known optimum, at full "
            "fidelity (the whole scene); --finalists N bounds it"
        )


def disagreements(runs: list[SearchRun], full: dict[Order, Evaluation], count: int) -> list[Disagreement]:
    found = []
    for run in runs:
        orders = finalist_orders(run, count)
        by_search = {e.order: e.ok_value for e in run.evaluations if e.ok}
        values = {o: full[o].ok_value for o in orders if o in full and full[o].ok}
        if len(values) < 2:
            continue
        search_rank = tuple(sorted(values, key=lambda o: by_search[o]))
        full_rank = tuple(sorted(values, key=lambda o: values[o]))
        largest = max(abs(values[o] - by_search[o]) / abs(values[o]) if values[o] else 0.0 for o in values)
        if search_rank != full_rank:
            found.append(Disagreement(run.method, run.seed, search_rank, full_rank, largest))
    return found


__all__ = [
    "Disagreement",
    "Finalists",
    "FinalistsConfig",
    "FinalistsResult",
    "RuleFinalists",
    "baselines",
    "best_of",
    "finalist_orders",
]
