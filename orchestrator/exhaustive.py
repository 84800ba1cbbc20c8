"""Exhaustive search: every order of 1..C, screened in chunks of ranks, checkpointed, then verified.

Why: "several seeds agree" is not evidence that the best order is the best.  At a few milliseconds per
order, every permutation of 8 or 9 columns takes minutes here and 11 columns (39,916,800 orders) tens of
core-hours, i.e. minutes on a large Dask cluster.

How:
- *Ranks*: order number r (0 <= r < C!) is the r-th permutation of 1..C in lexicographic order, decoded
  with the factorial number system (Lehmer code): :func:`order_from_rank`, :func:`rank_of`.  A chunk is a
  range of ranks, so the client never holds more than the chunks in flight.
- *Chunks* (:func:`evaluate_chunk`, a picklable task for any ``concurrent.futures.Executor``): every
  order of the range through ``objective(order) -> Evaluation`` (``types.safe_call``: a failure is
  counted, never a number), keeping the chunk's ``keep`` best orders, every order within the screening
  bound of the chunk's best (those are the only ones that can be the optimum), its failed orders, a
  histogram of its peaks, and its wall and CPU seconds.
- *Checkpoint*: each finished chunk is written atomically (a temporary file, then ``os.replace``) as
  JSON into the checkpoint folder; a run started again with the same folder skips the finished chunks.
  The folder's ``fingerprint.json`` (FMU file hash, objective, scene, C, chunk size, ...) must match,
  else the run is refused: results of two problems are never mixed.  A chunk whose future raised (a
  worker died) is submitted again.
- *Verification*: the screening objective errs by at most ``screening_error`` (relative), so an order
  screened at s can be the optimum only if ``s (1 - e) <= best (1 + e)``.  Every such order (and every
  order that failed at screening) is evaluated by ``full_objective``; the optimum is the best of those,
  to the full objective's own stated tolerance.
- *Cost guard*: beyond ``max_orders`` orders, a run is refused with its projected core-hours unless it
  goes to Dask with an explicit confirmation.

Censored evaluations (a force limit above which the FMU may stop early): ``objective_with_limit(limit)``,
when given, builds the objective for a limit; the chunk starts at the client's limit (the incumbent's
screening threshold when a chunk is submitted) and lowers it as its own best improves (e.g.
``FMURun.with_limit`` of ``orchestrator.objective``).  A censored evaluation (status "censored") counts as
"above the limit": never a peak, never a candidate.
"""
from __future__ import annotations

import json
import math
import os
import time
from concurrent.futures import FIRST_COMPLETED, Executor, Future, wait
from pathlib import Path
from typing import Any, Callable, Iterable, Sequence

import numpy as np

from concurrent.futures.process import BrokenProcessPool

from .executors import executor_slots
from .journal import file_sha256
from .types import Evaluation, Order, as_order, safe_call

MAX_LOCAL_ORDERS = math.factorial(10)
"""Beyond this many orders (10! = 3,628,800, hours on a 2-core machine) a sweep is refused unless it runs on
Dask and is confirmed; the refusal states the projected core-hours, measured on the spot."""

HISTOGRAM_RESOLUTION = 1e-3
"""Relative width of a histogram bin (0.1 %): bin k holds peaks in [(1+res)^k, (1+res)^(k+1)) N."""

MAX_KEPT_PER_CHUNK = 10_000  # orders within the bound (or failed) a chunk may return; beyond, it says so
CALIBRATION_ORDERS = 12  # orders timed on the client to project the cost of a refused sweep


# ------------------------------------------------------------------------------------------ ranks
def order_from_rank(rank: int, columns: int) -> Order:
    """The ``rank``-th permutation of 1..columns in lexicographic order (rank 0 is 1..C, C!-1 is C..1)."""
    columns = int(columns)
    rank = int(rank)
    if columns < 1:
        raise ValueError(f"columns must be at least 1, got {columns}")
    if not 0 <= rank < math.factorial(columns):
        raise ValueError(f"rank must be in [0, {columns}!) = [0, {math.factorial(columns)}), got {rank}")
    pool = list(range(1, columns + 1))
    order = []
    for position in range(columns - 1, -1, -1):
        digit, rank = divmod(rank, math.factorial(position))  # Lehmer code digit, most significant first
        order.append(pool.pop(digit))
    return tuple(order)


