"""A statistical estimate of the optimum where no sweep fits: an extreme-value fit to random designs' values.

Why: a space too large to sweep (12 columns, the 11 x 11 x 11 plate) leaves a search with "best found" and no
idea how far the optimum may lie below it. Near the lower end theta of the values (the optimum), the share of
random designs within x of it behaves like C x^a (a Weibull-type lower tail). ``tail_bound`` works on the k
smallest of n random designs' values: below the k-th, the k - 1 others are then independent draws of a power-law
(``scipy.stats.powerlaw``) on [theta, X_(k)], whose likelihood in (theta, a) gives the estimate. The interval
rests on a pivot: (X_(1) - theta) / (X_(k) - theta) is R^(1/a) with R ~ Beta(1, k - 1), whatever C, so for a
known exponent [X_(1) - w (X_(k) - X_(1)), X_(1)] holds theta with exact probability. The exponent is not known,
and a larger one puts theta further below: the interval takes the exponent's upper confidence limit (profile
likelihood), splitting the error between the two, so it holds theta with probability at least ``confidence``
under that law. Where the data cannot bound the exponent, the interval is unbounded below and says so.

``weibull_bound`` is the classical fit for quadratic assignment problems (Golden and Alt; Derigs): a
three-parameter Weibull to group minima, its location the estimate, its interval with the fitted shape and
scale taken as exact. That plug-in interval ignores their uncertainty; ``python -m bench.statistical_bound``
measures both where the optimum is certified.

This is a STATISTICAL ESTIMATE, never a certificate: it assumes the tail law and uniformly random designs.
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
    """The classical estimate from ``values`` of random designs, in groups of ``group_size`` (its interval
    takes the fitted shape and scale as exact; ``tail_bound`` does not).

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


MIN_DESIGNS = 100  # fewer random designs say too little about the lower tail to fit it
MIN_TAIL = 10  # the smallest values fitted, at least
MAX_EXPONENT = 100.0  # a tail exponent beyond this is read as "no end in sight": the interval is unbounded
_EXPONENTS = np.geomspace(1.0, MAX_EXPONENT, 101)  # the profile's grid; below 1 the likelihood has no maximum


@dataclass(frozen=True)
class TailBound:
    """The optimum estimated from the lower tail of random designs' values (a statistical estimate, not a
    certificate): ``lower`` is a lower confidence limit of the optimum, -inf where the data cannot bound it."""

    estimate: float  # the maximum-likelihood lower end of the values, at most the best value seen
    lower: float  # the optimum is at least this with probability ``confidence`` (if the tail law holds)
    best_seen: float  # the smallest value among the designs
    confidence: float  # nominal
    designs: int  # random designs' values fitted
    tail: int  # how many of the smallest values the fit uses
    exponent: float  # the fitted tail exponent a (the share within x of the optimum grows as x^a)
    exponent_upper: float  # its upper confidence limit, which the interval uses (inf: not bounded)

    @property
    def kind(self) -> str:
        return KIND

    @property
    def bounded(self) -> bool:
        return math.isfinite(self.lower)

    def holds(self, optimum: float) -> bool:
        """Whether the interval holds ``optimum`` (for validation where the optimum is known)."""
        return self.lower <= optimum <= self.best_seen

    def within(self, value: float) -> float:
        """How far ``value`` (say, a search's answer) may lie above the optimum at the nominal confidence."""
        return value - self.lower

    def text(self, value: float, unit: str) -> str:
        """The estimate for a reader, beside an answer of ``value`` (a design's value, so the optimum is at most
        that), in one sentence."""
        head = (
            f"statistical estimate from {self.designs:,} random designs (the lower tail of their values; not a "
            f"certificate): the optimum is estimated at {min(self.estimate, value):.2f} {unit}"
        )
        if not self.bounded:
            return f"{head}; their tail does not show where it ends, so no distance to it is given"
        if value < self.lower:
            return (
                f"{head}; the answer lies below the limit of {self.lower:.2f} {unit} the tail gives, so the tail's "
                "law does not describe this space and no distance to the optimum is given"
            )
        return (
            f"{head}; with probability {self.confidence:.0%} it is at least {self.lower:.2f} {unit}, so the answer "
            f"is within {self.within(value):.2f} {unit} ({self.within(value) / abs(value):.1%}) of the optimum"
        )


def default_tail(designs: int) -> int:
    """The smallest values a fit of ``designs`` values uses: about 2 sqrt(n), enough to pin the exponent while
    staying in the lower tail, where its law holds."""
    return max(MIN_TAIL, min(designs - 1, round(2.0 * math.sqrt(designs))))


