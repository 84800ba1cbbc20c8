"""Search strategies on cheap deterministic objectives (no FMU, no executor)."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from orchestrator.executors import make_executor
from orchestrator.loop import run_search
from orchestrator.search import SEARCHES, make_search
from orchestrator.search.base import keys_to_order, to_internal
from orchestrator.search.local import Descent, neighbours, order_to_keys, sequential_keys
from orchestrator.search.problems import Flaky, QuadraticAssignment, WeightedDistance, brute_force

METHODS = sorted(SEARCHES)


def drive(search, value, batches):
    """Ask/tell directly (no loop, no cache) and return every asked batch."""
    asked = []
    for _ in range(batches):
        if search.stop():
            break
        orders = search.ask()
        asked.append(orders)
        search.tell(orders, [value(o) for o in orders])
    return asked


def solve(method, objective, n, budget, seed, **options):
    with make_executor("serial") as executor:
        search = make_search(method, n, seed, budget=budget, **options)
        return run_search(search, objective, budget, executor, method_name=method, seed=seed)


# ---------------------------------------------------------------- optimum found
QAP7 = QuadraticAssignment.random(7, 11)
QAP8 = QuadraticAssignment.random(8, 1)
WD8 = WeightedDistance.random(8, 5)


@pytest.fixture(scope="module")
def qap7_optimum():
    (optimum,), value = brute_force(QAP7, 7)
    return optimum, value


@pytest.fixture(scope="module")
def qap8_optimum():
    (optimum,), value = brute_force(QAP8, 8)
    return optimum, value


@pytest.mark.parametrize("method,budget", [("cmaes", 700), ("pso", 500), ("sa", 400), ("ga", 500),
                                           ("de", 500)])
def test_finds_qap7_optimum(method, budget, qap7_optimum):
    optimum, value = qap7_optimum
    found = [solve(method, QAP7, 7, budget, seed) for seed in (0, 1, 2)]
    hits = [r.best_order == optimum for r in found]
    assert sum(hits) >= 2, [(r.best_order, r.best_peak, value) for r in found]
    for r in found:
        assert r.n_evaluations <= budget and r.best_peak >= value - 1e-9


@pytest.mark.parametrize("method,budget", [("cmaes", 700), ("pso", 500), ("sa", 400), ("ga", 500),
                                           ("de", 500)])
def test_core_alone_finds_qap7_optimum(method, budget, qap7_optimum):
    """The same without the polishing phase: the optimiser itself, not only the final descent."""
    optimum, value = qap7_optimum
    found = [solve(method, QAP7, 7, budget, seed, polish=0.0) for seed in (0, 1, 2)]
    assert all(r.diagnostics["phase"] == "search" for r in found)
    assert sum(r.best_order == optimum for r in found) >= 2, [(r.best_peak, value) for r in found]


@pytest.mark.parametrize("method,budget,needed", [("cmaes", 1000, 2), ("pso", 1000, 2), ("sa", 700, 3)])
def test_finds_qap8_optimum(method, budget, needed, qap8_optimum):
    optimum, value = qap8_optimum
    found = [solve(method, QAP8, 8, budget, seed) for seed in (0, 1, 2)]
    assert sum(r.best_order == optimum for r in found) >= needed, [(r.best_peak, value) for r in found]


@pytest.mark.parametrize("method,budget", [("sa", 700)])
def test_finds_weighted_distance_optimum(method, budget):
    found = [solve(method, WD8, 8, budget, seed) for seed in (0, 1, 2)]
    assert sum(r.best_order == WD8.optimum for r in found) >= 2, [r.best_peak for r in found]


def test_random_search_covers_n5_with_budget_120():
    objective = WeightedDistance.random(5, 3)
    run = solve("random", objective, 5, 120, seed=0)
    assert run.best_order == objective.optimum and run.best_peak == 0.0
    assert len({e.order for e in run.evaluations}) == 120


def test_sequential_asks_identity_once():
    run = solve("sequential", WD8, 8, 50, seed=0)
    assert [e.order for e in run.evaluations] == [tuple(range(1, 9))]
    assert run.stop_reason == "the search stopped itself"


# ---------------------------------------------------------------- reproducibility
@pytest.mark.parametrize("method", METHODS)
def test_same_seed_same_asks(method):
    value = QAP7.value
    a = drive(make_search(method, 7, 42, budget=200), value, 30)
    b = drive(make_search(method, 7, 42, budget=200), value, 30)
    c = drive(make_search(method, 7, 43, budget=200), value, 30)
    assert a == b
    if method != "sequential":
        assert a != c


def test_cmaes_unaffected_by_global_numpy_random():
    """pycma uses numpy's global RNG; ours runs it in a private, seeded state."""
    value = QAP7.value
    a = drive(make_search("cmaes", 7, 5), value, 20)
    search = make_search("cmaes", 7, 5)
    b = []
    for _ in range(20):
        np.random.seed(123)  # other code touching the global RNG between calls
        orders = search.ask()
        np.random.random(17)
        b.append(orders)
        search.tell(orders, [value(o) for o in orders])
    assert a == b
    state = np.random.get_state()
    make_search("cmaes", 7, 6).ask()
    assert np.array_equal(np.random.get_state()[1], state[1])  # caller's global state restored


