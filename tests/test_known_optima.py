"""The known optima (orchestrator/known_optima.json): each one reproduced by a freshly built FMU, locally
optimal, and the table's certified 11 x 11 entry is the one the project's whole sweep gave.

Fast for 8 columns; slow for 9 columns and for the whole 8-column sweep, which certifies its optimum again.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from orchestrator import run as cli
from orchestrator.design import DesignSpace
from orchestrator.executors import make_executor
from orchestrator.known_optima import known_optima
from orchestrator.loop import Evaluator
from orchestrator.objective import FULL, SEARCH, LatticeObjective

DATA = Path(__file__).parent / "data"
COLUMNS = [8, pytest.param(9, marks=pytest.mark.slow)]
SCREENING_ERROR = 1e-4


def stored(columns):
    return json.loads((DATA / f"known_optimum_11x{columns}.json").read_text())


def objective(fmu, columns):
    return LatticeObjective(fmu, DesignSpace.permutations(columns), 8.0)


@pytest.mark.parametrize("columns", COLUMNS)
def test_a_known_optimum_is_reproduced_and_locally_optimal(armour_fmu_of_width, columns):
    data = stored(columns)
    order = tuple(data["order"])
    lattice = objective(armour_fmu_of_width(columns), columns)
    space = lattice.space
    with make_executor("process", workers=2) as executor:
        evaluator = Evaluator(executor)
        (full,) = lattice.evaluate([order], evaluator, FULL)
        around = space.neighbour_list(order)
        values = lattice.evaluate([order] + around, evaluator, SEARCH)
    assert full.value == pytest.approx(data["peak_full"], rel=1e-6)  # the accuracy the FMU promises
    assert abs(values[0].value / full.value - 1) <= SCREENING_ERROR
    assert all(v.ok for v in values) and min(v.value for v in values[1:]) > values[0].value


@pytest.mark.parametrize("rule", ["receiver", "mean"])
def test_a_certified_11x11_optimum_and_its_runner_up_are_reproduced_and_the_optimum_is_locally_optimal(fmu_path, rule):
    """The certified entries, each swept once on a cluster, checked on every run of the suite by a freshly built
    FMU: the optimum's and the runner-up's peaks at the FMU's default accuracy, and no swap of two columns
    better at the searches' fidelity."""
    eleven = next(k for k in known_optima() if (k.rows, k.columns, k.diagonal_rule) == (11, 11, rule))
    assert eleven.certified and eleven.runner_up_peak > eleven.peak
    lattice = objective(fmu_path, 11).with_parameters(diagonal_rule=rule)
    around = lattice.space.neighbour_list(eleven.order)
    with make_executor("process", workers=2) as executor:
        evaluator = Evaluator(executor)
        full = lattice.evaluate([eleven.order, eleven.runner_up], evaluator, FULL)
        values = lattice.evaluate([eleven.order] + around, evaluator, SEARCH)
    assert [f.value for f in full] == pytest.approx([eleven.peak, eleven.runner_up_peak], rel=1e-6)
    assert all(v.ok for v in values) and min(v.value for v in values[1:]) > values[0].value


def test_the_table_holds_the_test_data_and_the_certified_sweep():
    table = {(k.rows, k.columns): k for k in known_optima() if k.diagonal_rule == "receiver"}
    for columns in (8, 9):
        data = stored(columns)
        assert list(table[(11, columns)].order) == data["order"]
        assert table[(11, columns)].peak == data["peak_full"]
    eleven = table[(11, 11)]
    assert eleven.certified and eleven.order == (1, 10, 9, 6, 4, 5, 7, 8, 3, 2, 11)
    assert eleven.runner_up == (1, 10, 9, 6, 5, 4, 7, 8, 3, 2, 11) and eleven.runner_up_peak > eleven.peak


@pytest.mark.slow
def test_the_whole_8_column_sweep_certifies_the_known_optimum(armour_fmu_of_width, tmp_path, capfd):
    out = tmp_path / "sweep8"
    code = cli.main(
        [
            "--fmu",
            str(armour_fmu_of_width(8)),
            "--cols",
            "8",
            "--out",
            str(out),
            "--method",
            "exhaustive",
            "cmaes",
            "--budget",
            "300",
            "--repeats",
            "1",
            "--diagonal-rule",
            "receiver",
            "--no-sensitivity",
            "--no-progress",
            "--workers",
            "2",
        ]
    )
    assert code == 0, capfd.readouterr().err
    certificate = json.loads((out / "exhaustive" / "certificate.json").read_text())
    assert certificate["certified"], certificate["reasons"]
    assert certificate["covered_once"] and certificate["designs"] == 40320
    assert certificate["optimum"]["order"] == stored(8)["order"]


def test_the_readme_quotes_the_certified_optimum_as_the_table_holds_it():
    from math import factorial

    from fmu_src.published import PUBLISHED_PEAKS

    readme = (Path(__file__).resolve().parents[1] / "README.md").read_text().replace("\n", " ")
    eleven = {(k.rows, k.columns): k for k in known_optima() if k.diagonal_rule == "receiver"}[(11, 11)]
    assert f"is {list(eleven.order)} at {eleven.peak:.2f} N" in readme
    # the runner-up's gap as the report gives it, from this FMU at full fidelity (tests/test_readme_recipes.py):
    # the table's figures (the sweep's) differ from it by at most two units of the report's last digit
    gap = float(re.search(r"\(([\d.]+) N higher\)", readme)[1])
    assert abs(gap - (eleven.runner_up_peak - eleven.peak)) < 2e-4
    assert f"all {factorial(11):,} orders certified it" in readme
    assert f"{min(PUBLISHED_PEAKS.values()):.2f} N for the study's best published order" in readme
    mean = {(k.rows, k.columns): k for k in known_optima() if k.diagonal_rule == "mean"}[(11, 11)]
    assert mean.certified and f"certified {list(mean.order)} at {mean.peak:.2f} N" in readme
    assert f"({mean.runner_up_peak:.2f} N)" in readme
