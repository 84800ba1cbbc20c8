"""The answers a designer takes away: the mean rule's design first (the file to build), the receiver rule's beside
it as the study's model; known optima looked up per rule; what a certificate covers; a runner-up equivalent
within sampling; what would settle an answer few runs reached; a small space swept and certified by default."""

from __future__ import annotations

import json
from itertools import permutations
from types import SimpleNamespace

import pytest

from fmu_src.materials import study_materials
from orchestrator import known_optima as known_optima_module
from command_line import main
from orchestrator.design import DesignSpace
from orchestrator.known_optima import known_optimum
from orchestrator.simulation import LatticeFMU
from orchestrator.steps.answers import Equivalence, Evidence
from orchestrator.types import RunOutputs

COMMON = ["--no-sensitivity", "--no-progress", "--executor", "serial"]


def brute_force(fmu, columns, rule):
    """Every order's sampled peak at full fidelity under ``rule``, best first."""
    with LatticeFMU(fmu) as lattice:
        values = {
            o: lattice.simulate(o, 8.0, {"diagonal_rule": rule})["peak_backplate_force"]
            for o in permutations(range(1, columns + 1))
        }
    return sorted(values.items(), key=lambda item: item[1])


def entry(columns, rule, ranked, source):
    (order, peak), (runner, runner_peak) = ranked[:2]
    return {
        "rows": 11,
        "columns": columns,
        "objective": "peak_backplate_force",
        "diagonal_rule": rule,
        "horizon": 8.0,
        "order": list(order),
        "peak": peak,
        "certified": True,
        "runner_up": {"order": list(runner), "peak": runner_peak},
        "source": source,
        "command": f"python orchestrator/run.py --method exhaustive --cols {columns} --diagonal-rule {rule}",
    }


def test_a_known_optimum_is_looked_up_per_rule(tmp_path, monkeypatch):
    case = SimpleNamespace(
        outputs=("peak_backplate_force",),
        parameters={},
        case_lists={},
        rows=11,
        columns=4,
        horizon=8.0,
        space=DesignSpace.permutations(4),
        materials=study_materials(4),
        depth=1,
        departures=(),
    )
    mean = entry(4, "mean", [((1, 2, 3, 4), 2.0), ((2, 1, 3, 4), 3.0)], "mean sweep")
    receiver = entry(4, "receiver", [((4, 3, 2, 1), 1.0), ((3, 4, 2, 1), 1.5)], "receiver sweep")
    table = tmp_path / "known.json"
    for entries in ([mean, receiver], [receiver, mean]):  # whatever the order of the entries
        table.write_text(json.dumps({"optima": entries}))
        monkeypatch.setattr(known_optima_module, "TABLE", table)
        assert known_optimum(case, "mean").order == (1, 2, 3, 4)
        assert known_optimum(case, "receiver").order == (4, 3, 2, 1)
    assert known_optimum(SimpleNamespace(**{**case.__dict__, "horizon": 4.0}), "mean") is None
    # a plate of the same columns, or an FMU whose own defaults are not the study's (a patch), is another case
    assert known_optimum(SimpleNamespace(**{**case.__dict__, "depth": 3}), "mean") is None
    assert known_optimum(SimpleNamespace(**{**case.__dict__, "departures": ("load_patch",)}), "mean") is None


