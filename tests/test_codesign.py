"""Co-design (docs/model.md section 12): the order and each column's properties searched together.

The design's representation (order and factors, scaled coordinates, the FMU parameters it sets, the stack's
mass against the budget), the options' one-line refusals before anything runs, the evaluator's cache telling
factors apart, and a whole run on the 11 x 3 lattice: its answer carries each column's properties and the
stack's mass within the budget, is at most the order search's answer, and its parameters, typed into FMPy, give
its peak.
"""

from __future__ import annotations

import itertools
import html
import json
import math
import re
from dataclasses import dataclass, field

import numpy as np
import pytest
from fmpy import simulate_fmu

from command_line import main, one_line
from fmu_src.materials import FIELD_NAMES, MaterialTable, MaterialTableError, load_materials, study_materials
from orchestrator.codesign import (
    MASS_PROFILES,
    SEED_SHARE,
    CoDesignObjective,
    CoDesignPoint,
    CoDesignSpace,
    TraceJacobian,
    cmaes_search,
    finite_difference_jacobian,
    first_order_measure,
    mass_ladder,
    mass_range,
    minimax_refusal,
    minimax_stationarity,
    mixed_ga_search,
    nsga2_front,
    parse_vary,
    parse_vary_range,
    point_of_mass,
    polish,
    repaired_order,
    sampled_traces,
    scaled_gradients,
    scaled_parameter_names,
    seed_budgets,
    seeded_front,
)
from orchestrator.design import DesignSpace
from orchestrator.executors import SerialExecutor
from orchestrator.loop import Evaluator
from orchestrator.objective import FULL, SEARCH, SEARCH_RTOL, LatticeObjective
from orchestrator.search.pareto import dominated_by
from orchestrator.ssp import read_design_parameters

TABLE = study_materials(3)
ROWS = 11


def codesign_space(names=("k", "c", "mass"), budget=None, low=0.5, high=2.0) -> CoDesignSpace:
    return CoDesignSpace(DesignSpace.permutations(3), TABLE, names, low, high, ROWS, budget)


def test_a_point_decodes_to_the_order_and_factors_it_was_encoded_from():
    space = codesign_space()
    point = space.with_factors((2, 3, 1), [0.5, 1.0, 2.0, 0.7, 1.3, 1.0, 1.9, 0.6, 0.8])
    x = space.encode(point)
    assert len(x) == space.dimension == 3 + 9
    assert np.all((x >= 0) & (x <= 1))
    again = space.decode(x)
    assert again.order == point.order
    np.testing.assert_allclose(np.array(again.factors), np.array(point.factors), rtol=1e-12)
    assert space.scaled_of(1.0, 1, "k") == pytest.approx(0.5)  # factor 1 in the middle of a range symmetric about it


def test_a_point_sets_its_columns_materials_parameters_and_weighs_what_section_12_says():
    space = codesign_space()
    point = space.with_factors((2, 3, 1), [0.5, 1.0, 2.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0])
    parameters = space.parameters(point)
    assert set(parameters) == {f"{n}[{m}]" for n in ("k", "c", "mass") for m in (1, 2, 3)}
    assert parameters["k[2]"] == pytest.approx(0.5 * TABLE.materials[1].k)  # column 1 holds material 2
    assert parameters["mass[2]"] == pytest.approx(2.0)
    assert parameters["k[3]"] == TABLE.materials[2].k
    assert space.total_mass(point) == pytest.approx(ROWS * (2.0 + 1.0 + 1.0))
    assert space.budget_for((2, 3, 1)) == pytest.approx(ROWS * 3.0)
    assert space.mass_excess(point, space.budget_for((2, 3, 1))) == pytest.approx(ROWS * 1.0)
    assert space.mass_excess(space.unit_point((2, 3, 1)), ROWS * 3.0) == 0
    columns = space.columns_of(point)
    assert [c.material for c in columns] == ["m2", "m3", "m1"]
    assert set(columns[0].values) == set(FIELD_NAMES) and columns[0].factors == {"k": 0.5, "c": 1.0, "mass": 2.0}


@pytest.mark.parametrize(
    "text, words",
    [("k,stiffness", "--vary 'stiffness': allowed values are k, k_diag"), ("k,k", "each property once")],
)
def test_vary_names_are_section_12s(text, words):
    with pytest.raises(ValueError, match=words):
        parse_vary(text)


@pytest.mark.parametrize("text", ["2,0.5", "0,2", "1.5,2", "0.5", "a,b", "0.5,inf"])
def test_a_vary_range_must_hold_the_tables_value(text):
    with pytest.raises(ValueError, match="--vary-range"):
        parse_vary_range(text)


def test_repeated_materials_cannot_vary_per_column():
    with pytest.raises(ValueError, match="not with --repeat"):
        CoDesignSpace(DesignSpace(3, 3, repeat=True), TABLE, ("k",))


