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
import itertools
import logging
import multiprocessing
import os
import shutil
import signal
import sys
import tempfile
import threading
import time
from concurrent.futures import Executor, Future, ProcessPoolExecutor
from typing import Any, Callable, Iterator

EXECUTORS = ("serial", "process", "dask")
LOCAL_CLUSTER_START = 120.0  # s a local Dask cluster may take to start all its workers
# The most designs one call to a Dask worker carries; bench.study_costs measures the default study at several
# sizes (its page has the figures).
DASK_BATCH_DESIGNS = 64
CALLS_PER_WORKER = 2  # the evaluator's submissions in flight per worker: one runs while the next waits there
WORKERS_REFRESH = 2.0  # s between two looks for workers that joined or left the cluster
# How many workers a call may lose on a cluster of batch jobs (each a worker that left: its lifetime, a cancelled
# job) before it fails: enough for jobs leaving at their walltime, few enough that a call that kills every
# worker it runs on stops.
JOB_ATTEMPTS = 5
BATCH_VARIABLE = "LATTICE_DASK_BATCH"  # another batch size, for bench.study_costs's measurement of it
# The process pool's start method: unset, the platform's default (spawn on Windows and macOS); set to spawn on
# Linux, the whole test suite runs the way a Windows or macOS user's runs do (every task and argument pickled).
START_METHOD_VARIABLE = "LATTICE_START_METHOD"
# A local cluster runs none of Dask's periodic work a run here does not use, or runs it less often: each wakes a
# thread that takes the interpreter lock from the one running the FMU (in a worker) or handling the calls (in
# this process, where the scheduler and the nannies share the client's event loop). No statistical profiler (it
# samples the worker's threads every few milliseconds for a dashboard a local cluster here does not serve), no
# work stealing (the calls are no Dask tasks), the event loop's health tick and the memory monitor once a second.
# Each process's system monitor samples its CPU, memory, disk and network use twice a second into a history for
# the dashboard; Dask keeps an hour of it, which grows with time whatever the run does: a local cluster here keeps
# LOCAL_MONITOR_SAMPLES samples a quantity (the heartbeats need only the latest).
LOCAL_MONITOR_SAMPLES = 10
LOCAL_WORKER_CONFIG = {
    "distributed.worker.profile.enabled": False,
    "distributed.scheduler.work-stealing": False,
    "distributed.admin.tick.interval": "1s",
    "distributed.worker.memory.monitor-interval": "1s",
    "distributed.admin.system-monitor.log-length": LOCAL_MONITOR_SAMPLES,
}


class SerialExecutor(Executor):
    """Runs each call inline at ``submit``; returns an already-finished Future.

    Why: the reference executor (no pickling, easy debugging, exceptions with
    their tracebacks), and the baseline the parallel ones must reproduce.
    """

    slots = 1

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


def make_executor(
    kind: str,
    workers: int | None = None,
    scheduler: str | None = None,
    temp_root: str | None = None,
    fmus: tuple = (),
    cluster=None,
) -> contextlib.AbstractContextManager[Executor]:
    """Context manager yielding an Executor; everything is shut down on exit.

    kind:
      "serial"   in this process, one call at a time.
      "process"  a ``ResilientProcessPool`` of ``workers`` processes (default ``os.cpu_count()``),
                 replaced when a worker dies; its workers ignore Ctrl-C and die with the main process.
      "dask"     ``Client(scheduler).get_executor()``; with no scheduler address, a
                 ``LocalCluster`` of ``workers`` single-threaded worker processes
                 (default ``os.cpu_count()``), closed on exit.  An external
                 cluster's workers must be able to import the objective's module
                 (the project installed); they need no folder of the client's:
                 each FMU of ``fmus`` (paths) is sent to every worker as bytes
                 (``dask_plugin.ShipFMU``) and the tasks run the worker's copy. With ``cluster`` (a
                 ``cluster.SlurmJobs``), the workers are batch jobs it starts; workers come and go
                 with their jobs, and a call whose worker left waits for another.
    """
    if kind not in EXECUTORS:
        raise ValueError(f"unknown executor {kind!r}; allowed: {', '.join(EXECUTORS)}")
    if workers is not None and int(workers) < 1:
        raise ValueError(f"workers must be at least 1, got {workers!r}")
    if cluster is not None and (kind != "dask" or scheduler):
        raise ValueError("a batch-job cluster needs executor 'dask' and no scheduler address")
    return _executor(kind, workers, scheduler, temp_root, tuple(fmus), cluster)  # bad arguments fail here


