"""The orchestrator on the real FMU: objective, study pipeline, CLI and report, executors."""
import csv
import json
import math

import pytest

from conftest import PUBLISHED_BEST, PUBLISHED_PEAKS, PUBLISHED_SEQUENTIAL
from orchestrator import run as cli
from orchestrator.executors import make_executor
from orchestrator.loop import Evaluator, run_search
from orchestrator.objective import FULL, SEARCH, ContinuousPeak, FMURun, SampledPeak
from orchestrator.search import make_search
from orchestrator.study import StudyConfig, neighbours, run_study


def test_objective_reports_both_peaks_and_reproduces_the_study(fmu_path):
    sampled = SampledPeak(fmu_path, 11, horizon=8.0)
    with make_executor("serial") as executor:
        evaluator = Evaluator(executor)
        evaluation, = sampled.evaluate([PUBLISHED_BEST], evaluator, FULL)
        assert evaluation.ok and sampled.unit == "N"
        assert evaluation.peak == pytest.approx(PUBLISHED_PEAKS[PUBLISHED_BEST], rel=1e-6)
        assert evaluation.details["peak_continuous"] > evaluation.details["peak_sampled"] == evaluation.peak
        continuous, = ContinuousPeak(fmu_path, 11, horizon=8.0).evaluate([PUBLISHED_BEST], evaluator, FULL)
        assert continuous.peak == evaluation.details["peak_continuous"]
        assert evaluator.simulated == 2  # the two objectives are two FMU runs ...
        sampled.evaluate([PUBLISHED_BEST], evaluator, FULL)
        assert evaluator.simulated == 2 and evaluator.cache_hits == 1  # ... and asking again costs nothing
        search, = sampled.evaluate([PUBLISHED_BEST], evaluator, SEARCH)
        assert search.details["horizon"] == 1.0 and search.peak == pytest.approx(evaluation.peak, rel=1e-4)


def test_a_short_horizon_falls_back_to_the_full_one_while_the_lattice_touches_the_plate(fmu_path):
    short = FMURun(str(fmu_path), horizon=0.3, fallback_horizon=8.0)(PUBLISHED_SEQUENTIAL)
    assert short.details["horizon"] == 8.0  # at 0.3 s the lattice is pressing on the plate
    assert short.peak == pytest.approx(PUBLISHED_PEAKS[PUBLISHED_SEQUENTIAL], rel=1e-6)
    safe = FMURun(str(fmu_path), horizon=1.0, fallback_horizon=8.0)(PUBLISHED_SEQUENTIAL)
    assert safe.details["horizon"] == 1.0 and safe.details["last_contact_time"] < 0.9


def test_load_cases_are_one_run_each_and_their_aggregate(fmu_path):
    worst = SampledPeak(fmu_path, 11, horizon=1.0, cases=[{"F_total": 600.0}, {"F_total": 2400.0}])
    mean = worst.with_cases([{"F_total": 600.0}, {"F_total": 2400.0}], aggregate="mean")
    with make_executor("serial") as executor:
        evaluator = Evaluator(executor)
        high, = worst.evaluate([PUBLISHED_BEST], evaluator, FULL)
        average, = mean.evaluate([PUBLISHED_BEST], evaluator, FULL)
        assert evaluator.simulated == 2  # the mean reused both cases' runs
    peaks = [case["peak"] for case in high.details["cases"]]
    assert [case["parameters"] for case in high.details["cases"]] == [{"F_total": 600.0}, {"F_total": 2400.0}]
    assert peaks[1] > 2 * peaks[0] and high.peak == max(peaks)
    assert average.peak == pytest.approx(sum(peaks) / 2)
    failing = worst.with_cases([{"F_total": 600.0}, {"solver": 1, "fixed_step": 0.05}])
    with make_executor("serial") as executor:
        broken, = failing.evaluate([PUBLISHED_BEST], Evaluator(executor), FULL)
    assert not broken.ok and broken.peak is None and "fixed_step" in broken.message


