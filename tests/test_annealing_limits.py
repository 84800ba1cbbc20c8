"""The annealing's force limit: each move is asked with its Metropolis threshold (the uniform drawn first), and
a censored value is a rejection, never a number."""

from __future__ import annotations

import math

import numpy as np
import pytest

from orchestrator.search import make_search
from orchestrator.search.annealing import Annealing, metropolis_threshold
from orchestrator.search.base import FAILURE
from orchestrator.types import Above
from problems import QuadraticAssignment, designs_of, search_run

pytestmark = pytest.mark.quick  # a first check: python -m pytest -m quick

QAP8 = QuadraticAssignment.random(8, 1)


def record_steps(monkeypatch) -> list[tuple]:
    """Every decided step of every Annealing: (chain, order, chain value before, threshold, accepted)."""
    steps: list[tuple] = []
    original = Annealing._step

    def recorded(self, c, order, value, threshold, **kwargs):
        before = (self.current[c], self.current_value[c])
        decided = original(self, c, order, value, threshold, **kwargs)
        if decided:
            steps.append((c, order, before[1], threshold, self.current[c] == order and before[0] != order))
        return decided

    monkeypatch.setattr(Annealing, "_step", recorded)
    return steps


HONOURING, IGNORING = True, False  # evaluations stop above the limit asked (like the FMU's peak_force_limit), or
# every one runs to the end: full values, whatever the limit


def anneal(honour_limits: bool, seed: int, budget: int = 300, **options):
    return search_run(make_search("sa", 8, seed, budget=budget, **options), QAP8, budget, honour_limits=honour_limits)


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_the_same_decisions_whether_or_not_the_evaluator_honours_the_limits(monkeypatch, seed):
    """The key test: same seed, same steps (every chain's accepted order and threshold), same distinct orders
    evaluated and the same best, with censored values in one run and full values in the other. (The
    annealing alone: in the polishing phase, local.Descent after a kick judges a neighbour censored below its
    new current value as not better, which full values can contradict.)"""
    steps = record_steps(monkeypatch)
    limited = anneal(HONOURING, seed, polish=0.0)
    limited_steps = list(steps)
    steps.clear()
    full = anneal(IGNORING, seed, polish=0.0)
    assert limited.censored > 100 and full.censored == 0
    assert limited_steps == steps and len(steps) > 200
    assert designs_of(limited) == [e.order for e in full.evaluations]
    assert (limited.best_order, limited.best_value) == (full.best_order, full.best_value)


def check_metropolis_decisions(steps: list[tuple], result) -> None:
    """Each step accepts exactly when the true value is at most the current value or below the threshold
    (current - T ln u), and no told move was left undecided."""
    assert result.diagnostics["undecided"] == 0
    worse_rejected = 0
    for _, order, current, threshold, accepted in steps:
        value = QAP8.value(order)
        if math.isfinite(current):
            assert accepted == (value <= current or value < threshold), (order, value, current, threshold)
            worse_rejected += value > current and not accepted
    assert worse_rejected > 100


def test_every_decision_is_the_metropolis_decision_on_the_true_value(monkeypatch):
    steps = record_steps(monkeypatch)
    result = anneal(HONOURING, 5, polish=0.0)
    assert result.censored > 100 and result.reevaluated > 0
    check_metropolis_decisions(steps, result)


def test_a_limit_below_the_threshold_is_caught(monkeypatch):
    """The check above must fail if limits() gave less than the Metropolis threshold: a move whose value lies
    between that limit and the threshold comes back censored and is not accepted as it should be."""
    monkeypatch.setattr(
        Annealing,
        "_limit",
        lambda self, c, threshold: (
            None if not math.isfinite(threshold) else threshold - 0.05 * (threshold - self.current_value[c])
        ),
    )
    steps = record_steps(monkeypatch)
    result = anneal(HONOURING, 5, polish=0.0)
    with pytest.raises(AssertionError):
        check_metropolis_decisions(steps, result)