def pool_start_method() -> str | None:
    """The start method the process pool uses: ``LATTICE_START_METHOD`` when set, else None (the platform's
    default); an unknown one is refused in one line naming the allowed values."""
    method = os.environ.get(START_METHOD_VARIABLE, "").strip()
    if not method:
        return None
    allowed = multiprocessing.get_all_start_methods()
    if method not in allowed:
        raise ValueError(
            f"{START_METHOD_VARIABLE}={method!r} is not a start method of this platform; allowed: {', '.join(allowed)}"
        )
    return method


_STARTS = None  # in a pool worker: where it tells the main process when each task starts


def _worker_start(temp_root: str | None, parent: int, starts) -> None:
    """Runs first in every pool worker.

    Ctrl-C reaches the whole process group: the main process ends the run, so a worker ignores SIGINT
    (no traceback from each worker). On Linux a worker also dies with the main process, even a killed
    one, so no worker outlives its run; elsewhere (no prctl) the pool's own shutdown and kill apply.
    Extracted FMUs go under the run's temp root, which the main process removes when the run ends.
    """
    global _STARTS
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if sys.platform.startswith("linux"):
        _die_with_parent(parent)
    if temp_root:
        tempfile.tempdir = temp_root
    _STARTS = starts


def _die_with_parent(parent: int) -> None:
    """Linux's parent-death signal (prctl PR_SET_PDEATHSIG), where the C library offers it; nothing elsewhere.
    A parent that died before the signal was set cannot send it: the worker then ends itself."""
    try:
        import ctypes

        ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG, from the loaded C library
    except (ImportError, OSError, AttributeError):  # pragma: no cover - no such C library or call
        return
    if os.getppid() != parent:
        os._exit(1)


def _run_reporting_start(token: int, fn: Callable[..., Any], args: tuple, kwargs: dict) -> Any:
    """Runs one task in a pool worker, first telling the main process it started (and when)."""
    if _STARTS is not None:
        _STARTS.send((token, time.monotonic()))
    return fn(*args, **kwargs)


