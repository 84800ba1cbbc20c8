"""The command line end to end on the real FMU: the answer, refusals in one line, nothing lost at the edges."""

from __future__ import annotations

import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from orchestrator import run as cli
from command_line import main, one_line

ROOT = Path(__file__).resolve().parents[1]
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
]


def refusals(fmu_path, tmp_path):
    corrupt = tmp_path / "corrupt.fmu"
    corrupt.write_text("not a zip")
    (tmp_path / "a_file").write_text("")
    return {
        "workers 0": (["--workers", "0"], "--workers"),
        "seed -1": (["--seed", "-1"], "--seed"),
        "unknown scene": (["--scene", "no_such_scene"], "no_such_scene"),
        "missing fmu": (["--fmu", tmp_path / "missing.fmu"], "missing.fmu"),
        "corrupt fmu": (["--fmu", corrupt], "corrupt.fmu"),
        "out is a file": (["--out", tmp_path / "a_file"], "--out"),
        "finalists -1": (["--finalists", "-1"], "--finalists"),
        "load nan": (["--load", "nan"], "--load"),
        "load inf": (["--load", "inf"], "--load"),
        "load angle nan": (["--load-angle", "nan"], "--load-angle"),
        "depth 0": (["--depth", "0"], "--depth"),
        "load patch -1": (["--load-patch", "-1"], "--load-patch"),
        "load patch even": (["--load-patch", "2"], "--load-patch 2"),
        "load patch on the 2-D lattice": (["--load-patch", "3"], "load_patch"),
        "search rtol 1": (["--search-rtol", "1"], "--search-rtol"),
        "horizon inf": (["--horizon", "inf"], "--horizon"),
        "horizon 1e9": (["--horizon", "1e9"], "--horizon"),
        "budget 0": (["--budget", "0"], "--budget"),
        "objective unknown": (["--objective", "stroke"], "objective"),
        "rule unknown": (["--diagonal-rule", "average"], "--diagonal-rule average"),
        "case unknown parameter": (["--case", "stiffness=1,2"], "stiffness"),
        "case empty list": (["--case", "F_total="], "--case"),
        "case malformed": (["--case", "F_total"], "--case"),
        "case not a number": (["--case", "F_total=600,heavy"], "heavy"),
        "case out of range": (["--case", "t_active=-1,0.1"], "t_active"),
        "case bad rule": (["--case", "diagonal_rule=receiver,average"], "diagonal_rule"),
        "case array element": (["--case", "material[1]=2"], "material[1]"),
        "case material table": (["--case", "k[1]=50"], "k[1]"),
        "case force limit": (["--case", "peak_force_limit=1"], "peak_force_limit"),
        "case and load": (["--case", "F_total=1200", "--load", "2400"], "--load"),
        "case and rule": (["--case", "diagonal_rule=receiver", "--diagonal-rule", "mean"], "--diagonal-rule"),
        "aggregate without case": (["--aggregate", "worst"], "--aggregate"),
        "chunk size without sweep": (["--chunk-size", "10"], "--chunk-size"),
        "scheduler without dask": (["--scheduler", "tcp://127.0.0.1:8786"], "--scheduler"),
        "too many workers": (["--workers", "1000", "--executor", "process"], "--workers 1000"),
        "case product too large": (
            [
                "--case",
                "F_total=" + ",".join(str(600 + k) for k in range(40)),
                "--case",
                "t_active=" + ",".join(f"0.{k + 10}" for k in range(30)),
            ],
            "--case",
        ),
        "sweep beyond the local limit": (["--method", "exhaustive"], "--executor dask"),
        "columns beyond the study's table": (["--cols", "12", "--scene", "armour_11x11"], "the study's table has 11"),
        "resume and overwrite": (["--resume", "--overwrite"], "--resume and --overwrite"),
        "resume without a run": (["--resume", "--out", tmp_path / "empty"], "no run to resume"),
        "sensitivity budget without sensitivity": (
            ["--sensitivity-budget", "5", "--no-sensitivity"],
            "--sensitivity-budget",
        ),
    }


