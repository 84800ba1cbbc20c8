"""The evaluation loop: budget, cache, failures, stop reasons, determinism."""

from __future__ import annotations

import math

import pytest

from orchestrator.executors import make_executor
from orchestrator.loop import SearchRun, run_search
from orchestrator.search import SEARCHES, make_search
from orchestrator.search.base import Search
from problems import Flaky, QuadraticAssignment, WeightedDistance
from orchestrator.types import Evaluation, check_evaluation, safe_call

METHODS = sorted(m for m in SEARCHES if SEARCHES[m].n_objectives == 1)
QAP7 = QuadraticAssignment.random(7, 11)


class Counting:
    """Objective that remembers every order it was called with (serial executor only)."""

    def __init__(self, base):
        self.base, self.calls = base, []

    def __call__(self, order):
        self.calls.append(tuple(order))
        return self.base(order)


def run(method, objective, budget, seed=0, n=7, executor="serial", **options):
    with make_executor(executor) as ex:
        search = make_search(method, n, seed, budget=budget, **options)
        return run_search(search, objective, budget, ex, method_name=method, seed=seed)


# ---------------------------------------------------------------- budget and cache
@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("budget", [1, 7, 50])
def test_budget_never_exceeded_and_no_order_evaluated_twice(method, budget):
    objective = Counting(QAP7)
    result = run(method, objective, budget)
    assert len(objective.calls) == result.n_evaluations <= budget
    assert len(set(objective.calls)) == len(objective.calls)  # the cache works
    assert [e.order for e in result.evaluations] == objective.calls
    if method != "sequential":
        assert result.n_evaluations == budget
        assert result.stop_reason.startswith(f"budget of {budget}")
    assert result.best_value == min(e.value for e in result.evaluations)


def test_cache_hits_cost_nothing():
    """Random search on n=4 (24 orders) asks many repeats; only distinct ones are evaluated."""
    objective = Counting(WeightedDistance([2, 4, 1, 3]))
    result = run("random", objective, 20, n=4, batch=16)
    assert result.n_evaluations == 20 == len(set(objective.calls))
    assert result.cache_hits > 0


def test_budget_zero():
    result = run("sa", QAP7, 0)
    assert result.n_evaluations == 0 and result.best_order is None and result.best_value is None


def test_partial_batch_is_not_told():
    """A budget cut mid-population stops the run without telling pycma a partial population."""
    result = run("cmaes", QAP7, 13, popsize=10)
    assert result.n_evaluations == 13
    assert "not told" in result.stop_reason
    assert result.diagnostics["told"] == 10  # the first, complete population only


def test_exhaustion_stops_the_run():
    result = run("random", WeightedDistance([3, 1, 2]), 100, n=3)
    assert result.n_evaluations == 6 and not result.stalled
    assert "every design of the space evaluated (6)" in result.stop_reason


class Stuck(Search):
    """A search that asks the same order forever."""

    name = "stuck"

    def _ask(self):
        return [tuple(range(1, self.n + 1))]

    def _tell(self, orders, values):
        pass


def test_stall_guard():
    with make_executor("serial") as ex:
        result = run_search(Stuck(7, 0), QAP7, 50, ex, method_name="stuck", seed=0, stall_batches=25)
    assert result.stalled and "stalled" in result.stop_reason
    assert result.n_evaluations == 1 and result.batches == 26


class Invalid(Stuck):
    def _ask(self):
        return [(1, 1, 2)]


def test_invalid_order_from_a_search_is_a_bug():
    with make_executor("serial") as ex, pytest.raises(ValueError, match="material 1 is used twice"):
        run_search(Invalid(3, 0), QAP7, 5, ex, method_name="bad", seed=0)


# ---------------------------------------------------------------- failures
@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("mode", ["raise", "nan", "inf", "failed"])
def test_failing_objective_does_not_stop_a_search(method, mode):
    objective = Flaky(QAP7, period=3, mode=mode)
    n = 7
    result = run(method, objective, 60, n=n)
    failures = [e for e in result.evaluations if not e.ok]
    assert result.failed == len(failures)
    if method == "sequential":
        return
    assert result.n_evaluations == 60  # went on to the full budget
    assert result.failed > 5
    for e in failures:
        assert e.value is None and e.status == "failed" and e.message
        assert objective.fails(e.order)
    best = next(e for e in result.evaluations if e.order == result.best_order)
    assert best.ok and math.isfinite(result.best_value) and not objective.fails(best.order)
    if mode == "raise":
        assert "simulated solver failure" in failures[0].message
    if mode in ("nan", "inf"):
        assert "non-finite" in failures[0].message


def test_all_failed():
    result = run("pso", Flaky(QAP7, period=1), 20)
    assert result.failed == 20 and result.best_order is None and result.best_value is None
    assert result.best_so_far() == [None] * 20


# ---------------------------------------------------------------- results
def test_same_seed_identical_run():
    objective = Flaky(QAP7, period=5, mode="nan")
    for method in METHODS:
        a, b = run(method, objective, 80, seed=3), run(method, objective, 80, seed=3)
        assert [(e.order, e.value, e.status, e.message) for e in a.evaluations] == [
            (e.order, e.value, e.status, e.message) for e in b.evaluations
        ]
        assert a.best_order == b.best_order


def test_best_so_far():
    result = run("sa", QAP7, 40)
    curve = result.best_so_far()
    assert len(curve) == 40 and curve[-1] == result.best_value
    assert all(x >= y for x, y in zip(curve, curve[1:]))
    assert curve[result.best_index - 1] == result.best_value


def test_progress_is_called_with_counts():
    seen = []
    with make_executor("serial") as ex:
        result = run_search(
            make_search("random", 6, 0, batch=8),
            QAP7.__class__.random(6, 0),
            20,
            ex,
            method_name="random",
            seed=0,
            progress=seen.append,
        )
    assert seen == list(range(1, result.n_evaluations + 1))


def test_searchrun_is_a_dataclass_with_diagnostics():
    result = run("sa", QAP7, 30)
    assert isinstance(result, SearchRun)
    assert result.method == "sa" and result.seed == 0 and result.budget == 30
    assert result.wall_seconds > 0 and "acceptance_rate" in result.diagnostics


# ---------------------------------------------------------------- safe_call and the guard
def boom(order):
    raise ZeroDivisionError("division by zero in the solver")


def test_safe_call_turns_exceptions_into_failures():
    e = safe_call(boom, [1, 2, 3])
    assert e == Evaluation((1, 2, 3), None, "failed", e.message, e.seconds)
    assert "division by zero in the solver" in e.message and e.seconds >= 0


@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf])
def test_guard_non_finite(value):
    e = check_evaluation(Evaluation((1, 2), value, "ok"), (1, 2))
    assert e.status == "failed" and e.value is None and "non-finite" in e.message


def test_guard_other_cases():
    assert check_evaluation(2, (1, 2)) == Evaluation((1, 2), 2.0, "ok")
    assert check_evaluation("x", (1, 2)).status == "failed"
    assert check_evaluation(Evaluation((2, 1), 1.0, "ok"), (1, 2)).status == "failed"
    assert check_evaluation(Evaluation((1, 2), 5.0, "failed", "bad"), (1, 2)).value is None
    assert check_evaluation(Evaluation((1, 2), 5.0, "weird"), (1, 2)).status == "failed"
    ok = Evaluation((1, 2), 1.5, "ok", values=(1.5, 0.2))
    assert check_evaluation(ok, (1, 2)) is ok
    assert check_evaluation(Evaluation((1, 2), 1.5, "ok", values=(1.5, math.nan)), (1, 2)).status == "failed"
