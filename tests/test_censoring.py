"""Censored evaluations (stopped above a force limit) are never a number, anywhere."""

from __future__ import annotations

import json
import math

import pytest

from orchestrator.executors import make_executor
from orchestrator.journal import Journal
from orchestrator.loop import Evaluator, run_search, told_value
from orchestrator.search import make_search
from orchestrator.search.base import FAILURE, to_internal
from problems import LimitedObjective, QuadraticAssignment, brute_force
from orchestrator.types import Above, Evaluation, censored, check_evaluation

pytestmark = pytest.mark.quick  # a first check: python -m pytest -m quick

KINDS = {"evaluation": Evaluation}

QAP = QuadraticAssignment.random(7, 3)


def test_a_censored_evaluation_is_not_a_number():
    evaluation = censored((1, 2, 3), 1500.0, 0.31, 0.002)
    assert not evaluation.ok and evaluation.censored and evaluation.value is None
    assert evaluation.lower_bound == 1500.0 and "above 1500" in evaluation.message
    assert check_evaluation(evaluation, (1, 2, 3)) == evaluation
    smuggled = Evaluation((1, 2, 3), 1.0, "censored", limit=1500.0)
    assert check_evaluation(smuggled, (1, 2, 3)).value is None  # a number sent with it is dropped
    no_limit = Evaluation((1, 2, 3), None, "censored", limit=math.nan)
    assert check_evaluation(no_limit, (1, 2, 3)).status == "failed"
    told = told_value(evaluation)
    assert isinstance(told, Above) and not isinstance(told, float) and to_internal(told) == FAILURE


def test_the_descent_with_limits_finds_the_same_optimum_for_less_and_no_consumer_sees_a_number(tmp_path):
    """The polishing descent asks each neighbour with the current value as its limit. On a cheap problem
    it reaches the known optimum, as it does with full values; censored evaluations stay out of every result.
    (Seed 1: from seed 0 three kicks end at a local optimum with full values too.)"""
    objective = LimitedObjective.of(QAP, 7)
    _, optimum = brute_force(QAP, 7)
    with make_executor("serial") as executor, Journal(tmp_path, {"test": 1}, KINDS) as journal:
        evaluator = Evaluator(executor, journal)
        run = run_search(make_search("local", 7, 1, kicks=3), objective, 400, evaluator, method_name="local", seed=1)
        full = run_search(make_search("local", 7, 1, kicks=3), QAP, 400, executor, method_name="local", seed=1)
    assert run.censored > run.n_evaluations / 2 and run.failed == 0
    assert run.best_value == pytest.approx(optimum) == full.best_value
    assert all(value is not None for value in run.best_so_far()[run.best_index - 1 :])
    assert run.best_value == min(e.value for e in run.evaluations if e.ok)
    assert all(e.value is None for e in run.evaluations if e.censored)
    lines = [json.loads(line) for line in (tmp_path / "journal.jsonl").read_text().splitlines()[1:]]
    assert any(line["result"]["status"] == "censored" and line["result"]["value"] is None for line in lines)
    with Journal(tmp_path, {"test": 1}, KINDS, resume=True) as journal:
        assert all(e.value is None for e in journal.load().values() if e.censored)


def test_the_descent_asks_again_a_neighbour_censored_below_its_current_value():
    """After a kick the current value can be above the limit a neighbour was censored at: that neighbour may be
    better, so it is asked again (the loop evaluates it again), never judged as +inf. A neighbour censored at
    or above the current value is not better: judged for free. A kick onto a censored order asks for it."""
    import numpy as np

    from orchestrator.search.local import Descent, neighbours

    start = (1, 2, 3, 4, 5)
    around = neighbours(start)
    memo = {order: FAILURE for order in around}
    memo[start] = 10.0
    above = {order: 12.0 for order in around}
    above[around[7]] = 5.0  # censored below the current value: unknown whether better
    descent = Descent(np.random.default_rng(0), batch=3)
    descent.start(start, 10.0)
    assert descent.propose(memo, above) == [around[7]] and descent.asked_again == 1
    assert descent.limits([around[7]]) == [10.0]
    descent.update([around[7]], [FAILURE])  # censored again at 10: not better
    above[around[7]] = 10.0
    kicked = descent.propose(memo, {**above, **{o: 20.0 for o in memo if o not in above and o != start}})
    assert len(kicked) == 1 and descent.kicks == 1 and descent.limits(kicked) == [None]