def test_every_bad_command_line_is_refused_in_one_line_before_any_simulation(fmu_path, tmp_path, capfd):
    for label, (argv, named) in refusals(fmu_path, tmp_path).items():
        argv = [str(a) for a in argv]
        if "--fmu" not in argv and "--scene" not in argv:
            argv += ["--fmu", str(fmu_path)]
        if "--out" not in argv:
            argv += ["--out", str(tmp_path / "out")]
        for flag in ("--no-progress", "--no-sensitivity"):
            if flag not in argv:
                argv.append(flag)
        if "--budget" not in argv:
            argv += ["--budget", "1"]
        code = main(*argv)
        line = one_line(capfd)
        assert code == 2, (label, code, line)
        assert named in line, (label, line)
    assert not (tmp_path / "out").exists() and not (tmp_path / "out.partial" / "results.json").exists()


def test_a_sweep_refusal_names_only_what_is_missing(fmu_path, tmp_path, capfd):
    """On Dask without --confirm-cost the refusal asks only for the confirmation; confirmed without Dask, only
    for a cluster; with neither, for both."""
    common = ["--method", "exhaustive", "--fmu", fmu_path, "--out", tmp_path / "out", "--no-progress"]
    assert main(*common, "--executor", "dask", "--scheduler", "tcp://127.0.0.1:8786") == 2
    line = one_line(capfd)
    assert line.endswith("confirm its cost with --confirm-cost") and "Dask cluster" not in line, line
    assert main(*common, "--confirm-cost") == 2
    line = one_line(capfd)
    assert "--executor dask --scheduler ADDRESS" in line and "--confirm-cost" not in line.split("core-second")[1], line
    assert main(*common) == 2
    assert one_line(capfd).endswith("--executor dask --scheduler ADDRESS --confirm-cost")
    assert not (tmp_path / "out").exists()


def test_an_export_or_an_executor_that_cannot_run_is_refused_before_the_fmu_is_built(tmp_path, capfd, monkeypatch):
    import orchestrator.runner
    import orchestrator.scene

    def no_build(*args, **kwargs):
        raise AssertionError("the FMU was prepared before the options were checked")

    monkeypatch.setattr(orchestrator.scene, "prepare_fmu", no_build)
    assert main("--export-optuna", "study.db", "--out", tmp_path / "out", "--no-progress") == 2
    assert "error: --export-optuna study.db: not a database URL" in one_line(capfd)
    monkeypatch.setattr(orchestrator.runner, "find_spec", lambda name: None)  # as where the dask extra is missing
    assert main("--executor", "dask", "--out", tmp_path / "out", "--no-progress") == 2
    assert "error: --executor dask: needs Dask, the project's dask extra" in one_line(capfd)
    assert not (tmp_path / "out").exists()


def test_a_confirmation_of_nothing_is_named_and_the_run_goes_on(fmu_path, tmp_path, capfd):
    """--confirm-cost where nothing is beyond a bound allows the run asked for: one line says it changes
    nothing (a user who expected a larger run learns this one is not), and the run answers as without it."""
    assert main("--confirm-cost", "--fmu", fmu_path, *QUICK, "--out", tmp_path / "out") == 0
    err = capfd.readouterr().err
    assert "--confirm-cost: nothing in this run is beyond a bound" in err and "so it changes nothing" in err
    assert "error" not in err
    assert (tmp_path / "out" / "results.json").is_file()


def test_the_default_study_answers_under_both_rules_with_their_evidence(fmu_path, tmp_path, capfd):
    out = tmp_path / "results"
    code = main(
        "--fmu",
        fmu_path,
        "--out",
        out,
        "--budget",
        "25",
        "--repeats",
        "2",
        "--method",
        "cmaes",
        "sa",
        "sequential",
        "--sensitivity-budget",
        "6",
        "--no-progress",
        "--executor",
        "serial",
    )
    printed = capfd.readouterr()
    assert code == 0, printed.err
    results = json.loads((out / "results.json").read_text())
    answers = {a["diagonal_rule"]: a for a in results["answers"]}
    assert set(answers) == {"receiver", "mean"}
    for rule, answer in answers.items():
        assert sorted(answer["order"]) == list(range(1, 12))
        assert set(answer["evidence"]) >= {"runs_reaching", "runs", "local_optimum", "status"}
        assert answer["evidence"]["status"] in ("certified", "known", "best_found")
        assert answer["evidence"]["runs"] == 4
        other = "mean" if rule == "receiver" else "receiver"
        assert answer["peak_other_rule"] == answer["values_by_rule"][other]
    assert [a["diagonal_rule"] for a in results["answers"]] == ["mean", "receiver"]  # the design file's first
    assert answers["mean"]["design_file"] == "best_design.ssp"
    assert answers["receiver"]["design_file"] == "design_receiver.ssp"
    from orchestrator.simulation import LatticeFMU

    with LatticeFMU(fmu_path) as fmu:  # each answer reproduced by the FMU itself, its design file there
        for rule, answer in answers.items():
            peak = fmu.simulate(answer["order"], 8.0, {"diagonal_rule": rule})["peak_backplate_force"]
            assert peak == pytest.approx(answer["peak"], rel=1e-6)
            assert (out / answer["design_file"]).is_file()
    for name in (
        "report.html",
        "evaluations.csv",
        "journal.jsonl",
        "convergence.png",
        "force_energy.png",
        "lattice.png",
        "work_precision.png",
    ):
        assert (out / name).is_file(), name
    html = (out / "report.html").read_text()
    first = html[: html.index("</table>")]
    for answer in answers.values():
        assert str(answer["order"]) in first.replace("&#39;", "'")
    assert "receiver rule" in printed.out and "mean rule" in printed.out and "report:" in printed.out
    sensitivity = results["steps"]["sensitivity"]
    mean_answer = answers["mean"]["peak"]
    for variation in sensitivity["variations"]:
        if variation["parameters"] == {"diagonal_rule": "mean"}:  # never worse than what the study knows
            assert variation["best_known"]["value"] <= mean_answer + 1e-9


