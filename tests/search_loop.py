"""A small ask/tell loop for the search tests, with the contract of the study's loop (no executor, no FMU).

Each batch: dedupe the asked designs (first occurrence, ask order), evaluate the ones not seen yet, tell the
search every asked design's value (a number or a vector, ``None`` for a failure, ``Above(limit)`` for a
censored one). The budget counts distinct designs and is never exceeded: when the new designs of a batch are
more than the budget left, only the first ones are evaluated and the batch is not told (pycma must not be
told a partial population). A design seen censored is evaluated again, without charging the budget, when it
is asked with no limit or a higher one. The run ends at the budget, at the search's ``stop()``, when every
design of the space is known, or after ``stall_batches`` batches in a row with nothing new.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Callable

from orchestrator.design import Design
from orchestrator.search import Search
from orchestrator.types import Above

STALL_BATCHES = 200


@dataclass(frozen=True)
class Evaluated:
    """One evaluation: the value (None: failed; for a censored one, None and the limit it is above)."""

    design: Design
    value: Any
    censored_above: float | None = None

    @property
    def told(self) -> Any:
        return Above(self.censored_above) if self.censored_above is not None else self.value


@dataclass(frozen=True)
class LoopRun:
    evaluations: tuple[Evaluated, ...]
    best_design: Design | None
    best_value: float | None
    stop_reason: str
    stalled: bool
    n_reevaluated: int
    diagnostics: dict = field(default_factory=dict)

    @property
    def n_evaluations(self) -> int:
        return len(self.evaluations)

    @property
    def n_censored(self) -> int:
        return sum(e.censored_above is not None for e in self.evaluations)

    @property
    def n_failed(self) -> int:
        return sum(e.value is None and e.censored_above is None for e in self.evaluations)

    def designs(self) -> list[Design]:
        """The distinct designs evaluated, in the order first evaluated."""
        return list(dict.fromkeys(e.design for e in self.evaluations))


def evaluate(value: Callable[[Design], Any], design: Design, limit: float | None, honour_limits: bool) -> Evaluated:
    """``value(design)``, a failure (an exception, a non-finite number) as None; above an honoured limit,
    censored."""
    try:
        result = value(design)
    except Exception:  # noqa: BLE001 - a failed evaluation is data
        return Evaluated(design, None)
    if result is None:
        return Evaluated(design, None)
    if isinstance(result, (tuple, list)):
        vector = tuple(float(v) for v in result)
        return Evaluated(design, vector if all(math.isfinite(v) for v in vector) else None)
    number = float(result)
    if not math.isfinite(number):
        return Evaluated(design, None)
    if honour_limits and limit is not None and number > limit:
        return Evaluated(design, None, float(limit))
    return Evaluated(design, number)


def run(search: Search, value: Callable[[Design], Any], budget: int, *, honour_limits: bool = False,
        stall_batches: int = STALL_BATCHES) -> LoopRun:
    """Drive ``search`` on ``value`` until the budget, its stop, exhaustion of the space or a stall."""
    seen: dict[Design, Evaluated] = {}
    evaluations: list[Evaluated] = []
    best: tuple[float, Design] | None = None
    reevaluated = no_new = 0
    stalled = False
    while True:
        if len(seen) >= budget:
            reason = f"budget of {budget} evaluations used"
            break
        if search.stop():
            reason = "the search stopped itself"
            break
        if len(seen) >= search.space.size:
            reason = f"all {search.space.size} designs evaluated"
            break
        asked = search.ask()
        limits = search.limits()
        limit_of = dict(zip(asked, limits)) if limits is not None else {}
        unique = list(dict.fromkeys(asked))
        fresh = [d for d in unique if d not in seen]
        truncated = len(fresh) > budget - len(seen)
        if truncated:
            new = fresh[:budget - len(seen)]
        else:
            new = [d for d in unique if d not in seen or (
                limits is not None and seen[d].censored_above is not None
                and (limit_of.get(d) is None or limit_of[d] > seen[d].censored_above))]
        for design in new:
            evaluation = evaluate(value, design, limit_of.get(design), honour_limits)
            reevaluated += design in seen
            seen[design] = evaluation
            evaluations.append(evaluation)
            if isinstance(evaluation.value, float) and (best is None or evaluation.value < best[0]):
                best = (evaluation.value, design)
        if truncated:
            reason = f"budget of {budget} evaluations used (last batch cut to {len(new)} new designs, not told)"
            break
        search.tell(asked, [seen[d].told for d in asked])
        no_new = 0 if fresh else no_new + 1
        if no_new >= stall_batches:
            stalled, reason = True, f"stalled: {stall_batches} batches in a row asked only designs already known"
            break
    return LoopRun(tuple(evaluations), None if best is None else best[1], None if best is None else best[0],
                   reason, stalled, reevaluated, search.state())
