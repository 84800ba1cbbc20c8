"""The 11 x 8 lattice's optimum, found by the exhaustive sweep (bench/exhaustive_sweep.py), as test data.

Fast: the stored optimum is reproduced by a freshly built 8-column FMU at both fidelities and no single swap
or insertion improves it.  Slow: the whole sweep (40,320 orders) finds it again.
"""
from __future__ import annotations

import json
from pathlib import Path

import pytest

import build_fmu
from orchestrator.executors import make_executor
from orchestrator.exhaustive import run_exhaustive
from orchestrator.search.local import neighbours
from orchestrator.objective import FULL, SEARCH, SampledPeak

KNOWN = json.loads((Path(__file__).parent / "data" / "known_optimum_11x8.json").read_text())


@pytest.fixture(scope="module")
def fmu8(tmp_path_factory):
    return build_fmu.build_fmu(output=tmp_path_factory.mktemp("fmu8") / "lattice_11x8.fmu", cols=8, werror=True)


def fidelities(fmu):
    """(search, full): the objective's one FMU run per order at each fidelity."""
    objective = SampledPeak(fmu, 8, 8.0)
    return objective.tasks(SEARCH)[0], objective.tasks(FULL)[0]


def test_stored_optimum_is_reproduced_at_both_fidelities(fmu8):
    order = tuple(KNOWN["order"])
    search, full = fidelities(fmu8)
    screened, full = search(order), full(order)
    assert screened.ok and full.ok
    assert full.peak == pytest.approx(KNOWN["peak_full"], rel=1e-9)
    # the search fidelity's solver may change (it did, DOP853 -> Tsit5); its value stays within the bound
    assert abs(screened.peak / KNOWN["peak_full"] - 1) <= KNOWN["screening_error"]


def test_stored_optimum_is_locally_optimal(fmu8):
    """Every one of its 70 swap and insertion neighbours is worse at the search fidelity."""
    objective, _ = fidelities(fmu8)
    order = tuple(KNOWN["order"])
    around = neighbours(order)
    assert len(around) == 28 + 49 - 7
    values = [objective(o) for o in around]
    assert all(v.ok for v in values)
    assert min(v.peak for v in values) > screened_peak(objective)


def screened_peak(objective):
    evaluation = objective(tuple(KNOWN["order"]))
    assert evaluation.ok
    return evaluation.peak


@pytest.mark.slow
def test_exhaustive_sweep_finds_the_stored_optimum(fmu8, tmp_path):
    with make_executor("process", workers=2) as executor:
        search, full = fidelities(fmu8)
        result = run_exhaustive(search, 8, executor, tmp_path, 1008, full_objective=full,
                                objective_with_limit=search.with_limit,  # the FMU's peak_force_limit
                                screening_error=KNOWN["screening_error"], full_error=KNOWN["full_error"])
    assert result["orders"] == 40320 and result["failed"] == 0 and result["censored"] > 30000
    assert result["optimum"]["order"] == KNOWN["order"]
    assert result["optimum"]["peak"] == pytest.approx(KNOWN["peak_full"], rel=1e-9)