def test_each_asked_limit_is_at_least_the_threshold_of_its_proposal():
    """Drive the search directly: every move's limit is >= current - T ln u of the uniform drawn for it, and
    an order known above a bound is asked again only with a higher limit (or none)."""
    search = Annealing(6, 3, budget=400, chains=4)
    value = QuadraticAssignment.random(6, 2).value
    asked_again = 0
    for _ in range(150):
        if search.stop():
            break
        orders = search.ask()
        limits = search.limits()
        for c, (proposal, limit) in enumerate(zip(search._proposals, limits)):
            assert proposal.order == orders[c]
            if proposal.kind == "move" and proposal.temperature is not None and limit is not None:
                current = search.current_value[c]
                assert limit >= current - proposal.temperature * math.log(proposal.u)
            if proposal.order in search.above and (limit is None or limit > search.above[proposal.order]):
                asked_again += 1  # the loop evaluates it again (a limit at or below the bound: answered as known)
        search.tell(
            orders,
            [Above(limit) if limit is not None and value(o) > limit else value(o) for o, limit in zip(orders, limits)],
        )
    assert asked_again > 0 and search.n_censored > 50 and search.undecided == 0


def test_metropolis_threshold():
    rng = np.random.default_rng(0)
    current, temperature = 100.0, 7.0
    for u in rng.random(2000):
        threshold = metropolis_threshold(current, temperature, u)
        for delta in (0.5, 3.0, 20.0):
            # the rule it replaces: accept a worsening move iff u < exp(-delta / T)
            assert (current + delta < threshold) == (u < math.exp(-delta / temperature)) or abs(
                u - math.exp(-delta / temperature)
            ) < 1e-12
    assert metropolis_threshold(current, temperature, 0.0) == math.inf  # -ln 0: every value accepted
    assert metropolis_threshold(current, 0.0, 0.5) == current  # T = 0: greedy
    assert metropolis_threshold(current, None, None) == current  # calibrating: greedy
    assert metropolis_threshold(FAILURE, temperature, 0.5) == math.inf  # a failed current: any real value


# ---------------------------------------------------------------- a censored value is never a number
def test_censored_values_never_reach_the_temperature_calibration():
    """Censored values fed while T0 is calibrated are rejections: no delta comes from them."""
    search = Annealing(7, 0, budget=200, chains=4)
    value = QuadraticAssignment.random(7, 3).value
    orders = search.ask()
    search.tell(orders, [value(o) for o in orders])  # the chains' starts
    for _ in range(5):
        orders = search.ask()
        assert search.limits() == [None] * 4  # calibration steps are asked for their exact values
        search.tell(orders, [Above(1e-9)] * len(orders))
    state = search.state()
    # the only deltas are those of free steps onto orders whose exact values are known; none from a censored one
    assert search.t0 is None and len(search.deltas) == search.free_steps == state["calibration_deltas"]
    assert search.accepted <= search.free_steps and search.steps == 20 + search.free_steps
    assert state["censored_told"] == 20 and state["chain_values"] == [value(o) for o in search.current]
    while search.t0 is None:
        orders = search.ask()
        search.tell(orders, [value(o) for o in orders])
    assert search.t0 > 0 and all(math.isfinite(d) and abs(d) < 1e6 for d in search.deltas)


@pytest.mark.parametrize("t0, verdict", [(1e-6, "too low"), (1e9, "too high")])
def test_the_temperature_check_bounds_censored_moves_and_still_flags(t0, verdict):
    """A forced T0 far too low: the worsening moves come back censored, each known only to be accepted at T0
    with probability below poor_low / 2, and the check still says too low; far too high: nothing is
    censored and it says too high. Same verdict when the evaluator ignores the limits."""
    for honour_limits in (HONOURING, IGNORING):
        state = anneal(honour_limits, 0, budget=200, t0=t0).diagnostics
        low, high = state["initial_acceptance_at_t0_bounds"]
        assert 0.0 <= low <= high <= 1.0
        assert state["poor_temperature"] and verdict in state["poor_temperature"], state
        if verdict == "too low":
            assert state["window_censored"] > 0 and high <= 0.02 and state["initial_acceptance_at_t0"] is None
            assert "censored" in state["poor_temperature"]
        else:
            assert state["window_censored"] == 0 and low >= 0.98
    assert honouring_censors_some(anneal(HONOURING, 0, budget=200, t0=1e-6))


def honouring_censors_some(result) -> bool:
    return result.censored > 0 and all(e.value is None for e in result.evaluations if e.censored)