def rank_of(order: Sequence[int]) -> int:
    """Inverse of :func:`order_from_rank`: the lexicographic rank of a permutation of 1..C."""
    order = as_order(order)
    columns = len(order)
    if sorted(order) != list(range(1, columns + 1)):
        raise ValueError(f"order must be a permutation of 1..{columns}, got {list(order)}")
    rank = 0
    pool = list(range(1, columns + 1))
    for position, material in enumerate(order):
        digit = pool.index(material)
        rank += digit * math.factorial(columns - 1 - position)
        pool.pop(digit)
    return rank


def orders_in_range(columns: int, start: int, stop: int) -> Iterable[Order]:
    """The orders of ranks start..stop-1, decoding only the first (then the next-permutation step)."""
    if start >= stop:
        return
    p = list(order_from_rank(start, columns))
    for _ in range(stop - start):
        yield tuple(p)
        i = len(p) - 2  # next lexicographic permutation (Knuth's algorithm L)
        while i >= 0 and p[i] >= p[i + 1]:
            i -= 1
        if i < 0:
            return
        j = len(p) - 1
        while p[j] <= p[i]:
            j -= 1
        p[i], p[j] = p[j], p[i]
        p[i + 1:] = reversed(p[i + 1:])


def chunk_ranges(total: int, chunk_size: int) -> list[tuple[int, int]]:
    """(start, stop) of chunk k, for every k (a list of C!/chunk_size pairs, not of orders)."""
    return [(start, min(start + chunk_size, total)) for start in range(0, total, chunk_size)]


# ------------------------------------------------------------------------------------------ histogram
def histogram_bin(peak: float, resolution: float = HISTOGRAM_RESOLUTION) -> int:
    """Bin of a peak on a logarithmic scale of relative width ``resolution`` (bin 0 holds [1, 1+res) N).

    Why logarithmic and fixed: chunks must share their bins without knowing each other's range, and a
    relative width resolves the few-newton gaps between good orders whatever the scene's force scale.
    Peaks at or below 0 share one bin (-10**9).
    """
    if peak <= 0:
        return -10**9
    return int(math.floor(math.log(peak) / math.log1p(resolution)))


def bin_edges(index: int, resolution: float = HISTOGRAM_RESOLUTION) -> tuple[float, float]:
    return (1 + resolution) ** index, (1 + resolution) ** (index + 1)


# ------------------------------------------------------------------------------------------ one chunk
def screening_threshold(best: float, screening_error: float) -> float:
    """Largest screened peak that can still be the optimum when the best screened is ``best``."""
    return best * (1 + screening_error) / (1 - screening_error)


