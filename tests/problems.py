"""Cheap deterministic problems with known optima over a design space (no FMU), for the tests.

Every class is a top-level, picklable callable ``objective(design) -> Evaluation``, so that the tests can run
it on a process pool or a Dask cluster: a worker imports this module as ``problems`` (pytest puts tests/ on
``sys.path``, and spawned workers inherit the parent's ``sys.path``); a new interpreter started with
``subprocess`` needs ``env=importable_env()``. ``value(design)`` gives the number
alone, ``values(designs)`` many at once; ``brute_force`` and ``exact_front`` give the known optimum and
Pareto front of a small space by enumerating it.
"""

from __future__ import annotations

import os
import time
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

from orchestrator.design import Design, DesignSpace, as_design
from orchestrator.types import Evaluation, censored

ENUMERABLE = 400_000  # designs brute force enumerates at most (9! = 362,880)
TESTS = Path(__file__).resolve().parent


def importable_env(environ: dict[str, str] | None = None) -> dict[str, str]:
    """``environ`` (default: this process's environment) with tests/ first on PYTHONPATH, so that a Python
    started by ``subprocess`` (and the workers it spawns) can ``import problems``."""
    environ = dict(os.environ if environ is None else environ)
    environ["PYTHONPATH"] = os.pathsep.join([str(TESTS)] + [p for p in [environ.get("PYTHONPATH")] if p])
    return environ


def as_space(space: DesignSpace | int) -> DesignSpace:
    return space if isinstance(space, DesignSpace) else DesignSpace.permutations(int(space))


def enumerate_space(space: DesignSpace | int) -> np.ndarray:
    """Every design of a small space, one row each, in rank order."""
    space = as_space(space)
    if space.size > ENUMERABLE:
        raise ValueError(f"brute force is for spaces of at most {ENUMERABLE:,} designs, not {space.size:,}")
    return np.array(list(space.designs(0, space.size)), dtype=int)


class WeightedDistance:
    """cost(d) = sum_j w_j |d_j - target_j|; unique minimum 0 at ``target``, in any space holding it."""

    def __init__(self, target: Sequence[int], weights: Sequence[float] | None = None) -> None:
        self.target = np.asarray(as_design(target), dtype=float)
        self.weights = np.ones(len(self.target)) if weights is None else np.asarray(weights, dtype=float)
        if np.any(self.weights <= 0):
            raise ValueError("weights must be positive for a unique optimum")
        self.optimum = as_design(target)

    @classmethod
    def random(cls, space: DesignSpace | int, seed: int) -> "WeightedDistance":
        space = as_space(space)
        rng = np.random.default_rng(seed)
        return cls(space.random(rng), rng.uniform(0.5, 2.0, space.columns))

    def values(self, designs: np.ndarray) -> np.ndarray:
        return np.abs(np.asarray(designs, dtype=float) - self.target) @ self.weights

    def value(self, design: Sequence[int]) -> float:
        return float(np.sum(self.weights * np.abs(np.asarray(design, dtype=float) - self.target)))

    def __call__(self, design: Sequence[int]) -> Evaluation:
        return Evaluation(as_design(design), self.value(design), "ok")