def test_the_first_screen_names_the_case_it_answers(fmu_path, tmp_path, capfd):
    out = tmp_path / "results"
    assert (
        main(
            "--fmu",
            fmu_path,
            "--out",
            out,
            "--load",
            "2400",
            "--load-angle",
            "20",
            "--diagonal-rule",
            "receiver",
            *QUICK,
        )
        == 0
    ), capfd.readouterr().err
    html = (out / "report.html").read_text()
    first = html[: html.index("</table>")]
    assert "2400 N" in first and "20 deg" in first
    results = json.loads((out / "results.json").read_text())
    assert results["case"]["load"]["F_total"] == 2400.0 and results["case"]["load"]["load_angle"] == 20.0
    assert [a["diagonal_rule"] for a in results["answers"]] == ["receiver"]


def test_a_study_where_every_evaluation_fails_exits_3_with_the_reason(fmu_path, tmp_path, capfd):
    code = main(
        "--fmu",
        fmu_path,
        "--out",
        tmp_path / "r",
        "--case",
        "solver=rk4",
        "--case",
        "fixed_step=0.05",
        "--diagonal-rule",
        "receiver",
        *QUICK,
    )
    line = one_line(capfd)
    assert code == 3 and "no design was evaluated successfully" in line and "diverged" in line, line
    assert re.search(r": \d+ evaluations failed; every one: ", line), line
    assert (tmp_path / "r" / "report.html").is_file()


def test_a_study_where_nothing_touches_the_plate_says_so_and_exits_3(fmu_path, tmp_path, capfd):
    code = main(
        "--fmu",
        fmu_path,
        "--out",
        tmp_path / "r",
        "--load",
        "5",
        "--load-angle",
        "180",
        "--diagonal-rule",
        "receiver",
        *QUICK,
    )
    line = one_line(capfd)
    assert code == 3 and "no design touches the backplate" in line, line


def journal_keys(folder: Path) -> list[str]:
    return [
        json.loads(line)["key"] for line in (folder / "journal.jsonl").read_text().splitlines()[1:] if '"key"' in line
    ]


def essence(folder: Path):
    results = json.loads((folder / "results.json").read_text())
    runs = [
        (r["method"], r["seed"], r["label"], r["best_order"], r["best_value"], len(r["evaluations"]))
        for r in results["steps"]["searches"]["runs"]
    ]
    return [(a["diagonal_rule"], a["order"], a["peak"]) for a in results["answers"]], runs


def test_a_run_resumes_by_value_from_another_folder_and_replays_when_finished(fmu_path, tmp_path, capfd):
    out = tmp_path / "results"
    argv = ["--fmu", fmu_path, "--diagonal-rule", "receiver", *QUICK]
    assert main("--out", out, *argv) == 0
    first = essence(out)
    moved = tmp_path / "elsewhere" / "copy"
    shutil.copytree(out, moved)
    copied_fmu = tmp_path / "elsewhere" / "MassSpringLattice.fmu"
    shutil.copy(fmu_path, copied_fmu)
    capfd.readouterr()
    # the same FMU by another path, the default load spelled out: the same run, replayed without simulating
    assert main("--out", moved, "--resume", "--load", "1200", *[a if a != fmu_path else copied_fmu for a in argv]) == 0
    assert essence(moved) == first
    results = json.loads((moved / "results.json").read_text())
    assert results["evaluator"]["simulated"] == 0 and results["evaluator"]["resumed"] > 0
    capfd.readouterr()
    assert main("--out", moved, "--resume", "--load", "2400", *argv) == 2
    assert "F_total" in one_line(capfd)


