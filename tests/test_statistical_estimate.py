"""The report's statistical estimate (--statistical-bound N): where no sweep fits, how far the answer may lie
above the optimum, named as a statistical estimate and never as a certificate."""

from __future__ import annotations

import json

import pytest

from command_line import main, one_line
from orchestrator.steps.statistical_estimate import StatisticalEstimateConfig

COMMON = ["--no-sensitivity", "--no-progress", "--executor", "serial", "--no-local-check"]


def test_the_answer_gets_a_statistical_estimate_never_called_certified(armour_fmu_of_width, tmp_path, capfd):
    out = tmp_path / "out"
    fmu = armour_fmu_of_width(6)
    args = ["--fmu", fmu, "--cols", 6, "--method", "sa", "--budget", 60, "--repeats", 1, *COMMON]
    assert main(*args, "--out", out, "--statistical-bound", 200) == 0
    console = capfd.readouterr().out
    lines = [line.strip() for line in console.splitlines() if line.strip().startswith("statistical estimate from")]
    assert len(lines) == 2  # one under each diagonal rule
    assert all("certified" not in line and "not a certificate" in line for line in lines)
    record = json.loads((out / "results.json").read_text())
    estimates = record["steps"]["statistical_estimate"]["estimates"]
    assert [e["diagonal_rule"] for e in estimates] == [a["diagonal_rule"] for a in record["answers"]]
    for estimate in estimates:
        assert estimate["designs"] == 200 and "not a certificate" in estimate["kind"]
        assert estimate["best_seen"] >= estimate["estimate"]
        assert estimate["lower"] is None or estimate["lower"] <= estimate["estimate"]
        assert estimate["answer_value"] >= estimate["estimate"]
    html = (out / "report.html").read_text()
    section = html[html.index('id="statistical-estimate"') :]
    section = section[: section.index("</table>")]
    assert "This is a statistical estimate, not a certificate" in section and "certified" not in section
    assert "--method exhaustive</code> certifies" in html  # 720 orders: a sweep would certify instead

    assert main(*args, "--out", tmp_path / "plain") == 0  # without the option: no estimate, no section
    plain = json.loads((tmp_path / "plain" / "results.json").read_text())
    assert "statistical_estimate" not in plain["steps"]
    assert 'id="statistical-estimate"' not in (tmp_path / "plain" / "report.html").read_text()


@pytest.mark.parametrize("designs", [1, 99])
def test_too_few_random_designs_are_refused_in_one_line(designs, capfd, tmp_path):
    with pytest.raises(ValueError, match="at least 100"):
        StatisticalEstimateConfig(designs=designs)
    assert main("--statistical-bound", designs, "--out", tmp_path / "out", *COMMON) == 2
    assert "--statistical-bound must be 0 (none) or at least 100 random designs" in one_line(capfd)


def test_a_space_too_small_to_fit_says_why_and_keeps_the_answer(armour_fmu_of_width, tmp_path, capfd):
    out = tmp_path / "out"  # 2 columns: 2 designs, so the smallest random values are all one design's
    fmu = armour_fmu_of_width(2)
    assert (
        main(
            "--fmu",
            fmu,
            "--cols",
            2,
            "--method",
            "sa",
            "--budget",
            2,
            "--repeats",
            1,
            *COMMON,
            "--diagonal-rule",
            "mean",
            "--out",
            out,
            "--statistical-bound",
            100,
        )
        == 0
    )
    console = capfd.readouterr().out
    assert "statistical estimate: mean rule: no estimate (the" in console and "all equal" in console
    record = json.loads((out / "results.json").read_text())
    assert record["answers"] and record["steps"]["statistical_estimate"]["estimates"] == []
