"""One ``concurrent.futures.Executor`` seam for every kind of parallelism.

Why one seam: the loop only calls ``submit`` and ``Future.result``; whether the
work runs inline, in a local process pool or on a Dask cluster is a choice made
here, and results do not depend on it (the loop processes results in ask
order).

    with make_executor("process", workers=2) as executor:
        run = run_search(search, objective, budget, executor, ...)
"""
from __future__ import annotations

import contextlib
import logging
import os
from concurrent.futures import Executor, Future, ProcessPoolExecutor
from typing import Any, Callable, Iterator

EXECUTORS = ("serial", "process", "dask")


class SerialExecutor(Executor):
    """Runs each call inline at ``submit``; returns an already-finished Future.

    Why: the reference executor (no pickling, easy debugging, exceptions with
    their tracebacks), and the baseline the parallel ones must reproduce.
    """

    def __init__(self) -> None:
        self._shutdown = False

    def submit(self, fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> Future:
        if self._shutdown:
            raise RuntimeError("cannot submit after shutdown")
        future: Future = Future()
        try:
            result = fn(*args, **kwargs)
        except BaseException as exc:  # noqa: BLE001 - delivered through the Future
            future.set_exception(exc)
        else:
            future.set_result(result)
        return future

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        self._shutdown = True


def make_executor(kind: str, workers: int | None = None,
                  scheduler: str | None = None) -> contextlib.AbstractContextManager[Executor]:
    """Context manager yielding an Executor; everything is shut down on exit.

    kind:
      "serial"   in this process, one call at a time.
      "process"  ``ProcessPoolExecutor(workers)``, workers default ``os.cpu_count()``.
      "dask"     ``Client(scheduler).get_executor()``; with no scheduler address, a
                 ``LocalCluster`` of ``workers`` single-threaded worker processes
                 (default ``os.cpu_count()``), closed on exit.  An external
                 cluster's workers must be able to import the objective's module.
    """
    if kind not in EXECUTORS:
        raise ValueError(f"unknown executor {kind!r}; allowed: {', '.join(EXECUTORS)}")
    if workers is not None and int(workers) < 1:
        raise ValueError(f"workers must be at least 1, got {workers!r}")
    return _executor(kind, workers, scheduler)  # bad arguments fail here, not at `with`


@contextlib.contextmanager
def _executor(kind: str, workers: int | None, scheduler: str | None) -> Iterator[Executor]:
    if kind == "serial":
        executor = SerialExecutor()
        try:
            yield executor
        finally:
            executor.shutdown()
    elif kind == "process":
        pool = ProcessPoolExecutor(max_workers=int(workers or os.cpu_count() or 1))
        try:
            yield pool
        finally:
            pool.shutdown(wait=True, cancel_futures=True)
    else:
        yield from _dask(workers, scheduler)


def _dask(workers: int | None, scheduler: str | None) -> Iterator[Executor]:
    try:
        from distributed import Client, LocalCluster  # imported lazily: dask is slow to import
    except ImportError:
        raise RuntimeError("executor 'dask' needs Dask: install the project's dask extra "
                           "(python -m pip install '.[dask]')") from None

    with contextlib.ExitStack() as stack:
        if scheduler:
            client = stack.enter_context(Client(scheduler))
        else:
            cluster = stack.enter_context(LocalCluster(
                n_workers=int(workers or os.cpu_count() or 1), threads_per_worker=1,
                processes=True, dashboard_address=None, silence_logs=logging.ERROR))
            client = stack.enter_context(Client(cluster))
        # pure=False: every submit is its own task; Dask never merges two calls by
        # hashing their arguments (the loop already removes duplicate orders).
        executor = client.get_executor(pure=False)
        try:
            yield executor
        except BaseException:
            executor.shutdown(wait=False)  # cancel what is still queued
            raise
        else:
            executor.shutdown(wait=True)