def test_the_mean_rule_is_the_design_file_and_a_mean_certificate_is_honoured(
    armour_fmu_of_width, tmp_path, monkeypatch, capfd
):
    """A recorded mean-rule optimum (the brute force of a small case, as the 11 x 11 one will be recorded) makes
    the mean answer certified although the searches are too short to reach it; the receiver rule, with no
    entry, is the study's model beside it, best found, with what would settle it."""
    fmu = armour_fmu_of_width(4)
    ranked = brute_force(fmu, 4, "mean")
    table = tmp_path / "known.json"
    table.write_text(json.dumps({"optima": [entry(4, "mean", ranked, "the test's brute force of 24 orders")]}))
    monkeypatch.setattr(known_optima_module, "TABLE", table)
    out = tmp_path / "out"
    assert (
        main("--fmu", fmu, "--cols", 4, "--out", out, "--method", "cmaes", "--budget", 1, "--repeats", 4, *COMMON) == 0
    )
    printed = capfd.readouterr().out
    results = json.loads((out / "results.json").read_text())
    mean, receiver = results["answers"]
    assert (mean["diagonal_rule"], receiver["diagonal_rule"]) == ("mean", "receiver")
    assert mean["design_file"] == "best_design.ssp" and receiver["design_file"] == "design_receiver.ssp"
    assert mean["roles"] == ["your design file"]
    assert receiver["roles"] == ["the study's model: reproduces its published numbers"]
    assert tuple(mean["order"]) == ranked[0][0] and mean["peak"] == pytest.approx(ranked[0][1], rel=1e-6)
    assert mean["evidence"]["status"] == "certified" and "the test's brute force" in mean["evidence"]["status_source"]
    assert mean["evidence"]["covers"] == "the sampled peak (0.01 s samples) over 8 s under the mean rule"
    assert tuple(mean["runner_up"]) == ranked[1][0]
    assert mean["equivalence"]["runner_up_outputs"] is not None  # the runner-up evaluated, not read from the table
    assert receiver["evidence"]["status"] == "best_found"
    for answer in (mean, receiver):  # no run reached it on its own: it came from elsewhere, and the line says where
        found_by = answer["evidence"]["found_by"]
        assert (found_by == "the searches' runs") == (answer["evidence"]["runs_reaching"] > 0)
        assert found_by == "the searches' runs" or f"found by {found_by};" in printed
    lines = printed.splitlines()
    first = next(i for i, line in enumerate(lines) if line.startswith("mean rule (your design file): build"))
    assert "certified for the sampled peak (0.01 s samples)" in lines[first]
    assert first < next(i for i, line in enumerate(lines) if line.startswith("receiver rule (the study's model"))
    evidence = receiver["evidence"]
    assert 2 * evidence["runs_reaching"] < evidence["runs"] == 4
    settle = evidence["settlement"]
    assert settle["budget"] == 10 and settle["sweep"]["designs"] == 24
    assert settle["sweep"]["designs_per_core_second"] > 0
    assert "to settle it: `--budget 10`" in printed and "`--method exhaustive`" in printed
    html = (out / "report.html").read_text()
    first_screen = html[: html.index("</table>")]
    assert first_screen.index("mean rule (your design file)") < first_screen.index("receiver rule (the study")
    assert "--diagonal-rule receiver</code> makes its order the design file" in first_screen


def test_a_small_space_is_swept_and_certified_by_default(armour_fmu_of_width, tmp_path, capfd):
    out = tmp_path / "out"
    assert main("--fmu", armour_fmu_of_width(3), "--cols", 3, "--out", out, *COMMON) == 0
    printed = capfd.readouterr().out
    results = json.loads((out / "results.json").read_text())
    assert "searches" not in results["steps"] and len(results["steps"]["exhaustive"]["sweeps"]) == 2
    for answer in results["answers"]:
        assert answer["evidence"]["status"] == "certified" and answer["evidence"]["swept"]
        assert answer["evidence"]["runs"] == 0
    assert printed.count("certified for the sampled peak") == 2 and "every design swept" in printed
    certificate = json.loads((out / "exhaustive" / "certificate.json").read_text())
    assert certificate["certified"] and certificate["objective"] == (
        "the sampled peak (0.01 s samples) over 8 s under the mean rule"
    )
    html = (out / "report.html").read_text()
    assert "distinct designs per seed" not in html and "best found" not in html


def test_an_explicit_sweep_alone_runs_no_search(armour_fmu_of_width, tmp_path, capfd):
    out = tmp_path / "out"
    assert (
        main(
            "--fmu",
            armour_fmu_of_width(3),
            "--cols",
            3,
            "--out",
            out,
            "--method",
            "exhaustive",
            "--diagonal-rule",
            "receiver",
            *COMMON,
        )
        == 0
    ), capfd.readouterr().err
    results = json.loads((out / "results.json").read_text())
    assert "searches" not in results["steps"] and results["answers"][0]["evidence"]["status"] == "certified"


