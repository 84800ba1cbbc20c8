"""A search composed with the one local search for the end of its budget.

Why a polishing phase: the optimisers on random keys change a design in several columns per step and late in
a run mostly decode to designs already seen; the annealing samples neighbours at random where a descent
checks them one by one. The last improvements are single moves (swaps, insertions, replacements), so
``make_search`` wraps each optimiser in ``Polished``: the optimiser gets the first ``budget - round(polish *
budget)`` distinct designs, then a ``local.Descent`` (with kicks: an iterated local search) starts at the best
design found. The switch happens between two batches. ``state()["phase"]`` says which phase the search is in.
"""

from __future__ import annotations

from typing import Any

from ..design import Design
from .base import Search
from .local import Descent


class Polished(Search):
    """``inner`` for its share of ``budget``, then a descent by the space's moves from the best design."""

    OPTIONS = {"polish": 0.0, "polish_batch": 4, "budget": None}

    def __init__(self, inner: Search, **options: Any) -> None:
        self.name = inner.name
        super().__init__(inner.space, inner.seed, **options)
        polish = self.options["polish"]
        if polish is None or not 0.0 <= float(polish) <= 1.0:
            raise ValueError(f"{self.name}: polish must be a fraction in [0, 1], got {polish!r}")
        self.inner = inner
        self.rng = inner.rng  # one stream of draws for the optimiser and its descent
        budget = self.options["budget"]
        self.switch_at = None if budget is None or not polish else int(budget) - round(float(polish) * int(budget))
        self.descent: Descent | None = None
        self.polish_started_at: int | None = None

    def _ask(self) -> list[Design]:
        if (
            self.descent is None
            and self.switch_at is not None
            and self.best_order is not None
            and len(self.memo) >= self.switch_at
        ):
            self.descent = Descent(self.rng, batch=int(self.options["polish_batch"] or 4), space=self.space)
            self.descent.start(self.best_order, self.best_value)
            self.polish_started_at = len(self.memo)
        # once the descent is made, every batch is the descent's (limits and _tell follow the same choice)
        self._asked = (
            self.descent.propose(self.memo, self.censored_above) if self.descent is not None else self.inner.ask()
        )
        return self._asked

    def limits(self) -> list[float | None] | None:
        return self.descent.limits(self._asked) if self.descent is not None else self.inner.limits()

    def tell(self, designs, values) -> None:
        self._told = list(values)  # the inner search is told what was told (Above stays Above), not +inf
        super().tell(designs, values)

    def _tell(self, designs: list[Design], values: list[float]) -> None:
        if self.descent is not None:
            self.descent.update(designs, values)
        else:
            self.inner.tell(designs, self._told)

    def _stop(self) -> bool:
        return self.descent is None and self.inner.stop()

    def state(self) -> dict[str, Any]:
        state = self.inner.state()
        own = super().state()
        for key in ("batches", "told", "failed_told", "censored_told", "best_value", "best_order", "evaluations_told"):
            state[key] = own[key]
        state["options"] = {**state.get("options", {}), **own["options"]}
        state["phase"] = "polish" if self.descent is not None else "search"
        state["polish_started_at"] = self.polish_started_at
        if self.descent is not None:
            state["polish_state"] = self.descent.state()
        return state