@pytest.mark.parametrize(
    "options, words",
    [
        (("--vary", "k,stiffness"), "--vary 'stiffness': allowed values are"),
        (("--vary", "k", "--vary-range", "2,0.5"), "--vary-range '2,0.5': allowed values are"),
        (("--mass-budget", "30"), "--mass-budget: only with --vary"),
        (("--vary-range", "0.5,3"), "--vary-range: only with --vary"),
        (("--codesign-method", "mixed-ga"), "--codesign-method: only with --vary"),
        (("--vary", "k", "--front-budgets", "3"), "--front-budgets: only with --objective ...,mass"),
        (("--vary", "k,mass", "--objective", "sampled,mass", "--front-budgets", "-1"), "--front-budgets"),
        (
            ("--vary", "k", "--codesign-method", "annealing"),
            "invalid choice: 'annealing' (choose from 'cmaes', 'mixed-ga')",
        ),
        (("--vary", "k", "--repeat"), "--vary: not with --repeat"),
        (("--vary", "mass", "--mass-budget", "-1"), "--mass-budget must be a finite number > 0"),
        (
            ("--vary", "k", "--objective", "sampled,max_compression"),
            "--vary: one objective, or an objective and the stack's mass",
        ),
    ],
)
def test_co_design_options_are_refused_in_one_line_before_any_run(armour_fmu_of_width, tmp_path, capfd, options, words):
    code = main("--fmu", armour_fmu_of_width(3), "--cols", 3, "--out", tmp_path / "out", "--no-progress", *options)
    line = one_line(capfd)
    assert code == 2 and words in line, line
    assert not (tmp_path / "out").exists() and not (tmp_path / "out.partial" / "journal.jsonl").exists()


def test_the_cache_tells_designs_of_one_order_with_other_factors_apart(armour_fmu_of_width):
    fmu = armour_fmu_of_width(3)
    space = codesign_space(("k",))
    objective = CoDesignObjective(LatticeObjective(fmu, space.space, 8.0), space)
    evaluator = Evaluator(SerialExecutor())
    unit = space.unit_point((1, 2, 3))
    softer = space.with_factors((1, 2, 3), [0.5, 0.5, 0.5])
    first = objective.evaluate([unit, softer, unit], evaluator, FULL)
    assert evaluator.state().simulated == 2
    assert first[0].value == first[2].value and not math.isclose(first[0].value, first[1].value, rel_tol=1e-6)
    plain = LatticeObjective(fmu, space.space, 8.0).evaluate([(1, 2, 3)], evaluator, FULL)[0]
    assert plain.value == pytest.approx(first[0].value, rel=1e-12)  # the table's values, set or not, are one design


def test_the_search_keeps_to_the_budget_and_the_polish_reports_its_optimality(
    armour_fmu_of_width, tmp_path, monkeypatch
):
    monkeypatch.chdir(tmp_path)  # pycma writes no log files into the working folder
    space = codesign_space(("k", "mass"))
    objective = CoDesignObjective(LatticeObjective(armour_fmu_of_width(3), space.space, 8.0), space)
    evaluator = Evaluator(SerialExecutor())
    budget = 0.9 * space.budget_for((1, 2, 3))  # below the order's own mass: the start is infeasible
    outcome = cmaes_search(objective, evaluator, (1, 2, 3), budget, 200, seed=3)
    assert outcome.best is not None and outcome.best.feasible
    assert space.total_mass(outcome.best.point) <= budget * (1 + 1e-9)
    assert any(not s.feasible for s in outcome.scored)  # the search met the constraint, it was not clipped away
    assert all(s.feasible == (s.mass <= budget * (1 + 1e-9)) for s in outcome.scored)
    polished = polish(objective, evaluator, outcome.best.point, budget, FULL, iterations=5)
    assert polished.end_value <= polished.start_value
    assert space.total_mass(polished.end) <= budget * (1 + 1e-9)
    assert polished.kkt_residual >= 0 and polished.tolerance > 0 and polished.evaluations > 0
    assert polished.active_times and sum(polished.sample_multipliers) == pytest.approx(1.0)
    assert [len(row) for row in polished.sensitivities] == [2, 2, 2]  # per column, per varied property
    assert not any(tmp_path.iterdir())


def test_a_repeated_choice_is_repaired_into_an_arrangement():
    assert repaired_order((2, 2, 1), 3) == (2, 3, 1)
    assert repaired_order((4, 4, 4), 5) == (4, 1, 2)
    assert repaired_order((3, 1, 2), 3) == (3, 1, 2)


def test_the_mixed_variable_ga_keeps_to_the_budget_and_starts_from_the_order(armour_fmu_of_width):
    space = codesign_space(("k", "mass"))
    objective = CoDesignObjective(LatticeObjective(armour_fmu_of_width(3), space.space, 8.0), space)
    evaluator = Evaluator(SerialExecutor())
    budget = 0.9 * space.budget_for((1, 2, 3))  # below the order's own mass: the start is infeasible
    outcome = mixed_ga_search(objective, evaluator, (1, 2, 3), budget, 120, seed=3, population=20)
    assert 0 < outcome.evaluations <= 120 and len(outcome.scored) == outcome.evaluations
    assert outcome.scored[0].point == space.unit_point((1, 2, 3)) and not outcome.scored[0].feasible
    assert outcome.best is not None and outcome.best.feasible
    assert space.total_mass(outcome.best.point) <= budget * (1 + 1e-9)
    assert all(s.feasible == (s.mass <= budget * (1 + 1e-9)) for s in outcome.scored)
    assert all(sorted(s.point.order) == [1, 2, 3] for s in outcome.scored)
    again = mixed_ga_search(objective, evaluator, (1, 2, 3), budget, 120, seed=3, population=20)
    assert again.best is not None and again.best.point == outcome.best.point  # one seed, one search


