"""The smaller seams a user meets around an answer: --cols without a table says what it takes, ..."""

from __future__ import annotations

import pytest

from command_line import main
from orchestrator.scene import narrowed_table_note
from orchestrator.study import CaseConfig

COMMON = ["--no-sensitivity", "--no-progress", "--executor", "serial"]


def test_cols_without_a_table_says_in_one_line_that_it_takes_the_first_materials_and_how_to_choose():
    note = narrowed_table_note(CaseConfig(cols=5))
    assert note == (
        "note: --cols 5 without --materials takes the first 5 of the study's 11 materials (m1..m5: 120 "
        "designs), as the study's narrower lattices and their known optima do; to choose 5 of the 11 "
        "(55,440 designs), give the study's table as --materials FILE (its values: docs/model.md "
        "section 3)"
    )
    assert "(161,051 designs)" in narrowed_table_note(CaseConfig(cols=5, repeat=True))
    for quiet in (
        CaseConfig(),
        CaseConfig(cols=11),
        CaseConfig(cols=5, fmu="given.fmu"),
        CaseConfig(cols=5, materials="table.csv"),
    ):
        assert narrowed_table_note(quiet) is None


def test_a_run_with_cols_and_no_table_prints_the_note(tmp_path, monkeypatch, capfd):
    monkeypatch.chdir(tmp_path)  # the scene's FMU is built into models/ here
    assert main("--cols", 3, "--out", tmp_path / "out", *COMMON) == 0
    err = capfd.readouterr().err
    assert "note: --cols 3 without --materials takes the first 3 of the study's 11 materials (m1..m3: 6 designs)" in err
    html = (tmp_path / "out" / "report.html").read_text()  # a sweep of one objective: no searches, no front
    link = html[html.index('<a href="explore.html">Explore') :]
    link = link[: link.index("</p>")]
    assert "a sortable table of every evaluation and each design&#39;s lattice" in link
    assert "Pareto" not in link and "convergence" not in link
    explore = (tmp_path / "out" / "explore.html").read_text()
    assert 'id="design-hint">Click a row of the table.</p>' in explore


def test_a_two_objective_run_writes_best_design_ssp_as_the_knee_of_its_front(armour_fmu_of_width, tmp_path, capfd):
    import json

    import numpy as np

    from orchestrator.ssp import read_design_parameters
    from orchestrator.steps.pareto import knee

    out = tmp_path / "out"
    assert (
        main(
            "--fmu",
            armour_fmu_of_width(4),
            "--cols",
            4,
            "--out",
            out,
            "--objective",
            "sampled,max_compression",
            "--diagonal-rule",
            "mean",
            "--budget",
            12,
            "--repeats",
            1,
            *COMMON,
        )
        == 0
    )
    printed = capfd.readouterr().out
    (front,) = json.loads((out / "results.json").read_text())["steps"]["pareto"]["fronts"]
    points = front["points"]
    order = points[knee(np.array([p["values"] for p in points]))]["order"]
    written = read_design_parameters(out / "best_design.ssp")
    assert [written[f"material[{j}]"] for j in range(1, 5)] == order
    assert f"best_design.ssp: the knee of the mean rule's front, {order}" in printed
    html = (out / "report.html").read_text()
    assert '<a href="best_design.ssp">best_design.ssp</a> holds the knee of the mean rule' in html
    assert (
        "Explore every run and every evaluation</a>: convergence by method and seed, a sortable table of every "
        "evaluation, the Pareto front and each design&#39;s lattice"
    ) in html
    explore = (out / "explore.html").read_text()
    assert 'id="design-hint">Click a row of the table or a point of the front.</p>' in explore


@pytest.mark.parametrize(
    "text, expected",
    [
        ('[searches]\nmethod = "cmaes"\n', {"SearchesConfig.methods": ("cmaes",)}),
        ('[searches]\nmethod = ["cmaes", "pso"]\n', {"SearchesConfig.methods": ("cmaes", "pso")}),
        ('[case]\ndiagonal-rule = "mean"\n', {"CaseConfig.diagonal_rules": ("mean",)}),
    ],
)
def test_a_study_file_takes_a_single_value_where_a_list_is_meant(tmp_path, text, expected):
    from orchestrator.studyfile import read_study_file

    path = tmp_path / "study.toml"
    path.write_text(text)
    assert read_study_file(path).values == expected


def test_a_study_file_still_refuses_a_wrong_single_value_for_a_list(tmp_path):
    from orchestrator.studyfile import StudyFileError, read_study_file

    path = tmp_path / "study.toml"
    path.write_text('[searches]\nmethod = "nelder"\n')
    with pytest.raises(StudyFileError, match=r"study.toml:2: .*method.*allowed values are cmaes"):
        read_study_file(path)


def test_resuming_with_another_build_of_the_fmu_names_it_as_such(armour_fmu_of_width, tmp_path, capfd):
    """The same model built again (here: one more file in the archive) has another SHA-256: --resume refuses it
    in one line that says it is another build and what to do, not with two raw hashes."""
    import re
    import shutil
    import zipfile

    fmu = armour_fmu_of_width(3)
    out = tmp_path / "out"
    assert main("--fmu", fmu, "--cols", 3, "--out", out, *COMMON) == 0
    rebuilt = tmp_path / "rebuilt.fmu"
    shutil.copy(fmu, rebuilt)
    with zipfile.ZipFile(rebuilt, "a") as archive:
        archive.writestr("documentation/build.txt", "built again")
    capfd.readouterr()
    assert main("--fmu", rebuilt, "--cols", 3, "--out", out, "--resume", *COMMON) == 2
    err = capfd.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert f"--resume: {rebuilt} is another build than the FMU the run in {out} started with" in err
    assert "--overwrite" in err and not re.search(r"[0-9a-f]{16}", err)


def test_an_answer_over_load_cases_names_them_beside_its_start_values(armour_fmu_of_width, tmp_path, capfd):
    """Its value is an aggregate over runs: the start values alone give one of them, so the line names the cases."""
    out = tmp_path / "out"
    assert (
        main(
            "--fmu",
            armour_fmu_of_width(3),
            "--cols",
            3,
            "--out",
            out,
            "--diagonal-rule",
            "mean",
            "--case",
            "F_total=600,1200",
            *COMMON,
        )
        == 0
    )
    line = next(line for line in capfd.readouterr().out.splitlines() if "in any FMI tool:" in line)
    assert (
        "diagonal_rule=1, with each load case of F_total = [600.0, 1200.0] (the value is the worst of their "
        "runs), stop time 8 s"
    ) in line
    html = (out / "report.html").read_text()
    assert "with each load case of F_total = [600.0, 1200.0] (the value is the worst of their runs)" in html