class QuadraticAssignment:
    """cost(d) = sum_{a,b} flow[d_a, d_b] distance[a, b] + sum_a linear[d_a, a] (materials x columns).

    A rugged, non-separable landscape closer in spirit to the lattice: what a material costs depends on its
    neighbours. ``random(space, seed)`` draws a line of columns (distance |a - b|), random symmetric integer
    flows between the M materials and a small random linear term that breaks the mirror symmetry, so the
    optimum is unique (with probability 1). With repetition the flow of a material with itself is drawn too
    (else one material in every column would cost nothing but its linear term).
    """

    def __init__(self, flow: np.ndarray, distance: np.ndarray, linear: np.ndarray | None = None) -> None:
        self.flow = np.asarray(flow, dtype=float)
        self.distance = np.asarray(distance, dtype=float)
        self.linear = (
            np.zeros((len(self.flow), len(self.distance))) if linear is None else np.asarray(linear, dtype=float)
        )

    @classmethod
    def random(cls, space: DesignSpace | int, seed: int) -> "QuadraticAssignment":
        space = as_space(space)
        rng = np.random.default_rng(seed)
        m, c = space.materials, space.columns
        flow = np.triu(rng.integers(0, 10, (m, m)).astype(float), 0 if space.repeat else 1)
        position = np.arange(c, dtype=float)
        distance = np.abs(position[:, None] - position[None, :])
        return cls(flow + np.triu(flow, 1).T, distance, rng.uniform(0.0, 3.0, (m, c)))

    def values(self, designs: np.ndarray) -> np.ndarray:
        """Vectorised cost of many designs (rows)."""
        m = np.asarray(designs, dtype=int) - 1
        columns = m.shape[1]
        total = np.zeros(m.shape[0])
        for a in range(columns):
            total += self.linear[m[:, a], a]
            for b in range(columns):
                if self.distance[a, b]:
                    total += self.flow[m[:, a], m[:, b]] * self.distance[a, b]
        return total

    def value(self, design: Sequence[int]) -> float:
        m = np.asarray(design, dtype=int) - 1
        return float(np.sum(self.flow[np.ix_(m, m)] * self.distance) + np.sum(self.linear[m, np.arange(len(m))]))

    def __call__(self, design: Sequence[int]) -> Evaluation:
        return Evaluation(as_design(design), self.value(design), "ok")


class TwoObjectives:
    """Two cheap objectives that conflict, for the multi-objective search: two independent quadratic
    assignments of the same space (``random(space, seed)``), both minimised. ``value(design)`` is the pair."""

    def __init__(self, first: QuadraticAssignment, second: QuadraticAssignment) -> None:
        self.first, self.second = first, second

    @classmethod
    def random(cls, space: DesignSpace | int, seed: int) -> "TwoObjectives":
        return cls(QuadraticAssignment.random(space, 2 * seed), QuadraticAssignment.random(space, 2 * seed + 1))

    def values(self, designs: np.ndarray) -> np.ndarray:
        return np.stack([self.first.values(designs), self.second.values(designs)], axis=1)

    n_objectives = 2

    def value(self, design: Sequence[int]) -> tuple[float, float]:
        return self.first.value(design), self.second.value(design)

    def __call__(self, design: Sequence[int]) -> Evaluation:
        pair = self.value(design)
        return Evaluation(as_design(design), pair[0], "ok", values=pair)


def brute_force(objective: Any, space: DesignSpace | int) -> tuple[list[Design], float]:
    """All minimisers and the minimum over every design of a small space (an int n: the permutations of n).

    Uses ``objective.values`` (vectorised) when it has one, else ``objective.value``.
    """
    designs = enumerate_space(space)
    if hasattr(objective, "values"):
        values = np.asarray(objective.values(designs), dtype=float)
    else:
        values = np.array([objective.value(d) for d in designs], dtype=float)
    best = float(values.min())
    winners = [as_design(d) for d in designs[values <= best + 1e-9]]
    return winners, best


def exact_front(objective: TwoObjectives, space: DesignSpace | int) -> list:
    """The exact Pareto front of a small space, by enumerating it (a list of ``pareto.ParetoPoint``)."""
    from orchestrator.search.pareto import pareto_front  # here: a worker importing the problems needs no search

    designs = enumerate_space(space)
    return pareto_front([as_design(d) for d in designs], objective.values(designs))