def outputs(sampled, continuous):
    return RunOutputs(
        {
            "peak_backplate_force": sampled,
            "peak_backplate_force_continuous": continuous,
            "peak_time": 0.3,
            "last_contact_time": 1.0,
        },
        8.0,
    )


@pytest.mark.quick
def test_a_runner_up_closer_than_sampling_decides_is_equivalent():
    close = Equivalence(gap=0.0066, sampling=9.6, integration=1e-3, runner_up_outputs=outputs(1405.91, 1415.44))
    assert close.equivalent and "less than the 9.60 N between the sampled and the continuous peak" in close.reason("N")
    far = Equivalence(gap=12.0, sampling=9.6, integration=1e-3, runner_up_outputs=None)
    assert not far.equivalent
    within_integration = Equivalence(gap=1e-4, sampling=None, integration=1e-3, runner_up_outputs=None)
    assert within_integration.equivalent and "integration error" in within_integration.reason("m")


@pytest.mark.quick
def test_the_evidence_says_where_an_answer_came_from_before_counting_the_runs():
    """A certified answer the final descent found, which no run reached on its own, says so: "certified ... 0 of 9
    runs reached it" alone would read as a contradiction."""
    from orchestrator.steps.answers import FOUND_BY_DESCENT, FOUND_BY_KNOWN

    descended = Evidence(0, 9, True, "certified", "", found_by=FOUND_BY_DESCENT).origin()
    assert descended == "found by the final descent from the runs' best; 0 of 9 runs reached it on their own"
    known = Evidence(1, 9, True, "best_found", "", found_by=FOUND_BY_KNOWN).origin()
    assert (
        known.startswith("found by the recorded known optimum") and "only 1 of 9 runs reached it on their own" in known
    )
    assert Evidence(3, 9, True, "best_found", "").origin() == "only 3 of 9 runs reached it"
    assert Evidence(0, 0, None, "certified", "", swept=True).origin() == "every design swept"
    capped = Evidence(0, 3, None, "best_found", "", local_unchecked="the local check stopped at its cap")
    assert capped.local_text() == "local optimum not checked (the local check stopped at its cap)"
    assert Evidence(0, 3, False, "best_found", "").local_text() == "not a local optimum"


@pytest.mark.quick
def test_few_runs_is_under_half_and_never_for_a_certified_answer():
    assert Evidence(4, 9, True, "best_found", "").few_runs
    assert not Evidence(5, 9, True, "best_found", "").few_runs
    assert not Evidence(1, 9, True, "certified", "").few_runs
    assert not Evidence(0, 0, True, "best_found", "").few_runs


def test_a_refused_sweep_projects_its_cost_from_the_censored_rate_it_will_meet(fmu_path, tmp_path, capfd):
    """The 11 x 11 sweep off Dask is refused with a projection timed on a chunk run as the sweep runs its chunks:
    the force limit at an incumbent's threshold, so most of the timed designs are censored, as in the sweep."""
    import re

    code = main(
        "--fmu", fmu_path, "--out", tmp_path / "out", "--method", "exhaustive", "--diagonal-rule", "receiver", *COMMON
    )
    err = [line for line in capfd.readouterr().err.splitlines() if line.strip()]
    assert code == 2 and len(err) == 1, err
    found = re.search(
        r"projected ([\d,.]+) core-hours at ([\d,]+) designs per core-second \(measured here on "
        r"(\d+) designs, (\d+) stopped at the force limit",
        err[0],
    )
    assert found and "--executor dask" in err[0], err[0]
    timed, censored = int(found[3]), int(found[4])
    assert timed == 200 and censored > timed // 2
    hours, rate = float(found[1].replace(",", "")), float(found[2].replace(",", ""))
    assert hours == pytest.approx(39916800 / rate / 3600, abs=0.051)  # as printed: hours to 0.1, a whole rate
    assert not (tmp_path / "out").exists()


