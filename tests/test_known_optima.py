"""The 11 x 8 and 11 x 9 lattices' optima, found by the exhaustive sweep (bench/exhaustive_sweep.py), as test data.

Fast (8 columns; slow for 9): the stored optimum is reproduced by a freshly built FMU at full fidelity, its
search-fidelity value is within the screening bound, and no single swap or insertion improves it.  Slow: the
whole 8-column sweep (40,320 orders) finds it again.
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

DATA = Path(__file__).parent / "data"
KNOWN = json.loads((DATA / "known_optimum_11x8.json").read_text())
COLUMNS = [8, pytest.param(9, marks=pytest.mark.slow)]


def known(columns):
    return json.loads((DATA / f"known_optimum_11x{columns}.json").read_text())


@pytest.fixture(scope="module")
def lattices(tmp_path_factory):
    """Freshly built 11 x C FMUs, one per C, built on first use."""
    built = {}

    def fmu(columns):
        if columns not in built:
            built[columns] = build_fmu.build_fmu(output=tmp_path_factory.mktemp(f"fmu{columns}")
                                                 / f"lattice_11x{columns}.fmu", cols=columns, werror=True)
        return built[columns]
    return fmu


@pytest.fixture(scope="module")
def fmu8(lattices):
    return lattices(8)


def fidelities(fmu, columns=8):
    """(search, full): the objective's one FMU run per order at each fidelity."""
    objective = SampledPeak(fmu, columns, 8.0)
    return objective.tasks(SEARCH)[0], objective.tasks(FULL)[0]


@pytest.mark.parametrize("columns", COLUMNS)
def test_stored_optimum_is_reproduced_at_both_fidelities(lattices, columns):
    data = known(columns)
    order = tuple(data["order"])
    search, full = fidelities(lattices(columns), columns)
    screened, full = search(order), full(order)
    assert screened.ok and full.ok
    assert full.peak == pytest.approx(data["peak_full"], rel=1e-9)
    # the search fidelity's solver may change (it did, DOP853 -> Tsit5); its value stays within the bound
    assert abs(screened.peak / data["peak_full"] - 1) <= data["screening_error"]


@pytest.mark.parametrize("columns", COLUMNS)
def test_stored_optimum_is_locally_optimal(lattices, columns):
    """Every one of its swap and insertion neighbours (70 for 8 columns, 92 for 9) is worse at the search
    fidelity."""
    data = known(columns)
    objective, _ = fidelities(lattices(columns), columns)
    order = tuple(data["order"])
    around = neighbours(order)
    assert len(around) == columns * (columns - 1) // 2 + (columns - 1) ** 2 - (columns - 1)
    values = [objective(o) for o in around]
    assert all(v.ok for v in values)
    best = objective(order)
    assert best.ok and min(v.peak for v in values) > best.peak


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


def test_the_report_s_known_optima_are_the_test_data():
    """orchestrator/known_optima.json (what the report draws) holds the swept optima of tests/data."""
    table = json.loads((Path(__file__).resolve().parents[1] / "orchestrator" / "known_optima.json").read_text())
    for columns in (8, 9):
        stored = known(columns)
        entry = next(e for e in table["optima"] if e["columns"] == columns)
        assert entry["order"] == stored["order"] and entry["peak"] == stored["peak_full"] and entry["proven"]
