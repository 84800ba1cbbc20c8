"""A statistical estimate of the optimum where no sweep fits: an extreme-value fit to random designs' peaks.

Why: a space too large to sweep (12 columns, the 11 x 11 x 11 plate) leaves a search with "best found" and no
idea how far the optimum may lie below it. The minimum of a group of random designs' values follows, for large
groups, a Weibull law whose location is the lower end of the values: the optimum. As done for quadratic
assignment problems (Golden and Alt; Derigs), the random designs are split into groups, a three-parameter
Weibull (``scipy.stats.weibull_min``) is fitted to the group minima, and its location estimates the optimum.
The interval rests on the same law: with n group minima from a Weibull of location a, scale b and shape c, the
smallest of them exceeds a + d with probability exp(-n (d / b)^c), so [y_min - d, y_min] with
d = b (ln(1 / alpha) / n)^(1 / c) holds a with probability 1 - alpha (b and c fitted).

This is a STATISTICAL ESTIMATE, never a certificate: it assumes the fitted law and random designs, and how
often its interval really holds the optimum is measured by ``python -m bench.statistical_bound`` where the
optimum is certified.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

KIND = "statistical estimate (extreme-value fit to random designs; not a certificate)"


@dataclass(frozen=True)
class StatisticalBound:
    """The optimum estimated from random designs' values (a statistical estimate, not a certificate)."""

    estimate: float  # the fitted Weibull location, at most the best value seen
    lower: float  # the interval [lower, best_seen] holds the optimum with probability ``confidence`` (if the law holds)
    best_seen: float  # the smallest value among the designs
    confidence: float  # nominal
    groups: int  # group minima fitted
    group_size: int  # designs per group
    shape: float  # the fitted Weibull shape c
    scale: float  # the fitted Weibull scale b

    @property
    def designs(self) -> int:
        return self.groups * self.group_size

    @property
    def kind(self) -> str:
        return KIND

    def holds(self, optimum: float) -> bool:
        """Whether the interval holds ``optimum`` (for validation where the optimum is known)."""
        return self.lower <= optimum <= self.best_seen

    def within(self, value: float) -> float:
        """How far ``value`` (say, a search's answer) may lie above the optimum at the nominal confidence."""
        return value - self.lower


def group_minima(values: Sequence[float], group_size: int) -> np.ndarray:
    """The minimum of each consecutive group of ``group_size`` values (a last, incomplete group is dropped)."""
    if isinstance(group_size, bool) or int(group_size) != group_size or group_size < 1:
        raise ValueError(f"group_size must be a whole number >= 1, got {group_size!r}")
    data = np.asarray(values, dtype=float)
    if not np.all(np.isfinite(data)):
        raise ValueError("values must be finite numbers (drop failed evaluations first)")
    groups = len(data) // group_size
    return data[: groups * group_size].reshape(groups, group_size).min(axis=1)


def weibull_bound(values: Sequence[float], group_size: int, confidence: float = 0.95) -> StatisticalBound:
    """The optimum's estimate from ``values`` of random designs, in groups of ``group_size``.

    The three-parameter Weibull is fitted by maximum likelihood to the group minima, its location kept below
    the smallest minimum (the optimum cannot lie above a value seen)."""
    from scipy import stats

    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence must lie strictly between 0 and 1, got {confidence!r}")
    minima = group_minima(values, group_size)
    if len(minima) < 5:
        raise ValueError(f"at least 5 groups of {group_size} values needed, got {len(minima)}")
    best = float(minima.min())
    spread = float(minima.max() - best)
    if spread == 0.0:
        return StatisticalBound(best, best, best, confidence, len(minima), int(group_size), math.inf, 0.0)
    # a start below the smallest minimum: the optimiser then stays where the likelihood is finite
    shape, location, scale = stats.weibull_min.fit(minima, loc=best - 0.1 * spread)
    if location >= best:  # the likelihood's edge: fit again with the location pinned just below the best seen
        location = best - 1e-9 * max(abs(best), spread)
        shape, location, scale = stats.weibull_min.fit(minima, floc=location)
    alpha = 1.0 - confidence
    reach = scale * (math.log(1.0 / alpha) / len(minima)) ** (1.0 / shape)
    return StatisticalBound(
        float(min(location, best)),
        float(best - reach),
        best,
        confidence,
        len(minima),
        int(group_size),
        float(shape),
        float(scale),
    )


def estimate_optimum(
    evaluator: Any,
    function: Callable,
    space: Any,
    groups: int,
    group_size: int,
    rng: np.random.Generator,
    confidence: float = 0.95,
) -> StatisticalBound:
    """Evaluates ``groups * group_size`` random designs of ``space`` through ``evaluator`` (the run's one
    Evaluator) and fits the bound to their values. Failed evaluations are drawn again, so every group is full."""
    wanted = groups * group_size
    values: list[float] = []
    attempts = 0
    while len(values) < wanted:
        missing = wanted - len(values)
        attempts += missing
        if attempts > 2 * wanted + 100:
            raise RuntimeError(f"more than half of {attempts} random designs failed: no bound from so few values")
        designs = [space.random(rng) for _ in range(missing)]
        values += [e.value for e in evaluator.evaluate([(function, d) for d in designs]) if e.ok]
    return weibull_bound(values, group_size, confidence)


__all__ = ["KIND", "StatisticalBound", "estimate_optimum", "group_minima", "weibull_bound"]
