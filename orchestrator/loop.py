"""The evaluation loop: ask a batch, evaluate the new orders in parallel, tell.

Guarantees (why each one exists):
- *Budget*: ``budget`` counts evaluations of distinct orders and is never
  exceeded; the study's cost was dominated by simulations, so that is what a
  user pays for and compares methods by.
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
from concurrent.futures import Executor, as_completed
from dataclasses import dataclass, field
from typing import Any, Callable

from .search.base import Search
from .types import Evaluation, Order, as_order, check_evaluation, failed, is_permutation, safe_call

STALL_BATCHES = 200


@dataclass
class SearchRun:
    """Everything one run of one search produced.

    ``evaluations[k]`` is evaluation number ``k + 1`` (indices are 1-based, as
    in "found at evaluation 4"), in the order first evaluated; cache hits are
    not evaluations.
    """

    method: str
    seed: int
    budget: int
    evaluations: list[Evaluation] = field(default_factory=list)
    best_order: Order | None = None
    best_peak: float | None = None          # None when every evaluation failed
    best_index: int | None = None           # 1-based index of the best evaluation
    n_failed: int = 0
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


def run_search(search: Search, objective: Callable[[Order], Evaluation], budget: int,
               executor: Executor, *, method_name: str, seed: int,
               progress: Callable[[int], Any] | None = None,
               stall_batches: int = STALL_BATCHES) -> SearchRun:
    """Drive ``search`` until the budget, its stop, exhaustion or a stall.

    Each batch: dedupe the asked orders, submit the ones not in the cache as
    ``executor.submit(safe_call, objective, order)``, process the results in
    ask order, tell the search every asked order's value (None for failures).
    When the remaining budget is smaller than the number of new orders, only
    the first ``remaining`` are evaluated and the run stops without telling
    the search (pycma must not be told a partial population).

    ``progress(n_done)`` is called with the number of evaluations done so far
    as results arrive (for a progress bar; it never affects the results).
    """
    if int(budget) != budget or budget < 0:
        raise ValueError(f"budget must be a non-negative integer, got {budget!r}")
    budget = int(budget)
    run = SearchRun(method=method_name, seed=int(seed), budget=budget)
    cache: dict[Order, Evaluation] = {}
    start = time.perf_counter()
    no_new = 0
    total_orders = math.factorial(search.n) if search.n <= 12 else None

    while True:
        if len(run.evaluations) >= budget:
            run.stop_reason = f"budget of {budget} evaluations used"
            break
        if search.stop():
            run.stop_reason = "the search stopped itself"
            break
        if total_orders is not None and len(cache) >= total_orders:
            run.stop_reason = f"all {total_orders} orders of 1..{search.n} evaluated"
            break

        asked = [as_order(o) for o in search.ask()]
        for order in asked:
            if len(order) != search.n or not is_permutation(order):
                raise ValueError(f"{method_name}: the search asked {order}, not a permutation of 1..{search.n}")
        new = [o for o in dict.fromkeys(asked) if o not in cache]  # first occurrence, ask order
        run.cache_hits += len(asked) - len(new)
        remaining = budget - len(run.evaluations)
        truncated = len(new) > remaining
        new = new[:remaining]

        results, broken = _evaluate(executor, objective, new, len(run.evaluations), progress)
        for order, evaluation in zip(new, results):
            cache[order] = evaluation
            run.evaluations.append(evaluation)
            if not evaluation.ok:
                run.n_failed += 1
            elif run.best_peak is None or evaluation.peak < run.best_peak:
                run.best_order, run.best_peak = order, evaluation.peak
                run.best_index = len(run.evaluations)
        run.batches += 1
        if broken is not None:
            run.stop_reason = f"executor error: {type(broken).__name__}: {broken}"
            break
        if truncated:
            run.stop_reason = (f"budget of {budget} evaluations used "
                               f"(last batch cut to {len(new)} new orders, not told)")
            break
        search.tell(asked, [cache[o].peak if cache[o].ok else None for o in asked])

        no_new = 0 if new else no_new + 1
        if no_new >= stall_batches:
            run.stalled = True
            run.stop_reason = (f"stalled: {stall_batches} batches in a row asked only orders "
                               f"already evaluated ({len(cache)} distinct so far)")
            break

    run.wall_seconds = time.perf_counter() - start
    run.diagnostics = search.state()
    return run


def _evaluate(executor: Executor, objective: Callable, orders: list[Order], done: int,
              progress: Callable[[int], Any] | None) -> tuple[list[Evaluation], BaseException | None]:
    """Evaluate ``orders`` through the executor; results in the same order.

    An exception raised by a future (e.g. a worker process died) becomes a
    failed evaluation of that order.  If ``submit`` itself raises (the
    executor is broken or shut down) the orders not submitted are dropped and
    the error is returned so the run can stop instead of burning its budget.
    """
    futures = []
    broken: BaseException | None = None
    for order in orders:
        try:
            futures.append(executor.submit(safe_call, objective, order))
        except Exception as exc:  # noqa: BLE001
            broken = exc
            break
    if progress is not None:
        for k, _ in enumerate(as_completed(futures), start=1):
            progress(done + k)
    results = []
    for order, future in zip(orders, futures):
        try:
            evaluation = check_evaluation(future.result(), order)
        except Exception as exc:  # noqa: BLE001
            evaluation = failed(order, f"executor: {type(exc).__name__}: {exc}")
        results.append(evaluation)
    return results, broken
