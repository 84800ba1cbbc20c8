"""The few types every level of the orchestrator shares: an evaluation and its parts, and the guards that keep
them honest.

An evaluation is what one design is worth under an objective: its value (the objective's number), the FMU's
outputs that explain it, or why there is no number (failed) or only a bound (censored). A failure is never a
number, so it can never be mistaken for a good or a bad value.
"""

from __future__ import annotations

import math
import numbers
import time
from dataclasses import dataclass, replace
from typing import Any, Callable, ClassVar, Protocol, runtime_checkable

from .design import Design, as_design

Order = Design
"""Material number per column (kept as the study's word: a material order)."""

OK = "ok"
FAILED = "failed"
CENSORED = "censored"  # the run stopped once the value passed a limit: known only to be above it
STATUSES = (OK, FAILED, CENSORED)


class UnknownOutput(KeyError):
    """An output name the FMU does not declare, with the names it does, in one line."""

    def __init__(self, name: str, known: tuple[str, ...]):
        super().__init__(name)
        self.name, self.known = name, known

    def __str__(self) -> str:
        return f"no output {self.name!r}: the FMU's outputs are {', '.join(self.known) or 'none'}"


class NamedOutputs:
    """Outputs read by the names the FMU's model description declares: ``outputs[name]``, ``name in outputs``."""

    values: dict[str, float | int]

    def __getitem__(self, name: str) -> float | int:
        try:
            return self.values[name]
        except KeyError:
            raise UnknownOutput(name, tuple(self.values)) from None

    def __contains__(self, name: object) -> bool:
        return name in self.values

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(self.values)


@dataclass(frozen=True)
class RunOutputs(NamedOutputs):
    """The FMU's outputs at the end of one run (for several load cases: the run that gave the value), by the
    names its model description declares, and the horizon simulated (a short horizon is extended while the
    lattice still touches the backplate).

    Its record (the journal, results.json) is flat: each output by its name, and ``horizon``; JSON's null
    (a value that was not a finite number) is read back as NaN.
    """

    values: dict[str, float | int]
    horizon: float  # s

    def __post_init__(self):
        if "horizon" in self.values:
            raise ValueError("an FMU output named 'horizon' would be taken for the horizon simulated: rename it")

    def as_record(self) -> dict[str, Any]:
        return {**self.values, "horizon": self.horizon}

    @classmethod
    def read_record(cls, data: Any) -> "RunOutputs":
        if not isinstance(data, dict):
            raise ValueError(f"expected an object for RunOutputs, got {type(data).__name__}")
        if "horizon" not in data:
            raise KeyError("RunOutputs: horizon is missing")
        values = {}
        for name, value in data.items():
            if value is None:
                values[name] = math.nan
            elif isinstance(value, bool) or not isinstance(value, (int, float)):
                raise ValueError(f"RunOutputs: {name} = {value!r} is not a number")
            else:
                values[name] = value
        horizon = values.pop("horizon")
        return cls(values, float(horizon))


@dataclass(frozen=True)
class CaseValue:
    """One load case of a design's evaluation: its parameters and its value."""

    parameters: dict[str, Any]
    value: float | None
    status: str
    message: str = ""


@dataclass(frozen=True)
class Evaluation:
    """One design under one objective.

    ``value`` is None exactly when ``status`` is not ``ok``. A ``censored`` evaluation stopped early at a
    limit: its value is only known to be above ``limit`` (reached at ``stopped_at`` s). ``values`` holds each
    objective output when the objective has several (the Pareto front); ``cases`` each load case's value.
    """

    order: Order
    value: float | None
    status: str
    message: str = ""
    seconds: float = 0.0  # the evaluation's own run time (never queue time)
    outputs: RunOutputs | None = None
    values: tuple[float, ...] = ()
    limit: float | None = None
    stopped_at: float | None = None
    cases: tuple[CaseValue, ...] = ()
    work: int | None = None  # right-hand sides the FMU evaluated (a censored run's too): what it cost
    kind: ClassVar[str] = "evaluation"  # what the journal calls this result

    @property
    def ok(self) -> bool:
        return self.status == OK

    @property
    def censored(self) -> bool:
        return self.status == CENSORED

    @property
    def lower_bound(self) -> float | None:
        """For a censored evaluation, the limit its value is above."""
        return self.limit if self.censored else None

    @property
    def censored_limit(self) -> float:
        """The limit a censored evaluation's value is above, where only those are compared; ValueError for any
        other."""
        if self.lower_bound is None:
            raise ValueError(f"the evaluation of {self.order} is {self.status}: it is not censored at a limit")
        return self.lower_bound

    @property
    def ok_value(self) -> float:
        """The value of an evaluation that is ok, where only those are compared; ValueError for any other."""
        if self.value is None:
            raise ValueError(f"the evaluation of {self.order} is {self.status}: it has no value")
        return self.value


