"""What the default study costs with the options a user adds: --export-optuna, and a local Dask cluster.

    python -m bench.study_costs            # about 10 min: the default study six times
    python -m bench.study_costs --quick    # about 3 min: --budget 300, four runs

Why: an option that changes no result must not change the run time much either. The default study
(``python -m orchestrator.run`` with the FMU given, so nothing is built) runs on the process pool, on the
process pool with ``--export-optuna sqlite:///...`` (every evaluation an Optuna trial), and on a local Dask
cluster of as many workers (``--executor dask``) at several batch sizes: the most designs one call to a worker
carries (``LATTICE_DASK_BATCH``; the default is ``orchestrator.executors.DASK_BATCH_DESIGNS``). Each run is a
fresh process timed from start to exit (wall clock); with ``--repeats`` the configurations take turns and the
fastest run of each counts. Every run must make the same evaluations (the rows of evaluations.csv).
"""

from __future__ import annotations

import csv
import json
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

from orchestrator.executors import BATCH_VARIABLE, DASK_BATCH_DESIGNS

from .common import add_fmu_option, lattice_fmu
from .measurements import ROOT, Page, Run, Table, write_page

POOL = "process pool"
OPTUNA = "process pool, --export-optuna sqlite:///study.db"
QUICK_BUDGET = 300


@dataclass(frozen=True)
class Configuration:
    name: str
    arguments: tuple[str, ...]
    batch: int | None = None  # the most designs per call to a Dask worker


@dataclass(frozen=True)
class Timed:
    configuration: Configuration
    seconds: float  # the process, start to exit
    study_seconds: float  # the study's own steps (results.json's wall_seconds): no start-up, no report
    export_seconds: float | None  # writing the Optuna trials (the export step's own time)
    evaluations: int


def dask_name(batch: int) -> str:
    return f"local Dask cluster, at most {batch} design{'s' if batch > 1 else ''} per call"


def configurations(batches: tuple[int, ...]) -> list[Configuration]:
    return [
        Configuration(POOL, ()),
        Configuration(OPTUNA, ("--export-optuna", "STORAGE")),
        *(Configuration(dask_name(b), ("--executor", "dask"), b) for b in batches),
    ]


def run_study(configuration: Configuration, fmu: Path, out: Path, extra: list[str]) -> Timed:
    """One default study in a fresh process, into the folder ``out``: its wall-clock seconds and evaluations."""
    folder = out.parent
    arguments = [str(folder / f"{out.name}.db") if a == "STORAGE" else a for a in configuration.arguments]
    arguments = [f"sqlite:///{a}" if a.endswith(".db") else a for a in arguments]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    if configuration.batch is not None:
        env[BATCH_VARIABLE] = str(configuration.batch)
    command = [
        sys.executable,
        "-m",
        "orchestrator.run",
        "--fmu",
        str(fmu),
        "--out",
        str(out),
        "--no-progress",
        *extra,
        *arguments,
    ]
    start = time.perf_counter()
    done = subprocess.run(command, cwd=folder, env=env, capture_output=True, text=True, check=False)
    seconds = time.perf_counter() - start
    if done.returncode != 0:
        raise SystemExit(
            f"{configuration.name}: the study exited {done.returncode}: "
            f"{(done.stderr.strip().splitlines() or ['no message'])[-1]}"
        )
    with (out / "evaluations.csv").open() as handle:
        evaluations = sum(1 for _ in csv.DictReader(handle))
    record = json.loads((out / "results.json").read_text())
    export = record["steps"].get("optuna_export")
    return Timed(
        configuration, seconds, record["wall_seconds"], None if export is None else export["seconds"], evaluations
    )


