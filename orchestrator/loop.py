"""The evaluation loop: ask a batch, evaluate the new orders in parallel, tell; and the one guarded path.

``Evaluator`` is the only way anything is simulated (the searches, the verification of finalists, the
local check, the report's sensitivity study): it runs tasks through one Executor, caches them, appends
each finished one to the run's journal, turns every failure (an exception, a dead worker, an evaluation
past its time limit) into a failed evaluation, and replaces a broken process pool.

Guarantees (why each one exists):
- *Budget*: ``budget`` counts evaluations of distinct orders and is never
  exceeded; the study's cost was dominated by simulations, so that is what a
  user pays for and compares methods by.  An order evaluated again because its
  earlier run stopped at a lower limit is logged, not charged again.
- *Cache by order*: an order asked again (random keys map many points to one
  order; annealing chains revisit) is answered from the cache for free.
- *Determinism*: results are collected and processed in ask order, never in
  completion order, so a run is identical whatever the executor and the number
  of workers.
- *Failures are data*: a failed evaluation is recorded (status, message), told
  to the search as ``None``, and the search goes on.
- *Termination*: the budget, the search's own ``stop()``, every order of 1..n
  evaluated, or the stall guard (no new order for ``stall_batches`` batches in
  a row) ends the run; ``stop_reason`` says which.
"""
from __future__ import annotations

import math
import time
from concurrent.futures import FIRST_COMPLETED, Executor, Future, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field
from typing import Any, Callable, Sequence

from .executors import executor_slots
from .objective import SEARCH, Objective, as_objective
from .search.base import Search
from .types import Above, Evaluation, Order, as_order, check_evaluation, failed, is_permutation, safe_call

STALL_BATCHES = 200


@dataclass
class SearchRun:
    """Everything one run of one search produced.

    ``evaluations[k]`` is evaluation number ``k + 1`` (indices are 1-based, as
    in "found at evaluation 4"), in the order first evaluated; cache hits are
    not evaluations. An order censored below a limit that later matters to the
    search is evaluated again and appears once more (``n_reevaluated``; see
    ``run_search``): the budget counts distinct orders, so ``n_evaluations`` is
    the budget plus those.
    """

    method: str
    seed: int
    budget: int
    evaluations: list[Evaluation] = field(default_factory=list)
    best_order: Order | None = None
    best_peak: float | None = None          # None when every evaluation failed
    best_index: int | None = None           # 1-based index of the best evaluation
    n_failed: int = 0
    n_censored: int = 0                      # stopped early above a limit the search gave (never a peak)
    n_reevaluated: int = 0                   # evaluations of an order seen censored (beyond the budget)
    stalled: bool = False
    stop_reason: str = ""
    wall_seconds: float = 0.0
    diagnostics: dict = field(default_factory=dict)   # search.state() at the end
    batches: int = 0
    cache_hits: int = 0                      # asked orders answered from the cache

    @property
    def n_evaluations(self) -> int:
        return len(self.evaluations)

    def best_so_far(self) -> list[float | None]:
        """Best ok value after each evaluation (None until the first ok one)."""
        curve: list[float | None] = []
        best: float | None = None
        for evaluation in self.evaluations:
            if evaluation.ok and (best is None or evaluation.peak < best):
                best = evaluation.peak
            curve.append(best)
        return curve

    def outcome(self) -> list[tuple[Order, float | None, str, str]]:
        """(order, peak, status, message) per evaluation: what must be identical
        for the same seed whatever the executor (wall times are not)."""
        return [(e.order, e.peak, e.status, e.message) for e in self.evaluations]

    def records(self) -> list[dict[str, Any]]:
        """One flat dict per evaluation (index is 1-based), e.g. for a CSV."""
        return [{"method": self.method, "seed": self.seed, "index": k,
                 "order": list(e.order), "peak": e.peak, "status": e.status,
                 "message": e.message, "seconds": e.seconds, **e.details}
                for k, e in enumerate(self.evaluations, start=1)]