# ---------------------------------------------------------------- failures are never good numbers
@pytest.mark.parametrize("method", [m for m in METHODS if m != "sequential"])
def test_failures_are_worst(method):
    """Every order but a few 'fail'; what is told as None must never become the best."""
    search = make_search(method, 6, 0, budget=300)
    for _ in range(20):
        if search.stop():
            break
        orders = search.ask()
        values = [None if o[0] != 1 else QAP7.value(o + (7,)) for o in orders]
        values = [math.nan if (v is None and k % 2) else v for k, v in enumerate(values)]
        search.tell(orders, values)
    state = search.state()
    assert state["failed_told"] > 0
    if state["best_order"] is not None:
        assert state["best_order"][0] == 1 and math.isfinite(state["best_value"])


def test_internal_failure_value():
    assert to_internal(None) == math.inf and to_internal(math.nan) == math.inf
    assert to_internal(-math.inf) == math.inf and to_internal(3) == 3.0


# ---------------------------------------------------------------- annealing temperature
def test_sa_flags_too_low_fixed_temperature():
    run = solve("sa", QAP8, 8, 300, seed=0, t0=1e-9)
    d = run.diagnostics
    assert d["t0_source"] == "forced"
    assert d["initial_uphill_acceptance"] < 0.02
    assert d["poor_temperature"] and "too low" in d["poor_temperature"]


def test_sa_flags_too_high_fixed_temperature():
    run = solve("sa", QAP8, 8, 300, seed=0, t0=1e9)
    assert "too high" in run.diagnostics["poor_temperature"]


def test_sa_automatic_temperature_is_not_poor():
    for seed in (0, 1, 2):
        d = solve("sa", QAP8, 8, 300, seed=seed).diagnostics
        assert d["t0_source"] == "automatic" and d["t0"] > 0
        assert d["poor_temperature"] is None, d
        assert 0.0 < d["acceptance_rate"] < 1.0
        assert d["temperature"] < d["t0"]  # it cooled


def test_sa_cooling_reaches_final_temperature_at_budget():
    d = solve("sa", QAP8, 8, 300, seed=0, t_final_ratio=1e-2).diagnostics
    # the last, budget-cut batch is never told, so the schedule is a few orders short of its end
    assert d["t0"] * 1e-2 <= d["temperature"] <= d["t0"] * 1e-2 * 1.2


# ---------------------------------------------------------------- baseline start and polishing
def test_order_keys_round_trip():
    rng = np.random.default_rng(0)
    for n in (1, 2, 5, 11):
        order = tuple(int(i) + 1 for i in rng.permutation(n))
        assert keys_to_order(order_to_keys(order)) == order
        assert keys_to_order(order_to_keys(order, n + 2), n) == order
    assert keys_to_order(sequential_keys(7)) == tuple(range(1, 8))