@pytest.mark.parametrize(
    "method, searched_by", [("cmaes", "CMA-ES evaluated"), ("mixed-ga", "mixed-variable GA evaluated")]
)
def test_a_co_design_answer_carries_its_columns_and_mass_and_fmpy_gives_its_peak(
    armour_fmu_of_width, tmp_path, capfd, method, searched_by
):
    fmu = armour_fmu_of_width(3)
    out = tmp_path / "run"
    common = ("--fmu", fmu, "--cols", 3, "--diagonal-rule", "mean", "--no-progress", "--budget", 6, "--repeats", 1)
    assert main(*common, "--out", out, "--vary", "k,c,mass", "--vary-budget", 150, "--codesign-method", method) == 0
    printed = capfd.readouterr().out
    assert "  co-design: " in printed and " kg of 33.00 kg; from " in printed
    record = json.loads((out / "results.json").read_text())
    answer = record["answers"][0]
    report = (out / "report.html").read_text()
    assert "Each layer (co-design" in report and "first-order optimality of the minimax problem" in report
    assert searched_by in report
    search = "pymoo's mixed-variable GA" if method == "mixed-ga" else "CMA-ES"
    found = f"found by co-design: {search} over the order and the factors together, then SLSQP on the epigraph"
    assert found in printed and found in html.unescape(report)  # credited to the search that ran
    codesign = record["steps"]["codesign"]["answers"][0]
    assert codesign["search_method"] == method and 0 < codesign["search_evaluations"] <= 150
    assert answer["total_mass"] <= codesign["mass_budget"] * (1 + 1e-9)
    assert codesign["mass_budget"] == pytest.approx(ROWS * 3.0)  # the order's own mass at the table's values
    assert answer["peak"] <= codesign["start_peak"]
    assert [c["column"] for c in answer["columns"]] == [1, 2, 3]
    for column in answer["columns"]:
        assert set(column["values"]) == set(FIELD_NAMES) and set(column["factors"]) == {"k", "c", "mass"}
        assert all(0.5 <= f <= 2.0 for f in column["factors"].values())
    assert answer["total_mass"] == pytest.approx(ROWS * sum(c["values"]["mass"] for c in answer["columns"]))
    parameters = answer["parameters"]
    assert any(name.startswith("mass[") for name in parameters)
    result = simulate_fmu(str(fmu), start_values=parameters, stop_time=8.0, output=["peak_backplate_force"])
    assert result["peak_backplate_force"][-1] == pytest.approx(answer["peak"], rel=1e-6)
    in_file = read_design_parameters(out / "best_design.ssp")
    for name, value in parameters.items():
        assert in_file[name] == pytest.approx(value, rel=1e-12), name


GRID = 7  # points per factor, evenly spaced in the scaled coordinate: a spacing of 1/6 of the range's log


@pytest.mark.slow
def test_on_an_11_x_2_lattice_a_grid_of_the_factors_confirms_the_co_design_to_its_spacing(armour_fmu_of_width):
    """Two columns (two orders), k and c varied in each: every order at every point of a 7^4 grid of the scaled
    factors, against CMA-ES and the polish at the same (search) fidelity."""
    table = study_materials(2)
    space = CoDesignSpace(DesignSpace.permutations(2), table, ("k", "c"), 0.5, 2.0, ROWS)
    objective = CoDesignObjective(
        LatticeObjective(armour_fmu_of_width(2), space.space, 8.0, parameters={"diagonal_rule": "mean"}), space
    )
    evaluator = Evaluator(SerialExecutor())
    ticks = np.linspace(0.0, 1.0, GRID)
    cells = list(itertools.product(range(GRID), repeat=4))
    grid = {}
    for order in ((1, 2), (2, 1)):
        names = [(order[j], name) for j in range(2) for name in space.names]
        points = [
            space.with_factors(order, [space.factor_of(ticks[i], *names[axis]) for axis, i in enumerate(cell)])
            for cell in cells
        ]
        for cell, result in zip(cells, objective.evaluate(points, evaluator, SEARCH)):
            assert result.ok, result.message
            grid[order, cell] = result.value
    (best_order, best_cell), best = min(grid.items(), key=lambda item: item[1])
    neighbours = [
        grid[best_order, tuple(c + d * (i == axis) for i, c in enumerate(best_cell))]
        for axis in range(4)
        for d in (-1, 1)
        if 0 <= best_cell[axis] + d < GRID
    ]
    spread = max(abs(v - best) for v in neighbours)  # how much the value moves over one spacing there

    budget = space.budget_for((1, 2))
    outcome = cmaes_search(objective, evaluator, (1, 2), budget, 600, seed=0)
    polished = polish(objective, evaluator, outcome.best.point, budget, SEARCH)
    found = min((outcome.best.value, outcome.best.point), (polished.end_value, polished.end), key=lambda p: p[0])
    value, point = found
    assert point.order == best_order
    # the polish's value is its recorded trace's maximum over the whole horizon, the grid's the search's run over its
    # shorter one: the same samples, integrated by one solver to the search's tolerance along two paths
    assert best - spread <= value <= best * (1 + SEARCH_RTOL)
    scaled = space.encode(point)[space.space.key_dimension :]
    assert np.all(np.abs(scaled - ticks[list(best_cell)]) <= 1.0 / (GRID - 1) + 1e-9), (scaled, best_cell)