def test_the_same_command_again_never_wipes_an_unfinished_run(fmu_path, tmp_path, capfd):
    out = tmp_path / "results"
    partial = tmp_path / "results.partial"
    argv = ["--fmu", fmu_path, "--out", out, "--diagonal-rule", "receiver", *QUICK]
    assert main(*argv) == 0
    shutil.copytree(out, partial)  # an unfinished run, as a killed one leaves it
    lines = (partial / "journal.jsonl").read_text().splitlines()
    (partial / "journal.jsonl").write_text("\n".join(lines[:-6]) + "\n")
    kept = len(journal_keys(partial))
    capfd.readouterr()
    assert main(*argv) == 2
    line = one_line(capfd)
    assert "unfinished run" in line and "--resume" in line and "--overwrite" in line
    assert len(journal_keys(partial)) == kept
    assert main(*argv, "--resume") == 0
    assert not partial.exists() and len(set(journal_keys(out))) == len(journal_keys(out))


def test_resume_after_a_kill_before_the_first_result_starts_the_run(fmu_path, tmp_path, capfd):
    out = tmp_path / "results"
    (tmp_path / "results.partial").mkdir()  # what a run killed before it wrote its journal leaves
    assert main("--fmu", fmu_path, "--out", out, "--diagonal-rule", "receiver", *QUICK, "--resume") == 0
    assert "nothing to resume" in capfd.readouterr().err
    assert (out / "results.json").is_file() and not (tmp_path / "results.partial").exists()


def test_the_test_run_leaves_nothing_in_tmpdir(fmu_path, tmp_path):
    temp = tmp_path / "tmp"
    temp.mkdir()
    command = [
        sys.executable,
        str(ROOT / "orchestrator" / "run.py"),
        "--fmu",
        str(fmu_path),
        "--out",
        str(tmp_path / "out"),
        "--diagonal-rule",
        "receiver",
        "--budget",
        "8",
        "--repeats",
        "1",
        "--method",
        "sa",
        "--workers",
        "2",
        "--no-sensitivity",
        "--no-progress",
    ]
    done = subprocess.run(command, capture_output=True, text=True, timeout=600, env={**os.environ, "TMPDIR": str(temp)})
    assert done.returncode == 0, done.stderr
    assert list(temp.iterdir()) == []


def _children(pid: int) -> set[int]:
    found = set()
    for task in Path(f"/proc/{pid}/task").glob("*"):
        try:
            found |= {int(c) for c in (task / "children").read_text().split()}
        except OSError:
            pass
    return found


def _alive(pid: int) -> bool:
    try:
        return "State:\tZ" not in Path(f"/proc/{pid}/status").read_text()
    except OSError:
        return False


LONG = [
    "--method",
    "sa",
    "cmaes",
    "--budget",
    "250",
    "--repeats",
    "2",
    "--workers",
    "2",
    "--no-progress",
    "--diagonal-rule",
    "receiver",
    "--no-sensitivity",
]


def wait_for_journal(path: Path, lines: int, process, seconds: float = 120) -> None:
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline and process.poll() is None:
        if path.is_file() and len(path.read_text().splitlines()) > lines:
            return
        time.sleep(0.05)


