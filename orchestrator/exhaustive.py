"""Exhaustive search: every design of the space, screened in chunks of ranks, then verified and certified.

"Several seeds agree" is not evidence that the best design is the best. Where the space can be enumerated,
the sweep gives the optimum with a certificate:

- *Ranks*: design number r is the r-th of the space in lexicographic order (``DesignSpace.unrank``); a chunk
  is a range of ranks, so the client holds no more than the chunks in flight.
- *Chunks* are tasks of the one Evaluator (``ScreenChunk``, keyed by the screening objective and the rank
  range): cached, journalled with a checksum, retried, resumed like every other task. A chunk evaluates each
  design at the screening fidelity and keeps its best designs, every design within the screening bound of
  its best (the only ones that can be the optimum), its failures and a histogram.
- *Force limit*: a chunk starts at the screening threshold of the best value known when it is submitted (a
  short search's best before the sweep, then the best of the chunks so far) and lowers it as its own best
  improves; a design stopped above the limit is censored, never a candidate. A chunk's result holds for any
  starting limit at or above the threshold of the global best, which every honest limit is.
- *Verification*: the screening errs by at most ``screening_error`` (relative), so a design screened at s can
  be the optimum only if ``s (1 - e) <= best (1 + e)``; every such design (and every failure) is evaluated at
  full fidelity.
- *Certificate*: every rank covered exactly once, the pruning exact (the screening bound held on every
  verified design), the optimum and the runner-up re-evaluated by a second integrator at a tight tolerance,
  and the gap between them larger than the integration error.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any, Callable, ClassVar

from .design import DesignSpace
from .tasks import function_key
from .types import LimitedObjective, Order, safe_call

SWEEP_METHOD = "exhaustive"  # the --method name that asks for the sweep (the study's Exhaustive step)
MAX_LOCAL_DESIGNS = math.factorial(10)
"""Beyond this many designs a sweep needs Dask and --confirm-cost; the refusal states the projected
core-hours, measured on the spot on a chunk run as the sweep runs its chunks (force limit at an incumbent)."""

HISTOGRAM_RESOLUTION = 1e-3  # relative width of a histogram bin: bin k holds [(1+res)^k, (1+res)^(k+1))
MAX_KEPT_PER_CHUNK = 10_000  # designs within the bound (or failed) a chunk may return; beyond, it says so
CALIBRATION_DESIGNS = 200  # designs of the chunk timed to project what a sweep costs


def histogram_bin(value: float, resolution: float = HISTOGRAM_RESOLUTION) -> int:
    """Bin of a value on a logarithmic scale of relative width ``resolution`` (values <= 0 share -10**9):
    chunks share their bins without knowing each other's range, and a relative width resolves the small
    gaps between good designs whatever the scene's force scale."""
    if value <= 0:
        return -(10**9)
    return int(math.floor(math.log(value) / math.log1p(resolution)))


def screening_threshold(best: float, screening_error: float) -> float:
    """Largest screened value that can still be the optimum when the best screened is ``best``."""
    return best * (1 + screening_error) / (1 - screening_error)


@dataclass(frozen=True)
class Scored:
    order: Order
    value: float
    values: tuple[float, ...] = ()  # every objective's value, with several objectives


@dataclass(frozen=True)
class Failure:
    order: Order
    message: str


@dataclass(frozen=True)
class ChunkResult:
    """One chunk's screening (what the journal keeps of it)."""

    kind: ClassVar[str] = "chunk"
    start: int
    stop: int
    status: str  # "ok", or "failed" when the chunk itself could not run (it runs again on resume)
    message: str
    best: tuple[Scored, ...]
    within: tuple[Scored, ...]
    within_truncated: bool
    failures: tuple[Failure, ...]
    failed: int
    censored: int
    start_limit: float | None
    final_limit: float | None
    histogram: tuple[tuple[int, int], ...]
    seconds: float
    cpu_seconds: float
    evaluation_seconds: float
    values: tuple[float | None, ...] = ()  # every design's screened value in rank order, when asked

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    @property
    def designs(self) -> int:
        return self.stop - self.start


