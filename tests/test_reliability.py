"""Nothing lost, nothing hangs: bad command lines, the journal and --resume, interrupts, temp folders."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from orchestrator import run as cli
from orchestrator.executors import make_executor
from orchestrator.journal import Journal, JournalError
from orchestrator.loop import Evaluator, run_search
from orchestrator.search import make_search
from orchestrator.search.problems import QuadraticAssignment

ROOT = Path(__file__).resolve().parents[1]
QAP = QuadraticAssignment.random(7, 5)


def bad_command_lines(fmu_path, tmp_path):
    corrupt = tmp_path / "corrupt.fmu"
    corrupt.write_text("not a zip")
    unwritable = tmp_path / "file"
    unwritable.write_text("")
    return {
        "workers 0": (["--workers", "0"], "--workers"),
        "seed -1": (["--seed", "-1"], "--seed"),
        "unknown scene": (["--scene", "no_such_scene"], "no_such_scene"),
        "missing fmu": (["--fmu", str(tmp_path / "missing.fmu")], "missing.fmu"),
        "corrupt fmu": (["--fmu", str(corrupt)], "corrupt.fmu"),
        "out is a file": (["--out", str(unwritable / "sub")], "--out"),
        "finalists -1": (["--finalists", "-1"], "--finalists"),
        "load nan": (["--load", "nan"], "--load"),
        "load inf": (["--load", "inf"], "--load"),
        "load angle nan": (["--load-angle", "nan"], "--load-angle"),
        "search rtol 1": (["--search-rtol", "1"], "--search-rtol"),
        "search rtol 1e-300": (["--search-rtol", "1e-300"], "--search-rtol"),
        "horizon inf": (["--horizon", "inf"], "--horizon"),
        "horizon 1e9": (["--horizon", "1e9"], "--horizon"),
        "budget 0": (["--budget", "0"], "--budget"),
        "case unknown parameter": (["--case", "stiffness=1,2"], "stiffness"),
        "case empty list": (["--case", "F_total="], "--case"),
        "case malformed": (["--case", "F_total"], "--case"),
        "case not a number": (["--case", "F_total=600,heavy"], "heavy"),
        "case out of range": (["--case", "t_active=-1,0.1"], "t_active"),
        "case bad rule": (["--case", "diagonal_rule=receiver,average"], "diagonal_rule"),
        "aggregate without case": (["--aggregate", "worst"], "aggregate"),
        "resume without journal": (["--resume", "--out", str(tmp_path / "empty")], "--resume"),
    }


def test_every_bad_command_line_is_one_line_and_exit_2(fmu_path, tmp_path, capfd):
    for label, (argv, named) in bad_command_lines(fmu_path, tmp_path).items():
        if "--fmu" not in argv and "--scene" not in argv:
            argv = argv + ["--fmu", str(fmu_path)]
        if "--out" not in argv:
            argv = argv + ["--out", str(tmp_path / "out")]
        try:
            code = cli.main(argv + ["--no-progress", "--budget", "1"] if "--budget" not in argv else argv)
        except SystemExit as exc:
            code = exc.code
        err = capfd.readouterr().err
        lines = [line for line in err.splitlines() if line.strip() and not line.startswith("building")]
        assert code == 2, (label, code, err)
        assert len(lines) == 1 and "Traceback" not in err, (label, err)
        assert named in lines[0], (label, lines[0])
    assert not (tmp_path / "out" / "results.json").exists()  # refused before any simulation


def test_a_run_with_no_load_finishes_with_a_result(fmu_path, tmp_path, capfd):
    code = cli.main(["--fmu", str(fmu_path), "--load", "0", "--method", "sequential", "random", "--budget", "4",
                     "--repeats", "1", "--executor", "serial", "--out", str(tmp_path), "--no-progress",
                     "--no-which-model", "--no-sensitivity", "--no-local-check"])
    assert code == 0, capfd.readouterr().err
    assert json.loads((tmp_path / "results.json").read_text())["best"]["peak"] == 0.0


def test_a_run_where_every_evaluation_fails_exits_non_zero_with_the_reason(fmu_path, tmp_path, capfd):
    code = cli.main(["--fmu", str(fmu_path), "--method", "random", "--budget", "3", "--repeats", "1",
                     "--executor", "serial", "--out", str(tmp_path), "--no-progress", "--case", "solver=1",
                     "--case", "fixed_step=0.05"])
    err = capfd.readouterr().err
    assert code == 3 and "every evaluation failed" in err and "diverged" in err, err


def test_the_journal_keeps_every_evaluation_and_refuses_other_settings(tmp_path):
    settings = {"budget": 30, "seed": 0}
    with make_executor("serial") as executor, Journal(tmp_path, settings) as journal:
        evaluator = Evaluator(executor, journal)
        first = run_search(make_search("sa", 7, 0, budget=30), QAP, 30, evaluator, method_name="sa", seed=0)
    lines = (tmp_path / "journal.jsonl").read_text().splitlines()
    assert len(lines) == 1 + first.n_evaluations
    with open(tmp_path / "journal.jsonl", "a") as handle:
        handle.write('{"task": "half a line')  # the line being written when the run was killed
    with make_executor("serial") as executor, Journal(tmp_path, settings, resume=True) as journal:
        evaluator = Evaluator(executor, journal)
        again = run_search(make_search("sa", 7, 0, budget=30), QAP, 30, evaluator, method_name="sa", seed=0)
    assert evaluator.simulated == 0 and evaluator.resumed == first.n_evaluations
    assert again.outcome() == first.outcome()
    with pytest.raises(JournalError, match="budget=30"):
        Journal(tmp_path, {"budget": 40, "seed": 0}, resume=True)


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
        status = Path(f"/proc/{pid}/status").read_text()
    except OSError:
        return False
    return "State:\tZ" not in status


COMMAND = ["--method", "sa", "cmaes", "--budget", "600", "--repeats", "2", "--workers", "2", "--no-progress",
           "--no-which-model", "--no-sensitivity", "--no-local-check"]


@pytest.mark.skipif(not Path("/proc").is_dir(), reason="reads child processes from /proc")
def test_sigint_keeps_the_journal_and_resume_finishes_the_same_run(fmu_path, tmp_path):
    """Ctrl-C mid-run: exit 130 within seconds, one line, no worker left; --resume simulates no order twice
    and ends with the results of a run that was never interrupted."""
    out = tmp_path / "interrupted"
    command = [sys.executable, str(ROOT / "orchestrator" / "run.py"), "--fmu", str(fmu_path), "--out", str(out),
               *COMMAND]
    # Ctrl-C's default action in the run, whatever this process inherited: a shell starts a background job
    # with SIGINT ignored, and a Python started so never raises KeyboardInterrupt
    process = subprocess.Popen(command, stderr=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
                               preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    journal = out / "journal.jsonl"
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        if journal.is_file() and len(journal.read_text().splitlines()) > 80:
            break
        time.sleep(0.05)
    workers = _children(process.pid)
    process.send_signal(signal.SIGINT)
    start = time.monotonic()
    _, err = process.communicate(timeout=30)
    assert time.monotonic() - start < 30
    assert process.returncode == 130, err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1 and "--resume" in err
    time.sleep(0.5)
    assert workers and not any(_alive(pid) for pid in workers)
    kept = len(journal.read_text().splitlines()) - 1
    assert kept >= 80

    resumed = subprocess.run(command + ["--resume"], capture_output=True, text=True, timeout=600)
    assert resumed.returncode == 0, resumed.stderr
    entries = [json.loads(line) for line in journal.read_text().splitlines()[1:]]
    keys = [(e["task"], tuple(e["order"])) for e in entries]
    assert len(keys) == len(set(keys))  # no order simulated twice
    results = json.loads((out / "results.json").read_text())
    assert results["evaluator"]["resumed"] == kept

    fresh = tmp_path / "fresh"
    assert cli.main(["--fmu", str(fmu_path), "--out", str(fresh), *COMMAND]) == 0
    reference = json.loads((fresh / "results.json").read_text())

    def essence(data):
        return (data["best"], [(r["method"], r["seed"], r["best_order"], r["best_peak"], r["evaluations"],
                                r["search_best_order"], r["search_best_peak"]) for r in data["runs"]])
    assert essence(results) == essence(reference)


def test_a_run_leaves_no_extracted_fmu_behind(fmu_path, tmp_path):
    """Workers and the main process extract the FMU under one temp root per run, removed when it ends."""
    temp = tmp_path / "tmp"
    temp.mkdir()
    command = [sys.executable, str(ROOT / "orchestrator" / "run.py"), "--fmu", str(fmu_path), "--method", "sa",
               "--budget", "8", "--repeats", "1", "--workers", "2", "--out", str(tmp_path / "out"), "--no-progress",
               "--no-which-model", "--no-sensitivity", "--no-local-check"]
    done = subprocess.run(command, capture_output=True, text=True, timeout=600,
                          env={**os.environ, "TMPDIR": str(temp)})
    assert done.returncode == 0, done.stderr
    assert list(temp.iterdir()) == []


def test_process_pool_workers_die_with_a_killed_main_process(fmu_path, tmp_path):
    """SIGKILL to the main process (no chance to clean up): its pool workers end too."""
    command = [sys.executable, str(ROOT / "orchestrator" / "run.py"), "--fmu", str(fmu_path),
               "--out", str(tmp_path), *COMMAND]
    process = subprocess.Popen(command, stderr=subprocess.DEVNULL, stdout=subprocess.DEVNULL)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and not (tmp_path / "journal.jsonl").is_file():
        time.sleep(0.05)
    workers = set()
    while time.monotonic() < deadline and len(workers) < 2 and process.poll() is None:
        # the pool's workers, as soon as both are up (a search evaluation takes about a millisecond, so a
        # fixed wait can outlast the whole run)
        workers = _children(process.pid)
        time.sleep(0.02)
    os.kill(process.pid, signal.SIGKILL)
    process.wait(timeout=10)
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline and any(_alive(pid) for pid in workers):
        time.sleep(0.1)
    assert workers and not any(_alive(pid) for pid in workers)


def test_a_killed_pool_worker_costs_nothing_but_its_evaluation(fmu_path, tmp_path):
    """SIGKILL to one worker mid-run: the pool is replaced, the orders in flight run again, the run ends
    with exit 0 and the best known order."""
    command = [sys.executable, str(ROOT / "orchestrator" / "run.py"), "--fmu", str(fmu_path), "--out", str(tmp_path),
               "--method", "sa", "cmaes", "--budget", "150", "--repeats", "1", "--workers", "2", "--no-progress",
               "--no-which-model", "--no-sensitivity"]
    process = subprocess.Popen(command, stderr=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    journal = tmp_path / "journal.jsonl"
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and not (journal.is_file() and len(journal.read_text().splitlines()) > 40):
        time.sleep(0.05)
    workers = sorted(_children(process.pid))
    assert workers
    os.kill(workers[0], signal.SIGKILL)
    _, err = process.communicate(timeout=600)
    assert process.returncode == 0, err
    results = json.loads((tmp_path / "results.json").read_text())
    assert results["evaluator"]["pool_renewals"] >= 1
    assert results["best"]["peak"] == pytest.approx(1405.906, rel=1e-3)


def test_a_mismatched_fmu_is_refused_and_a_stale_one_rebuilt(fmu_path, tmp_path, monkeypatch, capfd):
    code = cli.main(["--scene", "free_5x5", "--fmu", str(fmu_path), "--out", str(tmp_path), "--no-progress"])
    err = capfd.readouterr().err
    assert code == 2 and "free_5x5" in err and len(err.strip().splitlines()) == 1, err
    import build_fmu
    from fmpy import read_model_description

    from orchestrator.study import ensure_fmu

    monkeypatch.setattr(build_fmu, "MODELS_DIR", tmp_path)
    stale = tmp_path / "TwoMassesLinear.fmu"
    stale.write_bytes(Path(fmu_path).read_bytes())  # another model under the scene's name
    path = ensure_fmu("two_masses_linear")
    assert path == stale
    description = read_model_description(str(path))
    assert description.coSimulation.modelIdentifier == "TwoMassesLinear"