def test_neighbours_are_the_distinct_swaps_and_insertions():
    start = tuple(range(1, 12))
    found = neighbours(start)
    assert len(found) == len(set(found)) == 55 + 100 - 10  # swaps + insertions, adjacent swaps once
    assert start not in found and all(sorted(o) == list(start) for o in found)
    assert all(sum(a != b for a, b in zip(o, start)) >= 2 for o in found)


@pytest.mark.parametrize("method", ["pso", "sa", "ga", "de"])
def test_first_batch_holds_the_sequential_order(method):
    assert make_search(method, 7, 3, budget=100).ask()[0] == tuple(range(1, 8))
    assert tuple(range(1, 8)) not in make_search(method, 7, 3, budget=100, x0="random").ask()


def test_cmaes_first_mean_is_the_sequential_order():
    assert keys_to_order(make_search("cmaes", 7, 3, budget=100).inner.es.mean, 7) == tuple(range(1, 8))


@pytest.mark.parametrize("method,polish", [("cmaes", 0.7), ("pso", 0.7), ("sa", 0.3), ("ga", 0.7),
                                           ("de", 0.7)])
def test_polishing_phase_takes_the_end_of_the_budget(method, polish):
    budget = 300
    run = solve(method, QAP8, 8, budget, seed=0)
    d = run.diagnostics
    start = budget - round(polish * budget)
    assert d["phase"] == "polish" and d["options"]["polish"] == polish
    batch = len(make_search(method, 8, 0, budget=budget).ask())  # the switch waits for a batch to end
    assert start <= d["polish_started_at"] < start + batch
    assert run.n_evaluations == budget and not run.stalled


def test_no_polishing_phase_without_budget_or_with_zero():
    assert solve("cmaes", QAP8, 8, 200, seed=0, polish=0.0).diagnostics["phase"] == "search"
    search = make_search("sa", 7, 0)  # no budget: no end to reserve a share of
    drive(search, QAP7.value, 40)
    assert search.state()["phase"] == "search"
    with pytest.raises(ValueError, match="polish"):
        make_search("pso", 7, 0, polish=1.5)


def test_annealing_cools_until_the_polishing_phase():
    d = solve("sa", QAP8, 8, 300, seed=0, polish=0.5).diagnostics
    assert d["anneal_budget"] == 150
    assert d["temperature"] == pytest.approx(d["t0"] * 1e-3)


def test_descent_ends_in_a_local_optimum_then_kicks():
    """Polishing alone (polish=1) with a budget to spare: the best order has no better neighbour,
    and the descent goes on from kicks instead of stalling."""
    run = solve("sa", QAP8, 8, 1500, seed=1, polish=1.0)
    d = run.diagnostics
    assert d["polish_started_at"] <= 4 and d["polish_state"]["local_optima"] >= 2
    assert d["polish_state"]["kicks"] >= 1 and run.n_evaluations == 1500 and not run.stalled
    assert all(QAP8.value(o) >= run.best_peak for o in neighbours(run.best_order))


def test_descent_judges_known_neighbours_for_free():
    descent = Descent(np.random.default_rng(0), batch=3)
    start = (1, 2, 3, 4, 5)
    memo = {order: 20.0 for order in neighbours(start)}  # every neighbour known and worse ...
    memo[start] = 10.0
    better = neighbours(start)[5]
    memo[better] = 1.0  # ... but one: the descent moves there without asking anything
    descent.start(start, 10.0)
    asked = descent.propose(memo)
    assert descent.current == better and descent.free_moves == 1
    assert len(asked) == 3 and better not in asked and not set(asked) & set(memo)


# ---------------------------------------------------------------- protocol and options
def test_unknown_search_name_lists_allowed():
    with pytest.raises(ValueError) as err:
        make_search("genetic", 5, 0)
    for name in ("cmaes", "pso", "sa", "random", "sequential"):
        assert name in str(err.value)


def test_unknown_option_lists_allowed():
    with pytest.raises(ValueError, match="chains"):
        make_search("sa", 5, 0, chain=3)