def not_strongly_dominated(values, screening_error: float):
    """A boolean mask over ``values`` (a row of minimised objective values per design, each screened within
    ``screening_error``, relative, of its true value): False where another design is better on every objective
    by more than the screening can explain, so the design cannot be on the true front; every design of the true
    front keeps True."""
    import numpy as np

    F = np.asarray(values, dtype=float)
    if len(F) == 0:
        return np.zeros(0, dtype=bool)
    factor = (1 - screening_error) / (1 + screening_error)
    keep = np.ones(len(F), dtype=bool)
    for start in range(0, len(F), 512):  # blocks: the comparison matrix stays small
        block = F[start : start + 512]
        beaten = np.all(F[None, :, :] <= block[:, None, :] * factor, axis=2)
        strictly = np.any(F[None, :, :] < block[:, None, :] * factor, axis=2)
        keep[start : start + 512] = ~np.any(beaten & strictly, axis=1)
    return keep


def evaluate_chunk(
    objective: Callable[[Order], Any],
    space: DesignSpace,
    start: int,
    stop: int,
    *,
    keep: int,
    screening_error: float,
    limit: float | None = None,
    all_values: bool = False,
    objectives: int = 1,
) -> ChunkResult:
    """Every design of ranks [start, stop) through ``objective`` (an ``FMURun``, or any ``design ->
    Evaluation`` function; with ``limit``, one that has ``with_limit``). With several ``objectives`` the chunk's
    candidates are the designs no other design of the chunk beats on every objective by more than the
    screening error (the only ones that can be on the front), and no force limit applies."""
    wall, cpu = time.perf_counter(), time.process_time()
    evaluated_seconds = 0.0
    best: list[tuple[float, int]] = []
    good: list[tuple[float, int]] = []
    vectors: list[tuple[tuple[float, ...], int]] = []
    failures: list[tuple[int, str]] = []
    censored = 0
    histogram: dict[int, int] = {}
    values: list[float | None] = []
    chunk_best = math.inf
    # a table needs every value
    limited = objective if isinstance(objective, LimitedObjective) and objectives == 1 and not all_values else None
    current_limit = limit if limited is not None else None
    evaluate = limited.with_limit(current_limit) if limited is not None and current_limit is not None else objective
    for rank, order in enumerate(space.designs(start, stop), start=start):
        evaluation = safe_call(evaluate, order)
        evaluated_seconds += evaluation.seconds
        if evaluation.censored or not evaluation.ok:
            if evaluation.censored:
                censored += 1
            else:
                failures.append((rank, evaluation.message))
            if all_values:
                values.append(None)
            continue
        value = float(evaluation.ok_value)
        if all_values:
            values.append(value)
        index = histogram_bin(value)
        histogram[index] = histogram.get(index, 0) + 1
        if len(best) < keep or value < best[-1][0]:
            best.append((value, rank))
            best.sort()
            del best[keep:]
        if objectives > 1:
            vectors.append((tuple(evaluation.values), rank))
            continue
        if value <= screening_threshold(min(chunk_best, value), screening_error):
            good.append((value, rank))
        if value < chunk_best:
            chunk_best = value
            bound = screening_threshold(chunk_best, screening_error)
            if len(good) > 2 * MAX_KEPT_PER_CHUNK:
                good = [g for g in good if g[0] <= bound]
            if limited is not None and (current_limit is None or bound < current_limit):
                current_limit = bound
                evaluate = limited.with_limit(current_limit)
    if objectives > 1:
        mask = not_strongly_dominated([v for v, _ in vectors], screening_error)
        kept = sorted((v, r) for (v, r), k in zip(vectors, mask) if k)
        within = [Scored(space.unrank(r), v[0], v) for v, r in kept]
    else:
        bound = screening_threshold(chunk_best, screening_error) if math.isfinite(chunk_best) else math.inf
        within = [Scored(space.unrank(r), v) for v, r in sorted(g for g in good if g[0] <= bound)]
    return ChunkResult(
        start=start,
        stop=stop,
        status="ok",
        message="",
        best=tuple(Scored(space.unrank(r), v) for v, r in best),
        within=tuple(within[:MAX_KEPT_PER_CHUNK]),
        within_truncated=len(within) > MAX_KEPT_PER_CHUNK,
        failures=tuple(Failure(space.unrank(r), m) for r, m in failures[:MAX_KEPT_PER_CHUNK]),
        failed=len(failures),
        censored=censored,
        start_limit=limit,
        final_limit=current_limit,
        histogram=tuple(sorted(histogram.items())),
        seconds=time.perf_counter() - wall,
        cpu_seconds=time.process_time() - cpu,
        evaluation_seconds=evaluated_seconds,
        values=tuple(values) if all_values else (),
    )


