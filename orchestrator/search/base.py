"""The ask/tell protocol every search follows (the shape of pycma's).

A search sees orders and numbers only: never an objective, an FMU or an
executor.  The loop (``orchestrator.loop.run_search``) does the evaluating.

Contract:
- ``ask() -> list[Order]``: the next batch; orders may repeat (the loop answers
  repeats from its cache at no cost).
- ``tell(orders, values)``: exactly the orders of the last ``ask()``, in the
  same order; ``values[i]`` is a float, or ``None`` for a failed evaluation.
- ``stop() -> bool``: the search has nothing more to propose.
- ``state() -> dict``: diagnostics (JSON-friendly).

Failures: a ``None`` (or any non-finite number) is turned into ``+inf``
internally, i.e. the worst possible value: it is never accepted by annealing,
never becomes a personal/global best in the swarm, and gets the worst rank in
CMA-ES.  A failure is never treated as a good number.

Polishing is not in here: ``polish.Polished`` composes any search with the
one local search (``local.py``) for the end of its budget.

Randomness: every draw comes from ``numpy.random.default_rng(seed)`` (pycma
additionally through its own ``seed`` option), so given the same told values
a search makes exactly the same asks.
"""
from __future__ import annotations

import math
from typing import Any, Sequence

import numpy as np

from ..types import Above, Order, as_order

FAILURE = math.inf
"""Internal value of a failed evaluation: worse than every real value."""


def keys_to_order(keys: np.ndarray, n: int | None = None) -> Order:
    """Random-key decoding, ``order = argsort(keys) + 1``.

    Key i belongs to material i+1; the columns take the materials in
    increasing order of their keys.  Only the first ``n`` keys are used.

    Why random keys: they let continuous optimisers (CMA-ES, PSO) search over
    permutations; many points map to the same order, which is why the loop
    caches by order.  A stable sort makes ties (e.g. keys clipped to a bound)
    deterministic.
    """
    keys = np.asarray(keys, dtype=float)
    if n is not None:
        keys = keys[:n]
    return tuple(int(i) + 1 for i in np.argsort(keys, kind="stable"))


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


def random_order(rng: np.random.Generator, n: int) -> Order:
    return tuple(int(i) + 1 for i in rng.permutation(n))


class Search:
    """Base class: option checking, seeding, ask/tell bookkeeping, best tracking.

    Subclasses set ``name`` and ``OPTIONS`` (option -> default) and implement
    ``_ask``, ``_tell`` and optionally ``_stop`` / ``_state``.  Every search
    accepts ``budget`` (the loop's evaluation budget) so that callers can pass
    it uniformly; the optimisers use it to schedule their polishing phase
    (option ``polish``, the fraction of the budget it gets, and ``polish_batch``,
    its batch size; see ``polish.Polished``, which ``make_search`` wraps them in),
    the annealing also to scale its cooling.

    ``memo`` holds the value of every distinct order told so far (failures as
    ``FAILURE``); ``len(memo)`` is the number of evaluations spent.  A censored
    order is ``FAILURE`` in ``memo`` too (never a number), and ``censored_above``
    keeps the limit it is known to be above, for a search that must tell "above
    a limit that no longer matters" from "unknown" (the annealing).
    """

    name = "search"
    OPTIONS: dict[str, Any] = {}
    POLISH: float | None = None  # default share of the budget for the final descent; None: never polished
    deterministic = False  # the same asks whatever the seed (one run is enough)
    max_evaluations: int | None = None  # evaluations it can ever ask for (None: unbounded)

    def __init__(self, n: int, seed: int, **options: Any) -> None:
        if int(n) != n or n < 1:
            raise ValueError(f"n must be a positive integer, got {n!r}")
        allowed = dict(self.OPTIONS)
        allowed.setdefault("budget", None)
        unknown = sorted(set(options) - set(allowed))
        if unknown:
            raise ValueError(
                f"unknown option(s) {', '.join(unknown)} for search {self.name!r}; "
                f"allowed: {', '.join(sorted(allowed))}")
        self.n = int(n)
        self.seed = int(seed)
        self.options = {**allowed, **options}
        self.rng = np.random.default_rng(self.seed)
        self._pending: list[Order] | None = None
        self.batches = 0
        self.told = 0
        self.n_failed = 0
        self.n_censored = 0
        self.best_value = math.inf
        self.best_order: Order | None = None
        self.memo: dict[Order, float] = {}
        self.censored_above: dict[Order, float] = {}

    # -- protocol ---------------------------------------------------------
    def ask(self) -> list[Order]:
        if self._pending is not None:
            raise RuntimeError(f"{self.name}: ask() called twice without tell()")
        orders = [as_order(o) for o in self._ask()]
        self._pending = orders
        return list(orders)

    def tell(self, orders: Sequence[Sequence[int]], values: Sequence[Any]) -> None:
        if self._pending is None:
            raise RuntimeError(f"{self.name}: tell() without a preceding ask()")
        orders = [as_order(o) for o in orders]
        if orders != self._pending:
            raise ValueError(f"{self.name}: tell() must receive exactly the orders of the last ask()")
        if len(values) != len(orders):
            raise ValueError(f"{self.name}: {len(orders)} orders but {len(values)} values")
        internal = [to_internal(v) for v in values]
        self.n_censored += sum(isinstance(v, Above) for v in values)
        self._pending = None
        self.batches += 1
        self.told += len(orders)
        for order, value, told in zip(orders, internal, values):
            if value == FAILURE and not isinstance(told, Above):
                self.n_failed += 1
            elif value < self.best_value:
                self.best_value, self.best_order = value, order
            if isinstance(told, Above):
                self.censored_above[order] = max(told.limit, self.censored_above.get(order, -math.inf))
            else:
                self.censored_above.pop(order, None)
            self.memo[order] = value
        self._tell(orders, internal)

    def limits(self) -> list[float | None] | None:
        """For the last ask, a value per order above which its exact value does not matter to this search
        (the evaluation may then stop early and be told ``Above(limit)``); None: exact values for all."""
        return None

    def stop(self) -> bool:
        if self.n == 1 and self.batches > 0:
            return True  # a single order: nothing left to search
        return bool(self._stop())

    def state(self) -> dict[str, Any]:
        common = {
            "search": self.name, "n": self.n, "seed": self.seed,
            "options": {k: v for k, v in self.options.items() if _jsonable(v)},
            "batches": self.batches, "told": self.told, "failed_told": self.n_failed,
            "censored_told": self.n_censored,
            "best_value": None if self.best_order is None else self.best_value,
            "best_order": None if self.best_order is None else list(self.best_order),
            "evaluations_told": len(self.memo),
        }
        common.update(self._state())
        return common

    # -- to implement -----------------------------------------------------
    def _ask(self) -> list[Order]:
        raise NotImplementedError

    def _tell(self, orders: list[Order], values: list[float]) -> None:
        raise NotImplementedError

    def _stop(self) -> bool:
        return False

    def _state(self) -> dict[str, Any]:
        return {}

    def __repr__(self) -> str:
        return f"<{type(self).__name__} n={self.n} seed={self.seed}>"


def _jsonable(value: Any) -> bool:
    return value is None or isinstance(value, (bool, int, float, str))