@dataclass(frozen=True)
class Above:
    """What a search is told for a censored evaluation: the value is above ``limit``, never a number."""

    limit: float


def failed(order: Any, message: str, seconds: float = 0.0, **fields: Any) -> Evaluation:
    """A failed evaluation (value None)."""
    return Evaluation(as_design(order), None, FAILED, str(message), float(seconds), **fields)


def censored(order: Any, limit: float, stopped_at: float | None, seconds: float = 0.0, **fields: Any) -> Evaluation:
    """An evaluation stopped once its value passed ``limit`` (at ``stopped_at`` s)."""
    at = "" if stopped_at is None else f", reached at t = {stopped_at:.6g} s"
    return Evaluation(
        as_design(order),
        None,
        CENSORED,
        f"value above {limit:g}{at}",
        float(seconds),
        limit=float(limit),
        stopped_at=stopped_at,
        **fields,
    )


def check_evaluation(result: Any, order: Any) -> Evaluation:
    """Make whatever an objective returned into a trustworthy Evaluation.

    A NaN or an infinity compares in surprising ways and would silently become the "best" or poison a
    ranking, so every non-finite value becomes a failure; an evaluation for another design than the one
    asked is a bug in the objective and becomes a failure. A plain real number is accepted as an ok value.
    """
    order = as_design(order)
    if isinstance(result, numbers.Real) and not isinstance(result, bool):
        result = Evaluation(order, float(result), OK)
    if not isinstance(result, Evaluation):
        return failed(order, f"objective returned {type(result).__name__}, not an Evaluation")
    if as_design(result.order) != order:
        return failed(
            order, f"objective returned an evaluation for {list(result.order)}, asked {list(order)}", result.seconds
        )
    if result.status not in STATUSES:
        return failed(order, f"unknown status {result.status!r}: {result.message}", result.seconds)
    if result.status == FAILED:
        return result if result.value is None and result.order == order else replace(result, order=order, value=None)
    if result.status == CENSORED:
        limit = result.limit
        if not isinstance(limit, (int, float)) or isinstance(limit, bool) or not math.isfinite(limit):
            return failed(order, f"censored evaluation without a finite limit: {limit!r}", result.seconds)
        return result if result.value is None and result.order == order else replace(result, order=order, value=None)
    try:
        value = float(result.value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return failed(order, f"value is not a number: {result.value!r}", result.seconds)
    if not math.isfinite(value):
        return failed(order, f"non-finite value: {value}", result.seconds)
    if any(not (isinstance(v, (int, float)) and math.isfinite(v)) for v in result.values):
        return failed(order, f"non-finite objective values: {list(result.values)}", result.seconds)
    if value != result.value or type(result.value) is not float or result.order != order:
        return replace(result, order=order, value=value)
    return result


@runtime_checkable
class LimitedObjective(Protocol):
    """A ``design -> Evaluation`` function that can stop a run once its value passes a limit (objective.FMURun):
    ``with_limit(limit)`` is the same function with that limit (None: none)."""

    def __call__(self, order: Order) -> Evaluation: ...

    def with_limit(self, limit: float | None) -> LimitedObjective: ...


def safe_call(objective: Callable[[Order], Any], order: Any) -> Evaluation:
    """Call the objective; never raise.

    One bad design (a solver error, an FMI error) must cost one failed evaluation, not the whole search. An
    exception becomes a failed Evaluation whose message is the exception text; the result then goes through
    :func:`check_evaluation`. When the objective did not time itself the wall time of the call is filled in.
    """
    order = as_design(order)
    start = time.perf_counter()
    try:
        result = objective(order)
    except MemoryError:
        return failed(
            order, "out of memory in the evaluation (free memory or use fewer --workers)", time.perf_counter() - start
        )
    except Exception as exc:  # noqa: BLE001 - the point is to catch everything
        return failed(order, f"{type(exc).__name__}: {exc}", time.perf_counter() - start)
    elapsed = time.perf_counter() - start
    evaluation = check_evaluation(result, order)
    if evaluation.seconds == 0.0:
        evaluation = replace(evaluation, seconds=elapsed)
    return evaluation


__all__ = [
    "Above",
    "CENSORED",
    "CaseValue",
    "Evaluation",
    "FAILED",
    "LimitedObjective",
    "NamedOutputs",
    "OK",
    "Order",
    "RunOutputs",
    "STATUSES",
    "UnknownOutput",
    "censored",
    "check_evaluation",
    "failed",
    "safe_call",
]
