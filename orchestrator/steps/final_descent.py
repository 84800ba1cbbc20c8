"""The final descent: from each rule's best finalist, single moves until none improves, and the check that
the design it ends at is a local optimum (every swap, insertion and, in a catalogue, replacement evaluated)."""

from __future__ import annotations

from dataclasses import dataclass

from ..design import MOVES
from ..loop import run_search
from ..objective import FULL, SEARCH
from ..options import check_options, option
from ..search import make_search
from ..study import Step, StudyContext
from ..types import Evaluation, Order
from .finalists import Finalists, best_of
from .searches import Searches, rule_label

MAX_DESCENT = 5000  # designs a descent may evaluate (it stops at the first local optimum long before)


@dataclass(frozen=True)
class FinalDescentConfig:
    enabled: bool = option(
        True,
        "skip the final descent and local-optimality check of each rule's best design",
        flag="--no-local-check",
        action="store_false",
    )

    def __post_init__(self):
        check_options(self)


@dataclass(frozen=True)
class LocalCheck:
    """Whether the design a descent ended at is a local optimum at the search fidelity."""

    diagonal_rule: str
    start: Order
    order: Order
    evaluations: int
    improvements: int
    checked: dict[str, int]  # neighbours evaluated, by move
    neighbours: dict[str, int]  # neighbours there are, by move
    failed: int
    censored: int  # stopped once above the value they had to beat: not better
    locally_optimal: bool
    nearest_neighbour_gap: float | None  # the best neighbour's value minus the design's (search fidelity)
    full: Evaluation  # the design at full fidelity
    stop_reason: str

    @property
    def complete(self) -> bool:
        """Every neighbour of the design it ended at was evaluated (else the cap stopped it first: not known)."""
        return self.checked == self.neighbours


@dataclass(frozen=True)
class FinalDescentResult:
    rules: tuple[LocalCheck, ...]

    def for_rule(self, label: str) -> LocalCheck | None:
        return next((c for c in self.rules if c.diagonal_rule == label), None)


def descent_cap(context: StudyContext, label: str, start: Order) -> int:
    """Designs a descent may evaluate: MAX_DESCENT, and no more than the searches evaluated under the rule (so
    --budget bounds this step too) unless one neighbourhood needs more: a local optimum is known only once each
    of its neighbours is evaluated."""
    searched = context.result(Searches)
    runs = searched.runs_for(label) if searched else []
    if not runs:
        return MAX_DESCENT
    neighbourhood = sum(len(designs) for designs in context.case.space.neighbours(start).values())
    return min(MAX_DESCENT, max(sum(run.distinct for run in runs), neighbourhood + 1))


def check_local_optimum(
    context: StudyContext, rule: str | None, start: Order, seed: int, cap: int = MAX_DESCENT
) -> LocalCheck:
    objective = context.objective(rule)
    space = context.case.space
    descent = make_search("local", space, seed, start=start, kicks=0)
    run = run_search(descent, objective, cap, context.evaluator, method_name="local", seed=seed, label=rule_label(rule))
    end = run.best_order or start
    moves = space.neighbours(end)
    values = {e.order: e for e in run.evaluations}
    own = values.get(end) or objective.evaluate([end], context.evaluator, SEARCH)[0]
    around = {move: [values[o] for o in designs if o in values] for move, designs in moves.items()}
    every = [e for move in MOVES for e in around[move]]
    good = [e for e in every if e.ok]
    above = [e for e in every if e.censored]
    complete = all(len(around[m]) == len(moves[m]) for m in MOVES)
    optimal = bool(
        complete
        and own.ok
        and len(good) + len(above) == len(every)
        and all(e.ok_value >= own.ok_value for e in good)
        and all(e.censored_limit >= own.ok_value for e in above)
    )
    curve = [v for v in run.best_so_far() if v is not None]
    improvements = sum(1 for a, b in zip(curve, curve[1:]) if b < a)
    full = objective.evaluate([end], context.evaluator, FULL)[0]
    return LocalCheck(
        rule_label(rule),
        start,
        end,
        run.n_evaluations,
        improvements,
        {m: len(around[m]) for m in MOVES},
        {m: len(moves[m]) for m in MOVES},
        sum(1 for e in every if not e.ok and not e.censored),
        len(above),
        optimal,
        (min(e.ok_value for e in good) - own.ok_value) if good and own.ok else None,
        full,
        run.stop_reason,
    )


class FinalDescent(Step):
    """Descends from each rule's best finalist and checks that the design it ends at is a local optimum."""

    name = "final_descent"
    title = "Local optimality"
    template = "final_descent.html.j2"
    Config = FinalDescentConfig

    def applies(self, context: StudyContext) -> bool:
        return self.config.enabled and context.result(Finalists) is not None

    def run(self, context: StudyContext) -> FinalDescentResult:
        finalists = context.result(Finalists)
        seed = context.config(Searches).seed
        checks = []
        for rule in context.rules:
            best = finalists.for_rule(rule_label(rule)).best
            if best is not None:
                checks.append(
                    check_local_optimum(
                        context, rule, best.order, seed, descent_cap(context, rule_label(rule), best.order)
                    )
                )
        return FinalDescentResult(tuple(checks))

    def cost_note(self, context: StudyContext) -> str:
        result = context.result(FinalDescent)
        sizes = [sum(c.neighbours.values()) for c in (result.rules if result else ())]
        return (
            f"a local optimum is known only once each of its {max(sizes, default=0):,} neighbours is evaluated, "
            "and each improving move starts another neighbourhood; --no-local-check skips it"
        )


__all__ = [
    "FinalDescent",
    "FinalDescentConfig",
    "FinalDescentResult",
    "rule_best",
    "LocalCheck",
    "MAX_DESCENT",
    "check_local_optimum",
    "descent_cap",
]


def rule_best(context: StudyContext, label: str) -> Evaluation | None:
    """A rule's best design at full fidelity: over its finalists and the end of its final descent."""
    finalists = context.result(Finalists)
    candidates = list(finalists.for_rule(label).evaluations) if finalists else []
    descent = context.result(FinalDescent)
    check = descent.for_rule(label) if descent else None
    if check is not None:
        candidates.append(check.full)
    return best_of(candidates)