def test_the_front_of_peak_against_mass_is_never_dominated_by_a_design_the_run_evaluated(armour_fmu_of_width):
    space = codesign_space(("k", "mass"))
    lattice = LatticeObjective(armour_fmu_of_width(3), space.space, 8.0, ("peak_backplate_force", "stack_mass"))
    evaluator = Evaluator(SerialExecutor())
    front = nsga2_front(CoDesignObjective(lattice, space), evaluator, (1, 2, 3), 160, seed=1, population=20)
    assert len(front.evaluated) == front.evaluations == 160 and len(front.designs) >= 2
    on_front = [d.search_values for d in front.designs]
    assert not np.any(dominated_by(on_front, front.evaluated))
    for design in front.designs:  # the FMU's stack_mass is section 12's, and the full fidelity's run is reported
        assert design.search_values[1] == pytest.approx(space.total_mass(design.point), rel=1e-12)
        assert design.full_values is not None and design.full_values[1] == pytest.approx(design.search_values[1])
    masses = [d.search_values[1] for d in front.designs]
    assert masses == sorted(masses, reverse=True)  # by the peak, lowest first: the mass falls along the front
    assert front.mass_range == pytest.approx((ROWS * 3 * 0.5, ROWS * 3 * 2.0))  # no budget: the factors' range
    assert min(masses) == pytest.approx(front.mass_range[0])  # the lightest seed: nothing lighter dominates it


def test_a_mass_ladder_spaces_its_masses_evenly_up_to_the_budget():
    space = codesign_space(("k", "mass"))
    assert mass_range(space, (2, 3, 1), None) == pytest.approx((ROWS * 1.5, ROWS * 6.0))
    assert mass_range(space, (2, 3, 1), 50.0) == pytest.approx((ROWS * 1.5, 50.0))
    for profile in MASS_PROFILES:
        ladder = mass_ladder(space, (2, 3, 1), 50.0, 5, profile)
        masses = [space.total_mass(point) for point in ladder]
        np.testing.assert_allclose(masses, np.linspace(ROWS * 1.5, 50.0, 5), rtol=1e-9)
        assert all(point.order == (2, 3, 1) and all(f[0] == 1.0 for f in point.factors) for point in ladder)
        middle = [column[1] for column in ladder[2].factors]  # each column's mass factor
        if profile == "even":
            assert middle == pytest.approx([middle[0]] * 3)
        else:  # the columns fill one after the other, from the loaded face or from the back
            assert middle == sorted(middle, reverse=profile == "impact_side_first") and middle[0] != middle[2]
    with pytest.raises(ValueError, match="profile 'diagonal': allowed values are even, impact_side_first"):
        mass_ladder(space, (2, 3, 1), None, 3, "diagonal")
    assert mass_ladder(codesign_space(("k",)), (2, 3, 1), None, 5) == []  # no mass varied: no ladder


def test_a_front_under_a_mass_budget_keeps_to_it_and_spans_the_masses_up_to_it(armour_fmu_of_width):
    space = codesign_space(("k", "mass"))
    lattice = LatticeObjective(armour_fmu_of_width(3), space.space, 8.0, ("peak_backplate_force", "stack_mass"))
    evaluator = Evaluator(SerialExecutor())
    budget = ROWS * 4.5
    front = nsga2_front(
        CoDesignObjective(lattice, space), evaluator, (1, 2, 3), 100, seed=2, population=20, mass_budget=budget
    )
    assert front.mass_range == pytest.approx((ROWS * 1.5, budget))
    assert front.evaluations == 100 and 0 < len(front.evaluated) <= 100
    assert all(mass <= budget * (1 + 1e-9) for _, mass in front.evaluated)
    on_front = [d.search_values for d in front.designs]
    assert not np.any(dominated_by(on_front, front.evaluated))
    masses = [d.search_values[1] for d in front.designs]
    assert min(masses) == pytest.approx(ROWS * 1.5)
    assert max(mass for _, mass in front.evaluated) == pytest.approx(budget)  # the heaviest seed: beyond 33 kg


@dataclass(frozen=True)
class RecordingObjective(CoDesignObjective):
    """The co-design objective, keeping each batch of points it is asked to evaluate."""

    batches: list = field(default_factory=list, compare=False)

    def evaluate(self, points, evaluator, fidelity=SEARCH):
        self.batches.append((fidelity, list(points)))
        return super().evaluate(points, evaluator, fidelity)


def same_point(space: CoDesignSpace, a: CoDesignPoint, b: CoDesignPoint) -> bool:
    return a.order == b.order and np.allclose(space.encode(a), space.encode(b), rtol=0, atol=1e-9)


