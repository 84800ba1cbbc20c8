"""How everything is evaluated: the one Evaluator, and the search loop on top of it.

``Evaluator`` is the only way anything is simulated: the searches, the verification of finalists, the final
descent, the sensitivity study, the exhaustive sweep's chunks, the accuracy checks, the trajectories and the
solver sweep of the report. It runs *tasks* (``orchestrator.tasks``: what a task is, and the task of one
design) through one Executor and guards them:

- *Cache*: a key is computed once per run; a resumed run reaches its journal's results as it asks for them,
  so it knows at each point what the interrupted run knew there.
- *Journal*: each finished result is appended as it arrives (time-outs and a task's own transient failures
  are not: they run again on resume).
- *Bounded work in flight*: at most ``CALLS_PER_WORKER`` submissions per worker at a time.
- *Batches*: on an executor with a ``batch_size`` above one (Dask: each submission is a round trip to a
  worker), the designs pulled together go as ``TaskBatch`` submissions of up to ``batch_size`` designs,
  spread over the workers; each design is still cached and journalled on its own, and its time limit is its
  batch's share.
- *Time limit*: counted from when a task starts in its worker, never from its submission: the process pool
  and Dask start queued tasks first in, first out, so the k-th queued task starts when the k-th task before it
  finishes.
- *Failures are data*: an exception, a dead worker, a task past its time limit is that task's failed result.
  A dead worker breaks a process pool: the pool is replaced and the tasks that were in flight run again one at
  a time, so only the task that kills a worker fails.

``run_search`` drives an ask/tell search within a budget of distinct designs, processing results in ask order,
so a run is identical whatever the executor and the number of workers.
"""

from __future__ import annotations

import math
import re
import time
from concurrent.futures import FIRST_COMPLETED, Executor, Future, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field
from typing import Any, Callable, Iterable, Sequence

from .design import DesignSpace, as_design
from .executors import CALLS_PER_WORKER, executor_batch_size, executor_slots
from .interruption import raise_if_requested
from .tasks import EvaluateDesign, Task, TaskBatch, function_key, run_task
from .types import Above, Evaluation, Order

STALL_BATCHES = 200


@dataclass(frozen=True)
class EvaluatorState:
    """What the evaluator did in this run."""

    simulated: int
    cache_hits: int
    resumed: int
    pool_renewals: int
    timeouts: int
    journal_repaired: bool
    failed: int = 0  # evaluations (designs) that failed, among the results this run reached
    failure_causes: tuple[tuple[str, int], ...] = ()  # the most common causes and how many failed of each


def failures_of(result: Any) -> list[str]:
    """The cause of each evaluation a result counts as failed: an evaluation or a recorded run that failed is
    one; an exhaustive chunk is one per design that failed, or all its designs when it could not run."""
    if getattr(result, "ok", True) or getattr(result, "censored", False):
        failures = getattr(result, "failures", ())
        extra = max(0, int(getattr(result, "failed", 0) or 0) - len(failures))
        return [f.message for f in failures] + ["(cause not kept)"] * extra
    designs = getattr(result, "designs", 1)
    return [getattr(result, "message", "") or "no message"] * int(designs)


@dataclass
class _Flight:
    key: str
    task: Any
    sequence: int
    submitted: float
    future: Future | None = None
    members: tuple["_Flight", ...] = ()  # a TaskBatch's flight: one flight per task in it

    @property
    def tasks(self) -> int:
        return len(self.members) or 1