class ResilientProcessPool(Executor):
    """A ``ProcessPoolExecutor`` that can be replaced when a worker dies or hangs.

    Why: a dead worker breaks a ``ProcessPoolExecutor`` for good (every later ``submit`` raises
    ``BrokenProcessPool``); the evaluator records the evaluations in flight as failed and calls
    ``renew()`` so the run goes on. ``kill()`` ends the workers at once (a hung evaluation, an
    interrupted run): ``shutdown`` alone would wait for them.

    ``started_at(future)`` says when a task started in its worker (``time.monotonic``, one clock for every
    process of the machine), after the worker started and unpickled it: a time limit counts the task's own run
    time, not a spawned worker's start-up (seconds of imports on Windows and macOS) or its time in the queue.
    """

    def __init__(self, workers: int, temp_root: str | None = None) -> None:
        self.slots = int(workers)
        self.temp_root = temp_root
        self._tokens = itertools.count()
        self._pool = self._new_pool()

    def _new_pool(self) -> ProcessPoolExecutor:
        method = pool_start_method()
        context = multiprocessing.get_context(method)
        # Each worker sends (token, start) down one pipe; a message this small is written at once, so
        # workers need no lock (a worker killed holding one would block the others).
        self._starts_in, starts_out = context.Pipe(duplex=False)
        self._starts_out = starts_out
        self._starts: dict[int, float] = {}
        self._live: dict[Future, int] = {}
        self._live_tokens: set[int] = set()
        self._lock = threading.Lock()
        self._starts_open = True
        self._reader = threading.Thread(
            target=self._read_starts,
            args=(self._starts_in, self._starts, self._live_tokens),
            name="lattice-pool-starts",
            daemon=True,
        )
        self._reader.start()
        return ProcessPoolExecutor(
            max_workers=self.slots,
            initializer=_worker_start,
            initargs=(self.temp_root, os.getpid(), starts_out),
            mp_context=context,
        )

    def _read_starts(self, connection, starts: dict[int, float], live: set[int]) -> None:
        while True:
            try:
                message = connection.recv()
            except (EOFError, OSError):
                return
            if message is None:
                return
            token, started = message
            with self._lock:
                if token in live:
                    starts[token] = started

    def _close_starts(self) -> None:
        if not self._starts_open:
            return
        self._starts_open = False
        self._starts_out.send(None)  # the reader's end of the stream
        self._reader.join(timeout=5)
        self._starts_in.close()
        self._starts_out.close()

    def submit(self, fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> Future:
        token = next(self._tokens)
        with self._lock:  # before the task can start: its worker may report the start before submit returns
            self._live_tokens.add(token)
        try:
            future = self._pool.submit(_run_reporting_start, token, fn, args, kwargs)
        except BaseException:
            with self._lock:
                self._live_tokens.discard(token)
                self._starts.pop(token, None)
            raise
        with self._lock:
            self._live[future] = token
        starts, live, tokens, lock = self._starts, self._live, self._live_tokens, self._lock

        def forget(done: Future) -> None:
            with lock:
                done_token = live.pop(done, None)
                if done_token is not None:
                    tokens.discard(done_token)
                    starts.pop(done_token, None)

        future.add_done_callback(forget)
        return future

    def started_at(self, future: Future) -> float | None:
        """When ``future``'s task started in its worker, or None while it waits (or is not this pool's)."""
        with self._lock:
            token = self._live.get(future)
            return None if token is None else self._starts.get(token)

    def kill(self) -> None:
        processes = list((getattr(self._pool, "_processes", None) or {}).values())
        self._pool.shutdown(wait=False, cancel_futures=True)
        for process in processes:
            if process.is_alive():
                process.kill()
        for process in processes:
            process.join(timeout=5)
        self._close_starts()

    def renew(self) -> None:
        self.kill()
        self._pool = self._new_pool()

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        self._pool.shutdown(wait=wait, cancel_futures=cancel_futures)
        if wait:
            self._close_starts()


@contextlib.contextmanager
def _executor(
    kind: str, workers: int | None, scheduler: str | None, temp_root: str | None = None, fmus: tuple = (), cluster=None
) -> Iterator[Executor]:
    if kind == "serial":
        executor = SerialExecutor()
        try:
            yield executor
        finally:
            executor.shutdown()
    elif kind == "process":
        own_root = temp_root is None  # the workers' extracted FMUs go here; a killed worker cannot remove its own
        root = tempfile.mkdtemp(prefix="lattice-workers-") if temp_root is None else temp_root
        pool = ResilientProcessPool(int(workers or os.cpu_count() or 1), root)
        try:
            yield pool
        except BaseException:
            pool.kill()  # an interrupt or an error: no worker outlives the run
            raise
        else:
            pool.shutdown(wait=True)
        finally:
            if own_root:
                shutil.rmtree(root, ignore_errors=True)
    else:
        own_root = temp_root is None and not scheduler and cluster is None
        owned = tempfile.mkdtemp(prefix="lattice-workers-") if own_root else None
        try:
            yield from _dask(workers, scheduler, owned or temp_root, fmus, cluster)
        finally:
            if owned is not None:
                shutil.rmtree(owned, ignore_errors=True)


def _dask(
    workers: int | None, scheduler: str | None, temp_root: str | None, fmus: tuple = (), jobs=None
) -> Iterator[Executor]:
    try:
        import dask  # imported lazily: dask is slow to import
        from distributed import Client, LocalCluster
    except ImportError:
        raise RuntimeError(
            "executor 'dask' needs Dask: install the project's dask extra (python -m pip install '.[dask]')"
        ) from None

    with contextlib.ExitStack() as stack:
        if scheduler:
            client = stack.enter_context(Client(scheduler))
        elif jobs is not None:
            running: list[DaskWorkers] = []  # the executor once it exists: the jobs' scaling asks it what it wants

            def wanted_workers() -> int:
                return running[0].wanted_workers() if running else 0

            client = stack.enter_context(Client(stack.enter_context(jobs.open(wanted_workers))))
            jobs.wait(client)
        else:
            count = int(workers or os.cpu_count() or 1)
            start = {"distributed.worker.multiprocessing-method": dask_start_method()}
            with dask.config.set(LOCAL_WORKER_CONFIG | start):
                cluster = stack.enter_context(
                    LocalCluster(
                        n_workers=count,
                        threads_per_worker=1,
                        processes=True,
                        dashboard_address=None,
                        silence_logs=logging.ERROR,
                        local_directory=temp_root,
                    )
                )
            client = stack.enter_context(Client(cluster))
            try:  # every worker, or none: a cluster half started would run the study at a fraction of its speed
                client.wait_for_workers(count, timeout=LOCAL_CLUSTER_START)
            except TimeoutError:
                raise RuntimeError(
                    f"the local Dask cluster did not start its {count} workers within "
                    f"{LOCAL_CLUSTER_START:g} s; give fewer --workers"
                ) from None
        from .dask_plugin import RunCalls, ShipFMU

        client.register_plugin(RunCalls(), name="lattice-calls")
        for path in fmus:
            plugin = ShipFMU(path)
            client.register_plugin(plugin, name=plugin.plugin_name)  # raises the reason of a worker that cannot run it
        # A scheduler this run starts (a local cluster, the jobs') runs in this process, so this process reaches
        # every worker it reaches: calls go to the workers directly. Another scheduler's workers may be reachable
        # only from it: calls go through it, unless Dask's direct-to-workers setting says otherwise.
        direct = not scheduler or bool(client.direct_to_workers)
        if jobs is None:
            executor = DaskWorkers(client, dask_batch_size(), direct=direct)
        else:  # workers leave with their jobs: a call waits for a worker, and runs again while workers leave
            executor = DaskWorkers(
                client,
                dask_batch_size(),
                direct=direct,
                worker_wait=jobs.job_start,
                attempts=JOB_ATTEMPTS,
                planned_workers=jobs.workers,
            )
            running.append(executor)
        try:
            yield executor
        except BaseException:
            executor.shutdown(wait=False)
            raise
        else:
            executor.shutdown(wait=True)


class DaskWorkers(Executor):
    """Calls on a Dask cluster's workers, each a request to one worker and its reply (``dask_plugin.RunCalls``).

    Why not Dask tasks: a search asks a few designs at a time and waits for them, so what a call costs is its
    round trip; a Dask task goes client, scheduler, worker, scheduler, client, each hop through a batched stream
    that waits a few milliseconds, while a call goes to its worker and back (through the scheduler only when
    the workers may be out of the client's reach). A call goes to the worker with the fewest calls outstanding;
    a call whose worker could not be reached (it died, or left) runs once more on another worker, and the worker
    is dropped. Workers that join are used from the next look (every ``WORKERS_REFRESH`` s).
    """

    def __init__(
        self,
        client,
        batch_size: int = 1,
        worker_wait: float = 0.0,
        attempts: int = 2,
        planned_workers: int = 0,
        direct: bool = True,
    ) -> None:
        """``direct``: calls go to the workers directly, else through the scheduler; ``worker_wait``: seconds a
        call waits for a worker while the cluster has none (its workers' jobs left, others are queued);
        ``attempts``: on how many workers a call may run before its failure is delivered (a worker that could
        not be reached counts); ``planned_workers``: the workers the cluster is scaled to (its most), which the
        evaluator keeps busy although some jobs have not started yet."""
        self._planned = int(planned_workers)
        self._client = client
        self.batch_size = int(batch_size)
        self._worker_wait = float(worker_wait)
        self._attempts = int(attempts)
        self._direct = bool(direct)
        self._lock = threading.Lock()
        self._outstanding: dict[str, int] = {}  # worker address -> its calls outstanding
        self._peak_calls = 0  # the most calls outstanding at once since ``wanted_workers`` last looked
        self._looked = 0.0
        self._shutdown = False
        self._refresh()
        if not self._outstanding:
            raise RuntimeError("the Dask cluster has no worker to run the evaluations")

    @property
    def slots(self) -> int:
        return max(1, len(self._outstanding), self._planned)

    def _refresh(self) -> None:
        """Every worker of the cluster, none that left. It asks the scheduler (through the client's event
        loop), so it runs without the lock: the loop takes the lock when a call returns."""
        workers = set(self._client.scheduler_info(n_workers=-1)["workers"])
        with self._lock:
            self._looked = time.monotonic()
            for address in [a for a in self._outstanding if a not in workers]:
                self._outstanding.pop(address, None)
            for address in workers - set(self._outstanding):
                self._outstanding[address] = 0

    def _take(self, avoid: str | None = None, look: bool = True) -> str:
        """The worker with the fewest calls outstanding (not the one at ``avoid`` while there is another); with
        ``look``, first a look for workers that joined or left when one is due (it asks the scheduler: never
        on the client's event loop)."""
        if look and (time.monotonic() - self._looked > WORKERS_REFRESH or not self._outstanding):
            self._refresh()
        if look and not self._outstanding and self._worker_wait > 0:
            self._await_worker()
        with self._lock:
            choices = [a for a in self._outstanding if a != avoid] or list(self._outstanding)
            if not choices:
                raise RuntimeError("the Dask cluster has no worker left")
            address = min(choices, key=lambda a: (self._outstanding[a], a))
            self._outstanding[address] += 1
            self._peak_calls = max(self._peak_calls, sum(self._outstanding.values()))
            return address

    def wanted_workers(self) -> int:
        """The workers the calls since the last look would keep busy (``CALLS_PER_WORKER`` calls each, at the
        most calls outstanding at once since then): what a cluster of batch jobs scales to."""
        with self._lock:
            peak, self._peak_calls = self._peak_calls, sum(self._outstanding.values())
        return -(-peak // CALLS_PER_WORKER)

    def _give_back(self, address: str, reachable: bool) -> None:
        with self._lock:
            if not reachable:
                self._outstanding.pop(address, None)
            elif address in self._outstanding:
                self._outstanding[address] -= 1

    def _await_worker(self) -> None:
        """Looks for workers until one joined, for up to ``worker_wait`` seconds (not on the event loop)."""
        deadline = time.monotonic() + self._worker_wait
        while not self._outstanding and time.monotonic() < deadline and not self._shutdown:
            time.sleep(WORKERS_REFRESH)
            self._refresh()

    def _call_elsewhere(self, future: Future, avoid: str, payload: bytes, attempt: int) -> None:
        """In a thread of its own: waits for a worker (the cluster may have none a while), then the call runs
        there on the event loop."""
        try:
            address = self._take(avoid=avoid)
        except BaseException as exc:  # noqa: BLE001 - delivered through the Future
            future.set_exception(exc)
            return
        self._client.loop.add_callback(self._call, future, address, payload, attempt)

    async def _call(self, future: Future, address: str, payload: bytes, first_attempt: int = 1) -> None:
        """On the client's event loop: the call, its result into ``future`` (no thread waits for it)."""
        from distributed.protocol import pickle

        from .dask_plugin import CALL_HANDLER

        for attempt in range(first_attempt, self._attempts + 1):
            try:
                if self._direct:
                    answer = await getattr(self._client.rpc(address), CALL_HANDLER)(payload=payload)
                else:
                    answer = await self._client.scheduler.proxy(
                        msg={"op": CALL_HANDLER, "payload": payload}, worker=address
                    )
                if not isinstance(answer, bytes):  # a worker that joined has not set its handler up yet
                    raise ConnectionError(f"Dask worker {address} cannot take calls yet")
            except OSError as exc:
                self._give_back(address, reachable=False)
                if attempt == self._attempts or self._shutdown:
                    future.set_exception(exc)
                    return
                if not self._outstanding and self._worker_wait > 0:
                    threading.Thread(
                        target=self._call_elsewhere,
                        name="lattice-dask-wait",
                        daemon=True,
                        args=(future, address, payload, attempt + 1),
                    ).start()
                    return
                if not self._outstanding:
                    future.set_exception(exc)
                    return
                address = self._take(avoid=address, look=False)
                continue
            except BaseException as exc:  # noqa: BLE001 - delivered through the Future
                self._give_back(address, reachable=True)
                future.set_exception(exc)
                return
            self._give_back(address, reachable=True)
            try:
                succeeded, result = pickle.loads(answer)
            except Exception as exc:  # noqa: BLE001 - a result this process cannot unpickle
                future.set_exception(exc)
                return
            if succeeded:
                future.set_result(result)
            else:
                future.set_exception(result)
            return

    def submit(self, fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> Future:
        if self._shutdown:
            raise RuntimeError("cannot submit after shutdown")
        from distributed.protocol import pickle

        payload = pickle.dumps((fn, args, kwargs))  # here, so that what cannot be pickled fails the submit
        address = self._take()
        future: Future = Future()
        future.set_running_or_notify_cancel()
        self._client.loop.add_callback(self._call, future, address, payload)
        return future

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        self._shutdown = True
        with self._lock:
            self._outstanding.clear()


def dask_start_method() -> str:
    """How a local Dask cluster starts its worker processes: ``LATTICE_START_METHOD`` when set, else ``fork`` on
    Linux (a forked worker has the project imported already; a spawned one imports it afresh, seconds of a short
    study) and ``spawn`` elsewhere (Dask's default; macOS and Windows have no safe fork)."""
    return pool_start_method() or ("fork" if sys.platform.startswith("linux") else "spawn")


def dask_batch_size() -> int:
    """The most designs one call to a Dask worker carries: ``LATTICE_DASK_BATCH`` when set (a positive integer), else
    ``DASK_BATCH_DESIGNS``."""
    given = os.environ.get(BATCH_VARIABLE, "").strip()
    if not given:
        return DASK_BATCH_DESIGNS
    if not given.isdigit() or int(given) < 1:
        raise ValueError(f"{BATCH_VARIABLE}={given!r}: give a positive integer (designs per call to a Dask worker)")
    return int(given)


def executor_batch_size(executor: Executor) -> int:
    """How many short tasks the evaluator may send as one submission (1: each task on its own)."""
    return max(1, int(getattr(executor, "batch_size", 1) or 1))


def executor_slots(executor: Executor) -> int:
    """How many evaluations the executor runs at once (what the evaluator keeps in flight)."""
    slots = getattr(executor, "slots", None)
    if slots:
        return int(slots)
    client = getattr(executor, "_client", None)  # Dask's ClientExecutor
    if client is not None:
        try:
            return max(1, sum(client.nthreads().values()))
        except Exception:  # noqa: BLE001 - a cluster that cannot say: assume a modest one
            return os.cpu_count() or 1
    return getattr(executor, "_max_workers", None) or os.cpu_count() or 1