@pytest.mark.parametrize("method", METHODS)
def test_every_search_accepts_budget_and_reports_state(method):
    search = make_search(method, 5, 0, budget=10)
    orders = search.ask()
    assert orders and all(sorted(o) == [1, 2, 3, 4, 5] for o in orders)
    search.tell(orders, [1.0] * len(orders))
    state = search.state()
    assert state["search"] == method == search.name
    json.dumps(state)  # diagnostics go straight into results.json


def test_tell_must_match_ask():
    search = make_search("random", 5, 0)
    with pytest.raises(RuntimeError):
        search.tell([(1, 2, 3, 4, 5)], [1.0])
    orders = search.ask()
    with pytest.raises(ValueError):
        search.tell(orders[::-1] if len(set(orders)) > 1 else [], [1.0] * len(orders))
    with pytest.raises(ValueError):
        search.tell(orders, [1.0])


def test_options_change_batch_sizes():
    assert len(make_search("cmaes", 8, 0, popsize=6).ask()) == 6
    assert len(make_search("pso", 8, 0, swarm=7).ask()) == 7
    assert len(make_search("sa", 8, 0, chains=3).ask()) == 3
    assert len(make_search("random", 8, 0, batch=5).ask()) == 5
    assert len(make_search("ga", 8, 0, pop_size=6).ask()) == 6
    assert len(make_search("de", 8, 0, pop_size=7).ask()) == 7


def test_keys_to_order_is_argsort_plus_one():
    assert keys_to_order(np.array([0.3, 0.1, 0.2])) == (2, 3, 1)
    assert keys_to_order(np.array([0.5, 0.5, 0.1])) == (3, 1, 2)  # stable on ties


@pytest.mark.parametrize("method", METHODS)
def test_tiny_n(method):
    for n in (1, 2):
        run = solve(method, WeightedDistance(list(range(n, 0, -1))), n, 10, seed=0)
        assert run.n_evaluations <= math.factorial(n) and not run.stalled
        if method != "sequential":
            assert run.best_peak == 0.0


# ---------------------------------------------------------------- pymoo's GA and DE
@pytest.mark.parametrize("method", ["ga", "de"])
@pytest.mark.parametrize("executor", ["serial", "process"])
def test_pymoo_searches_never_exceed_the_budget_and_keep_failures_out(method, executor):
    """Through the loop, with a third of the orders failing: the budget holds, every failure is
    recorded as failed, and the best is a real value; the run is the same on a process pool."""
    objective = Flaky(QAP7, period=3, mode="raise")
    with make_executor(executor, workers=2) as pool:
        run = run_search(make_search(method, 7, 4, budget=137), objective, 137, pool,
                         method_name=method, seed=4)
    assert run.n_evaluations == 137 and run.n_failed > 20
    assert all(e.peak is None for e in run.evaluations if not e.ok)
    assert not objective.fails(run.best_order) and run.best_peak == QAP7.value(run.best_order)
    assert run.outcome() == solve_flaky(method, objective).outcome()


def solve_flaky(method, objective):
    with make_executor("serial") as executor:
        return run_search(make_search(method, 7, 4, budget=137), objective, 137, executor,
                          method_name=method, seed=4)


def test_ga_restarts_when_its_population_only_repeats_known_orders():
    """n = 3 has 6 orders: the GA soon asks only known ones and restarts instead of stalling."""
    search = make_search("ga", 3, 0, pop_size=4, stagnation=2, polish=0.0)
    drive(search, lambda o: float(o[0]), 30)
    assert search.state()["restarts"] >= 1 and search.best_order[0] == 1


def test_pymoo_options_are_checked():
    with pytest.raises(ValueError, match="variant"):
        make_search("de", 5, 0, variant="DE/rand/9/bin")
    with pytest.raises(ValueError, match="x0"):
        make_search("ga", 5, 0, x0="middle")
    with pytest.raises(ValueError, match="pop_size"):
        make_search("ga", 5, 0, pop_size=1)