@pytest.mark.skipif(not Path("/proc").is_dir(), reason="reads child processes from /proc")
def test_sigint_keeps_the_journal_and_resume_finishes_the_same_run(fmu_path, tmp_path):
    out = tmp_path / "interrupted"
    command = [sys.executable, str(ROOT / "orchestrator" / "run.py"), "--fmu", str(fmu_path), "--out", str(out), *LONG]
    process = subprocess.Popen(
        command,
        stderr=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    journal = tmp_path / "interrupted.partial" / "journal.jsonl"
    wait_for_journal(journal, 80, process)
    workers = _children(process.pid)
    process.send_signal(signal.SIGINT)
    _, err = process.communicate(timeout=30)
    assert process.returncode == 130, err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1 and "--resume" in err
    time.sleep(0.5)
    assert workers and not any(_alive(pid) for pid in workers)
    kept = len(journal.read_text().splitlines()) - 1
    second = subprocess.run(command, capture_output=True, text=True, timeout=60)  # the flag forgotten
    assert second.returncode == 2 and "unfinished run" in second.stderr
    assert len(journal.read_text().splitlines()) - 1 == kept
    resumed = subprocess.run(command + ["--resume"], capture_output=True, text=True, timeout=600)
    assert resumed.returncode == 0, resumed.stderr
    keys = journal_keys(out)
    assert len(keys) == len(set(keys))  # nothing simulated twice
    results = json.loads((out / "results.json").read_text())
    assert results["evaluator"]["resumed"] >= kept
    fresh = tmp_path / "fresh"
    assert cli.main(["--fmu", str(fmu_path), "--out", str(fresh), *LONG]) == 0
    assert essence(out) == essence(fresh)


def test_two_runs_on_one_folder_the_second_is_refused(fmu_path, tmp_path):
    out = tmp_path / "results"
    command = [sys.executable, str(ROOT / "orchestrator" / "run.py"), "--fmu", str(fmu_path), "--out", str(out), *LONG]
    first = subprocess.Popen(command, stderr=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    wait_for_journal(tmp_path / "results.partial" / "journal.jsonl", 5, first)
    second = subprocess.run(command + ["--resume"], capture_output=True, text=True, timeout=60)
    first.send_signal(signal.SIGTERM)
    _, err = first.communicate(timeout=60)
    assert second.returncode == 2 and "is in use by a running run (pid" in second.stderr, second.stderr
    assert first.returncode == 143, err


@pytest.mark.skipif(not Path("/proc").is_dir(), reason="reads child processes from /proc")
def test_process_pool_workers_die_with_a_killed_main_process(fmu_path, tmp_path):
    command = [
        sys.executable,
        str(ROOT / "orchestrator" / "run.py"),
        "--fmu",
        str(fmu_path),
        "--out",
        str(tmp_path / "r"),
        *LONG,
    ]
    process = subprocess.Popen(command, stderr=subprocess.DEVNULL, stdout=subprocess.DEVNULL)
    deadline = time.monotonic() + 120
    workers: set[int] = set()
    while time.monotonic() < deadline and len(workers) < 2 and process.poll() is None:
        workers = _children(process.pid)
        time.sleep(0.02)
    os.kill(process.pid, signal.SIGKILL)
    process.wait(timeout=10)
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline and any(_alive(pid) for pid in workers):
        time.sleep(0.1)
    assert workers and not any(_alive(pid) for pid in workers)


@pytest.mark.skipif(not Path("/proc").is_dir(), reason="reads child processes from /proc")
def test_sigint_in_the_report_phase_and_resume_simulate_nothing_twice(fmu_path, tmp_path):
    """The report's simulations (trajectories, solver sweep) are journalled tasks too: interrupted among them,
    --resume runs only what was not finished."""
    out = tmp_path / "r"
    argv = [
        "--method",
        "sequential",
        "random",
        "--budget",
        "10",
        "--repeats",
        "1",
        "--no-sensitivity",
        "--diagonal-rule",
        "receiver",
        "--horizon",
        "20",
        "--no-progress",
        "--workers",
        "2",
    ]
    command = [sys.executable, str(ROOT / "orchestrator" / "run.py"), "--fmu", str(fmu_path), "--out", str(out), *argv]
    process = subprocess.Popen(
        command,
        stderr=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    journal = tmp_path / "r.partial" / "journal.jsonl"
    deadline = time.monotonic() + 300
    while time.monotonic() < deadline and process.poll() is None:
        if journal.is_file() and '"key":"record|' in journal.read_text():
            break
        time.sleep(0.02)
    process.send_signal(signal.SIGINT)
    _, err = process.communicate(timeout=60)
    assert process.returncode == 130, err
    finished = set(journal_keys(tmp_path / "r.partial"))
    assert any(key.startswith("record|") for key in finished)
    resumed = subprocess.run(command + ["--resume"], capture_output=True, text=True, timeout=600)
    assert resumed.returncode == 0, resumed.stderr
    keys = journal_keys(out)
    assert len(keys) == len(set(keys)) and finished <= set(keys)
    results = json.loads((out / "results.json").read_text())
    assert results["evaluator"]["resumed"] == len(finished)
    assert results["evaluator"]["simulated"] == len(keys) - len(finished)
