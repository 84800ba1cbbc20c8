"""The statistical bound: an extreme-value fit to random designs' values (bench.statistical_bound measures its
coverage where the optimum is known)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

from orchestrator.design import DesignSpace
from orchestrator.executors import make_executor
from orchestrator.loop import Evaluator
from orchestrator.statistical_bound import (
    KIND,
    MIN_DESIGNS,
    default_tail,
    estimate_optimum,
    group_minima,
    tail_bound,
    weibull_bound,
)
from orchestrator.types import Evaluation


def test_group_minima_are_each_groups_smallest_value():
    minima = group_minima([5, 3, 4, 9, 1, 2, 7], 3)
    assert minima.tolist() == [3, 1]


def test_the_location_of_weibull_minima_is_found_and_held():
    from scipy import stats

    # group minima drawn from the law the fit assumes: location 1000, shape 2, scale 30
    minima = stats.weibull_min.rvs(2.0, loc=1000.0, scale=30.0, size=200, random_state=0)
    bound = weibull_bound(minima, group_size=1, confidence=0.95)
    assert bound.lower <= bound.estimate <= bound.best_seen
    assert bound.estimate == pytest.approx(1000.0, abs=4.0)
    assert bound.shape == pytest.approx(2.0, abs=0.3)
    assert bound.holds(1000.0) and not bound.holds(bound.lower - 1.0)
    assert bound.designs == 200 and bound.groups == 200
    assert "not a certificate" in bound.kind


def test_a_higher_confidence_widens_the_interval():
    values = 50.0 + np.random.default_rng(3).gamma(2.0, 1.0, 2000)
    narrow, wide = weibull_bound(values, 50, 0.8), weibull_bound(values, 50, 0.99)
    assert wide.lower < narrow.lower < narrow.best_seen == wide.best_seen


def test_equal_values_give_an_interval_of_one_point():
    bound = weibull_bound([3.0] * 100, 10)
    assert bound.lower == bound.estimate == bound.best_seen == 3.0


@pytest.mark.parametrize(
    "values, size, confidence, message",
    [
        ([1.0] * 100, 10, 1.0, "confidence"),
        ([1.0] * 100, 0, 0.9, "group_size"),
        ([1.0] * 40, 10, 0.9, "at least 5 groups"),
        ([1.0, float("nan")] * 50, 10, 0.9, "finite"),
    ],
)
def test_bad_input_is_refused(values, size, confidence, message):
    with pytest.raises(ValueError, match=message):
        weibull_bound(values, size, confidence)


@dataclass(frozen=True)
class Quadratic:
    """A cheap objective whose optimum over permutations is known: sum of (position - material)^2 plus 10."""

    key = "quadratic"

    def __call__(self, order) -> Evaluation:
        value = 10.0 + float(sum((i + 1 - m) ** 2 for i, m in enumerate(order)))
        return Evaluation(tuple(order), value, "ok")


def test_estimate_optimum_runs_random_designs_through_the_evaluator():
    with make_executor("serial") as executor:
        evaluator = Evaluator(executor)
        bound = estimate_optimum(
            evaluator, Quadratic(), DesignSpace.permutations(6), designs=600, rng=np.random.default_rng(11)
        )
    assert bound.designs == 600 and bound.tail == default_tail(600)
    assert bound.best_seen >= 10.0
    assert bound.lower <= bound.estimate <= bound.best_seen
    assert KIND.startswith("statistical estimate")


def test_the_tail_interval_holds_a_known_minimum_about_as_often_as_its_confidence():
    """Samples from a law whose lower end is known (Weibull, location 50): the 95% interval must hold it in most
    samplings, and be finite and narrow enough to say something."""
    from scipy import stats

    samplings, held, widths = 60, 0, []
    for seed in range(samplings):
        values = stats.weibull_min.rvs(2.0, loc=50.0, scale=5.0, size=400, random_state=seed)
        bound = tail_bound(values, confidence=0.95)
        held += bound.holds(50.0)
        widths.append(bound.best_seen - bound.lower)
        assert bound.lower <= bound.estimate <= bound.best_seen
    assert 0.85 <= held / samplings <= 1.0
    assert np.median(widths) < 5.0  # the law's scale: an interval this wide still says where the end is


def test_the_tail_interval_widens_with_the_confidence_and_the_exponent():
    from scipy import stats

    values = stats.weibull_min.rvs(1.5, loc=10.0, scale=1.0, size=1000, random_state=4)
    narrow, wide = tail_bound(values, 0.8), tail_bound(values, 0.99)
    assert wide.lower < narrow.lower < narrow.best_seen == wide.best_seen
    assert narrow.exponent_upper <= wide.exponent_upper
    assert 1.0 <= narrow.exponent <= narrow.exponent_upper


def test_the_tail_bound_is_never_called_certified():
    values = 100.0 + np.random.default_rng(5).gamma(2.0, 1.0, 500)
    bound = tail_bound(values)
    sentence = bound.text(bound.best_seen, "N")
    assert sentence.startswith("statistical estimate") and "not a certificate" in sentence
    assert "certified" not in sentence and "certified" not in bound.kind
    assert f"within {bound.within(bound.best_seen):.2f} N" in sentence


@pytest.mark.parametrize(
    "values, confidence, tail, message",
    [
        (list(range(MIN_DESIGNS - 1)), 0.95, None, f"at least {MIN_DESIGNS}"),
        (list(range(200)), 1.0, None, "confidence"),
        (list(range(200)), 0.95, 5, "tail must be"),
        (list(range(200)), 0.95, 200, "tail must be"),
        ([1.0] * 30 + list(range(2, 200)), 0.95, 20, "all equal"),
        ([1.0, float("inf")] * 100, 0.95, None, "finite"),
    ],
)
def test_the_tail_bound_refuses_too_few_or_bad_values(values, confidence, tail, message):
    with pytest.raises(ValueError, match=message):
        tail_bound(values, confidence, tail)
