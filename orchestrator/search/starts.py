"""Starting designs: designs a person knows, which every search evaluates first and may start from.

``Started`` composes any search with its starting designs: its first batch is the starting designs (asked with
no force limit, so each gets an exact value), then the inner search runs as it would. The inner search is
given the same designs (option ``starts``) and starts from them where it has a start (CMA-ES's mean and its
first population, the swarm's particles, the annealing's chains, the GA's, DE's and NSGA-II's first
population, the descent's start); when it asks one of them again the loop answers from its cache at no cost,
so the search is told their values. The random search and the sequential baseline have no start of their own:
the first batch is how they evaluate the starting designs.

Why a composition rather than code in each search: "evaluated first" then holds for every search, whatever
its library does with the points it is given.
"""

from __future__ import annotations

from typing import Any, Sequence

from fmu_src.published import STUDY_BEST_ORDER

from ..design import Design, as_design
from .base import Search

# How a design is written, shown by the study's published best order
DESIGN_EXAMPLE = ",".join(map(str, STUDY_BEST_ORDER))


def parse_design(text: str, what: str = "--start") -> Design:
    """A design written as material numbers separated by commas, as ``DESIGN_EXAMPLE`` (spaces, brackets and a
    trailing comma allowed)."""
    cleaned = text.strip().strip("[]()").replace(" ", ",")
    items = [item for item in cleaned.split(",") if item.strip()]
    try:
        design = tuple(int(item) for item in items)
    except ValueError:
        raise ValueError(
            f"{what} {text.strip()!r}: expected material numbers separated by commas, e.g. {DESIGN_EXAMPLE}"
        ) from None
    if not design:
        raise ValueError(f"{what} {text!r}: no material numbers")
    return design


class Started:
    """``inner`` after a first batch of ``starts`` (see the module docstring); everything else is ``inner``'s."""

    def __init__(self, inner: Search, starts: Sequence[Sequence[int]]) -> None:
        self.inner = inner
        self.starts = tuple(dict.fromkeys(inner.space.check(d, f"{inner.name}: starting design") for d in starts))
        self._phase = "start"  # "start": not asked yet; "asked": the starts asked; "inner": the search's own

    def __getattr__(self, name: str) -> Any:  # the inner search's space, n, n_objectives, pareto_front, ...
        if name == "inner":
            raise AttributeError(name)
        return getattr(self.inner, name)

    def ask(self) -> list[Design]:
        if self._phase == "start":
            self._phase = "asked"
            return list(self.starts)
        return self.inner.ask()

    def limits(self) -> list[float | None] | None:
        return None if self._phase == "asked" else self.inner.limits()

    def tell(self, designs: Sequence[Sequence[int]], values: Sequence[Any]) -> None:
        if self._phase == "asked":
            if [as_design(d) for d in designs] != list(self.starts):
                raise ValueError(f"{self.inner.name}: tell() must receive exactly the starting designs first")
            self._phase = "inner"  # the inner search learns them when it asks them (from the loop's cache)
            return
        self.inner.tell(designs, values)

    def stop(self) -> bool:
        return self._phase == "inner" and self.inner.stop()

    def state(self) -> dict[str, Any]:
        return {**self.inner.state(), "starts": [list(d) for d in self.starts]}


__all__ = ["DESIGN_EXAMPLE", "Started", "parse_design"]