class Evaluator:
    """Runs tasks through one Executor: cached, journalled, guarded (see the module docstring)."""

    def __init__(self, executor: Executor, journal=None, time_limit: float | None = None):
        if time_limit is not None and not (math.isfinite(time_limit) and time_limit > 0):
            raise ValueError(f"time_limit must be a finite number of seconds > 0, got {time_limit!r}")
        self.executor = executor
        self.journal = journal
        self.time_limit = time_limit
        # A resumed run's journal, reached key by key: a result moves into the cache when the run first asks
        # for it, so what the run knows at each point (``cached``, ``known``) is what it knew then when it ran
        # uninterrupted, and its searches are told the same values and ask the same designs.
        self._journalled: dict[str, Any] = journal.load() if journal is not None else {}
        self.cache: dict[str, Any] = {}
        self.resumed = len(self._journalled)
        self.simulated = 0
        self.cache_hits = 0
        self.pool_renewals = 0
        self.timeouts = 0
        self.failed = 0
        self._causes: dict[str, tuple[str, int]] = {}  # a cause's kind -> (its first message, count)
        self._slots = executor_slots(executor)
        self._batch = executor_batch_size(executor)
        self._new_generation()

    def _new_generation(self) -> None:
        """A fresh pool: submissions and completions are counted anew for the start times."""
        self._submissions = 0
        self._completions: list[float] = []

    # ------------------------------------------------------------------------------------------ public
    def run(
        self,
        tasks: Iterable[Task],
        progress: Callable[[int], Any] | None = None,
        on_result: Callable[[int, Any], Any] | None = None,
    ) -> list[Any]:
        """The result of every task, in the given order. ``tasks`` is pulled lazily, one when a worker can
        take it, so a task may be built from the results so far (``on_result(index, result)`` is called as
        each becomes known, cache hits at once); ``progress(done)`` counts finished tasks."""
        results: dict[int, Any] = {}
        waiting: dict[str, list[int]] = {}
        flights: dict[Future, _Flight] = {}
        alone: list[_Flight] = []
        source = iter(enumerate(tasks))
        exhausted = False
        count = 0
        done = [0]

        def deliver(index: int, result: Any) -> None:
            results[index] = result
            done[0] += 1
            if on_result is not None:
                on_result(index, result)
            if progress is not None:
                progress(done[0])

        def finish(flight: _Flight, result: Any, journal: bool = True) -> None:
            if flight.members:
                if not isinstance(result, list) or len(result) != len(flight.members):
                    result = flight.task.failure(f"executor: a batch of {len(flight.members)} gave {result!r:.80}", 0.0)
                for member, member_result in zip(flight.members, result):
                    finish(member, member_result, journal)
                return
            self._record(flight.key, flight.task, result, journal)
            for index in waiting.pop(flight.key):
                deliver(index, result)

        def submit(flight: _Flight) -> None:
            future = self._submit(flight)
            if future is None:
                finish(
                    flight,
                    flight.task.failure("executor: could not submit (the executor is shut down)", 0.0),
                    journal=False,
                )
            else:
                flights[future] = flight

        def submit_batches(pending: list[_Flight]) -> None:
            """The pulled designs as batches of up to ``batch_size`` designs, as few as keep every worker busy
            (a call costs the same whatever it carries) and of equal sizes (so that no worker is left with a
            remainder while the others wait)."""
            calls = self._slots * -(-len(pending) // (self._slots * self._batch))
            size = -(-len(pending) // calls)
            for start in range(0, len(pending), size):
                members = tuple(pending[start : start + size])
                if len(members) == 1:
                    submit(members[0])
                else:
                    submit(_Flight("", TaskBatch(tuple(m.task for m in members)), 0, 0.0, members=members))

        while True:
            raise_if_requested()  # a SIGTERM a library swallowed still ends the run here
            pending: list[_Flight] = []  # designs pulled for batches: up to batch_size per submission
            while (
                not exhausted
                and not alone
                and len(flights) < CALLS_PER_WORKER * self._slots
                and len(pending) < CALLS_PER_WORKER * self._slots * self._batch
            ):
                try:
                    index, task = next(source)
                except StopIteration:
                    exhausted = True
                    break
                count = index + 1
                key = task.key
                if key not in self.cache and key in self._journalled:
                    self.cache[key] = self._journalled.pop(key)
                    self._tally(self.cache[key])
                if key in self.cache:
                    self.cache_hits += 1
                    deliver(index, self.cache[key])
                elif key in waiting:
                    waiting[key].append(index)
                else:
                    waiting[key] = [index]
                    flight = _Flight(key, task, 0, 0.0)
                    if self._batch > 1 and getattr(task, "batchable", False):
                        pending.append(flight)
                    else:
                        submit(flight)
            if pending:
                submit_batches(pending)
            if not flights:
                if alone:
                    for flight in alone:
                        finish(flight, *self._run_alone(flight))
                    alone = []
                    continue
                if exhausted:
                    break
                continue
            finished, _ = wait(list(flights), timeout=self._wait_timeout(flights), return_when=FIRST_COMPLETED)
            broken = False
            for future in sorted(finished, key=lambda f: flights[f].sequence):
                flight = flights.pop(future)
                self._completions.append(time.monotonic())
                try:
                    result = future.result()
                except BrokenProcessPool:
                    broken = True
                    alone += flight.members or [flight]
                    continue
                except Exception as exc:  # noqa: BLE001 - the executor's error is this task's failure
                    result = flight.task.failure(f"executor: {type(exc).__name__}: {exc}", 0.0)
                finish(flight, result)
            if not finished:
                for flight in self._expire(flights):
                    finish(flight, flight.task.failure(self._timeout_message(), self.time_limit), journal=False)
            if broken:  # every other task in flight died with the pool: each runs again, alone
                alone += [
                    member for f in sorted(flights.values(), key=lambda f: f.sequence) for member in (f.members or [f])
                ]
                flights.clear()
                self._renew()
        return [results[i] for i in range(count)]

    def evaluate(
        self,
        pairs: Sequence[tuple[Callable[[Order], Any], Sequence[int]]],
        progress: Callable[[int], Any] | None = None,
    ) -> list[Evaluation]:
        """Every (function, design) pair's Evaluation, in order."""
        return self.run([EvaluateDesign(function, as_design(order)) for function, order in pairs], progress)

    def cached(self, task: Task) -> Any | None:
        """The result of ``task`` if this run has reached it (asked for it, or simulated it)."""
        return self.cache.get(task.key)

    def known(self, function: Callable[[Order], Any]) -> list[Evaluation]:
        """Every evaluation this run has reached of ``function`` (an FMU run's settings), whatever the design."""
        prefix = function_key(function) + "#"
        return [result for key, result in self.cache.items() if key.startswith(prefix)]

    def state(self) -> EvaluatorState:
        causes = tuple(sorted(self._causes.values(), key=lambda item: (-item[1], item[0]))[:3])
        return EvaluatorState(
            self.simulated,
            self.cache_hits,
            self.resumed,
            self.pool_renewals,
            self.timeouts,
            bool(getattr(self.journal, "repaired", False)),
            self.failed,
            causes,
        )

    def _tally(self, result: Any) -> None:
        """Counts failed evaluations by cause: messages that differ only in their numbers (the time a solution
        diverged, a design's index) are one cause, named by its first message."""
        for cause in failures_of(result):
            self.failed += 1
            kind = re.sub(r"\d+(\.\d*)?([eE][-+]?\d+)?", "#", cause)
            example, count = self._causes.get(kind, (cause, 0))
            self._causes[kind] = (example, count + 1)

    # ------------------------------------------------------------------------------------------ guards
    def _record(self, key: str, task: Any, result: Any, journal: bool) -> None:
        self.cache[key] = result
        self.simulated += 1
        self._tally(result)
        if journal and self.journal is not None and task.keep(result):
            self.journal.append(key, result)

    def _submit(self, flight: _Flight) -> Future | None:
        for attempt in range(2):
            try:
                future = self.executor.submit(run_task, flight.task)
            except BrokenProcessPool:
                self._renew()
                continue
            except RuntimeError:
                return None
            flight.sequence = self._submissions
            flight.submitted = time.monotonic()
            flight.future = future
            self._submissions += 1
            return future
        return None

    def _started_at(self, flight: _Flight) -> float | None:
        """When the task started in its worker, or None while it is still queued: as the process pool's
        worker said, else estimated (first in, first out; a worker's start-up counts as run time)."""
        reported = getattr(self.executor, "started_at", None)
        if reported is not None and flight.future is not None:
            return reported(flight.future)
        before = flight.sequence - self._slots
        if before < 0:
            return flight.submitted
        if before < len(self._completions):
            return max(flight.submitted, self._completions[before])
        return None

    def _wait_timeout(self, flights: dict[Future, _Flight]) -> float | None:
        if self.time_limit is None:
            return None
        now = time.monotonic()
        ends = []
        for flight in flights.values():
            started = self._started_at(flight)
            if started is None and hasattr(self.executor, "started_at"):
                started = now  # a task that starts now expires the latest
            if started is not None:
                ends.append(started + self.time_limit * flight.tasks)
        if not ends:
            return None
        return max(0.0, min(ends) - now)

    def _timeout_message(self) -> str:
        return (
            f"exceeded the time limit of {self.time_limit:g} s of its own run time (--time-limit; it runs "
            "again on --resume)"
        )

    def _expire(self, flights: dict[Future, _Flight]) -> list[_Flight]:
        """The tasks past their time limit, taken out of ``flights``; on a process pool (a hung process is
        stopped only by ending it) the pool is replaced and the others in flight run again."""
        if self.time_limit is None:
            return []  # no limit: nothing expires
        now, limit = time.monotonic(), self.time_limit
        expired = []
        for future, flight in list(flights.items()):
            started = self._started_at(flight)
            if started is not None and now - started >= limit * flight.tasks:
                self.timeouts += flight.tasks
                future.cancel()
                del flights[future]
                expired.append(flight)
        if expired and hasattr(self.executor, "renew"):
            survivors = sorted(flights.values(), key=lambda f: f.sequence)
            flights.clear()
            self._renew()
            for flight in survivors:
                resubmitted = self._submit(flight)
                if resubmitted is not None:
                    flights[resubmitted] = flight
        return expired

    def _renew(self) -> None:
        renew = getattr(self.executor, "renew", None)
        if renew is not None:
            renew()
            self.pool_renewals += 1
        self._new_generation()

    def _run_alone(self, flight: _Flight) -> tuple[Any, bool]:
        """A task whose worker died, alone on a fresh pool: (its result, whether to journal it)."""
        future = self._submit(flight)
        if future is None:
            return flight.task.failure("executor: could not submit (the executor is shut down)", 0.0), False
        try:
            while True:
                finished, _ = wait([future], timeout=self._wait_timeout({future: flight}))
                if finished:
                    break
                started, limit = self._started_at(flight), self.time_limit
                if started is not None and limit is not None and time.monotonic() - started >= limit:
                    self.timeouts += 1
                    self._renew()
                    return flight.task.failure(self._timeout_message(), limit), False
            return future.result(), True
        except BrokenProcessPool as exc:
            self._renew()
            return flight.task.failure(f"executor: the worker died running this task twice ({exc})", 0.0), True
        except Exception as exc:  # noqa: BLE001
            return flight.task.failure(f"executor: {type(exc).__name__}: {exc}", 0.0), True
        finally:
            self._completions.append(time.monotonic())


def as_evaluator(executor_or_evaluator) -> Evaluator:
    if isinstance(executor_or_evaluator, Evaluator):
        return executor_or_evaluator
    return Evaluator(executor_or_evaluator)


# ---------------------------------------------------------------------------------------------- searches
@dataclass(frozen=True)
class SearchRun:
    """Everything one run of one search produced.

    ``evaluations[k]`` is evaluation number ``k + 1`` (1-based, as in "found at evaluation 4"), in the order
    first evaluated; cache hits are not evaluations. ``budget`` counts distinct designs: a design evaluated
    again because its earlier run stopped at a lower force limit is an extra evaluation (``reevaluated``), so
    ``len(evaluations)`` is at most ``budget + reevaluated``.
    """

    method: str
    seed: int
    budget: int
    label: str  # what the run searched for (the diagonal rule, a variation of the case)
    evaluations: tuple[Evaluation, ...]
    best_order: Order | None
    best_value: float | None  # None when no evaluation gave a value
    best_index: int | None  # 1-based index of the best evaluation
    failed: int
    censored: int  # stopped early above a limit the search gave (never a value)
    reevaluated: int
    distinct: int  # distinct designs evaluated (what the budget bounds)
    stalled: bool
    truncated: bool  # the budget ran out inside a batch: its first designs were evaluated, the search not told
    stop_reason: str
    wall_seconds: float
    batches: int
    cache_hits: int
    diagnostics: dict[str, Any] = field(default_factory=dict)  # the search's own state() at the end

    @property
    def n_evaluations(self) -> int:
        return len(self.evaluations)

    def best_so_far(self) -> list[float | None]:
        """Best value after each evaluation (None until the first one with a value)."""
        curve: list[float | None] = []
        best: float | None = None
        for evaluation in self.evaluations:
            if evaluation.ok and (best is None or evaluation.ok_value < best):
                best = evaluation.ok_value
            curve.append(best)
        return curve


def _censored_below(evaluation: Evaluation, limit: float | None) -> bool:
    """Censored at a lower limit than the one now asked (or asked with none): what is known no longer
    answers the search, so the design is evaluated again."""
    return evaluation.censored and (limit is None or limit > evaluation.censored_limit)


def told_value(evaluation: Evaluation, objectives: int = 1):
    """What a search is told: the value (a tuple of values for a multi-objective search), Above(limit) for a
    censored evaluation, None for a failure."""
    if evaluation.ok:
        return tuple(evaluation.values) if objectives > 1 else evaluation.value
    if evaluation.censored:
        return Above(evaluation.censored_limit)
    return None


def search_space(search) -> DesignSpace:
    space = getattr(search, "space", None)
    return space if space is not None else DesignSpace.permutations(search.n)


def run_search(
    search,
    objective,
    budget: int,
    evaluator,
    *,
    method_name: str,
    seed: int,
    label: str = "",
    progress: Callable[[int], Any] | None = None,
    fidelity: str = "search",
    stall_batches: int = STALL_BATCHES,
) -> SearchRun:
    """Drive ``search`` until the budget, its stop, exhaustion of the space or a stall.

    Each batch: dedupe the asked designs, evaluate the ones this run has not seen through the objective and
    the evaluator, process the results in ask order, tell the search every asked design's value. A design
    already seen censored is evaluated again when the search asks it with no limit or a higher one (the
    annealing); that run is not charged to the budget, so the search makes the same asks whether or not the
    evaluator honours its limits. When the remaining budget is smaller than the batch's new designs, only the
    first ``remaining`` are evaluated and the run stops without telling the search (pycma must not be told a
    partial population).
    """
    from .objective import as_objective

    if isinstance(budget, bool) or int(budget) != budget or budget < 0:
        raise ValueError(f"budget must be a non-negative integer, got {budget!r}")
    budget = int(budget)
    objective = as_objective(objective)
    evaluator = as_evaluator(evaluator)
    space = search_space(search)
    objectives = int(getattr(search, "n_objectives", 1) or 1)
    seen: dict[Order, Evaluation] = {}
    evaluations: list[Evaluation] = []
    best_order = best_value = best_index = None
    n_failed = n_censored = n_reevaluated = batches = cache_hits = no_new = 0
    stalled = truncated = False
    start = time.perf_counter()

    while True:
        if len(seen) >= budget:
            stop_reason = f"budget of {budget} designs used"
            break
        if search.stop():
            stop_reason = "the search stopped itself"
            break
        if len(seen) >= space.size:
            stop_reason = f"every design of the space evaluated ({space.size})"
            break
        asked = [as_design(o) for o in search.ask()]
        asked_limits = search.limits()
        limit_of = dict(zip(asked, asked_limits)) if asked_limits is not None else {}
        for order in asked:
            problem = space.problem(order)
            if problem is not None:
                raise ValueError(f"{method_name}: the search asked {list(order)}: {problem}")
        unique = list(dict.fromkeys(asked))
        fresh = [o for o in unique if o not in seen]
        remaining = budget - len(seen)
        truncated = len(fresh) > remaining
        if truncated:
            new = fresh[:remaining]
        else:
            new = [
                o
                for o in unique
                if o not in seen or (asked_limits is not None and _censored_below(seen[o], limit_of.get(o)))
            ]
        cache_hits += len(asked) - len(new)
        done = len(evaluations)
        results = objective.evaluate(
            new,
            evaluator,
            fidelity,
            progress=None if progress is None else (lambda k, d=done: progress(d + k)),
            limits=[limit_of.get(o) for o in new] if limit_of else None,
        )
        for order, evaluation in zip(new, results):
            n_reevaluated += order in seen
            seen[order] = evaluation
            evaluations.append(evaluation)
            if evaluation.censored:
                n_censored += 1
            elif not evaluation.ok:
                n_failed += 1
            elif best_value is None or evaluation.value < best_value:
                best_order, best_value, best_index = order, evaluation.value, len(evaluations)
        batches += 1
        if truncated:
            stop_reason = (
                f"budget of {budget} designs used inside a batch: its first {len(new)} new designs were "
                "evaluated, the search was not told them"
            )
            break
        search.tell(asked, [told_value(seen[o], objectives) for o in asked])
        no_new = 0 if fresh else no_new + 1
        if no_new >= stall_batches:
            stalled = True
            stop_reason = (
                f"stalled: {stall_batches} batches in a row asked only designs already evaluated "
                f"({len(seen)} distinct so far)"
            )
            break
    return SearchRun(
        method=method_name,
        seed=int(seed),
        budget=budget,
        label=label,
        evaluations=tuple(evaluations),
        best_order=best_order,
        best_value=best_value,
        best_index=best_index,
        failed=n_failed,
        censored=n_censored,
        reevaluated=n_reevaluated,
        distinct=len(seen),
        stalled=stalled,
        truncated=truncated,
        stop_reason=stop_reason,
        wall_seconds=time.perf_counter() - start,
        batches=batches,
        cache_hits=cache_hits,
        diagnostics=_jsonable(search.state()),
    )


def _jsonable(value: Any) -> Any:
    """A search's diagnostics as plain JSON data (tuples as lists, numpy scalars as numbers)."""
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if hasattr(value, "item"):
        return value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


__all__ = ["Evaluator", "EvaluatorState", "SearchRun", "as_evaluator", "run_search", "told_value"]
