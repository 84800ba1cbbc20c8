"""The ask/tell protocol every search follows (the shape of pycma's).

A search sees designs and numbers only: never an objective, an FMU or an executor. The loop does the
evaluating, the caching and the budget.

Contract:
- ``Search(space, seed, **options)``: ``space`` is an ``orchestrator.design.DesignSpace`` (an int n means
  ``DesignSpace.permutations(n)``); ``search.space`` is it, ``search.n`` its number of columns.
- ``ask() -> list[Design]``: the next batch, every design in ``space``; designs may repeat (the loop answers
  repeats from its cache at no cost).
- ``limits() -> list[float | None] | None``: for the last ask, a value per design above which its exact value
  does not matter (the evaluation may stop early and be told ``Above(limit)``); None: exact values for all.
- ``tell(designs, values)``: exactly the designs of the last ``ask()``, in the same order. ``values[i]`` is a
  float for a search of one objective (``n_objectives == 1``), a sequence of ``n_objectives`` floats for a
  multi-objective one; ``None`` for a failed evaluation, ``Above(limit)`` for a censored one.
- ``stop() -> bool``: the search has nothing more to propose.
- ``state() -> dict``: diagnostics (JSON-friendly).

Failures: a ``None`` (or any non-finite number, or a vector with a non-finite entry) becomes ``FAILURE``
internally, the worst possible value on every objective: never accepted by the annealing, never a personal
or global best of the swarm, ranked last by CMA-ES. A failure is never treated as a good number.

Polishing is not in here: ``polish.Polished`` composes a search with the one local search (``local.py``) for
the end of its budget.

Randomness: every draw comes from ``numpy.random.default_rng(seed)`` (pycma's and pymoo's seeds are drawn
from it), so given the same told values a search makes exactly the same asks.
"""

from __future__ import annotations

import math
import numbers
from typing import Any, Sequence

import numpy as np

from ..design import Design, DesignSpace, as_design
from ..types import Above

FAILURE = math.inf
"""Internal value of a failed evaluation: worse than every real value."""


def as_space(space: DesignSpace | int) -> DesignSpace:
    """A design space, or a number of columns n for the permutations of n materials."""
    if isinstance(space, DesignSpace):
        return space
    if isinstance(space, bool) or not isinstance(space, numbers.Integral) or space < 1:
        raise ValueError(f"space must be a DesignSpace or a positive number of columns, got {space!r}")
    return DesignSpace.permutations(int(space))


def to_internal(value: Any) -> float:
    """None / NaN / inf -> +inf (a failure); Above(limit) (a censored evaluation) -> +inf too: it was asked
    with that limit because only a value below it would have mattered; anything else -> float."""
    if value is None or isinstance(value, Above):
        return FAILURE
    try:
        value = float(value)
    except (TypeError, ValueError):
        return FAILURE
    return value if math.isfinite(value) else FAILURE


