"""SIGKILL at random moments, then --resume, again and again: the run ends as one never interrupted, with
nothing simulated twice, and a finished folder still resumes (slow: `python -m pytest -m slow tests/test_kills.py`).
"""

from __future__ import annotations

import json
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from builder.build import build_fmu

ROOT = Path(__file__).resolve().parents[1]
KILLS = 10


@pytest.fixture(scope="module")
def fmu7(tmp_path_factory):
    return build_fmu("armour_11x11", tmp_path_factory.mktemp("fmu7") / "MassSpringLattice11x7.fmu", cols=7, werror=True)


def command(fmu, out, argv):
    return [
        sys.executable,
        str(ROOT / "orchestrator" / "run.py"),
        "--fmu",
        str(fmu),
        "--out",
        str(out),
        "--no-progress",
        *argv,
    ]


def keys(folder: Path) -> list[str]:
    return [
        json.loads(line)["key"] for line in (folder / "journal.jsonl").read_text().splitlines()[1:] if '"key"' in line
    ]


def essence(folder: Path):
    results = json.loads((folder / "results.json").read_text())
    searches = results["steps"].get("searches", {}).get("runs", [])
    sweeps = results["steps"].get("exhaustive", {}).get("sweeps", [])
    return (
        [(a["diagonal_rule"], a["order"], a["peak"]) for a in results["answers"]],
        [(r["method"], r["seed"], r["best_order"], r["best_value"], len(r["evaluations"])) for r in searches],
        [(s["certificate"]["optimum"], s["certificate"]["certified"]) for s in sweeps],
    )


def killed_and_resumed(fmu, out, argv, rng):
    """KILLS runs each killed with SIGKILL at a random moment of the run (the first without --resume), then one
    to the end. A moment of the run: once its folder exists, so from before its first result on; a process
    killed while Python still imports has started no run, and --resume there is refused by design."""
    partial = out.with_name(out.name + ".partial")
    for attempt in range(KILLS):
        process = subprocess.Popen(
            command(fmu, out, argv + (["--resume"] if attempt else [])),
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
        )
        started = time.monotonic()
        while not partial.exists() and process.poll() is None and time.monotonic() - started < 120:
            time.sleep(0.01)
        time.sleep(rng.uniform(0.0, 5.0))
        if process.poll() is None:
            process.send_signal(signal.SIGKILL)
        process.wait(timeout=60)
        if process.returncode == 0:
            break  # it finished before the kill
    done = subprocess.run(command(fmu, out, argv + ["--resume"]), capture_output=True, text=True, timeout=1800)
    assert done.returncode == 0, done.stderr
    return out


@pytest.mark.slow
@pytest.mark.parametrize(
    "name, argv",
    [
        (
            "search",
            [
                "--cols",
                "7",
                "--method",
                "sa",
                "cmaes",
                "--budget",
                "300",
                "--repeats",
                "2",
                "--workers",
                "2",
                "--sensitivity-budget",
                "20",
            ],
        ),
        (
            "sweep",
            [
                "--cols",
                "7",
                "--method",
                "exhaustive",
                "random",
                "--budget",
                "40",
                "--repeats",
                "1",
                "--workers",
                "2",
                "--chunk-size",
                "60",
                "--diagonal-rule",
                "receiver",
                "--no-sensitivity",
            ],
        ),
    ],
)
def test_ten_kills_and_resumes_end_as_an_uninterrupted_run(fmu7, tmp_path, name, argv):
    rng = random.Random(name)
    out = killed_and_resumed(fmu7, tmp_path / "killed", argv, rng)
    found = keys(out)
    assert len(found) == len(set(found))  # nothing simulated twice
    again = subprocess.run(command(fmu7, out, argv + ["--resume"]), capture_output=True, text=True, timeout=600)
    assert again.returncode == 0, again.stderr  # a finished folder still resumes
    assert keys(out) == found
    fresh = tmp_path / "fresh"
    assert subprocess.run(command(fmu7, fresh, argv), capture_output=True, text=True, timeout=1800).returncode == 0
    assert essence(out) == essence(fresh)
