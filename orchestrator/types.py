"""The few types every layer shares: an order, an evaluation, and the safe call.

An *objective* is any picklable callable ``objective(order) -> Evaluation``.
It runs wherever the executor puts it (this process, a process pool, a Dask
worker), so it must be defined at module top level (or be an instance of a
top-level class).  The search layer never sees what is behind it.
"""
from __future__ import annotations

import math
import numbers
import time
from dataclasses import dataclass, field, replace
from typing import Any, Callable

Order = tuple[int, ...]
"""Material number per column, a permutation of 1..n."""

OK = "ok"
FAILED = "failed"
CENSORED = "censored"  # the run stopped once the peak passed a limit: known only to be above it


@dataclass(frozen=True)
class Evaluation:
    """The outcome of one objective call.

    ``peak`` is ``None`` exactly when ``status`` is not ``"ok"``: a failure is never
    a number, so it can never be mistaken for a good (or bad) value.  A
    ``"censored"`` evaluation stopped early at a force limit: its peak is only
    known to be above ``details["censored_above"]`` (reached at
    ``details["censored_at"]`` s), and it is never reported as a peak.
    """

    order: Order
    peak: float | None          # objective value; None when the evaluation failed
    status: str                 # "ok" or "failed"
    message: str = ""           # why it failed
    seconds: float = 0.0        # wall time of the simulation
    details: dict = field(default_factory=dict)  # e.g. {"peak_sampled":..., "peak_continuous":...}

    @property
    def ok(self) -> bool:
        return self.status == OK

    @property
    def censored(self) -> bool:
        return self.status == CENSORED

    @property
    def lower_bound(self) -> float | None:
        """For a censored evaluation, the limit its peak is above."""
        return self.details.get("censored_above") if self.censored else None


@dataclass(frozen=True)
class Above:
    """What a search is told for a censored evaluation: the value is above ``limit``, never a number."""

    limit: float


def as_order(order: Any) -> Order:
    """Normalise any sequence of integers (numpy included) to a tuple of ints."""
    return tuple(int(x) for x in order)


def is_permutation(order: Order) -> bool:
    return sorted(order) == list(range(1, len(order) + 1))


def failed(order: Any, message: str, seconds: float = 0.0, details: dict | None = None) -> Evaluation:
    """A failed evaluation (peak None)."""
    return Evaluation(as_order(order), None, FAILED, str(message), float(seconds), dict(details or {}))


def censored(order: Any, limit: float, reached_at: float | None, seconds: float = 0.0,
             details: dict | None = None) -> Evaluation:
    """An evaluation stopped once its peak passed ``limit`` (at ``reached_at`` s)."""
    return Evaluation(as_order(order), None, CENSORED, f"peak above {limit:g}, reached at t = {reached_at}",
                      float(seconds), {**(details or {}), "censored_above": float(limit), "censored_at": reached_at})


def check_evaluation(result: Any, order: Any) -> Evaluation:
    """Guard: make whatever an objective returned into a trustworthy Evaluation.

    Why: a NaN or an infinity compares in surprising ways and would silently
    become the "best" or poison a ranking, so every non-finite peak becomes a
    failure.  Also accepted for convenience: a plain real number (wrapped as ok).
    A failed evaluation always has ``peak=None``; an evaluation for another
    order than the one asked is a bug in the objective and becomes a failure.
    """
    order = as_order(order)
    if isinstance(result, numbers.Real) and not isinstance(result, bool):
        result = Evaluation(order, float(result), OK)
    if not isinstance(result, Evaluation):
        return failed(order, f"objective returned {type(result).__name__}, not an Evaluation")
    if as_order(result.order) != order:
        return failed(order, f"objective returned an evaluation for order {result.order}, asked {order}",
                      result.seconds, result.details)
    if result.status == FAILED:
        if result.peak is not None or result.order != order:
            return replace(result, order=order, peak=None)
        return result
    if result.status == CENSORED:
        limit = result.details.get("censored_above")
        if not isinstance(limit, (int, float)) or isinstance(limit, bool) or not math.isfinite(limit):
            return failed(order, f"censored evaluation without a finite limit: {limit!r}", result.seconds,
                          result.details)
        return replace(result, order=order, peak=None) if result.peak is not None or result.order != order else result
    if result.status != OK:
        return failed(order, f"unknown status {result.status!r}: {result.message}", result.seconds, result.details)
    peak = result.peak
    try:
        value = float(peak)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return failed(order, f"peak is not a number: {peak!r}", result.seconds, result.details)
    if not math.isfinite(value):
        return failed(order, f"non-finite peak: {value}", result.seconds, result.details)
    if value != peak or type(peak) is not float or result.order != order:
        return replace(result, order=order, peak=value)
    return result


def safe_call(objective: Callable[[Order], Any], order: Any) -> Evaluation:
    """Call the objective; never raise.

    Why: one bad order (a solver error, an FMI error) must cost one failed
    evaluation, not the whole search.  An exception becomes a failed Evaluation
    whose message is the exception text; the result then goes through
    :func:`check_evaluation`.  When the objective did not time itself
    (``seconds == 0``) the wall time of the call is filled in.
    """
    order = as_order(order)
    start = time.perf_counter()
    try:
        result = objective(order)
    except Exception as exc:  # noqa: BLE001 - the point is to catch everything
        return failed(order, f"{type(exc).__name__}: {exc}", time.perf_counter() - start)
    elapsed = time.perf_counter() - start
    evaluation = check_evaluation(result, order)
    if evaluation.seconds == 0.0:
        evaluation = replace(evaluation, seconds=elapsed)
    return evaluation