def test_cma_es_answers_within_each_budget_seed_the_front_and_none_lies_above_it(armour_fmu_of_width):
    space = codesign_space(("k", "mass"))
    lattice = LatticeObjective(armour_fmu_of_width(3), space.space, 8.0, ("peak_backplate_force", "stack_mass"))
    objective = RecordingObjective(lattice, space)
    evaluator = Evaluator(SerialExecutor())
    mass_budget = ROWS * 4.5
    budgets = seed_budgets(space, (1, 2, 3), mass_budget, 3)
    assert budgets == pytest.approx((ROWS * 2.5, ROWS * 3.5, mass_budget))  # above the lightest, 16.5 kg

    def refine(point, budget):
        return polish(objective, evaluator, point, budget, SEARCH, iterations=3).end

    evaluations, population = 240, 20
    front = seeded_front(
        objective, evaluator, (1, 2, 3), evaluations, budgets, seed=4, population=population,
        mass_budget=mass_budget, refine=refine,
    )  # fmt: skip
    assert [s.budget for s in front.seeds] == pytest.approx(budgets)
    share = int(evaluations * SEED_SHARE) // len(budgets)
    assert all(0 < s.evaluations <= share for s in front.seeds)
    unit = space.unit_point((1, 2, 3))
    for run, seed in zip(front.seeds, (6, 5, 4)):  # the heaviest budget's run draws from the front's own seed
        # each seed is CMA-ES's answer within its budget (the polish's where lower), from the order at the table's
        # values where that is within it, else from the order's design of the budget's mass
        start = unit if space.total_mass(unit) <= run.budget else point_of_mass(space, (1, 2, 3), run.budget)
        alone = cmaes_search(
            CoDesignObjective(lattice, space), evaluator, (1, 2, 3), run.budget, share, seed=seed, start=start
        )
        assert alone.best is not None and run.search_best == alone.best.value
        assert run.point is not None and run.values is not None and space.mass_excess(run.point, run.budget) == 0
        assert run.values[0] <= alone.best.value
        assert run.polished == (run.values[0] < alone.best.value)
    # NSGA-II's first population (its first batch, after CMA-ES's and the polish's) holds every seed
    nsga2_batches = [points for fidelity, points in objective.batches if len(points) == population]
    assert nsga2_batches, "NSGA-II evaluated no population"
    first = nsga2_batches[0]
    for run in front.seeds:
        assert any(same_point(space, run.point, p) for p in first), run
    # the front: never dominated by a design evaluated, CMA-ES's included; one at least as good as each seed
    cmaes_designs = sum(s.evaluations for s in front.seeds)
    assert len(front.evaluated) > front.evaluations and front.evaluations + cmaes_designs <= evaluations + population
    on_front = [d.search_values for d in front.designs]
    assert not np.any(dominated_by(on_front, front.evaluated))
    for run in front.seeds:
        assert any(v[0] <= run.values[0] and v[1] <= run.values[1] * (1 + 1e-12) for v in on_front), run


def test_a_design_of_a_given_mass_weighs_it():
    space = codesign_space(("k", "mass"))
    for profile in MASS_PROFILES:
        point = point_of_mass(space, (2, 3, 1), 40.0, profile)
        assert space.total_mass(point) == pytest.approx(40.0, rel=1e-9) and point.order == (2, 3, 1)
    assert space.total_mass(point_of_mass(space, (2, 3, 1), 1.0)) == pytest.approx(ROWS * 1.5)  # the lightest


def test_without_varied_masses_the_front_is_seeded_within_one_budget():
    space = codesign_space(("k",))
    assert seed_budgets(space, (2, 3, 1), None, 4) == pytest.approx((ROWS * 3.0,))
    assert seed_budgets(codesign_space(("k", "mass")), (2, 3, 1), None, 0) == ()


def test_the_co_design_front_is_a_run_of_its_own(armour_fmu_of_width, tmp_path, capfd):
    out = tmp_path / "front"
    options = ("--fmu", armour_fmu_of_width(3), "--cols", 3, "--diagonal-rule", "mean", "--no-progress")
    assert (
        main(
            *options,
            "--out",
            out,
            "--budget",
            6,
            "--repeats",
            1,
            "--vary",
            "k,mass",
            "--objective",
            "sampled,mass",
            "--vary-budget",
            80,
            "--mass-budget",
            45,
            "--front-budgets",
            2,
        )
        == 0
    )
    printed = capfd.readouterr().out
    assert "designs (order and factors) on the co-design front" in printed
    assert "seeded by CMA-ES (then the polish) within 2 mass budgets" in printed
    fronts = json.loads((out / "results.json").read_text())["steps"]["codesign"]["fronts"]
    report = (out / "report.html").read_text()
    assert "on the front of the objective against the" in report and "What seeded the front" in report
    seeds = fronts[0]["seeds"]
    assert [s["budget"] for s in seeds] == pytest.approx([(ROWS * 1.5 + 45.0) / 2, 45.0])
    assert all(s["evaluations"] <= 20 and s["values"][1] <= s["budget"] * (1 + 1e-9) for s in seeds)
    assert fronts[0]["diagonal_rule"] == "mean" and fronts[0]["designs"]
    assert fronts[0]["mass_range"] == pytest.approx([ROWS * 1.5, 45.0])  # --mass-budget: the front's upper end
    assert all(d["search_values"][1] <= 45.0 * (1 + 1e-9) for d in fronts[0]["designs"])
    # the first screen shows the co-design front's chosen designs, each with a design file FMPy runs to its peak
    chosen = fronts[0]["chosen"]
    assert [c["label"] for c in chosen][:1] == ["lowest peak"] and any(c["varied"] for c in chosen)
    lowest = min(d["full_values"][0] for d in fronts[0]["designs"] if d["full_values"])
    assert chosen[0]["design"]["full_values"][0] == lowest
    first_screen = report[: report.index('id="codesign"')]
    assert "Tailored layers (--vary): the co-design front" in first_screen
    for choice in chosen:
        assert choice["design_file"] in first_screen and f"({choice['design_file']})" in printed
        parameters = read_design_parameters(out / choice["design_file"])
        assert {k: v for k, v in parameters.items() if k in choice["varied"]} == pytest.approx(
            choice["varied"], rel=1e-12
        )
        result = simulate_fmu(
            str(armour_fmu_of_width(3)), start_values=parameters, stop_time=8.0, output=["peak_backplate_force"]
        )
        assert result["peak_backplate_force"][-1] == pytest.approx(choice["design"]["full_values"][0], rel=1e-6)
    assert "among the orders at the table's values" in printed