# ---------------------------------------------------------------- each step's verdict on the study's answer
def verdict_steps(*verdicts):
    """Steps of their own types, each giving one verdict, and a study holding a result for each."""
    from orchestrator.study import Step

    steps = [
        type(f"Step{k}", (Step,), {"name": f"step{k}", "title": "", "verdict": lambda self, result, study, v=v: v})()
        for k, v in enumerate(verdicts)
    ]
    return steps, SimpleNamespace(result=lambda step_type: object())


def test_the_runner_asks_each_step_in_order_until_one_answers_or_refuses():
    from orchestrator.runner import NoResult, check_answer
    from orchestrator.study import SILENT, Verdict

    steps, study = verdict_steps(SILENT, Verdict.no_answer("the first refusal"), Verdict.no_answer("not asked"))
    with pytest.raises(NoResult, match="^the first refusal$"):
        check_answer(study, steps)
    steps, study = verdict_steps(SILENT, Verdict.answer(), Verdict.no_answer("not asked"))
    check_answer(study, steps)
    steps, study = verdict_steps(SILENT, SILENT)
    check_answer(study, steps)


# ---------------------------------------------------------------- the answer copied into an FMI tool
@pytest.fixture(scope="module")
def copied_study(armour_fmu_of_width, tmp_path_factory):
    """A study of the 3-column armour scene under both rules (swept: certified), and the same scene's FMI 3 FMU."""
    from builder import build as build_fmu

    out = tmp_path_factory.mktemp("copied") / "out"
    assert main("--fmu", armour_fmu_of_width(3), "--cols", 3, "--out", out, *COMMON) == 0
    fmu3 = build_fmu.build_fmu(
        "armour_11x11", tmp_path_factory.mktemp("fmu3_3") / "lattice3.fmu", cols=3, fmi_version=3
    )
    return out, {2: armour_fmu_of_width(3), 3: fmu3}


@pytest.mark.quick
@pytest.mark.parametrize("fmi_version", [2, 3])
def test_the_answer_copied_from_results_json_into_fmpy_gives_the_reports_number(copied_study, fmi_version):
    """A user copies each answer's parameters into fmpy.simulate_fmu (defaults otherwise; FMI 3 through
    orchestrator.simulation.start_values, which gathers material[j] into the array material) and gets the report's
    peak, under both rules; without diagonal_rule the mean rule's answer gives another number."""
    from fmpy import simulate_fmu

    from orchestrator.simulation import model_description, start_values

    out, fmus = copied_study
    description = model_description(fmus[fmi_version])
    results = json.loads((out / "results.json").read_text())
    answers = {a["diagonal_rule"]: a for a in results["answers"]}
    assert set(answers) == {"mean", "receiver"}
    for rule, answer in answers.items():
        assert answer["parameters"]["diagonal_rule"] == results["case"]["rule_codes"][rule]
        assert [answer["parameters"][f"material[{j}]"] for j in range(1, 4)] == answer["order"]
        copied = simulate_fmu(
            str(fmus[fmi_version]),
            stop_time=results["case"]["horizon"],
            start_values=start_values(description, answer["parameters"]),
            output=["peak_backplate_force"],
        )
        assert copied["peak_backplate_force"][-1] == pytest.approx(answer["peak"], rel=1e-6), rule
    mean = answers["mean"]
    materials_only = {k: v for k, v in mean["parameters"].items() if k != "diagonal_rule"}
    default_rule = simulate_fmu(
        str(fmus[fmi_version]),
        stop_time=results["case"]["horizon"],
        start_values=start_values(description, materials_only),
        output=["peak_backplate_force"],
    )
    assert abs(default_rule["peak_backplate_force"][-1] - mean["peak"]) > 1.0