def evaluate_chunk(objective: Callable[[Order], Evaluation], columns: int, start: int, stop: int, *,
                   keep: int = 20, screening_error: float = 0.0,
                   resolution: float = HISTOGRAM_RESOLUTION, all_peaks: bool = False,
                   objective_with_limit: Callable[[float], Callable[[Order], Evaluation]] | None = None,
                   limit: float | None = None) -> dict[str, Any]:
    """Evaluate every order of ranks [start, stop); a JSON-ready summary (the checkpoint file's content).

    ``best``: the ``keep`` best (order, peak), best first; ``within``: every order whose screened peak is
    within ``screening_error`` of the chunk's best (see :func:`screening_threshold`; a superset of the
    orders that can be the global optimum); ``failed``: the failed orders and their messages;
    ``histogram``: {bin: count} of the peaks (:func:`histogram_bin`); ``peaks`` (when ``all_peaks``):
    every order's peak in rank order, None for a failure or a censored order (run without a limit for a table).
    """
    wall, cpu = time.perf_counter(), time.process_time()
    evaluated_seconds = 0.0
    best: list[tuple[float, int]] = []  # (peak, rank), sorted, at most `keep`
    good: list[tuple[float, int]] = []  # candidates for `within` (pruned as the chunk's best improves)
    failed: list[tuple[int, str]] = []
    censored = 0
    histogram: dict[int, int] = {}
    peaks: list[float | None] = []
    chunk_best = math.inf
    current_limit = limit
    evaluate = objective if objective_with_limit is None or limit is None else objective_with_limit(limit)
    for rank, order in enumerate(orders_in_range(columns, start, stop), start=start):
        evaluation = safe_call(evaluate, order)
        evaluated_seconds += evaluation.seconds
        if evaluation.censored:
            censored += 1
            if all_peaks:
                peaks.append(None)
            continue
        if not evaluation.ok:
            failed.append((rank, evaluation.message))
            if all_peaks:
                peaks.append(None)
            continue
        peak = float(evaluation.peak)
        if all_peaks:
            peaks.append(peak)
        bin_index = histogram_bin(peak, resolution)
        histogram[bin_index] = histogram.get(bin_index, 0) + 1
        if len(best) < keep or peak < best[-1][0]:
            best.append((peak, rank))
            best.sort()
            del best[keep:]
        if peak <= screening_threshold(min(chunk_best, peak), screening_error):
            good.append((peak, rank))
        if peak < chunk_best:
            chunk_best = peak
            bound = screening_threshold(chunk_best, screening_error)
            if len(good) > 2 * MAX_KEPT_PER_CHUNK:
                good = [g for g in good if g[0] <= bound]
            if objective_with_limit is not None and (current_limit is None or bound < current_limit):
                current_limit = bound
                evaluate = objective_with_limit(current_limit)
    bound = screening_threshold(chunk_best, screening_error) if math.isfinite(chunk_best) else math.inf
    within = sorted(g for g in good if g[0] <= bound)
    result = {
        "start": start, "stop": stop, "orders": stop - start, "columns": columns,
        "best": [[list(order_from_rank(r, columns)), p] for p, r in best],
        "within": [[list(order_from_rank(r, columns)), p] for p, r in within[:MAX_KEPT_PER_CHUNK]],
        "within_truncated": len(within) > MAX_KEPT_PER_CHUNK,
        "failed": [[list(order_from_rank(r, columns)), m] for r, m in failed[:MAX_KEPT_PER_CHUNK]],
        "n_failed": len(failed), "n_censored": censored, "final_limit": current_limit,
        "histogram": {str(k): v for k, v in sorted(histogram.items())},
        "seconds": time.perf_counter() - wall, "cpu_seconds": time.process_time() - cpu,
        "evaluation_seconds": evaluated_seconds,
    }
    if all_peaks:
        result["peaks"] = peaks
    return result


# ------------------------------------------------------------------------------------------ checkpoint
def describe_objective(objective: Any) -> dict[str, Any]:
    """What identifies an objective in a fingerprint: its repr and, when it has an FMU, the FMU's hash."""
    described: dict[str, Any] = {"objective": repr(objective)}
    fmu_path = getattr(objective, "fmu_path", None)
    if fmu_path is not None:
        described["fmu_sha256"] = file_sha256(fmu_path)
    return described


def write_json_atomically(path: Path, content: Any) -> None:
    """Write to a temporary file in the same folder, then ``os.replace``: a reader (or a restart after a
    SIGKILL) sees the whole old file or the whole new one, never half of one."""
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    with open(tmp, "w") as handle:
        json.dump(content, handle)
        handle.flush()
        os.fsync(handle.fileno())
    os.replace(tmp, path)


def chunk_path(checkpoint_dir: Path, index: int) -> Path:
    return checkpoint_dir / f"chunk_{index:08d}.json"


def open_checkpoint(checkpoint_dir: str | os.PathLike, fingerprint: dict[str, Any]) -> Path:
    """Create the folder with its fingerprint, or check that an existing one has the same fingerprint."""
    folder = Path(checkpoint_dir)
    folder.mkdir(parents=True, exist_ok=True)
    stored_path = folder / "fingerprint.json"
    fingerprint = json.loads(json.dumps(fingerprint))  # what it will read back as
    if stored_path.exists():
        stored = json.loads(stored_path.read_text())
        differ = sorted(k for k in set(stored) | set(fingerprint) if stored.get(k) != fingerprint.get(k))
        if differ:
            raise ValueError(f"checkpoint {folder} belongs to another sweep (differs in: {', '.join(differ)}); "
                             "use another checkpoint folder")
    else:
        if any(folder.glob("chunk_*.json")):
            raise ValueError(f"checkpoint {folder} holds chunks but no fingerprint.json; use another folder")
        write_json_atomically(stored_path, fingerprint)
    return folder


def read_chunk(path: Path) -> dict[str, Any] | None:
    """A finished chunk, or None when the file is unreadable (then the chunk runs again)."""
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return None


