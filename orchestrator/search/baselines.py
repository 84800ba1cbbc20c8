"""Baselines every optimiser must beat: the sequential order and random search."""
from __future__ import annotations

from typing import Any

from ..types import Order
from .base import Search, random_order


class Sequential(Search):
    """Asks the order [1, 2, ..., n] once, then stops (the study's reference)."""

    name = "sequential"
    OPTIONS = {"budget": None}
    deterministic = True
    max_evaluations = 1

    def _ask(self) -> list[Order]:
        return [tuple(range(1, self.n + 1))]

    def _tell(self, orders: list[Order], values: list[float]) -> None:
        pass

    def _stop(self) -> bool:
        return self.batches > 0


class RandomSearch(Search):
    """Uniform random permutations, ``batch`` per ask (default 16), with replacement.

    Repeats are answered from the loop's cache for free, so the budget counts
    distinct orders; the search never stops by itself.
    """

    name = "random"
    OPTIONS = {"batch": 16, "budget": None}

    def __init__(self, n: int, seed: int, **options: Any) -> None:
        super().__init__(n, seed, **options)
        self.batch = int(self.options["batch"])
        if self.batch < 1:
            raise ValueError("random: batch must be at least 1")

    def _ask(self) -> list[Order]:
        return [random_order(self.rng, self.n) for _ in range(self.batch)]

    def _tell(self, orders: list[Order], values: list[float]) -> None:
        pass

    def _state(self) -> dict[str, Any]:
        return {"batch": self.batch}
