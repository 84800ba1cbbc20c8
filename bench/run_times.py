"""Run times a user meets: the plate study under a small budget, the default plate study, the quick tests and
the whole test suite.

    python -m bench.run_times            # the plate at --budget 20 --repeats 1 and at its defaults; the quick
                                         # tests; the whole test suite (about half an hour on two loaded cores)
    python -m bench.run_times --quick    # the plate at --budget 20 --repeats 1 and the quick tests only

Why: the README tells a user how long the plate's study and the test suite take before they start them, and
that ``--budget`` bounds a study. Each command runs as a user runs it, in a fresh process from the project's
folder: the studies with the plate's FMU built beforehand (its build is not timed), writing into a temporary
folder; the tests with an empty build cache of their own, so the session builds its FMUs as a fresh clone's
does. Wall-clock seconds; each study also says what it simulated (results.json's ``costs``), which does not
depend on the machine's load.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

from .common import lattice_fmu
from .measurements import ROOT, Page, Run, Table, write_page

PLATE = "plate_11x11x11"
SMALL_BUDGET = ("--budget", "20", "--repeats", "1")


@dataclass(frozen=True)
class Timed:
    command: str
    seconds: float
    outcome: str  # what it did: FMU runs by step, or tests passed


def run_command(words: list[str], env: dict[str, str]) -> tuple[float, subprocess.CompletedProcess]:
    start = time.perf_counter()
    done = subprocess.run(words, cwd=ROOT, env=env, capture_output=True, text=True, check=False)
    return time.perf_counter() - start, done


def time_study(fmu: Path, options: tuple[str, ...], folder: Path) -> Timed:
    out = folder / f"study{len(list(folder.iterdir()))}"
    words = [
        sys.executable,
        "-m",
        "orchestrator.run",
        "--scene",
        PLATE,
        "--fmu",
        str(fmu),
        "--out",
        str(out),
        "--no-progress",
        *options,
    ]
    seconds, done = run_command(words, {**os.environ, "TMPDIR": str(folder)})
    if done.returncode != 0:
        raise SystemExit(f"the study failed ({done.returncode}): {done.stderr.strip()[-2000:]}")
    costs = json.loads((out / "results.json").read_text())["costs"]
    total = sum(cost["simulated"] for cost in costs)
    shown = ", ".join(f"{cost['step'].replace('_', ' ')} {cost['simulated']:,}" for cost in costs if cost["simulated"])
    return Timed(
        " ".join(["python orchestrator/run.py --scene", PLATE, *options]), seconds, f"{total:,} FMU runs: {shown}"
    )


def time_tests(arguments: tuple[str, ...], folder: Path) -> Timed:
    env = {key: value for key, value in os.environ.items() if key != "LATTICE_BUILD_CACHE"}
    seconds, done = run_command(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", *arguments], {**env, "TMPDIR": str(folder)}
    )
    summary = (done.stdout.strip().splitlines() or [""])[-1]
    if done.returncode != 0:
        raise SystemExit(f"the tests failed ({done.returncode}): {summary}")
    passed = re.search(r"(\d+) passed", summary)
    return Timed(" ".join(["python -m pytest", *arguments]), seconds, f"{passed[1] if passed else '?'} tests passed")


def minutes(seconds: float) -> str:
    return f"{seconds / 60:.1f} min"


def main(argv=None) -> int:
    run = Run.start(__file__, argv)
    parser = run.parser(__doc__, quick="the plate at --budget 20 --repeats 1 and the quick tests only")
    args = parser.parse_args(argv)
    timed: list[Timed] = []
    with tempfile.TemporaryDirectory(prefix="bench_run_times_") as scratch:
        folder = Path(scratch)
        with lattice_fmu(scene=PLATE) as fmu:
            timed.append(time_study(fmu, SMALL_BUDGET, folder))
            if not args.quick:
                timed.append(time_study(fmu, (), folder))
        timed.append(time_tests(("-m", "quick"), folder))
        if not args.quick:
            timed.append(time_tests((), folder))
    by_command = {t.command: t for t in timed}
    small = timed[0]
    quick = by_command["python -m pytest -m quick"]
    suite = by_command.get("python -m pytest")
    headline = (
        f"the plate at --budget 20 --repeats 1: {minutes(small.seconds)}; the quick tests: "
        f"{minutes(quick.seconds)}"
        + (
            f"; the whole suite: {minutes(suite.seconds)}"
            if suite
            else "; the whole suite: not measured in --quick mode"
        )
    )
    page = Page(
        name=run.name,
        title="Run times a user meets",
        headline=headline,
        summary=(
            f"Each command as a user runs it from the project's folder, one after the other: the studies of "
            f"the `{PLATE}` scene with its FMU built beforehand (not timed), on the default process pool; the "
            "tests with an empty build cache, so the session compiles its FMUs as a fresh clone's does. "
            "Wall-clock time, which grows with the machine's load (below); what each study simulated does not."
        ),
        tables=(
            Table(
                ("command", "wall", "what it did"),
                tuple((f"`{t.command}`", minutes(t.seconds), t.outcome) for t in timed),
            ),
        ),
        notes=(
            ("Measured with --quick: the default plate study and the whole suite were not run.",) if args.quick else ()
        ),
    )
    write_page(run, page)
    return 0


if __name__ == "__main__":
    sys.exit(main())