# ------------------------------------------------------------------------------------------ the sweep
def projected_cost(objective: Callable[[Order], Evaluation], columns: int) -> tuple[float, float]:
    """(orders per core-second, projected core-hours for C! orders), timing a few orders here (after one
    untimed order: an FMU objective opens its FMU on first use)."""
    safe_call(objective, order_from_rank(0, columns))
    cpu = time.process_time()
    evaluations = [safe_call(objective, order_from_rank(rank * 7919 % math.factorial(columns), columns))
                   for rank in range(CALIBRATION_ORDERS)]
    seconds = time.process_time() - cpu
    if not any(e.ok for e in evaluations):
        raise ValueError(f"exhaustive: the objective failed on every one of {CALIBRATION_ORDERS} orders of "
                         f"{columns} columns (first: {evaluations[0].message}); is it for {columns} columns?")
    rate = CALIBRATION_ORDERS / max(seconds, 1e-9)
    return rate, math.factorial(columns) / rate / 3600


def check_cost(objective, columns: int, executor_kind: str, confirm: bool, max_orders: int) -> None:
    """Refuse a sweep beyond ``max_orders`` unless it goes to Dask with an explicit confirmation."""
    total = math.factorial(columns)
    if total <= max_orders or (executor_kind == "dask" and confirm):
        return
    rate, core_hours = projected_cost(objective, columns)
    raise ValueError(
        f"exhaustive: {columns}! = {total:,} orders is beyond the local limit of {max_orders:,}: projected "
        f"{core_hours:,.1f} core-hours at {rate:,.0f} orders per core-second (measured here); run it with "
        "executor 'dask' on a cluster, confirmed explicitly (--executor dask --confirm-exhaustive)")


