"""The objective on the real FMU: both peaks, fidelities, the horizon's fallback, load cases, failures."""

from __future__ import annotations

import pytest

from fmu_src.published import PUBLISHED_PEAKS, SEQUENTIAL_ORDER, STUDY_BEST_ORDER
from orchestrator.design import DesignSpace
from orchestrator.executors import make_executor
from orchestrator.loop import Evaluator, run_search
from orchestrator.objective import FULL, SEARCH, FMURun, LatticeObjective, output_names
from orchestrator.search import make_search

pytestmark = pytest.mark.quick  # a first check: python -m pytest -m quick

SPACE = DesignSpace.permutations(11)


def objective(fmu_path, outputs=("peak_backplate_force",), **kwargs):
    return LatticeObjective(fmu_path, SPACE, 8.0, outputs, **kwargs)


def test_the_objective_reports_both_peaks_and_reproduces_the_study(fmu_path):
    sampled = objective(fmu_path)
    with make_executor("serial") as executor:
        evaluator = Evaluator(executor)
        (evaluation,) = sampled.evaluate([STUDY_BEST_ORDER], evaluator, FULL)
        assert evaluation.ok and sampled.unit == "N"
        assert evaluation.value == pytest.approx(PUBLISHED_PEAKS[STUDY_BEST_ORDER], rel=1e-6)
        outputs = evaluation.outputs
        assert outputs["peak_backplate_force_continuous"] > outputs["peak_backplate_force"] == evaluation.value
        (continuous,) = objective(fmu_path, ("continuous",)).evaluate([STUDY_BEST_ORDER], evaluator, FULL)
        assert continuous.value == outputs["peak_backplate_force_continuous"]
        assert evaluator.simulated == 2  # two objectives, two FMU runs ...
        sampled.evaluate([STUDY_BEST_ORDER], evaluator, FULL)
        assert evaluator.simulated == 2 and evaluator.cache_hits == 1  # ... and asking again costs nothing
        (search,) = sampled.evaluate([STUDY_BEST_ORDER], evaluator, SEARCH)
        assert search.outputs.horizon == 1.0 and search.value == pytest.approx(evaluation.value, rel=1e-4)


def test_a_short_horizon_falls_back_to_the_full_one_while_the_lattice_touches_the_plate(fmu_path):
    short = FMURun(str(fmu_path), horizon=0.3, fallback_horizon=8.0)(SEQUENTIAL_ORDER)
    assert short.outputs.horizon == 8.0  # at 0.3 s the lattice presses on the plate
    assert short.value == pytest.approx(PUBLISHED_PEAKS[SEQUENTIAL_ORDER], rel=1e-6)
    safe = FMURun(str(fmu_path), horizon=1.0, fallback_horizon=8.0)(SEQUENTIAL_ORDER)
    assert safe.outputs.horizon == 1.0 and safe.outputs["last_contact_time"] < 0.9


def test_load_cases_are_one_run_each_and_their_aggregate(fmu_path):
    cases = [{"F_total": 600.0}, {"F_total": 2400.0}]
    worst = LatticeObjective(fmu_path, SPACE, 1.0, cases=cases)
    mean = worst.with_cases(cases, aggregate="mean")
    with make_executor("serial") as executor:
        evaluator = Evaluator(executor)
        (high,) = worst.evaluate([STUDY_BEST_ORDER], evaluator, FULL)
        (average,) = mean.evaluate([STUDY_BEST_ORDER], evaluator, FULL)
        assert evaluator.simulated == 2  # the mean reused both cases' runs
    peaks = [case.value for case in high.cases]
    assert [case.parameters for case in high.cases] == cases
    assert peaks[1] > 2 * peaks[0] and high.value == max(peaks)
    assert average.value == pytest.approx(sum(peaks) / 2)
    failing = worst.with_cases([{"F_total": 600.0}, {"solver": "rk4", "fixed_step": 0.05}])
    with make_executor("serial") as executor:
        (broken,) = failing.evaluate([STUDY_BEST_ORDER], Evaluator(executor), FULL)
    assert not broken.ok and broken.value is None and "fixed_step" in broken.message