def main(argv=None) -> int:
    run = Run.start(__file__, argv)
    parser = run.parser(__doc__, quick=f"--budget {QUICK_BUDGET}; Dask at 1 and {DASK_BATCH_DESIGNS} designs per call")
    add_fmu_option(parser)
    parser.add_argument("--repeats", type=int, default=1, help="runs of each configuration (the fastest counts)")
    parser.add_argument(
        "--batches",
        type=int,
        nargs="+",
        help="the most designs per call to a Dask worker, to measure "
        f"(default 1 4 {DASK_BATCH_DESIGNS} 64; --quick: 1 {DASK_BATCH_DESIGNS})",
    )
    args = parser.parse_args(argv)
    if args.repeats < 1 or (args.batches and min(args.batches) < 1):
        parser.error("--repeats and --batches: give positive integers")
    batches = tuple(args.batches or ((1, DASK_BATCH_DESIGNS) if args.quick else (1, 4, DASK_BATCH_DESIGNS, 64)))
    if DASK_BATCH_DESIGNS not in batches:
        batches += (DASK_BATCH_DESIGNS,)
    extra = ["--budget", str(QUICK_BUDGET)] if args.quick else []
    fastest: dict[str, Timed] = {}
    with lattice_fmu(args.fmu) as fmu, tempfile.TemporaryDirectory(prefix="bench_study_costs_") as folder:
        for repeat in range(args.repeats):
            for index, configuration in enumerate(configurations(batches)):
                timed = run_study(configuration, Path(fmu), Path(folder) / f"run{repeat}-{index}", extra)
                print(f"{configuration.name}: {timed.seconds:.1f} s, {timed.evaluations} evaluations", file=sys.stderr)
                best = fastest.get(configuration.name)
                if best is None or timed.seconds < best.seconds:
                    fastest[configuration.name] = timed
    counts = {t.evaluations for t in fastest.values()}
    if len(counts) != 1:
        raise SystemExit(f"the configurations made different numbers of evaluations: {sorted(counts)}")
    pool = fastest[POOL].seconds
    chosen = fastest[dask_name(DASK_BATCH_DESIGNS)].seconds
    optuna = fastest[OPTUNA].seconds
    rows = tuple(
        (
            t.configuration.name,
            f"{t.seconds:.1f}",
            f"{t.seconds / pool:.2f}",
            f"{t.study_seconds:.1f}",
            "" if t.export_seconds is None else f"{t.export_seconds:.1f}",
            f"{t.evaluations:,}",
        )
        for t in fastest.values()
    )
    exported = fastest[OPTUNA]
    study = "python -m orchestrator.run" + (f" --budget {QUICK_BUDGET}" if args.quick else "")
    page = Page(
        name=run.name,
        title="What the default study costs with --export-optuna and on Dask",
        headline=(
            f"default study{f' (--budget {QUICK_BUDGET})' if args.quick else ''}: {pool:.1f} s on the "
            f"process pool, {optuna:.1f} s with --export-optuna ({optuna / pool:.2f}x), {chosen:.1f} s on a "
            f"local Dask cluster at most {DASK_BATCH_DESIGNS} designs per call ({chosen / pool:.2f}x)"
        ),
        summary=(
            f"`{study} --fmu FMU --no-progress` in a fresh process per run, timed from start to exit, with "
            f"{os.cpu_count()} workers (the default: one per core); the fastest of {args.repeats} run"
            f"{'s' if args.repeats > 1 else ''} of each configuration, the configurations taking turns. The "
            f"Dask rows set `{BATCH_VARIABLE}`, the most designs one call to a worker carries (the default is "
            f"{DASK_BATCH_DESIGNS}). Every run made the same {counts.pop():,} evaluations."
        ),
        tables=(
            Table(("configuration", "wall s", "x process pool", "study s", "Optuna export s", "evaluations"), rows),
        ),
        notes=(
            f"Writing the {exported.evaluations:,} trials took {exported.export_seconds:.1f} s of the run with "
            f"--export-optuna (the export step's own time), {exported.export_seconds / pool:.0%} of the process "
            "pool's run without it. Wall s: the process from start to exit (with the Dask cluster's start); "
            "study s: the study's steps alone (results.json's wall_seconds).",
        ),
    )
    write_page(run, page)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