@dataclass(frozen=True)
class ScreenChunk:
    """A chunk of ranks as a task of the Evaluator; its key names the screening, the space and the range,
    not the starting limit (which changes what is censored, never which designs can be the optimum)."""

    screening: Any
    space: DesignSpace
    start: int
    stop: int
    best_count: int
    screening_error: float
    limit: float | None = None
    all_values: bool = False
    objectives: int = 1

    @property
    def key(self) -> str:
        return (
            f"chunk|{function_key(self.screening)}|{self.space.key}|{self.start}:{self.stop}|"
            f"best={self.best_count}|error={self.screening_error!r}|values={self.all_values}|"
            f"objectives={self.objectives}"
        )

    def __call__(self) -> ChunkResult:
        return evaluate_chunk(
            self.screening,
            self.space,
            self.start,
            self.stop,
            keep=self.best_count,
            screening_error=self.screening_error,
            limit=self.limit,
            all_values=self.all_values,
            objectives=self.objectives,
        )

    def failure(self, message: str, seconds: float) -> ChunkResult:
        return ChunkResult(
            self.start,
            self.stop,
            "failed",
            message,
            (),
            (),
            False,
            (),
            0,
            0,
            self.limit,
            self.limit,
            (),
            seconds,
            0.0,
            0.0,
        )

    def keep(self, result: ChunkResult) -> bool:
        return result.ok


def chunk_ranges(total: int, chunk_size: int) -> list[tuple[int, int]]:
    return [(start, min(start + chunk_size, total)) for start in range(0, total, chunk_size)]


def coverage(chunks: list[ChunkResult], total: int) -> tuple[bool, str]:
    """Whether the chunks cover every rank of [0, total) exactly once, and if not, where they do not."""
    position = 0
    for chunk in sorted(chunks, key=lambda c: c.start):
        if chunk.start != position:
            what = "overlap" if chunk.start < position else "gap"
            return False, f"{what} at rank {min(chunk.start, position)}"
        position = chunk.stop
    if position != total:
        return False, f"ranks {position}..{total - 1} not covered"
    return True, f"ranks 0..{total - 1}, each once"


def calibration_range(space: DesignSpace, designs: int = CALIBRATION_DESIGNS) -> tuple[int, int]:
    """The ranks of the chunk a projection times: ``designs`` from the middle of the space (neither end's
    ordered designs, which are atypically good or bad)."""
    stop = min(space.size, space.size // 2 + designs)
    return max(0, stop - designs), stop


def projected_cost(chunk: "ChunkResult", space: DesignSpace) -> tuple[float, float]:
    """(designs per core-second, projected core-hours for the whole space) from a timed chunk: its designs over
    its own CPU time, so the rate is the one the sweep meets when its chunks run with the same force limit."""
    if not chunk.ok:
        raise ValueError(f"exhaustive: the chunk timed to project the cost failed ({chunk.message})")
    if chunk.failed == chunk.designs:
        raise ValueError(
            f"exhaustive: the objective failed on every one of the {chunk.designs} designs timed "
            f"(first: {chunk.failures[0].message if chunk.failures else 'no message'})"
        )
    rate = chunk.designs / max(chunk.cpu_seconds, 1e-9)
    return rate, space.size / rate / 3600


__all__ = [
    "ChunkResult",
    "Failure",
    "HISTOGRAM_RESOLUTION",
    "MAX_LOCAL_DESIGNS",
    "SWEEP_METHOD",
    "ScreenChunk",
    "Scored",
    "calibration_range",
    "chunk_ranges",
    "coverage",
    "evaluate_chunk",
    "histogram_bin",
    "not_strongly_dominated",
    "projected_cost",
    "screening_threshold",
]