class Search:
    """Base class: option checking, seeding, ask/tell bookkeeping, best tracking.

    Subclasses set ``name`` and ``OPTIONS`` (option -> default) and implement ``_ask``, ``_tell`` and
    optionally ``_stop`` / ``_state``. Every search accepts ``budget`` (the loop's evaluation budget) so that
    callers can pass it uniformly, and ``starts`` (designs to start from, see ``start_designs``); the annealing
    scales its cooling by it and ``make_search`` splits it between an optimiser and its polishing phase
    (``polish.Polished``).

    ``memo`` holds the value of every distinct design told so far (failures as ``FAILURE``; a tuple per
    design for a multi-objective search); ``len(memo)`` is the number of evaluations spent. A censored design
    is ``FAILURE`` in ``memo`` too (never a number), and ``censored_above`` keeps the limit it is known to be
    above, for a search that must tell "above a limit that no longer matters" from "unknown" (the annealing).
    """

    name = "search"
    OPTIONS: dict[str, Any] = {}
    POLISH: float | None = None  # default share of the budget for the final descent; None: never polished
    deterministic = False  # the same asks whatever the seed (one run is enough)
    baseline = False  # a reference every study can run, whatever the number of objectives
    max_evaluations: int | None = None  # evaluations it can ever ask for (None: unbounded)
    n_objectives = 1  # values told per design

    def __init__(self, space: DesignSpace | int, seed: int, **options: Any) -> None:
        allowed = dict(self.OPTIONS)
        allowed.setdefault("budget", None)
        allowed.setdefault("starts", None)
        unknown = sorted(set(options) - set(allowed))
        if unknown:
            raise ValueError(
                f"unknown option(s) {', '.join(unknown)} for search {self.name!r}; "
                f"allowed: {', '.join(sorted(allowed))}"
            )
        self.space = as_space(space)
        self.n = self.space.columns
        self.seed = int(seed)
        self.options = {**allowed, **options}
        self.rng = np.random.default_rng(self.seed)
        self._pending: list[Design] | None = None
        self.batches = 0
        self.told = 0
        self.n_failed = 0
        self.n_censored = 0
        self.best_value = math.inf
        self.best_order: Design | None = None
        self.memo: dict[Design, Any] = {}
        self.censored_above: dict[Design, float] = {}
        self.starts = tuple(
            self.space.check(d, f"{self.name}: starting design") for d in (self.options["starts"] or ())
        )

    def start_designs(self) -> tuple[Design, ...]:
        """Where the search starts (its ``x0="sequential"``): the starting designs it was given (option
        ``starts``: designs a person knows), else the space's baseline (the design a designer already has)."""
        return self.starts or (self.space.baseline(),)

    # -- protocol ---------------------------------------------------------
    def ask(self) -> list[Design]:
        if self._pending is not None:
            raise RuntimeError(f"{self.name}: ask() called twice without tell()")
        designs = [self.space.check(d, f"{self.name} asked") for d in self._ask()]
        self._pending = designs
        return list(designs)

    def tell(self, designs: Sequence[Sequence[int]], values: Sequence[Any]) -> None:
        if self._pending is None:
            raise RuntimeError(f"{self.name}: tell() without a preceding ask()")
        designs = [as_design(d) for d in designs]
        if designs != self._pending:
            raise ValueError(f"{self.name}: tell() must receive exactly the designs of the last ask()")
        if len(values) != len(designs):
            raise ValueError(f"{self.name}: {len(designs)} designs but {len(values)} values")
        internal = [self._internal(v) for v in values]
        self.n_censored += sum(isinstance(v, Above) for v in values)
        self._pending = None
        self.batches += 1
        self.told += len(designs)
        for design, value, told in zip(designs, internal, values):
            if self._is_failure(value) and not isinstance(told, Above):
                self.n_failed += 1
            elif self.n_objectives == 1 and value < self.best_value:
                self.best_value, self.best_order = value, design
            if isinstance(told, Above):
                self.censored_above[design] = max(told.limit, self.censored_above.get(design, -math.inf))
            else:
                self.censored_above.pop(design, None)
            self.memo[design] = value
        self._tell(designs, internal)

    def limits(self) -> list[float | None] | None:
        """For the last ask, a value per design above which its exact value does not matter to this search
        (the evaluation may then stop early and be told ``Above(limit)``); None: exact values for all."""
        return None

    def stop(self) -> bool:
        if self.space.size == 1 and self.batches > 0:
            return True  # a single design: nothing left to search
        return bool(self._stop())

    def state(self) -> dict[str, Any]:
        common = {
            "search": self.name,
            "n": self.n,
            "seed": self.seed,
            "space": {
                "kind": self.space.kind,
                "columns": self.space.columns,
                "materials": self.space.materials,
                "repeat": self.space.repeat,
            },
            "n_objectives": self.n_objectives,
            "options": {k: v for k, v in self.options.items() if _jsonable(v)},
            "batches": self.batches,
            "told": self.told,
            "failed_told": self.n_failed,
            "censored_told": self.n_censored,
            "best_value": None if self.best_order is None else self.best_value,
            "best_order": None if self.best_order is None else list(self.best_order),
            "evaluations_told": len(self.memo),
        }
        common.update(self._state())
        return common

    # -- values -------------------------------------------------------------
    def _internal(self, value: Any) -> Any:
        """A told value as the search keeps it (one objective: a float, ``FAILURE`` for a failure)."""
        if self.n_objectives == 1 and not isinstance(value, (str, bytes)) and isinstance(value, Sequence):
            raise ValueError(f"{self.name}: told {value!r}; a search of one objective takes one number per design")
        return to_internal(value)

    def _is_failure(self, value: Any) -> bool:
        return value == FAILURE

    # -- to implement -----------------------------------------------------
    def _ask(self) -> list[Design]:
        raise NotImplementedError

    def _tell(self, designs: list[Design], values: list[Any]) -> None:
        raise NotImplementedError

    def _stop(self) -> bool:
        return False

    def _state(self) -> dict[str, Any]:
        return {}

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.space.key} seed={self.seed}>"


def _jsonable(value: Any) -> bool:
    return value is None or isinstance(value, (bool, int, float, str))