def _profile(below: np.ndarray, top: float) -> tuple[np.ndarray, np.ndarray]:
    """For each exponent of the grid, the largest log-likelihood over the lower end (and where it is): the
    values ``below`` the ``top`` one are power-law draws on [lower end, top]."""
    from scipy import optimize, stats

    span = top - below[0]
    ends = below[0] - span * np.exp(np.linspace(-25.0, 10.0, 71))  # the lower end, from just below to far below
    likelihoods, where = [], []
    for exponent in _EXPONENTS:

        def loglik(end, exponent=exponent):
            return stats.powerlaw.logpdf(below, exponent, loc=end, scale=top - end).sum(axis=-1)

        grid = loglik(ends[:, None])
        i = int(np.argmax(grid))
        lo, hi = ends[min(i + 1, len(ends) - 1)], ends[max(i - 1, 0)]
        refined = optimize.minimize_scalar(lambda e: -loglik(e), bounds=(lo, hi), method="bounded")
        best, at = (-refined.fun, refined.x) if -refined.fun > grid[i] else (grid[i], ends[i])
        likelihoods.append(best)
        where.append(at)
    return np.array(likelihoods), np.array(where)


def tail_bound(values: Sequence[float], confidence: float = 0.95, tail: int | None = None) -> TailBound:
    """The optimum's estimate and lower confidence limit from ``values`` of uniformly random designs, fitted on
    their ``tail`` smallest (default ``default_tail``). Refuses fewer than MIN_DESIGNS values."""
    from scipy import stats

    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence must lie strictly between 0 and 1, got {confidence!r}")
    data = np.sort(np.asarray(values, dtype=float))
    if not np.all(np.isfinite(data)):
        raise ValueError("values must be finite numbers (drop failed evaluations first)")
    if len(data) < MIN_DESIGNS:
        raise ValueError(f"at least {MIN_DESIGNS} random designs' values needed, got {len(data)}")
    k = default_tail(len(data)) if tail is None else tail
    if isinstance(k, bool) or int(k) != k or not MIN_TAIL <= k < len(data):
        raise ValueError(f"tail must be a whole number from {MIN_TAIL} to {len(data) - 1}, got {tail!r}")
    k = int(k)
    below, top = data[: k - 1], float(data[k - 1])
    best = float(data[0])
    if top == best:
        raise ValueError(f"the {k} smallest values are all equal: no tail to fit (use more designs or a larger tail)")
    likelihood, ends = _profile(below, top)
    fitted = int(np.argmax(likelihood))
    # the error is split: the exponent's upper limit and the pivot each at 1 - (1 - confidence) / 2
    each = 1.0 - (1.0 - confidence) / 2.0
    plausible = likelihood >= likelihood[fitted] - stats.chi2.ppf(2.0 * each - 1.0, 1) / 2.0
    upper = fitted
    while upper + 1 < len(_EXPONENTS) and plausible[upper + 1]:
        upper += 1
    exponent_upper = math.inf if upper == len(_EXPONENTS) - 1 else float(_EXPONENTS[upper])
    if math.isfinite(exponent_upper):
        # (X_(1) - theta) / (X_(k) - theta) = R^(1/a), R ~ Beta(1, k - 1): its upper quantile bounds theta
        share = float(stats.beta.ppf(each, 1, k - 1)) ** (1.0 / exponent_upper)
        lower = best - share / (1.0 - share) * (top - best)
    else:
        lower = -math.inf
    return TailBound(
        estimate=float(min(ends[fitted], best)),
        lower=float(lower),
        best_seen=best,
        confidence=confidence,
        designs=len(data),
        tail=k,
        exponent=float(_EXPONENTS[fitted]),
        exponent_upper=exponent_upper,
    )


def random_values(evaluate: Callable[[list], list], space: Any, designs: int, rng: np.random.Generator) -> list[float]:
    """The values of ``designs`` uniformly random designs of ``space``; ``evaluate`` takes a list of designs and
    returns their Evaluations (through the run's one Evaluator). Failed evaluations are drawn again; refuses when
    more than half fail."""
    values: list[float] = []
    attempts = 0
    while len(values) < designs:
        missing = designs - len(values)
        attempts += missing
        if attempts > 2 * designs + 100:
            raise RuntimeError(f"more than half of {attempts} random designs failed: no bound from so few values")
        values += [e.value for e in evaluate([space.random(rng) for _ in range(missing)]) if e.ok]
    return values


def estimate_optimum(
    evaluator: Any,
    function: Callable,
    space: Any,
    designs: int,
    rng: np.random.Generator,
    confidence: float = 0.95,
) -> TailBound:
    """``tail_bound`` of ``designs`` random designs of ``space``, each evaluated by ``function`` through
    ``evaluator``."""
    if designs < MIN_DESIGNS:
        raise ValueError(f"at least {MIN_DESIGNS} random designs needed, got {designs}")

    def evaluate(drawn: list) -> list:
        return evaluator.evaluate([(function, d) for d in drawn])

    return tail_bound(random_values(evaluate, space, designs, rng), confidence)


__all__ = [
    "KIND",
    "MIN_DESIGNS",
    "MIN_TAIL",
    "StatisticalBound",
    "TailBound",
    "default_tail",
    "estimate_optimum",
    "group_minima",
    "random_values",
    "tail_bound",
    "weibull_bound",
]