@pytest.mark.quick
def test_the_answer_is_shown_as_its_start_values_with_the_rule_code(copied_study):
    from html import unescape

    out, _ = copied_study
    results = json.loads((out / "results.json").read_text())
    html = unescape((out / "report.html").read_text())
    first_screen = html[: html.index("</table>")]
    for answer in results["answers"]:
        typed = " ".join(f"{name}={value}" for name, value in answer["parameters"].items())
        assert f"<code>{typed}</code>" in first_screen
    assert (
        "without it the FMU runs its default, 0 = receiver, which reproduces the study's published table"
        in first_screen
    )
    assert "diagonal_rule 0 = receiver is also the FMU's default" in first_screen


def test_the_console_gives_each_answer_as_its_start_values(armour_fmu_of_width, tmp_path, capfd):
    out = tmp_path / "out"
    assert main("--fmu", armour_fmu_of_width(3), "--cols", 3, "--out", out, "--diagonal-rule", "mean", *COMMON) == 0
    printed = capfd.readouterr().out.splitlines()
    (answer,) = json.loads((out / "results.json").read_text())["answers"]
    line = next(line for line in printed if "in any FMI tool:" in line)
    assert line.strip().startswith(f"in any FMI tool: material[1]={answer['order'][0]} ")
    assert "diagonal_rule=1, stop time 8 s" in line and "its default, 0 = receiver" in line


# ---------------------------------------------------------------- a budget that bounds every step
def test_the_budget_bounds_the_sensitivity_and_the_local_check_and_the_console_says_which_exceeds_it(
    armour_fmu_of_width, tmp_path, capfd
):
    """With --budget small, the sensitivity's short searches together evaluate no more designs than the searches
    did, the local check no more than the searches or one neighbourhood, and the console names the step that
    simulated more than the searches, why, and the option that bounds it."""
    out = tmp_path / "out"
    assert (
        main(
            "--fmu",
            armour_fmu_of_width(5),
            "--cols",
            5,
            "--out",
            out,
            "--method",
            "cmaes",
            "sa",
            "--budget",
            4,
            "--repeats",
            1,
            "--diagonal-rule",
            "mean",
            "--no-progress",
            "--executor",
            "serial",
        )
        == 0
    )
    printed = capfd.readouterr().out
    results = json.loads((out / "results.json").read_text())
    searched = sum(run["distinct"] for run in results["steps"]["searches"]["runs"])
    sensitivity = results["steps"]["sensitivity"]
    assert sensitivity["budget"] == max(1, searched // (2 * len(sensitivity["variations"]))) < 100
    (check,) = results["steps"]["final_descent"]["rules"]
    neighbourhood = sum(check["neighbours"].values())
    assert check["evaluations"] <= max(searched, neighbourhood + 1)
    costs = {cost["step"]: cost["simulated"] for cost in results["costs"]}
    assert costs["searches"] <= searched  # two runs may ask one design: simulated once
    assert sum(costs.values()) == results["evaluator"]["simulated"]
    assert f"simulated: {sum(costs.values()):,} FMU runs: searches {costs['searches']}," in printed
    assert costs["final_descent"] > searched  # one neighbourhood is more than 8 designs
    assert (
        f"final descent: {costs['final_descent']:,} FMU runs, more than the searches' {costs['searches']} "
        f"(--budget): a local optimum is known only once each of its {neighbourhood} neighbours is evaluated"
    ) in printed
    assert "--no-local-check skips it" in printed


@pytest.mark.quick
def test_a_sensitivity_budget_given_is_kept_and_the_default_one_is_its_ceiling():
    from orchestrator.steps.sensitivity import DEFAULT_BUDGET, SensitivityConfig, search_budget

    runs = [SimpleNamespace(distinct=d) for d in (200, 200, 1)]
    context = SimpleNamespace(result=lambda step: SimpleNamespace(runs_for=lambda label: runs))
    assert search_budget(context, SensitivityConfig(), "mean", 6) == 401 // 12
    assert search_budget(context, SensitivityConfig(budget=500), "mean", 6) == 500
    assert search_budget(context, SensitivityConfig(), "mean", 1) == DEFAULT_BUDGET
    no_search = SimpleNamespace(result=lambda step: None)
    assert search_budget(no_search, SensitivityConfig(), "mean", 6) == DEFAULT_BUDGET