def test_a_censored_order_met_again_below_a_higher_threshold_is_evaluated_again():
    """Censored at L1, proposed again from a chain whose threshold is above L1: not decided on what is known, so
    evaluated again with the higher limit; the loop logs it but does not charge the budget."""
    result = anneal(HONOURING, 2, budget=300, polish=0.0)
    assert result.reevaluated > 0
    assert len(designs_of(result)) == 300 == result.n_evaluations - result.reevaluated
    first: dict = {}
    for evaluation in result.evaluations:
        if evaluation.order in first:
            earlier = first[evaluation.order]
            assert earlier.censored  # only a censored design is evaluated again ...
            assert not evaluation.censored or evaluation.limit > earlier.limit  # ... with a higher limit
        first[evaluation.order] = evaluation
    assert result.diagnostics["reevaluations"] >= result.reevaluated


def test_a_kick_onto_a_censored_order_gets_its_value():
    """A kick is taken whatever the value, so it is asked with no limit: a censored order is evaluated again
    and the chain holds its real value, never a bound."""
    search = Annealing(5, 0, budget=100, chains=1, max_free=1, kick=1, t0=5.0)
    value = QuadraticAssignment.random(5, 4).value
    orders = search.ask()
    search.tell(orders, [value(o) for o in orders])
    search.above[(5, 4, 3, 2, 1)] = 1e9  # as if censored earlier at 1e9: every move there is a free rejection
    search.memo[(5, 4, 3, 2, 1)] = FAILURE
    search._neighbour = lambda order: (5, 4, 3, 2, 1)  # every proposal and the kick land there
    orders = search.ask()
    assert search._proposals[0].kind == "kick" and search.limits() == [None]
    search.tell(orders, [value(orders[0])])
    assert search.current_value[0] == value((5, 4, 3, 2, 1)) and (5, 4, 3, 2, 1) not in search.above


def test_use_limits_false_asks_for_exact_values():
    search = make_search("sa", 8, 0, budget=200, use_limits=False, polish=0.0)
    value = QAP8.value
    for _ in range(30):
        orders = search.ask()
        assert all(limit is None for limit in search.limits())
        search.tell(orders, [value(o) for o in orders])
    assert anneal(HONOURING, 0, budget=200, use_limits=False, polish=0.0).censored == 0
    with pytest.raises(ValueError, match="use_limits must be True or False"):
        make_search("sa", 8, 0, use_limits="no")


def test_on_the_fmu_the_limit_saves_right_hand_sides_and_changes_no_decision(fmu_path):
    """The study's search objective with and without the FMU's peak_force_limit: the same orders evaluated and
    the same best for the annealing with its polishing phase (100 evaluations: no kick yet), and fewer
    right-hand sides than without limits, and than with limits in the polishing phase only (use_limits=False:
    how the annealing ran before)."""
    from orchestrator.executors import make_executor
    from orchestrator.loop import run_search
    from orchestrator.design import DesignSpace
    from orchestrator.objective import LatticeObjective

    runs = {}
    for name, objective_limits, search_limits in (
        ("limited", True, True),
        ("full", False, True),
        ("polish only", True, False),
    ):
        with make_executor("serial") as executor:
            runs[name] = run_search(
                make_search("sa", 11, 0, budget=100, use_limits=search_limits),
                LatticeObjective(fmu_path, DesignSpace(11, 11), 8.0, use_limits=objective_limits),
                100,
                executor,
                method_name="sa",
                seed=0,
            )
    limited, full = runs["limited"], runs["full"]
    assert limited.censored > runs["polish only"].censored > 0 == full.censored
    assert limited.failed == full.failed == 0
    assert list(dict.fromkeys(e.order for e in limited.evaluations)) == [e.order for e in full.evaluations]
    assert (limited.best_order, limited.best_value) == (full.best_order, full.best_value)
    assert limited.diagnostics["censored_told"] > 0 and limited.diagnostics["phase"] == "polish"
    rhs = {name: sum(e.work or 0 for e in r.evaluations) for name, r in runs.items()}
    assert rhs["limited"] < 0.9 * rhs["polish only"] and rhs["limited"] < 0.75 * rhs["full"], rhs