def test_a_tables_bounds_give_each_materials_own_range(tmp_path):
    path = tmp_path / "bounded.csv"
    path.write_text(
        "name,k,k_diag,c,alpha,alpha_diag,k_min,k_max,mass_max\n"
        "steel,100,50,5,10,10,80,300,1.5\n"
        "aramid,44,22,2,10,10,,,\n"
        "foam,8,4,0.4,10,10,4,,\n"
    )
    table = load_materials(path)
    assert table.bound(1, "k") == (80.0, 300.0) and table.bound(1, "mass") == (None, 1.5)
    assert table.bound(2, "k") == (None, None) and table.bound(3, "k") == (4.0, None)
    space = CoDesignSpace(DesignSpace.permutations(3), table, ("k", "mass"), 0.5, 2.0, ROWS)
    assert space.factor_range(1, "k") == pytest.approx((0.8, 3.0))
    assert space.factor_range(1, "mass") == pytest.approx((0.5, 1.5))
    assert space.factor_range(2, "k") == (0.5, 2.0) and space.factor_range(3, "k") == pytest.approx((0.5, 2.0))
    rng = np.random.default_rng(0)
    ends = space.decode(np.concatenate([space.space.to_keys((1, 2, 3)), np.ones(6)]))
    assert space.value(ends, 1, "k") == 300.0 and space.value(ends, 1, "mass") == 1.5  # the bound itself
    for _ in range(50):  # every point decodes within each column's material's own bounds
        point = space.decode(rng.random(space.dimension))
        for column, material in enumerate(point.order, start=1):
            low, high = space.factor_range(material, "k")
            assert low * (1 - 1e-12) <= point.factors[column - 1][0] <= high * (1 + 1e-12)
        for column in range(1, 4):
            low, high = table.bound(point.order[column - 1], "k")
            assert (low or 0) <= space.value(point, column, "k") <= (high or math.inf)
        again = space.decode(space.encode(point))
        np.testing.assert_allclose(np.array(again.factors), np.array(point.factors), rtol=1e-12)


@pytest.mark.parametrize(
    "header, row, words",
    [
        ("k_min", "120", "field k: 100.0 is outside its bounds [120.0, -]"),
        ("k_max", "-3", "field k_max: '-3' is not allowed; allowed: a finite number > 0 (N)"),
        ("stiffness_max", "3", "unknown field 'stiffness_max'"),
    ],
)
def test_a_bad_bound_is_refused_in_one_line_naming_its_row_and_field(tmp_path, header, row, words):
    path = tmp_path / "bad.csv"
    path.write_text(f"name,k,k_diag,c,alpha,alpha_diag,{header}\nsteel,100,50,5,10,10,{row}\n")
    with pytest.raises(MaterialTableError, match=re.escape(words)) as refused:
        load_materials(path)
    assert "row 1" in str(refused.value) and len(str(refused.value).splitlines()) == 1


@pytest.mark.slow
def test_a_co_design_is_the_same_on_any_executor(armour_fmu_of_width, tmp_path):
    options = ("--fmu", armour_fmu_of_width(3), "--cols", 3, "--diagonal-rule", "mean", "--no-progress", "--budget", 6)
    options += ("--repeats", 1, "--vary", "k,mass", "--vary-budget", 60, "--no-sensitivity")
    answers = []
    for executor in ("serial", "process"):
        assert main(*options, "--executor", executor, "--out", tmp_path / executor) == 0
        answers.append(json.loads((tmp_path / executor / "results.json").read_text())["answers"][0])
    assert answers[0]["parameters"] == answers[1]["parameters"] and answers[0]["peak"] == answers[1]["peak"]


def test_a_tables_bounds_hold_when_cols_takes_fewer_columns_than_it_has_materials(tmp_path, capfd):
    path = tmp_path / "tight.csv"  # each k within 1 % of its value: far inside --vary-range's 0.5..2
    path.write_text(
        "name,k,k_diag,c,alpha,alpha_diag,k_min,k_max\n"
        "steel,100,50,5,10,10,99,101\n"
        "aramid,44,22,2,10,10,43.56,44.44\n"
        "foam,8,4,0.4,10,10,7.92,8.08\n"
        "felt,5,2,0.3,10,10,4.95,5.05\n"
    )
    out = tmp_path / "out"
    options = ("--materials", path, "--cols", 3, "--vary", "k", "--vary-budget", 30, "--budget", 6, "--repeats", 1)
    options += ("--diagonal-rule", "mean", "--no-sensitivity", "--no-progress", "--out", out)
    assert main(*options) == 0
    capfd.readouterr()
    record = json.loads((out / "results.json").read_text())
    answer = record["answers"][0]
    bounds = {"steel": (99, 101), "aramid": (43.56, 44.44), "foam": (7.92, 8.08), "felt": (4.95, 5.05)}
    assert len(answer["columns"]) == 3
    for column in answer["columns"]:
        low, high = bounds[column["material"]]
        assert low <= column["values"]["k"] <= high, column
    # results.json's table carries the bounds: read back, it is the table, and its materials' factor ranges
    rows = record["case"]["materials"]
    assert rows[0]["k_min"] == 99 and rows[0]["k_max"] == 101 and "mass_min" not in rows[0]
    again = tmp_path / "again.json"
    again.write_text(json.dumps({"materials": rows}))
    table = load_materials(path)
    for read in (MaterialTable.from_rows(rows), load_materials(again)):
        assert read == table and read.bounds
        first = CoDesignSpace(DesignSpace(3, 4), table, ("k",))
        second = CoDesignSpace(DesignSpace(3, 4), read, ("k",))
        assert [first.factor_range(m, "k") for m in range(1, 5)] == [second.factor_range(m, "k") for m in range(1, 5)]


