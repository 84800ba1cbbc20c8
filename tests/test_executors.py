"""Executors: one seam, identical results whatever runs the work."""

from __future__ import annotations

import os
import time
from concurrent.futures import Executor

import pytest

from orchestrator.executors import EXECUTORS, SerialExecutor, make_executor
from orchestrator.loop import Evaluator, run_search
from orchestrator.search import SEARCHES, make_search
from problems import Flaky, QuadraticAssignment

METHODS = sorted(m for m in SEARCHES if SEARCHES[m].n_objectives == 1)
# Top-level (picklable) objective: fails on some orders, so failures cross processes too.
OBJECTIVE = Flaky(QuadraticAssignment.random(7, 11), period=6, mode="raise")


def runs_with(executor, budget=40, seed=1):
    return {
        m: run_search(make_search(m, 7, seed, budget=budget), OBJECTIVE, budget, executor, method_name=m, seed=seed)
        for m in METHODS
    }


def outcomes(runs):
    return {
        m: (
            [(e.order, e.value, e.status, e.message) for e in r.evaluations],
            r.best_order,
            r.best_value,
            r.failed,
            r.stop_reason,
        )
        for m, r in runs.items()
    }


@pytest.fixture(scope="module")
def serial_outcomes():
    with make_executor("serial") as ex:
        return outcomes(runs_with(ex))


def test_serial_executor_is_an_executor():
    with make_executor("serial") as ex:
        assert isinstance(ex, (Executor, SerialExecutor))
        assert ex.submit(pow, 2, 5).result() == 32
        assert list(ex.map(abs, [-1, -2])) == [1, 2]
        with pytest.raises(ZeroDivisionError):
            ex.submit(divmod, 1, 0).result()
    with pytest.raises(RuntimeError):
        ex.submit(abs, 1)


def test_unknown_executor_lists_allowed():
    with pytest.raises(ValueError) as err:
        make_executor("threads")
    for kind in EXECUTORS:
        assert kind in str(err.value)
    with pytest.raises(ValueError):
        make_executor("process", workers=0)


def test_process_pool_identical_to_serial(serial_outcomes):
    with make_executor("process", workers=2) as ex:
        assert outcomes(runs_with(ex)) == serial_outcomes
        assert any(o[3] for o in serial_outcomes.values())  # failures did cross the process boundary


def test_dask_local_cluster_identical_to_serial(serial_outcomes):
    with make_executor("dask", workers=2) as ex:
        client = ex._client
        assert len(client.scheduler_info()["workers"]) == 2
        assert ex.batch_size > 1  # designs go to the workers in batches
        assert outcomes(runs_with(ex)) == serial_outcomes
    assert client.status == "closed"


def test_dask_calls_through_another_scheduler_go_through_it_and_give_the_same_results(serial_outcomes, tmp_path):
    """A scheduler the run did not start may be the only one that reaches its workers: the calls go through
    it, and an exception raised in a worker reaches the caller as itself."""
    from distributed import LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, dashboard_address=None, local_directory=tmp_path) as cluster:
        with make_executor("dask", scheduler=cluster.scheduler_address) as ex:
            assert not ex._direct
            assert outcomes(runs_with(ex)) == serial_outcomes
            with pytest.raises(ZeroDivisionError):
                ex.submit(divmod, 1, 0).result()


@pytest.mark.skipif(not hasattr(os, "fork"), reason="no fork on this platform")
def test_a_forked_child_does_not_hold_its_parents_fmu_instances(monkeypatch):
    """A forked Dask worker that closed the parent's instances would remove the folder they run from."""
    import multiprocessing

    from orchestrator import objective

    monkeypatch.setitem(objective._INSTANCES, "parent.fmu", object())
    child = multiprocessing.get_context("fork").Process(target=_exit_with_instances_held)
    child.start()
    child.join(timeout=60)
    assert child.exitcode == 0
    assert "parent.fmu" in objective._INSTANCES


def _exit_with_instances_held() -> None:
    from orchestrator import objective

    os._exit(len(objective._INSTANCES))


def test_dask_calls_go_on_when_a_worker_leaves():
    """A worker that leaves the cluster takes its actor with it: the calls go to the workers that remain, and
    every evaluation still has its value."""
    from orchestrator.executors import WORKERS_REFRESH

    orders = [tuple((k + c) % 7 + 1 for c in range(7)) for k in range(7)]
    with make_executor("serial") as serial:
        expected = [e.value for e in Evaluator(serial).evaluate([(OBJECTIVE, o) for o in orders])]
    with make_executor("dask", workers=2) as ex:
        client = ex._client
        evaluator = Evaluator(ex)
        assert [e.value for e in evaluator.evaluate([(OBJECTIVE, o) for o in orders[:3]])] == expected[:3]
        leaving = sorted(client.scheduler_info(n_workers=-1)["workers"])[0]
        client.retire_workers([leaving], close_workers=True, remove=True)
        time.sleep(WORKERS_REFRESH)
        assert [e.value for e in evaluator.evaluate([(OBJECTIVE, o) for o in orders[3:]])] == expected[3:]


