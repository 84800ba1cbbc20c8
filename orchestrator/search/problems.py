"""Cheap deterministic permutation objectives with known optima (no FMU).

Why here and not in tests/: objectives used with process or Dask executors
must be importable by the workers; these also let anyone try a search or an
executor in milliseconds (e.g. a CLI smoke test).  Every class is a top-level,
picklable callable ``objective(order) -> Evaluation``.
"""
from __future__ import annotations

import itertools
from typing import Any, Callable, Sequence

import numpy as np

from ..types import Evaluation, Order, as_order


class WeightedDistance:
    """cost(p) = sum_j w_j |p_j - target_j|; unique minimum 0 at ``target``."""

    def __init__(self, target: Sequence[int], weights: Sequence[float] | None = None) -> None:
        self.target = np.asarray(as_order(target), dtype=float)
        self.weights = (np.ones(len(self.target)) if weights is None
                        else np.asarray(weights, dtype=float))
        if np.any(self.weights <= 0):
            raise ValueError("weights must be positive for a unique optimum")
        self.optimum = as_order(target)

    @classmethod
    def random(cls, n: int, seed: int) -> "WeightedDistance":
        rng = np.random.default_rng(seed)
        return cls(rng.permutation(n) + 1, rng.uniform(0.5, 2.0, n))

    def value(self, order: Sequence[int]) -> float:
        return float(np.sum(self.weights * np.abs(np.asarray(order, dtype=float) - self.target)))

    def __call__(self, order: Sequence[int]) -> Evaluation:
        return Evaluation(as_order(order), self.value(order), "ok")


class QuadraticAssignment:
    """cost(p) = sum_{a,b} flow[p_a, p_b] distance[a, b] + sum_a linear[p_a, a].

    (materials x columns.)  A rugged, non-separable landscape closer in spirit
    to the lattice: what a material costs depends on its neighbours.
    ``random(n, seed)`` draws a line layout (distance |a - b|), random
    symmetric integer flows and a small random linear term that breaks the
    mirror symmetry, so the optimum is unique (with probability 1).
    """

    def __init__(self, flow: np.ndarray, distance: np.ndarray, linear: np.ndarray | None = None) -> None:
        self.flow = np.asarray(flow, dtype=float)
        self.distance = np.asarray(distance, dtype=float)
        n = len(self.flow)
        self.linear = np.zeros((n, n)) if linear is None else np.asarray(linear, dtype=float)

    @classmethod
    def random(cls, n: int, seed: int) -> "QuadraticAssignment":
        rng = np.random.default_rng(seed)
        flow = np.triu(rng.integers(0, 10, (n, n)).astype(float), 1)
        position = np.arange(n, dtype=float)
        distance = np.abs(position[:, None] - position[None, :])
        return cls(flow + flow.T, distance, rng.uniform(0.0, 3.0, (n, n)))

    def values(self, orders: np.ndarray) -> np.ndarray:
        """Vectorised cost of many orders (rows)."""
        m = np.asarray(orders, dtype=int) - 1
        n = m.shape[1]
        total = np.zeros(m.shape[0])
        for a in range(n):
            total += self.linear[m[:, a], a]
            for b in range(n):
                if self.distance[a, b]:
                    total += self.flow[m[:, a], m[:, b]] * self.distance[a, b]
        return total

    def value(self, order: Sequence[int]) -> float:
        m = np.asarray(order, dtype=int) - 1
        return float(np.sum(self.flow[np.ix_(m, m)] * self.distance)
                     + np.sum(self.linear[m, np.arange(len(m))]))

    def __call__(self, order: Sequence[int]) -> Evaluation:
        return Evaluation(as_order(order), self.value(order), "ok")


def brute_force(objective: Any, n: int) -> tuple[list[Order], float]:
    """All minimisers and the minimum over every permutation of 1..n (n <= 9).

    Uses ``objective.values`` (vectorised) when it has one, else ``objective.value``.
    """
    if n > 9:
        raise ValueError("brute force is for n <= 9")
    perms = np.array(list(itertools.permutations(range(1, n + 1))), dtype=int)
    if hasattr(objective, "values"):
        values = np.asarray(objective.values(perms), dtype=float)
    else:
        values = np.array([objective.value(p) for p in perms], dtype=float)
    best = float(values.min())
    winners = [as_order(p) for p in perms[values <= best + 1e-9]]
    return winners, best


class Flaky:
    """Wraps an objective; fails deterministically on about 1 order in ``period``.

    mode "raise" raises RuntimeError, "nan"/"inf" return that peak,
    "failed" returns a failed Evaluation.  Orders in ``never`` never fail (so
    a test can keep the optimum evaluable).  Whether an order fails depends
    only on the order, so results do not depend on the executor.
    """

    def __init__(self, base: Callable[[Order], Any], period: int = 4, mode: str = "raise",
                 never: Sequence[Sequence[int]] = ()) -> None:
        if mode not in ("raise", "nan", "inf", "failed"):
            raise ValueError("mode must be raise, nan, inf or failed")
        self.base, self.period, self.mode = base, int(period), mode
        self.never = {as_order(o) for o in never}

    def fails(self, order: Sequence[int]) -> bool:
        order = as_order(order)
        if order in self.never:
            return False
        return sum((k + 1) * (p * p + 7) for k, p in enumerate(order)) % self.period == 0

    def __call__(self, order: Sequence[int]) -> Evaluation:
        order = as_order(order)
        if self.fails(order):
            if self.mode == "raise":
                raise RuntimeError(f"simulated solver failure for {list(order)}")
            if self.mode == "failed":
                return Evaluation(order, None, "failed", "simulated failure")
            return Evaluation(order, float(self.mode), "ok")
        return self.base(order)


class Limited:
    """A cheap objective's evaluation that stops above a force limit, like the FMU's ``peak_force_limit``:
    a value above ``force_limit`` comes back censored (its value unknown), never as a number."""

    def __init__(self, base: Callable[[Order], Any], force_limit: float | None = None) -> None:
        self.base, self.force_limit = base, force_limit

    @property
    def key(self) -> str:
        return f"Limited:{id(self.base)}:{self.force_limit!r}"

    def with_limit(self, limit: float | None) -> "Limited":
        return Limited(self.base, limit)

    def __call__(self, order: Sequence[int]) -> Evaluation:
        from ..types import censored

        evaluation = self.base(order)
        if self.force_limit is not None and evaluation.peak > self.force_limit:
            return censored(order, self.force_limit, reached_at=0.5, seconds=evaluation.seconds)
        return evaluation


class LimitedObjective:
    """Factory of an ``Objective`` over a cheap problem whose evaluations can be censored (tests)."""

    @staticmethod
    def of(base: Callable[[Order], Any], n: int):
        from ..objective import CallableObjective

        class _Limited(CallableObjective):
            name = "limited"
            supports_limits = True

        return _Limited(Limited(base), n)


class Delayed:
    """Wraps an objective and sleeps ``seconds`` per call: a cheap stand-in for a simulation's cost, so
    that a test can interrupt a parallel run midway (e.g. the exhaustive sweep's kill-and-resume test)."""

    def __init__(self, base: Callable[[Order], Any], seconds: float) -> None:
        self.base, self.seconds = base, float(seconds)

    def __repr__(self) -> str:
        return f"Delayed({type(self.base).__name__}, {self.seconds})"

    def __call__(self, order: Sequence[int]) -> Any:
        import time

        time.sleep(self.seconds)
        return self.base(order)
