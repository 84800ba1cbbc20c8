"""The study file: every run writes study.toml; --study runs it again, to the same evaluations in the same order;
a wrong key or value is refused in one line naming the file's line, the key and the allowed values."""

from __future__ import annotations

import csv
import json
import re
import tomllib
from pathlib import Path

import pytest

from fmu_src.materials import Material, MaterialTable, study_materials, write_materials_csv
from command_line import main
from orchestrator.options import NOT_KEPT, flag_of
from orchestrator.studyfile import StudyFileError, read_study_file, render_study_file, sections, write_study_file
from orchestrator.study import CaseConfig
from orchestrator.steps.finalists import FinalistsConfig
from orchestrator.steps.searches import SearchesConfig

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
    "--diagonal-rule",
    "mean",
]


def rows(path: Path) -> list[dict]:
    """evaluations.csv without its seconds (a run's own timing)."""
    with path.open() as handle:
        return [{k: v for k, v in row.items() if k != "seconds"} for row in csv.DictReader(handle)]


def answers(path: Path) -> list[tuple]:
    record = json.loads((path / "results.json").read_text())
    return [(a["diagonal_rule"], tuple(a["order"]), a["peak"]) for a in record["answers"]]


METHODS = ["cmaes", "pso", "sa", "random", "sequential"]


@pytest.fixture(scope="module")
def first(fmu_path, tmp_path_factory):
    """A run of five methods, a seed and a starting design: the study file to run again."""
    out = tmp_path_factory.mktemp("study") / "results"
    assert (
        main(
            "--fmu",
            fmu_path,
            "--out",
            out,
            "--executor",
            "serial",
            *QUICK,
            "--method",
            *METHODS,
            "--seed",
            "4",
            "--start",
            "1,7,5,9,3,6,11,8,2,4,10",
        )
        == 0
    )
    return out


def test_a_study_file_runs_again_to_the_same_evaluations_and_answers(fmu_path, first, tmp_path, capfd):
    again = tmp_path / "again"
    methods = METHODS
    study = first / "study.toml"
    data = tomllib.loads(study.read_text())
    assert data["searches"]["budget"] == 12 and data["searches"]["method"] == methods
    assert data["searches"]["seed"] == 4 and data["starts"]["start"] == ["1,7,5,9,3,6,11,8,2,4,10"]
    assert data["case"]["diagonal-rule"] == ["mean"] and data["sensitivity"]["no-sensitivity"] is True
    assert "executor" not in data["run"] and "out" not in data["run"]  # changes no number / one invocation
    assert Path(data["case"]["fmu"]) == Path(fmu_path).resolve()  # outside the project folder: absolute
    assert data["recorded"]["fmu-sha256"] and data["recorded"]["materials-sha256"]
    capfd.readouterr()
    assert main("--study", study, "--out", again, "--no-progress", "--workers", "2") == 0
    assert capfd.readouterr().err.count("note:") == 0  # the same FMU: no note
    assert {r["method"] for r in rows(first / "evaluations.csv")} == set(methods)
    assert rows(again / "evaluations.csv") == rows(first / "evaluations.csv")  # another executor, the same rows
    assert answers(again) == answers(first) and answers(first)
    assert tomllib.loads((again / "study.toml").read_text()) == data  # the same study, the same file


def test_the_command_line_overrides_the_study_file(first, tmp_path):
    assert (
        main(
            "--study",
            first / "study.toml",
            "--out",
            tmp_path / "b",
            "--budget",
            "5",
            "--no-progress",
            "--executor",
            "serial",
        )
        == 0
    )
    assert tomllib.loads((tmp_path / "b" / "study.toml").read_text())["searches"]["budget"] == 5
    runs = {(r["method"], r["seed"]) for r in rows(tmp_path / "b" / "evaluations.csv")}
    assert ("cmaes", "4") in runs and {m for m, _ in runs} == set(METHODS)  # the rest is the file's
    assert max(int(r["index"]) for r in rows(tmp_path / "b" / "evaluations.csv") if r["method"] == "cmaes") <= 5