class BatchingSerial(SerialExecutor):
    """A serial executor that takes batches, as the Dask one does; it keeps what each submission carried."""

    slots = 2
    batch_size = 4

    def __init__(self) -> None:
        super().__init__()
        self.submitted: list[int] = []

    def submit(self, fn, /, *args, **kwargs):
        task = args[0]
        self.submitted.append(len(getattr(task, "tasks", (task,))))
        return super().submit(fn, *args, **kwargs)


class Lines:
    """A journal in memory: what the evaluator appends."""

    def __init__(self) -> None:
        self.keys: list[str] = []

    def load(self) -> dict:
        return {}

    def append(self, key, result) -> None:
        self.keys.append(key)


def test_batches_are_spread_over_the_workers_and_each_design_is_cached_and_journalled_alone(serial_outcomes):
    executor, journal = BatchingSerial(), Lines()
    evaluator = Evaluator(executor, journal)
    orders = [tuple((k + c) % 7 + 1 for c in range(7)) for k in range(7)]
    first = evaluator.evaluate([(OBJECTIVE, o) for o in orders[:3]])
    assert executor.submitted == [2, 1]  # three designs on two workers
    executor.submitted.clear()
    both = evaluator.evaluate([(OBJECTIVE, o) for o in orders])
    assert executor.submitted == [2, 2]  # the three known ones are cache hits
    assert both[:3] == first and evaluator.cache_hits == 3
    assert len(journal.keys) == len(set(journal.keys)) == 7 and all("batch" not in k for k in journal.keys)
    with make_executor("serial") as serial:
        alone = Evaluator(serial).evaluate([(OBJECTIVE, o) for o in orders])
    assert [(e.order, e.value, e.status, e.message) for e in both] == [
        (e.order, e.value, e.status, e.message) for e in alone
    ]
    executor.submitted.clear()
    evaluator.evaluate([(OBJECTIVE, tuple(reversed(o))) for o in orders] * 3)
    assert executor.submitted == [4, 3]  # duplicates run once; at most batch_size designs a submission
    assert outcomes(runs_with(BatchingSerial())) == serial_outcomes


def exit_on_identity(order):
    """Kills its worker process for the identity order (like a crashing native library)."""
    if tuple(order) == tuple(range(1, len(order) + 1)):
        os._exit(3)
    return float(sum(order))


def test_dead_worker_is_a_failed_evaluation():
    with make_executor("process", workers=2) as ex:
        run = run_search(make_search("sequential", 5, 0), exit_on_identity, 10, ex, method_name="sequential", seed=0)
    assert run.failed == 1 and run.evaluations[0].status == "failed"
    assert "the worker died" in run.evaluations[0].message


def test_a_dead_worker_costs_only_its_order_and_the_pool_is_replaced():
    """Every order in flight when the worker died is tried again alone: only the one that kills its
    worker fails, and the run spends its whole budget."""
    with make_executor("process", workers=2) as ex:
        evaluator = Evaluator(ex)
        run = run_search(
            make_search("random", 5, 0, batch=120), exit_on_identity, 120, evaluator, method_name="random", seed=0
        )
    assert run.n_evaluations == 120 and run.failed == 1, run.stop_reason
    failed = next(e for e in run.evaluations if not e.ok)
    assert failed.order == (1, 2, 3, 4, 5) and "died" in failed.message
    assert all(e.value == 15.0 for e in run.evaluations if e.ok)
    assert evaluator.pool_renewals >= 1


def sleep_on_identity(order):
    """Hangs for the identity order (like a solver that never ends)."""
    import time

    if tuple(order) == tuple(range(1, len(order) + 1)):
        time.sleep(60)
    return float(sum(order))


def test_a_hung_evaluation_is_failed_at_the_time_limit_and_the_run_goes_on():
    with make_executor("process", workers=2) as ex:
        evaluator = Evaluator(ex, time_limit=1.0)
        run = run_search(
            make_search("random", 4, 0, batch=24), sleep_on_identity, 24, evaluator, method_name="random", seed=0
        )
    assert run.n_evaluations == 24 and run.failed == 1
    failed = next(e for e in run.evaluations if not e.ok)
    assert failed.order == (1, 2, 3, 4) and "time limit of 1 s of its own run time" in failed.message
    assert evaluator.timeouts == 1


def touch_then_sleep(path):
    """Says it started (a file), then runs long enough to be asked when it started."""
    import pathlib
    import time

    pathlib.Path(path).touch()
    time.sleep(3)
    return 1


def test_a_task_that_starts_before_submit_returns_still_has_its_start(tmp_path, monkeypatch):
    """The time limit counts from the start the worker reports; a worker quick enough to report it while
    ``submit`` has not yet returned must not lose it (the task would then never time out)."""
    import time

    started = tmp_path / "started"
    with make_executor("process", workers=1) as ex:
        real_submit = ex._pool.submit

        def submit_returning_after_the_start(*args, **kwargs):
            future = real_submit(*args, **kwargs)
            deadline = time.monotonic() + 60
            while not started.exists() and time.monotonic() < deadline:
                time.sleep(0.01)
            time.sleep(0.3)  # the start message read by the pool's reader thread meanwhile
            return future

        monkeypatch.setattr(ex._pool, "submit", submit_returning_after_the_start)
        future = ex.submit(touch_then_sleep, str(started))
        assert started.exists()
        assert ex.started_at(future) is not None
        assert future.result() == 1
