"""Starting designs: every search evaluates them first and starts from them; they are checked against the design
space in one line; the answer says how much better it is than each of them."""

from __future__ import annotations

import json
import tomllib

import numpy as np
import pytest

from command_line import main
from orchestrator.design import DesignSpace
from orchestrator.executors import SerialExecutor
from orchestrator.loop import Evaluator, run_search
from orchestrator.search import SEARCHES, make_search, parse_design
from orchestrator.types import OK, Evaluation

STUDY_BEST = (1, 7, 5, 9, 3, 6, 11, 8, 2, 4, 10)
OTHER = (2, 1, 3, 4, 5, 6, 7, 8, 9, 10, 11)
QUICK = [
    "--budget",
    "12",
    "--repeats",
    "1",
    "--method",
    "cmaes",
    "sequential",
    "--no-sensitivity",
    "--no-progress",
    "--executor",
    "serial",
    "--diagonal-rule",
    "receiver",
]


def weighted(design) -> float:
    return float(sum(column * material for column, material in enumerate(design)))


def two_objectives(design) -> Evaluation:
    values = (weighted(design), float(sum(abs(a - b) for a, b in zip(design, design[1:]))))
    return Evaluation(tuple(design), values[0], OK, values=values)


@pytest.mark.parametrize("method", sorted(SEARCHES))
def test_every_search_evaluates_the_starting_designs_first(method):
    space = DesignSpace(11, 11)
    options = {"objectives": 2} if method == "nsga2" else {}
    search = make_search(method, space, 3, budget=30, starts=[STUDY_BEST, OTHER], **options)
    function = two_objectives if method == "nsga2" else weighted
    run = run_search(search, function, 30, Evaluator(SerialExecutor()), method_name=method, seed=3)
    assert [e.order for e in run.evaluations[:2]] == [STUDY_BEST, OTHER]
    assert all(e.ok for e in run.evaluations[:2])
    assert len({e.order for e in run.evaluations}) == len(run.evaluations)  # no design paid for twice


def test_the_searches_start_from_the_starting_design():
    space = DesignSpace(11, 11)
    cmaes = make_search("cmaes", space, 0, budget=50, starts=[STUDY_BEST]).inner.inner
    assert space.from_keys(cmaes.es.mean) == STUDY_BEST  # pycma's x0, in the random-key encoding
    pso = make_search("pso", space, 0, budget=50, starts=[STUDY_BEST, OTHER]).inner.inner
    assert [space.from_keys(x) for x in pso.x[:2]] == [STUDY_BEST, OTHER]
    ga = make_search("ga", space, 0, budget=50, starts=[STUDY_BEST]).inner.inner
    assert ga.genome.decode(ga.algorithm.ask().get("X")[0]) == STUDY_BEST  # pymoo's sampling
    sa = make_search("sa", space, 0, budget=50, starts=[STUDY_BEST]).inner.inner
    assert sa.ask()[0] == STUDY_BEST
    local = make_search("local", space, 0, budget=50, starts=[STUDY_BEST]).inner
    assert local.start == STUDY_BEST


def test_without_starting_designs_the_searches_ask_as_before():
    space = DesignSpace(8, 8)
    for method in ("cmaes", "pso", "sa", "ga", "de"):
        plain = make_search(method, space, 5, budget=40)
        given = make_search(method, space, 5, budget=40, starts=None)
        assert plain.ask() == given.ask()
    cmaes = make_search("cmaes", space, 5, budget=40).inner
    assert np.allclose(cmaes.es.mean, space.to_keys(space.baseline(), cmaes.dim))


@pytest.mark.parametrize("text, design", [("1,7,5", (1, 7, 5)), ("[1, 7, 5]", (1, 7, 5)), ("1 7 5,", (1, 7, 5))])
def test_a_design_is_written_as_the_material_of_each_column(text, design):
    assert parse_design(text) == design


@pytest.mark.parametrize(
    "argv, named",
    [
        (["--start", "1,2,3"], ["--start [1, 2, 3]", "3 materials for 11 columns", "allowed: every order of 11"]),
        (["--start", "1,1,2,3,4,5,6,7,8,9,10"], ["--start", "material 1 is used twice"]),
        (["--start", "1,seven"], ["--start '1,seven'", "material numbers separated by commas"]),
        (["--start", "1,2,3,4,5,6,7,8,9,10,12"], ["material 12 is not in 1..11"]),
    ],
)
def test_a_starting_design_outside_the_space_is_refused_in_one_line(fmu_path, tmp_path, capfd, argv, named):
    assert main("--fmu", fmu_path, "--out", tmp_path / "r", *QUICK, *argv) == 2
    err = capfd.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    for word in named:
        assert word in err, err
    assert not (tmp_path / "r").exists()


def test_a_start_file_names_the_line_of_a_wrong_design(fmu_path, tmp_path, capfd):
    starts = tmp_path / "starts.txt"
    starts.write_text("# designs we build\n1,7,5,9,3,6,11,8,2,4,10\n\n1,2,3  # too short\n")
    assert main("--fmu", fmu_path, "--out", tmp_path / "r", *QUICK, "--start-file", starts) == 2
    err = capfd.readouterr().err.strip()
    assert f"--start-file {starts}:4 [1, 2, 3]: 3 materials for 11 columns" in err, err


def test_the_answer_says_how_much_better_it_is_than_the_starting_design(fmu_path, tmp_path, capfd):
    out = tmp_path / "r"
    starts = tmp_path / "starts.txt"
    starts.write_text(",".join(map(str, OTHER)) + "\n")
    assert (
        main("--fmu", fmu_path, "--out", out, *QUICK, "--start", ",".join(map(str, STUDY_BEST)), "--start-file", starts)
        == 0
    )
    printed = capfd.readouterr().out
    record = json.loads((out / "results.json").read_text())
    comparisons = record["steps"]["starts"]["comparisons"]
    assert [tuple(c["order"]) for c in comparisons] == [STUDY_BEST, OTHER]
    finalists = record["steps"]["finalists"]["rules"][0]["evaluations"]
    answer = record["answers"][0]
    for comparison in comparisons:
        full = next(e["value"] for e in finalists if tuple(e["order"]) == tuple(comparison["order"]))
        assert comparison["value"] == full and comparison["answer_value"] == answer["peak"]
        assert comparison["improvement"] == pytest.approx(full - answer["peak"])
        assert comparison["improvement"] >= 0  # the starting designs are finalists: the answer is never worse
        assert comparison["improvement_percent"] == pytest.approx(100 * comparison["improvement"] / full)
        line = (
            f"starting design {list(comparison['order'])}: {full:.2f} N under the receiver rule; the answer is "
            f"{comparison['improvement']:.2f} N ({comparison['improvement_percent']:.1f} %) lower"
        )
        assert line in printed, printed
    with (out / "evaluations.csv").open() as handle:
        first = [row.split(",")[4] for row in handle.read().splitlines()[1:] if row.split(",")[3] in ("1", "2")]
    assert first == [" ".join(map(str, STUDY_BEST)), " ".join(map(str, OTHER))] * 2  # cmaes, sequential
    page = (out / "report.html").read_text()
    assert "Against your starting designs" in page and f"{comparisons[0]['improvement_percent']:.1f} %" in page
    study = tomllib.loads((out / "study.toml").read_text())
    assert study["starts"]["start"] == [",".join(map(str, STUDY_BEST))]
    assert study["starts"]["start-file"] == str(starts.resolve())