def bad_study(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "study.toml"
    path.write_text(text)
    return path


@pytest.mark.parametrize(
    "text, line, named",
    [
        ("[searches]\nbudget = 10\nbudgett = 12\n", 3, ["[searches] budgett", "allowed: method, budget, seed"]),
        ("[searches]\n\nbudget = 0\n", 3, ["[searches] budget", "at least 1"]),
        ('[searches]\nmethod = ["cmaes", "nelder"]\n', 2, ["method", "allowed values are cmaes", "nelder"]),
        ("[case]\nobjective = 3\n", 2, ["objective", "string"]),
        ('[case]\nrepeat = "yes"\n', 2, ["repeat", "true or false"]),
        ('[case]\nload = "heavy"\n', 2, ["[case] load", "--load must be a number"]),
        ('[run]\nexecutor = "cloud"\n', 2, ["[run] executor", "allowed values are", "process"]),
        ('[run]\nout = "elsewhere"\n', 2, ["[run] out", "allowed: "]),  # one invocation's: not a study's key
        ("[case]\n[solver]\nrtol = 1\n", 2, ["[solver]", "allowed: [case], [searches]"]),
        ('scene = "armour_11x11"\n', 1, ["scene", "belongs to a section"]),
        ('[recorded]\nfmu = "x"\n', 2, ["[recorded] fmu", "materials-sha256, fmu-sha256"]),
        ("[searches]\nfinalists = 2\n", 2, ["[searches] finalists", "an option of [finalists]"]),
        ("[case]\ncols = 65\n", 2, ["[case] cols", "--cols must be at least 2 and at most 64, got 65"]),
    ],
)
def test_a_wrong_key_or_value_is_refused_in_one_line_naming_its_line(tmp_path, capfd, text, line, named):
    path = bad_study(tmp_path, text)
    assert main("--study", path, "--out", tmp_path / "r") == 2
    err = capfd.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    assert f"{path}:{line}:" in err, err
    for word in named:
        assert word in err, err
    assert not (tmp_path / "r").exists() and not (tmp_path / "r.partial").exists()


@pytest.mark.parametrize(
    "flag, text, config_type, field, value",
    [
        ("--cols", "65", CaseConfig, "cols", 65),
        ("--cols", "1", CaseConfig, "cols", 1),
        ("--seed", "-1", SearchesConfig, "seed", -1),
        ("--seed", str(2**32), SearchesConfig, "seed", 2**32),
        ("--finalists", "0", FinalistsConfig, "per_run", 0),
        ("--search-rtol", "0.5", CaseConfig, "search_rtol", 0.5),
    ],
)
def test_a_value_is_refused_alike_from_the_command_line_a_study_file_and_python(
    tmp_path, capfd, flag, text, config_type, field, value
):
    """One rule and one message per option, whatever the value came from."""
    with pytest.raises(ValueError) as python:
        config_type(**{field: value})
    message = str(python.value)
    assert message.startswith(flag) and len(message.splitlines()) == 1, message
    assert main(flag, text, "--out", tmp_path / "r") == 2
    assert message in capfd.readouterr().err
    section = next(name for name, kind in sections() if kind is config_type)
    with pytest.raises(StudyFileError, match=re.escape(message)):
        read_study_file(bad_study(tmp_path, f"[{section}]\n{flag[2:]} = {text}\n"))


def test_a_study_file_that_is_not_toml_is_refused(tmp_path, capfd):
    assert main("--study", bad_study(tmp_path, "[case\n"), "--out", tmp_path / "r") == 2
    assert "not a TOML file" in capfd.readouterr().err


def test_every_option_of_every_config_is_a_key_of_the_file(tmp_path):
    """The keys come from the configs' options: every option a study keeps is written (set or as a comment)."""
    text = render_study_file({}, tmp_path, "0" * 64, "1" * 64)
    tomllib.loads(text)
    for section, config_type in sections():
        assert f"\n[{section}]\n" in text
        for name, field in config_type.__dataclass_fields__.items():
            if "option" not in field.metadata or field.metadata["option"]["study"] == NOT_KEPT:
                continue
            assert f"# {flag_of(config_type, name)[2:]}: " in text, (section, name)


def test_values_round_trip_through_the_file_paths_relative_to_it(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # the project folder: its files are written relative to the study file
    table = MaterialTable((Material("soft", 10.0, 5.0, 1.0, 10.0, 10.0), *study_materials(11).materials[1:]))
    materials = write_materials_csv(table, tmp_path / "mine.csv")
    case = CaseConfig(
        materials=str(materials),
        load=600.0,
        load_angle=12.5,
        case=("t_active=0.1,0.2",),
        aggregate="mean",
        diagonal_rules=("mean", "receiver"),
        horizon=4.0,
        objective="continuous",
    )
    searches = SearchesConfig(methods=("pso", "ga"), budget=40, seed=7, repeats=2)
    folder = tmp_path / "study" / "results.partial"
    folder.mkdir(parents=True)
    path = write_study_file(folder, {CaseConfig: case, SearchesConfig: searches}, table.sha256(), "f" * 64)
    assert tomllib.loads(path.read_text())["case"]["materials"] == "../../mine.csv"  # from results/, not .partial
    moved = tmp_path / "study" / "results"
    folder.rename(moved)
    study = read_study_file(moved / "study.toml")
    assert study.values == {
        "CaseConfig.materials": str(moved / "../../mine.csv"),
        "CaseConfig.load": 600.0,
        "CaseConfig.load_angle": 12.5,
        "CaseConfig.case": ["t_active=0.1,0.2"],
        "CaseConfig.aggregate": "mean",
        "CaseConfig.diagonal_rules": ("mean", "receiver"),
        "CaseConfig.horizon": 4.0,
        "CaseConfig.objective": "continuous",
        "SearchesConfig.methods": ("pso", "ga"),
        "SearchesConfig.budget": 40,
        "SearchesConfig.seed": 7,
        "SearchesConfig.repeats": 2,
    }
    study.check_materials(table)
    other = MaterialTable((Material("soft", 11.0, 5.0, 1.0, 10.0, 10.0), *table.materials[1:]))
    with pytest.raises(StudyFileError, match=r"study.toml:\d+: \[recorded\] materials-sha256"):
        study.check_materials(other)
    assert study.fmu_note("f" * 64) is None and "another build" in study.fmu_note("e" * 64)


def test_a_start_file_changed_since_the_study_ran_is_refused(tmp_path, monkeypatch):
    from orchestrator.steps.starts import StartsConfig

    monkeypatch.chdir(tmp_path)
    starts = tmp_path / "starts.txt"
    starts.write_text("1,7,5,9,3,6,11,8,2,4,10\n")
    folder = tmp_path / "results"
    folder.mkdir()
    path = write_study_file(folder, {StartsConfig: StartsConfig(start_file=str(starts))}, "0" * 64, "1" * 64)
    data = tomllib.loads(path.read_text())
    assert data["starts"]["start-file"] == "../starts.txt" and len(data["recorded"]["start-file-sha256"]) == 64
    assert read_study_file(path).values == {"StartsConfig.start_file": str(folder / "../starts.txt")}
    starts.write_text("1,2,3,4,5,6,7,8,9,10,11\n")
    with pytest.raises(
        StudyFileError,
        match=r"study.toml:\d+: \[recorded\] start-file-sha256: .*starts.txt has "
        r"changed since the study was run",
    ):
        read_study_file(path)