def test_a_failing_fmu_evaluation_is_recorded_not_a_number(fmu_path):
    diverging = FMURun(str(fmu_path), horizon=1.0, parameters=(("fixed_step", 0.05), ("solver", 1)))
    evaluation = diverging(PUBLISHED_SEQUENTIAL)
    assert evaluation.status == "failed" and evaluation.peak is None
    assert "diverged" in evaluation.message or "non-finite" in evaluation.message
    with make_executor("serial") as executor:
        run = run_search(make_search("random", 11, seed=0), diverging, 5, executor, method_name="random", seed=0)
    assert run.n_evaluations == 5 and run.n_failed == 5 and run.best_peak is None


def test_neighbours_are_every_distinct_swap_and_insertion():
    moves = neighbours(tuple(range(1, 12)))
    assert len(moves["swap"]) == 55
    everything = set(moves["swap"]) | set(moves["insertion"])
    assert len(everything) == len(moves["swap"]) + len(moves["insertion"])
    assert tuple(range(1, 12)) not in everything
    # an insertion moves one column: (n-1)^2 distinct such orders, adjacent swaps counted once
    assert len(moves["insertion"]) + 10 == 100


def test_dask_gives_the_same_search_as_a_process_pool(fmu_path):
    objective = FMURun(str(fmu_path), horizon=1.0, parameters=(("atol", 1e-8), ("rtol", 1e-6)))
    results = {}
    for kind in ("process", "dask"):
        with make_executor(kind, workers=2) as executor:
            run = run_search(make_search("cmaes", 11, seed=3), objective, 16, executor, method_name="cmaes", seed=3)
        results[kind] = [(e.order, e.peak) for e in run.evaluations]
    assert results["dask"] == results["process"]
    assert len(results["dask"]) == 16


def test_cli_end_to_end_writes_the_report(fmu_path, tmp_path):
    out = tmp_path / "report"
    code = cli.main(["--fmu", str(fmu_path), "--method", "cmaes", "sa", "sequential", "--budget", "12",
                     "--repeats", "2", "--executor", "process", "--workers", "2", "--out", str(out), "--no-progress",
                     "--which-model-budget", "20", "--sensitivity-budget", "10"])
    assert code == 0
    results = json.loads((out / "results.json").read_text())
    assert {r["method"] for r in results["runs"]} == {"cmaes", "sa", "sequential"}
    for run in results["runs"]:
        assert set(run) >= {"method", "seed", "budget", "objective", "best_order", "best_peak",
                            "best_peak_continuous", "evaluations", "wall_seconds"}
        assert run["objective"] == "sampled" and run["evaluations"] <= 12
        assert sorted(run["best_order"]) == list(range(1, 12))
        assert run["best_peak_continuous"] >= run["best_peak"]
    best = results["best"]
    # the final answer is the runs' best, improved by single swaps/insertions until none helps
    assert best["peak"] <= min(r["best_peak"] for r in results["runs"])
    local = results["local_optimality"]
    assert local["swaps_checked"] == 55 and local["insertions_checked"] == 90
    assert local["order"] == best["order"] and local["locally_optimal"]
    assert local["nearest_neighbour_gap"] is None or local["nearest_neighbour_gap"] >= 0
    assert local["censored"] > 0 and local["failed"] == 0
    # which model: both rules' optima, each judged by both rules, with the energy flows
    which = results["which_model"]
    assert which["receiver"]["order"] == best["order"]
    for rule in ("receiver", "mean"):
        for judge in ("receiver", "mean"):
            assert which[rule][f"peak_{judge}"] > 0
        assert which[rule]["energy_receiver"]["nonreciprocal_work"] < 0  # the receiver rule's sink
        assert which[rule]["energy_mean"]["nonreciprocal_work"] == pytest.approx(0, abs=1e-6)
    assert which["mean"]["peak_mean"] <= which["receiver"]["peak_mean"]
    # sensitivity: six variations, each with the chosen order's regret against a short search's best
    variations = {v["variation"]: v for v in results["sensitivity"]["variations"]}
    assert len(variations) == 6
    assert variations["load 2x"]["parameters"] == {"F_total": 2400.0}
    for variation in variations.values():
        chosen = variation["orders"]["chosen"]
        assert chosen["regret"] == pytest.approx(chosen["peak"] - variation["best_found"]["peak"])
        assert variation["best_found"]["peak"] <= min(o["peak"] for o in variation["orders"].values()) + 1e-9
    page = (out / "report.html").read_text()
    assert "Which model, which optimum" in page and "How the chosen order holds up" in page
    from orchestrator.ssp import read_design_parameters

    assert results["known_optimum"]["order"] == [1, 10, 9, 6, 4, 5, 7, 8, 3, 2, 11]  # drawn in the convergence
    design = read_design_parameters(out / "best_design.ssp")
    assert [design[f"material[{j}]"] for j in range(1, 12)] == best["order"]
    assert results["accuracy"]["sampled_relative_error"] < 1e-6
    with open(out / "evaluations.csv") as handle:
        rows = list(csv.DictReader(handle))
    assert len(rows) == sum(r["evaluations"] for r in results["runs"])
    assert all(row["status"] == "ok" and math.isfinite(float(row["peak"])) or row["status"] == "censored"
               and row["peak"] == "" for row in rows)
    assert any(row["status"] == "censored" for row in rows)  # the polishing descent stops above its limit
    by_horizon = results["accuracy"]["peak_by_horizon"]
    assert set(by_horizon) == {"0.5", "0.75", "1.0", "2.0"}
    assert by_horizon["1.0"] == pytest.approx(best["peak_sampled"], rel=1e-9)  # contact ends before 1 s
    sweep = results["accuracy"]["work_precision"]
    default = next(p for p in sweep if p["setting"] == "rtol 1e-07")
    assert default["status"] == "ok" and default["rel_error"] < 1e-6
    assert any(p["status"].startswith("failed") for p in sweep)  # RK4 at 0.04 s diverges: an FMI error
    for name in ("convergence.png", "force_energy.png", "lattice.png", "work_precision.png", "report.html"):
        assert (out / name).stat().st_size > 1000
    assert "Best order" in (out / "report.html").read_text()


