"""The searches on the real FMU: failures, and the annealing's temperature checks where the lattice is stiff."""

from __future__ import annotations

import math
from dataclasses import dataclass

import pytest

from orchestrator.design import DesignSpace
from orchestrator.executors import make_executor
from orchestrator.loop import run_search
from orchestrator.objective import FMURun, LatticeObjective
from orchestrator.search import make_search
from orchestrator.types import Order

SPACE = DesignSpace.permutations(11)


@dataclass(frozen=True)
class SometimesDiverging:
    """The real FMU objective, except that orders starting with a material > 6 are run with column C 0.5 m
    inside the plate: the FMU's own divergence check fails them (a real FMI error through FMURun)."""

    good: FMURun
    bad: FMURun

    def __call__(self, order: Order):
        return (self.bad if order[0] > 6 else self.good)(order)


def test_a_search_survives_an_objective_that_fails_for_some_orders(fmu_path):
    good = FMURun(str(fmu_path), horizon=0.5, parameters=(("atol", 1e-7), ("rtol", 1e-5)))
    bad = FMURun(str(fmu_path), horizon=0.5, parameters=(("fixed_step", 0.05), ("solver", "rk4")))
    objective = SometimesDiverging(good, bad)
    for method in ("cmaes", "sa"):
        with make_executor("serial") as executor:
            run = run_search(
                make_search(method, SPACE, seed=1, budget=24), objective, 24, executor, method_name=method, seed=1
            )
        assert run.n_evaluations == 24, run.stop_reason
        failed = [e for e in run.evaluations if not e.ok]
        assert run.failed == len(failed) > 0
        assert all(e.value is None and ("diverged" in e.message or "non-finite" in e.message) for e in failed)
        assert all(e.order[0] > 6 for e in failed) and all(e.order[0] <= 6 for e in run.evaluations if e.ok)
        assert run.best_order[0] <= 6 and math.isfinite(run.best_value)
        assert run.diagnostics["failed_told"] == len(failed)


@pytest.mark.parametrize("t0, verdict", [(1e-6, "too low"), (1e7, "too high")])
def test_annealing_at_a_poor_temperature_is_flagged_on_the_fmu(fmu_path, t0, verdict):
    objective = FMURun(str(fmu_path), horizon=0.5, parameters=(("atol", 1e-7), ("rtol", 1e-5)))
    with make_executor("serial") as executor:
        run = run_search(
            make_search("sa", SPACE, seed=0, budget=48, t0=t0, chains=4, window=10),
            objective,
            48,
            executor,
            method_name="sa",
            seed=0,
        )
    state = run.diagnostics
    assert run.n_evaluations == 48
    assert state["poor_temperature"] and verdict in state["poor_temperature"], state
    assert state["acceptance_rate"] is not None and state["uphill_acceptance_rate"] is not None
    if verdict == "too low":
        assert state["uphill_acceptance_rate"] <= 0.02
    else:
        assert state["uphill_acceptance_rate"] >= 0.9  # it cools by 1e-3 over the budget: still ~1e4 N at the end


def test_annealing_automatic_temperature_is_not_poor_on_the_fmu(fmu_path):
    """The study pipeline's search objective and budget 100: the automatic temperature must not be flagged.

    Found by bench/search_convergence.py: seed 9's T0 (46.6) accepted none of its first 30 worsening moves, and
    the check used to call that T0 too low. At T0 those moves' mean acceptance is about a third; at 100
    evaluations the temperature falls a hundredfold within them, and the large deltas happened to come first.
    The check now judges T0 by the acceptance those moves would have at T0; with the force limit some of them
    are censored, so it bounds that acceptance (a censored move's is known only to be small)."""
    objective = LatticeObjective(fmu_path, SPACE, 8.0)
    with make_executor("serial") as executor:
        run = run_search(make_search("sa", SPACE, 9, budget=100), objective, 100, executor, method_name="sa", seed=9)
    assert run.diagnostics["t0_source"] == "automatic"
    assert run.diagnostics["poor_temperature"] is None, run.diagnostics["poor_temperature"]
    low, high = run.diagnostics["initial_acceptance_at_t0_bounds"]
    assert run.diagnostics["window_censored"] > 0 and 0.02 < low <= high < 0.98
    assert run.diagnostics["initial_uphill_acceptance"] < low  # it cooled


def test_annealing_flags_a_poor_automatic_temperature_on_the_fmu(fmu_path):
    """Seed 2 calibrates on two worsening deltas (0.4 N and 83 N) and gets T0 = 0.45 N, far below the moves it
    meets next: a real failure of the automatic temperature, which the check must report."""
    with make_executor("serial") as executor:
        run = run_search(
            make_search("sa", SPACE, 2, budget=100),
            LatticeObjective(fmu_path, SPACE, 8.0),
            100,
            executor,
            method_name="sa",
            seed=2,
        )
    state = run.diagnostics
    assert state["t0_source"] == "automatic" and state["t0"] < 1.0
    assert state["window_censored"] > 0 and state["initial_acceptance_at_t0_bounds"][1] <= 0.02
    assert state["poor_temperature"] and "too low" in state["poor_temperature"]