# ------------------------------------------------------------------------------- the polish as a minimax problem
def test_the_recorded_trace_peaks_at_the_fmus_sampled_peak(armour_fmu_of_width):
    """The polish's samples are the FMU's: a trace recorded every peak_sample_interval through the evaluator has
    the FMU's sampled peak as its maximum, at the table's values and with factors set."""
    space = codesign_space()
    lattice = LatticeObjective(armour_fmu_of_width(3), space.space, 8.0, parameters={"diagonal_rule": "mean"})
    objective = CoDesignObjective(lattice, space)
    evaluator = Evaluator(SerialExecutor())
    points = [space.unit_point((2, 3, 1)), space.with_factors((2, 3, 1), [0.6, 1.7, 1.3, 1.9, 0.5, 0.8, 1.1, 1.2, 0.7])]
    peaks = [e.value for e in objective.evaluate(points, evaluator, FULL)]
    traces = sampled_traces(objective, evaluator, (2, 3, 1), [space.parameters(p) for p in points], FULL)
    for (times, values), peak in zip(traces, peaks):
        assert len(times) == len(values) == 801 and times[0] == 0.0
        np.testing.assert_allclose(np.diff(times), 0.01, rtol=1e-9)
        assert float(np.max(values)) == pytest.approx(peak, rel=1e-9)
    assert not math.isclose(peaks[0], peaks[1], rel_tol=1e-3)


def test_the_epigraph_polish_ends_first_order_optimal_and_no_higher(armour_fmu_of_width):
    space = codesign_space()
    lattice = LatticeObjective(armour_fmu_of_width(3), space.space, 8.0, parameters={"diagonal_rule": "mean"})
    objective = CoDesignObjective(lattice, space)
    evaluator = Evaluator(SerialExecutor())
    budget = space.budget_for((1, 2, 3))
    outcome = cmaes_search(objective, evaluator, (1, 2, 3), budget, 150, seed=0)
    assert outcome.best is not None
    polished = polish(objective, evaluator, outcome.best.point, budget, FULL, jacobian=finite_difference_jacobian)
    assert polished.converged and polished.kkt_residual <= polished.tolerance
    assert polished.end_value <= polished.start_value
    assert space.total_mass(polished.end) <= budget * (1 + 1e-9)
    (full,) = objective.evaluate([polished.end], evaluator, FULL)
    assert full.value == pytest.approx(polished.end_value, rel=1e-9)  # the trace's maximum is the reported peak
    assert polished.active_times and len(polished.sample_multipliers) == len(polished.active_times)
    assert all(w >= 0 for w in polished.sample_multipliers) and sum(polished.sample_multipliers) == pytest.approx(1)
    assert polished.kkt_residual <= polished.smooth_residual + 1e-12  # the peak's sample alone is one choice
    assert [len(row) for row in polished.sensitivities] == [3, 3, 3]
    again = polish(objective, evaluator, outcome.best.point, budget, FULL)
    assert again.evaluations == 0 and again.end == polished.end  # every run went through the evaluator's cache


def kinked_trace(objective, evaluator, point, names, fidelity, relative_step) -> TraceJacobian:
    """A made-up trace of three samples in u, v, w (the log factors of k in column 1, c in column 2 and mass in
    column 3): F_1 = 1000 + 100 u + 30 v - 50 w and F_2 = 1000 - 100 u + 30 v - 50 w tie where u = 0; F_3 lies
    5 N below them. Its derivatives are exact, per unit of each FMU parameter."""
    space = objective.space
    parameters = space.parameters(point)
    order = point.order
    u, v, w = (
        math.log(parameters[f"{name}[{order[column]}]"] / getattr(TABLE.materials[order[column] - 1], name))
        for column, name in ((0, "k"), (1, "c"), (2, "mass"))
    )
    rows = {0: (100.0, 30.0, -50.0), 1: (-100.0, 30.0, -50.0), 2: (0.0, 30.0, -50.0)}
    values = np.array([1000 + a * u + b * v + c * w for a, b, c in rows.values()]) - np.array([0, 0, 5.0])
    jacobian = np.zeros((3, len(names)))
    for column, name, slot in ((0, "k", 0), (1, "c", 1), (2, "mass", 2)):
        index = names.index(f"{name}[{order[column]}]")
        for sample, row in rows.items():
            jacobian[sample, index] = row[slot] / parameters[names[index]]  # d F / d ln p = p d F / d p
    return TraceJacobian((0.1, 0.2, 0.3), values, jacobian, tuple(names), 0)