def test_a_study_where_everything_fails_still_reports(fmu_path, tmp_path):
    config = StudyConfig(methods=("random",), budget=3, repeats=1, executor="serial", out=str(tmp_path),
                         fmu=str(fmu_path), parameters={"F_total": 1200.0, "solver": 1, "fixed_step": 0.05},
                         search_rtol=None, progress=False)
    study = run_study(config)
    assert study.runs[0].n_failed == 3 and study.best_verified() is None
    from orchestrator.report import write_report

    page = write_report(study).read_text()
    assert "No order was evaluated successfully" in page


def test_bad_cli_values_name_the_parameter(capsys):
    with pytest.raises(SystemExit):
        cli.parse_args(["--budget", "0"])
    assert "budget" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        cli.parse_args(["--method", "tabu"])
    assert "tabu" in capsys.readouterr().err


def test_a_study_over_load_cases_reports_each_case_and_the_aggregate(fmu_path, tmp_path):
    from orchestrator.report import results_dict

    config = StudyConfig(methods=("sequential", "sa"), budget=6, repeats=1, executor="serial", out=str(tmp_path),
                         fmu=str(fmu_path), cases={"F_total": [600.0, 2400.0]}, aggregate="worst",
                         local_check=False, which_model=False, sensitivity=False, progress=False)
    study = run_study(config)
    data = results_dict(study, {})
    best = data["best"]
    assert [case["parameters"] for case in best["cases"]] == [{"F_total": 600.0}, {"F_total": 2400.0}]
    assert best["peak"] == max(case["peak"] for case in best["cases"]) and best["aggregate"] == "worst"
    assert data["cases"] == [{"F_total": 600.0}, {"F_total": 2400.0}]
    assert data["objective_description"]["aggregate"] == "worst"
    for run in study.runs:  # every evaluation of a run carries its cases
        assert all(len(e.details["cases"]) == 2 for e in run.evaluations if e.ok)
    with pytest.raises(ValueError, match="aggregate"):
        StudyConfig(aggregate="worst")
