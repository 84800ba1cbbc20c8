"""The one Evaluator: cache, journal, time limits on an evaluation's own run time, dead workers, lazy tasks."""

from __future__ import annotations

import os
import time
from dataclasses import dataclass

import pytest

from orchestrator.executors import make_executor
from orchestrator.journal import Journal
from orchestrator.loop import Evaluator
from orchestrator.tasks import EvaluateDesign
from orchestrator.types import Evaluation, failed

KINDS = {"evaluation": Evaluation}


@dataclass(frozen=True)
class Sleep:
    """An evaluation function that takes ``seconds`` of its own run time (``key``: what it computes)."""

    seconds: float

    @property
    def key(self) -> str:
        return f"sleep={self.seconds!r}"

    def __call__(self, order):
        time.sleep(self.seconds)
        return Evaluation(tuple(order), float(sum(order)), "ok")


@dataclass(frozen=True)
class Dies:
    """Kills its worker for one design, answers the others."""

    fatal: tuple

    @property
    def key(self) -> str:
        return f"dies={self.fatal}"

    def __call__(self, order):
        if tuple(order) == self.fatal:
            os._exit(1)
        return Evaluation(tuple(order), 1.0, "ok")


def tasks(function, orders):
    return [EvaluateDesign(function, order) for order in orders]


def test_the_time_limit_counts_an_evaluations_own_run_time_not_its_queue(tmp_path):
    """One worker, two evaluations in flight: the second waits 0.4 s in the queue, then runs 0.4 s."""
    with make_executor("process", workers=1) as executor:
        evaluator = Evaluator(executor, time_limit=0.7)
        results = evaluator.run(tasks(Sleep(0.4), [(1, 2), (2, 1), (1, 3), (3, 1)]))
    assert [r.status for r in results] == ["ok"] * 4
    assert evaluator.timeouts == 0


def test_a_time_out_fails_the_evaluation_is_not_journalled_and_runs_again_on_resume(tmp_path):
    settings = {"run": 1}
    with make_executor("process", workers=1) as executor, Journal(tmp_path, settings, KINDS) as journal:
        evaluator = Evaluator(executor, journal, time_limit=0.3)
        slow, quick = evaluator.run(tasks(Sleep(1.0), [(1, 2)]) + tasks(Sleep(0.0), [(2, 1)]))
    assert slow.status == "failed" and "time limit of 0.3 s of its own run time" in slow.message
    assert quick.ok and evaluator.timeouts == 1
    with make_executor("process", workers=1) as executor, Journal(tmp_path, settings, KINDS, resume=True) as journal:
        evaluator = Evaluator(executor, journal, time_limit=5.0)  # a larger limit: the time-out runs again
        assert evaluator.resumed == 1
        slow, quick = evaluator.run(tasks(Sleep(1.0), [(1, 2)]) + tasks(Sleep(0.0), [(2, 1)]))
    assert slow.ok and quick.ok and evaluator.simulated == 1 and evaluator.cache_hits == 1


def test_a_dead_worker_costs_only_the_task_that_killed_it():
    orders = [(1, 2, 3), (3, 2, 1), (2, 1, 3), (1, 3, 2), (2, 3, 1)]
    with make_executor("process", workers=2) as executor:
        evaluator = Evaluator(executor, time_limit=30)
        results = evaluator.run(tasks(Dies((2, 1, 3)), orders))
    assert [r.ok for r in results] == [True, True, False, True, True]
    assert "the worker died running this task twice" in results[2].message
    assert evaluator.pool_renewals >= 1


def test_each_key_is_computed_once_and_journalled_once(tmp_path):
    calls = []

    @dataclass(frozen=True)
    class Counted:
        @property
        def key(self):
            return "counted"

        def __call__(self, order):
            calls.append(order)
            return Evaluation(tuple(order), 1.0, "ok")

    with make_executor("serial") as executor, Journal(tmp_path, {}, KINDS) as journal:
        evaluator = Evaluator(executor, journal)
        evaluator.run(tasks(Counted(), [(1, 2), (1, 2), (2, 1)]))
        evaluator.run(tasks(Counted(), [(2, 1), (1, 2)]))
    assert calls == [(1, 2), (2, 1)]
    lines = (tmp_path / "journal.jsonl").read_text().splitlines()
    assert len(lines) == 3  # the header and one line per key


def test_tasks_are_pulled_as_workers_free_so_later_ones_see_earlier_results():
    seen = []

    def lazy():
        for k in range(6):
            yield EvaluateDesign(Sleep(0.0), (k, k + 1))

    with make_executor("serial") as executor:
        evaluator = Evaluator(executor)
        results = evaluator.run(lazy(), on_result=lambda index, result: seen.append(index))
    assert sorted(seen) == list(range(6)) and [r.value for r in results] == [2 * k + 1 for k in range(6)]


def test_a_task_that_raises_is_its_own_failure_and_the_run_goes_on():
    class Raises:
        key = "raises"

        def __call__(self, order):
            raise RuntimeError("the FMU refused")

    with make_executor("serial") as executor:
        (result,) = Evaluator(executor).run(tasks(Raises(), [(1, 2)]))
    assert result == failed((1, 2), "RuntimeError: the FMU refused", result.seconds)


@pytest.mark.parametrize("limit", [0, -1, float("nan"), float("inf")])
def test_a_bad_time_limit_is_refused(limit):
    with pytest.raises(ValueError, match="time_limit must be a finite number of seconds > 0"):
        Evaluator(None, time_limit=limit)