def test_a_failing_fmu_evaluation_is_recorded_not_a_number(fmu_path):
    diverging = FMURun(str(fmu_path), horizon=1.0, parameters=(("fixed_step", 0.05), ("solver", "rk4")))
    evaluation = diverging(SEQUENTIAL_ORDER)
    assert evaluation.status == "failed" and evaluation.value is None
    assert "diverged" in evaluation.message or "non-finite" in evaluation.message
    with make_executor("serial") as executor:
        run = run_search(make_search("random", SPACE, seed=0), diverging, 5, executor, method_name="random", seed=0)
    assert run.n_evaluations == 5 and run.failed == 5 and run.best_value is None


def test_two_outputs_make_a_two_objective_evaluation_without_force_limits(fmu_path):
    if not _has(fmu_path, "max_compression"):
        pytest.skip("this FMU has no max_compression output")
    both = objective(fmu_path, ("sampled", "max_compression"))
    assert both.n_objectives == 2 and not both.supports_limits
    with make_executor("serial") as executor:
        (evaluation,) = both.evaluate([STUDY_BEST_ORDER], Evaluator(executor), FULL)
    assert evaluation.values[0] == evaluation.value == evaluation.outputs["peak_backplate_force"]
    assert evaluation.values[1] == evaluation.outputs["max_compression"] > 0


def _has(fmu_path, name):
    from orchestrator.simulation import model_description

    return any(v.name == name for v in model_description(fmu_path).modelVariables)


@pytest.mark.parametrize(
    "text, expected",
    [
        ("sampled", ("peak_backplate_force",)),
        ("continuous,max_compression", ("peak_backplate_force_continuous", "max_compression")),
    ],
)
def test_objective_names(text, expected):
    assert output_names(text) == expected


@pytest.mark.parametrize("text", ["stroke", "sampled,sampled", "a,b,c,d", ""])
def test_unknown_or_repeated_objectives_are_refused(text):
    with pytest.raises(ValueError, match="objective"):
        output_names(text)


def test_dask_gives_the_same_search_as_a_process_pool(fmu_path):
    function = FMURun(str(fmu_path), horizon=1.0, parameters=(("atol", 1e-8), ("rtol", 1e-6)))
    results = {}
    for kind in ("process", "dask"):
        with make_executor(kind, workers=2) as executor:
            run = run_search(make_search("cmaes", SPACE, seed=3), function, 16, executor, method_name="cmaes", seed=3)
        results[kind] = [(e.order, e.value) for e in run.evaluations]
    assert results["dask"] == results["process"] and len(results["dask"]) == 16


def test_a_resumed_run_knows_at_each_point_only_what_the_interrupted_run_knew_there(fmu_path, tmp_path):
    """A censored evaluation, then the same design's exact value later in the run: resumed, the censored ask
    is answered censored again (from the journal), not with the exact value the journal also holds, so a search
    is told what it was told and nothing is simulated anew."""
    from orchestrator.journal import Journal
    from orchestrator.types import Evaluation

    lattice = objective(fmu_path)
    limit = 0.5 * PUBLISHED_PEAKS[SEQUENTIAL_ORDER]

    def the_run(resume):
        with (
            make_executor("serial") as executor,
            Journal(tmp_path, {"run": 1}, {"evaluation": Evaluation}, resume=resume) as journal,
        ):
            evaluator = Evaluator(executor, journal)
            (first,) = lattice.evaluate([SEQUENTIAL_ORDER], evaluator, SEARCH, limits=[limit])
            (later,) = lattice.evaluate([SEQUENTIAL_ORDER], evaluator, SEARCH)
            (again,) = lattice.evaluate([SEQUENTIAL_ORDER], evaluator, SEARCH, limits=[limit])
            return first, later, again, evaluator.simulated

    first, later, again, simulated = the_run(resume=False)
    assert first.censored and later.ok and again.ok and simulated == 2  # an exact value, once known, is used
    resumed = the_run(resume=True)
    assert resumed[0].censored and resumed[1].ok and resumed[2].ok and resumed[3] == 0
