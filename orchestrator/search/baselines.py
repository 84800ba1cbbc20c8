"""Baselines every optimiser must beat: the design a designer already has, and random search."""

from __future__ import annotations

from typing import Any

from ..design import Design, DesignSpace
from .base import Search


class Sequential(Search):
    """Asks the space's baseline once (materials 1..C in order: the study's reference), then stops."""

    name = "sequential"
    OPTIONS = {"budget": None}
    deterministic = True
    baseline = True
    max_evaluations = 1

    def _ask(self) -> list[Design]:
        return [self.space.baseline()]

    def _tell(self, designs: list[Design], values: list[float]) -> None:
        pass

    def _stop(self) -> bool:
        return self.batches > 0


class RandomSearch(Search):
    """Uniform random designs of the space, ``batch`` per ask (default 16), with replacement.

    Repeats are answered from the loop's cache for free, so the budget counts distinct designs; the search
    never stops by itself.
    """

    name = "random"
    baseline = True
    OPTIONS = {"batch": 16, "budget": None}

    def __init__(self, space: DesignSpace | int, seed: int, **options: Any) -> None:
        super().__init__(space, seed, **options)
        self.batch = int(self.options["batch"])
        if self.batch < 1:
            raise ValueError(f"random: batch must be at least 1, got {self.options['batch']!r}")

    def _ask(self) -> list[Design]:
        return [self.space.random(self.rng) for _ in range(self.batch)]

    def _tell(self, designs: list[Design], values: list[float]) -> None:
        pass

    def _state(self) -> dict[str, Any]:
        return {"batch": self.batch}