def run_exhaustive(objective: Callable[[Order], Evaluation], columns: int, executor: Executor,
                   checkpoint_dir: str | os.PathLike, chunk_size: int, *,
                   full_objective: Callable[[Order], Evaluation] | None = None,
                   screening_error: float, full_error: float | None = None,
                   keep: int = 20, scene: Any = None, executor_kind: str = "process",
                   confirm: bool = False, max_orders: int = MAX_LOCAL_ORDERS, in_flight: int | None = None,
                   all_peaks: bool = False, max_attempts: int = 3, verify_top: int = 5,
                   objective_with_limit: Callable[[float], Callable[[Order], Evaluation]] | None = None,
                   progress: Callable[[int, int], Any] | None = None) -> dict[str, Any]:
    """Screen every order of 1..``columns`` with ``objective``, verify the candidates with ``full_objective``.

    ``screening_error``: the screening objective's stated relative error bound (it decides which orders
    are re-evaluated); ``full_error``: the full objective's (stated in the result as the tolerance).
    ``verify_top``: the best orders verified at full fidelity besides the candidates (so the result can say
    how far the runner-up is).  ``in_flight``: chunks submitted at once (default: twice the executor's
    workers when known, else 8).
    ``progress(chunks_done, chunks_total)`` is called as chunks finish.  Returns the result dict
    (``"exhaustive"`` shape of issue 11, plus the optimum and the evidence for it).
    """
    start_time = time.perf_counter()
    columns, chunk_size = int(columns), int(chunk_size)
    if columns < 1:
        raise ValueError(f"columns must be at least 1, got {columns}")
    if chunk_size < 1:
        raise ValueError(f"chunk_size must be at least 1, got {chunk_size}")
    if not 0.0 <= screening_error < 1.0:
        raise ValueError(f"screening_error must be a relative error in [0, 1), got {screening_error}")
    if executor_kind not in ("serial", "process", "dask"):
        raise ValueError(f"executor_kind must be serial, process or dask, got {executor_kind!r}")
    check_cost(objective, columns, executor_kind, confirm, max_orders)
    total = math.factorial(columns)
    fingerprint = {
        **describe_objective(objective), "scene": scene, "columns": columns, "chunk_size": chunk_size,
        "keep": keep, "screening_error": screening_error, "histogram_resolution": HISTOGRAM_RESOLUTION,
        "all_peaks": bool(all_peaks), "with_limit": objective_with_limit is not None,
    }
    folder = open_checkpoint(checkpoint_dir, fingerprint)
    ranges = chunk_ranges(total, chunk_size)
    chunks: dict[int, dict[str, Any]] = {}
    for index in range(len(ranges)):
        path = chunk_path(folder, index)
        if path.exists():
            content = read_chunk(path)
            if content is not None and [content.get("start"), content.get("stop")] == list(ranges[index]):
                chunks[index] = content
    from_checkpoint = len(chunks)
    todo = [k for k in range(len(ranges)) if k not in chunks]
    if in_flight is None:
        in_flight = 2 * executor_slots(executor)
    attempts: dict[int, int] = {}
    rerun = 0
    incumbent = min((c["best"][0][1] for c in chunks.values() if c["best"]), default=math.inf)
    running: dict[Future, int] = {}
    queue = list(reversed(todo))  # pop() from the end: ascending chunk order

    def submit(index: int) -> None:
        chunk_start, chunk_stop = ranges[index]
        limit = screening_threshold(incumbent, screening_error) if math.isfinite(incumbent) else None
        future = executor.submit(evaluate_chunk, objective, columns, chunk_start, chunk_stop, keep=keep,
                                 screening_error=screening_error, all_peaks=all_peaks,
                                 objective_with_limit=objective_with_limit, limit=limit)
        attempts[index] = attempts.get(index, 0) + 1
        running[future] = index

    broken: BaseException | None = None  # the executor refused work: finish what runs, then stop
    try:
        while (queue and broken is None) or running:
            while queue and broken is None and len(running) < in_flight:
                try:
                    submit(queue[-1])
                except Exception as exc:  # noqa: BLE001 - the executor is broken or shut down
                    broken = exc
                    break
                queue.pop()
            if not running:
                break
            done, _ = wait(list(running), return_when=FIRST_COMPLETED)
            for future in sorted(done, key=lambda f: running[f]):
                if future not in running:
                    continue  # requeued when the pool was replaced
                index = running.pop(future)
                try:
                    content = future.result()
                except Exception as exc:  # noqa: BLE001 - a dead worker costs only its chunk
                    if isinstance(exc, BrokenProcessPool) and hasattr(executor, "renew"):
                        executor.renew()  # a new pool; the chunks that were in it run again
                        for other in list(running):
                            queue.append(running.pop(other))
                    if attempts[index] >= max_attempts:
                        raise RuntimeError(f"exhaustive: chunk {index} (ranks {ranges[index][0]}.."
                                           f"{ranges[index][1] - 1}) failed {attempts[index]} times, last: "
                                           f"{type(exc).__name__}: {exc}") from exc
                    rerun += 1
                    queue.append(index)
                    continue
                write_json_atomically(chunk_path(folder, index), content)
                chunks[index] = content
                if content["best"]:
                    incumbent = min(incumbent, content["best"][0][1])
                if progress is not None:
                    progress(len(chunks), len(ranges))
    finally:
        for future in running:
            future.cancel()
    if broken is not None:
        raise RuntimeError(f"exhaustive: the executor cannot take more work ({type(broken).__name__}: {broken}); "
                           f"{len(chunks)} of {len(ranges)} chunks are in {folder}: run again to resume") from broken
    screening_seconds = time.perf_counter() - start_time
    result = merge(chunks, ranges, columns, screening_error, keep)
    result.update({"from_checkpoint": from_checkpoint, "chunks_rerun": rerun, "checkpoint": str(folder),
                   "screening_seconds": screening_seconds})
    if full_objective is not None:
        verify_candidates(result, executor, full_objective, full_error, verify_top)
    result["seconds"] = time.perf_counter() - start_time
    return result