class Flaky:
    """Wraps an objective; fails deterministically on about 1 design in ``period``.

    mode "raise" raises RuntimeError, "nan"/"inf" return that peak, "failed" returns a failed Evaluation.
    Designs in ``never`` never fail (so a test can keep the optimum evaluable). Whether a design fails depends
    only on the design, so results do not depend on the executor.
    """

    def __init__(
        self, base: Callable[[Design], Any], period: int = 4, mode: str = "raise", never: Sequence[Sequence[int]] = ()
    ) -> None:
        if mode not in ("raise", "nan", "inf", "failed"):
            raise ValueError(f"mode must be raise, nan, inf or failed, got {mode!r}")
        self.base, self.period, self.mode = base, int(period), mode
        self.never = {as_design(d) for d in never}

    def fails(self, design: Sequence[int]) -> bool:
        design = as_design(design)
        if design in self.never:
            return False
        return sum((k + 1) * (p * p + 7) for k, p in enumerate(design)) % self.period == 0

    def __call__(self, design: Sequence[int]) -> Evaluation:
        design = as_design(design)
        if self.fails(design):
            if self.mode == "raise":
                raise RuntimeError(f"simulated solver failure for {list(design)}")
            if self.mode == "failed":
                return Evaluation(design, None, "failed", "simulated failure")
            return Evaluation(design, float(self.mode), "ok")
        return self.base(design)


class Limited:
    """A cheap objective's evaluation that stops above a force limit, like the FMU's ``peak_force_limit``:
    a value above ``force_limit`` comes back censored (its value unknown), never as a number."""

    def __init__(self, base: Callable[[Design], Any], force_limit: float | None = None) -> None:
        self.base, self.force_limit = base, force_limit

    @property
    def key(self) -> str:
        return f"Limited:{id(self.base)}:{self.force_limit!r}"

    def with_limit(self, limit: float | None) -> "Limited":
        return Limited(self.base, limit)

    def __call__(self, design: Sequence[int]) -> Evaluation:
        evaluation = self.base(design)
        if self.force_limit is not None and evaluation.value > self.force_limit:
            return censored(design, self.force_limit, 0.5, evaluation.seconds)
        return evaluation


class LimitedObjective:
    """Factory of an ``Objective`` over a cheap problem whose evaluations can be censored."""

    @staticmethod
    def of(base: Callable[[Design], Any], space: DesignSpace | int):
        from orchestrator.objective import CallableObjective

        class _Limited(CallableObjective):
            name = "limited"
            supports_limits = True

        return _Limited(Limited(base), space=as_space(space))


def search_run(search, problem: Callable[[Design], Any], budget: int, *, honour_limits: bool = False):
    """``search`` on ``problem`` for ``budget`` designs through the study's own loop (``run_search``, one
    Evaluator on the serial executor): the same dedupe, budget, censoring and stop rules as a study's searches.
    ``honour_limits``: the evaluations stop above the limit each design is asked with (like the FMU's
    ``peak_force_limit``), so a value above it comes back censored."""
    from orchestrator.executors import SerialExecutor
    from orchestrator.loop import Evaluator, run_search
    from orchestrator.objective import CallableObjective

    objective = (
        LimitedObjective.of(problem, search.space) if honour_limits else CallableObjective(problem, space=search.space)
    )
    return run_search(search, objective, budget, Evaluator(SerialExecutor()), method_name=search.name, seed=search.seed)


def designs_of(run) -> list[Design]:
    """The distinct designs a search run evaluated, in the order first evaluated."""
    return list(dict.fromkeys(e.order for e in run.evaluations))


class Delayed:
    """Wraps an objective and sleeps ``seconds`` per call: a cheap stand-in for a simulation's cost, so that
    a test can interrupt a parallel run midway (e.g. the exhaustive sweep's kill-and-resume test)."""

    def __init__(self, base: Callable[[Design], Any], seconds: float) -> None:
        self.base, self.seconds = base, float(seconds)

    def __repr__(self) -> str:
        return f"Delayed({type(self.base).__name__}, {self.seconds})"

    def __call__(self, design: Sequence[int]) -> Any:
        time.sleep(self.seconds)
        return self.base(design)