def test_the_minimax_measure_is_small_at_a_kink_where_the_smooth_gradient_is_not():
    """At u = 0 the two samples tie: max(F_1, F_2) has a kink with 0 in its Clarke subdifferential along u; c's
    factor sits on its lower end with the gradient pointing out of the box, and the mass budget binds with more
    mass lowering the peak: the first-order conditions hold (multipliers 1/2, 1/2 and a positive mu), while the
    peak's sample alone leaves 100 log_span along u, relative to the peak."""
    space = codesign_space(("k", "c", "mass"))
    order = (1, 2, 3)
    point = space.with_factors(order, [1.0, 1.0, 1.0, 1.0, 0.5, 1.0, 1.0, 1.0, 1.0])
    objective = type("Made", (), {"space": space})()
    found = kinked_trace(objective, None, point, scaled_parameter_names(space, order), FULL, 1e-3)
    gradients = scaled_gradients(space, point, found)
    span = math.log(4.0)
    assert gradients[0, 0] == pytest.approx(100 * span) and gradients[1, 0] == pytest.approx(-100 * span)
    z = space.encode(point)[space.space.key_dimension :]
    assert z[4] == pytest.approx(0.0, abs=1e-12)  # c of column 2 on its lower end
    mass_normal = np.zeros(len(z))
    mass_normal[8] = ROWS * span / space.budget_for(order)  # d (mass / budget) / d z of column 3's mass
    measure = first_order_measure(found.values, gradients, z, mass_normal)
    peak = float(np.max(found.values))  # 1000 + 30 ln 0.5: the gradients are relative to it
    assert measure.active == (0, 1) or measure.active == (1, 0)  # F_3, 5 N below, is not active
    assert measure.stationarity.residual <= 1e-6
    assert measure.stationarity.sample_multipliers == pytest.approx((0.5, 0.5), abs=1e-6)
    assert measure.stationarity.mass_multiplier == pytest.approx(50 * span / peak / mass_normal[8], rel=1e-6)
    assert measure.smooth.residual == pytest.approx(100 * span / peak, rel=1e-6)
    away = minimax_stationarity(gradients[:2] / peak, z)  # without the budget the mass coordinate is not stationary
    assert away.residual == pytest.approx(50 * span / peak, rel=1e-6)


def test_the_polish_refuses_an_objective_that_is_no_maximum_over_samples(armour_fmu_of_width):
    space = codesign_space(("k",))
    fmu = armour_fmu_of_width(3)
    continuous = LatticeObjective(fmu, space.space, 8.0, ("peak_backplate_force_continuous",))
    mean_of_cases = LatticeObjective(fmu, space.space, 8.0).with_cases([{"F_total": 600.0}, {"F_total": 900.0}], "mean")
    for lattice, words in ((continuous, "is not the sampled peak"), (mean_of_cases, "mean over load cases")):
        objective = CoDesignObjective(lattice, space)
        assert words in (minimax_refusal(objective) or "")
        with pytest.raises(ValueError, match=words):
            polish(objective, Evaluator(SerialExecutor()), space.unit_point((1, 2, 3)), 33.0, FULL)
    worst = CoDesignObjective(LatticeObjective(fmu, space.space, 8.0).with_cases([{"F_total": 600.0}], "worst"), space)
    assert minimax_refusal(worst) is None


@pytest.mark.slow
def test_at_the_studys_co_design_answer_under_the_mean_rule_the_polish_converges(armour_fmu_of_width, tmp_path, capfd):
    """The study's 11 x 11 lattice, k, c and mass varied within the order's own mass: the polish ends where the
    minimax problem's first-order conditions hold."""
    out = tmp_path / "mean"
    options = ("--fmu", armour_fmu_of_width(11), "--diagonal-rule", "mean", "--vary", "k,c,mass", "--no-sensitivity")
    assert main(*options, "--no-progress", "--out", out) == 0
    capfd.readouterr()
    codesign = json.loads((out / "results.json").read_text())["steps"]["codesign"]["answers"][0]
    polished = codesign["polish"]
    assert polished["kkt_residual"] <= polished["tolerance"] == 0.01
    assert polished["end_value"] <= polished["start_value"] and codesign["peak"] <= polished["end_value"] + 1e-9
    assert sum(polished["sample_multipliers"]) == pytest.approx(1.0)


def test_a_co_design_of_the_continuous_peak_says_why_it_has_no_polish(armour_fmu_of_width, tmp_path, capfd):
    out = tmp_path / "continuous"
    options = ("--fmu", armour_fmu_of_width(3), "--cols", 3, "--diagonal-rule", "mean", "--objective", "continuous")
    options += ("--vary", "k", "--vary-budget", 30, "--budget", 6, "--repeats", 1, "--no-sensitivity")
    assert main(*options, "--no-progress", "--out", out) == 0
    capfd.readouterr()
    codesign = json.loads((out / "results.json").read_text())["steps"]["codesign"]["answers"][0]
    assert codesign["polish"] is None and "is not the sampled peak" in codesign["polish_note"]
    assert (
        "The polish did not run (the objective peak_backplate_force_continuous is not the sampled peak"
        in (out / "report.html").read_text()
    )


def test_a_table_without_bounds_is_stated_as_its_rows():
    from orchestrator.study import table_rows

    assert list(table_rows(TABLE)) == TABLE.rows()