def merge(chunks: dict[int, dict[str, Any]], ranges: list[tuple[int, int]], columns: int,
          screening_error: float, keep: int) -> dict[str, Any]:
    """One summary of every chunk: counts, the best orders, the candidates, the histogram, the costs."""
    best: list[tuple[float, tuple]] = []
    histogram: dict[int, int] = {}
    failed: list[tuple[tuple, str]] = []
    within: list[tuple[float, tuple]] = []
    truncated = False
    for content in chunks.values():
        best += [(p, tuple(o)) for o, p in content["best"]]
        within += [(p, tuple(o)) for o, p in content["within"]]
        failed += [(tuple(o), m) for o, m in content["failed"]]
        truncated |= bool(content.get("within_truncated"))
        for k, v in content["histogram"].items():
            histogram[int(k)] = histogram.get(int(k), 0) + v
    best.sort()
    screened_best = best[0][0] if best else None
    threshold = screening_threshold(screened_best, screening_error) if best else None
    candidates = sorted(w for w in within if w[0] <= threshold) if best else []
    cpu = sum(c["cpu_seconds"] for c in chunks.values())
    orders = sum(c["orders"] for c in chunks.values())
    return {
        "orders": orders, "columns": columns, "chunks": len(ranges), "chunk_size": ranges[0][1] - ranges[0][0],
        "failed": sum(c["n_failed"] for c in chunks.values()),
        "censored": sum(c.get("n_censored", 0) for c in chunks.values()),
        "failed_orders": [[list(o), m] for o, m in failed[:100]],
        "screened_best": {"order": list(best[0][1]), "peak": screened_best} if best else None,
        "top": [{"order": list(o), "peak": p} for p, o in best[:keep]],
        "screening_error": screening_error, "screening_threshold": threshold,
        "candidates": [{"order": list(o), "peak": p} for p, o in candidates],
        "candidates_truncated": truncated,
        "histogram": {"resolution": HISTOGRAM_RESOLUTION, "counts": {str(k): v for k, v in sorted(histogram.items())}},
        "cpu_seconds": cpu, "orders_per_core_second": orders / cpu if cpu > 0 else None,
        "chunk_overhead_seconds": sum(c["seconds"] - c["evaluation_seconds"] for c in chunks.values()) / len(chunks)
        if chunks else None,
    }


def verify_candidates(result: dict[str, Any], executor: Executor,
                      full_objective: Callable[[Order], Evaluation], full_error: float | None,
                      verify_top: int = 0) -> None:
    """Every candidate, every screening failure and the ``verify_top`` best orders at full fidelity; the
    optimum is the best of them."""
    orders = ([tuple(c["order"]) for c in result["candidates"]] + [tuple(o) for o, _ in result["failed_orders"]]
              + [tuple(c["order"]) for c in result["top"][:verify_top]])
    orders = list(dict.fromkeys(orders))
    futures = [executor.submit(safe_call, full_objective, order) for order in orders]
    evaluations = []
    for order, future in zip(orders, futures):
        try:
            evaluations.append(future.result())
        except Exception as exc:  # noqa: BLE001
            evaluations.append(Evaluation(order, None, "failed", f"executor: {type(exc).__name__}: {exc}"))
    screened = {tuple(c["order"]): c["peak"] for c in result["top"] + result["candidates"]}
    checks = [{"order": list(e.order), "screened": screened.get(e.order), "full": e.peak if e.ok else None,
               "status": e.status, "message": e.message} for e in evaluations]
    ok = sorted((c for c in checks if c["full"] is not None), key=lambda c: c["full"])
    errors = [abs(c["screened"] / c["full"] - 1) for c in ok if c["screened"] is not None and c["full"]]
    result["full_fidelity_checks"] = len(checks)
    result["full_fidelity"] = checks
    result["full_error"] = full_error
    result["max_screening_error_seen"] = max(errors) if errors else None
    result["screening_bound_held"] = (max(errors) <= result["screening_error"]) if errors else None
    if ok:
        best = ok[0]
        runner_up = ok[1]["full"] if len(ok) > 1 else None
        result["optimum"] = {"order": best["order"], "peak": best["full"], "screened_peak": best["screened"],
                             "tolerance": None if full_error is None else full_error * best["full"],
                             "runner_up_peak": runner_up,
                             "distinct_from_runner_up": None if runner_up is None or full_error is None
                             else runner_up - best["full"] > 2 * full_error * max(runner_up, best["full"])}
    else:
        result["optimum"] = None


def peak_table(checkpoint_dir: str | os.PathLike, columns: int) -> np.ndarray:
    """Every order's screened peak by lexicographic rank (NaN: failed), from a sweep run with all_peaks."""
    folder = Path(checkpoint_dir)
    table = np.full(math.factorial(columns), np.nan)
    seen = 0
    for path in sorted(folder.glob("chunk_*.json")):
        content = read_chunk(path)
        if content is None or "peaks" not in content:
            raise ValueError(f"{path}: no peaks (run the sweep with all_peaks=True)")
        values = [np.nan if p is None else p for p in content["peaks"]]
        table[content["start"]:content["stop"]] = values
        seen += content["stop"] - content["start"]
    if seen != len(table):
        raise ValueError(f"{folder}: the chunks cover {seen} of {len(table)} orders; finish the sweep first")
    return table