def _censored_below(evaluation: Evaluation, limit: float | None) -> bool:
    """Censored at a lower limit than the one now asked (or asked with none): what is known no longer
    answers the search, so the order is evaluated again."""
    return evaluation.censored and (limit is None or limit > evaluation.lower_bound)


def told_value(evaluation: Evaluation) -> float | Above | None:
    """What a search is told: the peak, Above(limit) for a censored evaluation, None for a failure."""
    if evaluation.ok:
        return evaluation.peak
    if evaluation.censored:
        return Above(evaluation.lower_bound)
    return None


def task_key(task: Any) -> str:
    """The cache and journal key of a task: its own ``key`` when it has one (FMURun), else its repr."""
    key = getattr(task, "key", None)
    return key if isinstance(key, str) else f"{type(task).__module__}.{type(task).__qualname__}:{task!r}"


class Evaluator:
    """Runs (task, order) pairs through one Executor: cached, journalled, guarded.

    - *Cache*: a (task, order) pair is simulated once per run; a resumed run starts with the journal's.
    - *Journal*: each finished evaluation is appended as it arrives, so an interruption loses only what
      was in flight.
    - *In flight*: at most ``2 * slots`` evaluations are submitted at a time, so a crash costs little and
      a time limit can be measured from submission (at most one evaluation queued ahead per worker).
    - *Failures*: an exception, a dead worker or a run past ``time_limit`` seconds is a failed evaluation
      with its reason. A dead worker breaks a process pool: the pool is replaced and the orders that were
      in flight are tried again one at a time, so only the order that kills a worker fails.
    """

    def __init__(self, executor: Executor, journal=None, time_limit: float | None = None):
        if time_limit is not None and not (math.isfinite(time_limit) and time_limit > 0):
            raise ValueError(f"time_limit must be a finite number of seconds > 0, got {time_limit!r}")
        self.executor = executor
        self.journal = journal
        self.time_limit = time_limit
        self.cache: dict[tuple[str, Order], Evaluation] = dict(journal.load()) if journal is not None else {}
        self.resumed = len(self.cache)
        self.simulated = 0
        self.cache_hits = 0
        self.pool_renewals = 0
        self.timeouts = 0

    def run(self, items: Sequence[tuple[Callable[[Order], Evaluation], Order]],
            progress: Callable[[int], Any] | None = None) -> list[Evaluation]:
        """The evaluation of every (task, order), in the given order."""
        keyed = [((task_key(task), as_order(order)), task, as_order(order)) for task, order in items]
        todo: dict[tuple[str, Order], tuple[Any, Order]] = {}
        for key, task, order in keyed:
            if key in self.cache:
                self.cache_hits += 1
            elif key not in todo:
                todo[key] = (task, order)
        if todo:
            self._run_all(todo, progress)
        return [self.cache[key] for key, _, _ in keyed]

    def cached(self, task: Any, order: Order) -> Evaluation | None:
        """The evaluation of (task, order) if this run already has it."""
        return self.cache.get((task_key(task), as_order(order)))

    def _record(self, key: tuple[str, Order], evaluation: Evaluation) -> None:
        self.cache[key] = evaluation
        self.simulated += 1
        if self.journal is not None:
            self.journal.append(key[0], evaluation)

    def _run_all(self, todo: dict, progress) -> None:
        pending = list(todo.items())
        pending.reverse()  # pop() from the end keeps submission in the given order
        in_flight: dict[Future, tuple[tuple[str, Order], Any, Order, float]] = {}
        limit = 2 * executor_slots(self.executor)
        retry_alone: list = []
        done = 0
        while pending or in_flight or retry_alone:
            while pending and len(in_flight) < limit:
                key, (task, order) = pending.pop()
                future = self._submit(task, order)
                if future is None:
                    self._record(key, failed(order, "executor: could not submit (the executor is shut down)"))
                    continue
                in_flight[future] = (key, task, order, time.monotonic())
            if not in_flight and retry_alone:
                self._retry_alone(retry_alone)
                done += len(retry_alone)
                retry_alone = []
                continue
            timeout = None
            if self.time_limit is not None:
                oldest = min(started for _, _, _, started in in_flight.values())
                timeout = max(0.0, oldest + self.time_limit - time.monotonic())
            finished, _ = wait(list(in_flight), timeout=timeout, return_when=FIRST_COMPLETED)
            broken = False
            for future in finished:
                key, task, order, started = in_flight.pop(future)
                try:
                    evaluation = check_evaluation(future.result(), order)
                except BrokenProcessPool:
                    broken = True
                    retry_alone.append((key, task, order))
                    continue
                except Exception as exc:  # noqa: BLE001 - a worker's error is this order's failure
                    evaluation = failed(order, f"executor: {type(exc).__name__}: {exc}")
                self._record(key, evaluation)
                done += 1
                if progress is not None:
                    progress(done)
            if not finished and self.time_limit is not None:
                self._expire(in_flight, pending)
            if broken:
                # every other evaluation in flight died with the pool: try each again, one at a time
                retry_alone += [(key, task, order) for key, task, order, _ in in_flight.values()]
                in_flight.clear()
                self._renew()

    def _submit(self, task, order) -> Future | None:
        try:
            return self.executor.submit(safe_call, task, order)
        except BrokenProcessPool:
            self._renew()
        except RuntimeError:
            return None
        try:
            return self.executor.submit(safe_call, task, order)
        except Exception:  # noqa: BLE001
            return None

    def _renew(self) -> None:
        renew = getattr(self.executor, "renew", None)
        if renew is not None:
            renew()
            self.pool_renewals += 1

    def _expire(self, in_flight: dict, pending: list) -> None:
        """Fails the evaluations past the time limit; the others in flight are submitted again."""
        now = time.monotonic()
        for future, (key, task, order, started) in list(in_flight.items()):
            if now - started >= self.time_limit:
                self.timeouts += 1
                future.cancel()
                del in_flight[future]
                self._record(key, failed(order, f"exceeded the time limit of {self.time_limit:g} s per evaluation"))
        if hasattr(self.executor, "renew"):  # a hung process cannot be stopped but by ending it
            for future, (key, task, order, _) in in_flight.items():
                pending.append((key, (task, order)))
            in_flight.clear()
            self._renew()

    def _retry_alone(self, items: list) -> None:
        """Orders whose worker died: each alone on a fresh pool; one that kills it again has failed."""
        for key, task, order in items:
            future = self._submit(task, order)
            if future is None:
                self._record(key, failed(order, "executor: could not submit (the executor is shut down)"))
                continue
            try:
                finished, _ = wait([future], timeout=self.time_limit)
                if not finished:
                    raise TimeoutError(f"exceeded the time limit of {self.time_limit:g} s per evaluation")
                evaluation = check_evaluation(future.result(), order)
            except BrokenProcessPool as exc:
                evaluation = failed(order, f"executor: BrokenProcessPool: the worker died evaluating this order "
                                           f"twice ({exc})")
                self._renew()
            except TimeoutError as exc:
                self.timeouts += 1
                evaluation = failed(order, str(exc))
                self._renew()
            except Exception as exc:  # noqa: BLE001
                evaluation = failed(order, f"executor: {type(exc).__name__}: {exc}")
            self._record(key, evaluation)

    def state(self) -> dict:
        return {"simulated": self.simulated, "cache_hits": self.cache_hits, "resumed": self.resumed,
                "pool_renewals": self.pool_renewals, "timeouts": self.timeouts}


def as_evaluator(executor_or_evaluator) -> Evaluator:
    if isinstance(executor_or_evaluator, Evaluator):
        return executor_or_evaluator
    return Evaluator(executor_or_evaluator)


def run_search(search: Search, objective, budget: int, evaluator, *, method_name: str, seed: int,
               progress: Callable[[int], Any] | None = None, fidelity: str = SEARCH,
               stall_batches: int = STALL_BATCHES) -> SearchRun:
    """Drive ``search`` until the budget, its stop, exhaustion or a stall.

    ``objective``: an ``Objective`` (or any ``order -> Evaluation`` callable); ``evaluator``: an
    ``Evaluator`` (or a bare Executor, wrapped in one). Each batch: dedupe the asked orders, evaluate the
    ones this run has not seen through the objective and the evaluator, process the results in ask
    order, tell the search every asked order's value (None for failures, ``Above(limit)`` when censored).
    An order already seen censored is evaluated again when the search gives limits and asks it with no
    limit or a higher one than it was censored at (the annealing, whose thresholds vary from chain to
    chain); that run is logged in ``evaluations`` but not charged to the budget, which counts distinct
    orders, so that a search makes the same asks whether or not the evaluator honours its limits (its FMU
    time is in the evaluation's ``seconds`` like any other). When the remaining budget is
    smaller than the number of new orders, only the first ``remaining`` are evaluated and the run stops
    without telling the search (pycma must not be told a partial population).

    ``progress(n_done)`` is called with the number of evaluations done so far as results arrive (for a
    progress bar; it never affects the results).
    """
    if int(budget) != budget or budget < 0:
        raise ValueError(f"budget must be a non-negative integer, got {budget!r}")
    budget = int(budget)
    objective: Objective = as_objective(objective)
    evaluator = as_evaluator(evaluator)
    run = SearchRun(method=method_name, seed=int(seed), budget=budget)
    seen: dict[Order, Evaluation] = {}
    start = time.perf_counter()
    no_new = 0
    total_orders = math.factorial(search.n) if search.n <= 12 else None

    while True:
        if len(seen) >= budget:
            run.stop_reason = f"budget of {budget} evaluations used"
            break
        if search.stop():
            run.stop_reason = "the search stopped itself"
            break
        if total_orders is not None and len(seen) >= total_orders:
            run.stop_reason = f"all {total_orders} orders of 1..{search.n} evaluated"
            break

        asked = [as_order(o) for o in search.ask()]
        asked_limits = search.limits()
        limit_of = dict(zip(asked, asked_limits)) if asked_limits is not None else {}
        for order in asked:
            if len(order) != search.n or not is_permutation(order):
                raise ValueError(f"{method_name}: the search asked {order}, not a permutation of 1..{search.n}")
        unique = list(dict.fromkeys(asked))  # first occurrence, ask order
        fresh = [o for o in unique if o not in seen]
        remaining = budget - len(seen)
        truncated = len(fresh) > remaining
        if truncated:
            new = fresh[:remaining]
        else:
            new = [o for o in unique if o not in seen
                   or (asked_limits is not None and _censored_below(seen[o], limit_of.get(o)))]
        run.cache_hits += len(asked) - len(new)

        done = len(run.evaluations)
        results = objective.evaluate(new, evaluator, fidelity,
                                     progress=None if progress is None else (lambda k, d=done: progress(d + k)),
                                     limits=[limit_of.get(o) for o in new] if limit_of else None)
        for order, evaluation in zip(new, results):
            run.n_reevaluated += order in seen
            seen[order] = evaluation
            run.evaluations.append(evaluation)
            if evaluation.censored:
                run.n_censored += 1
            elif not evaluation.ok:
                run.n_failed += 1
            elif run.best_peak is None or evaluation.peak < run.best_peak:
                run.best_order, run.best_peak = order, evaluation.peak
                run.best_index = len(run.evaluations)
        run.batches += 1
        if truncated:
            run.stop_reason = (f"budget of {budget} evaluations used "
                               f"(last batch cut to {len(new)} new orders, not told)")
            break
        search.tell(asked, [told_value(seen[o]) for o in asked])

        no_new = 0 if fresh else no_new + 1
        if no_new >= stall_batches:
            run.stalled = True
            run.stop_reason = (f"stalled: {stall_batches} batches in a row asked only orders "
                               f"already evaluated ({len(seen)} distinct so far)")
            break

    run.wall_seconds = time.perf_counter() - start
    run.diagnostics = search.state()
    return run
