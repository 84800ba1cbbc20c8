"""Sweep or search: where sweeping every design costs less than the default searches, and a catalogue's default
study with each.

    python -m bench.sweep_crossover           # about 3 min on 2 cores: each study three times
    python -m bench.sweep_crossover --quick   # about 2 min: each study once

Why: the default study sweeps a space instead of searching it when the sweep costs less
(``orchestrator.steps.exhaustive.sweep_instead``): then its answer is certified, not "best found". The crossover is
a ratio of two rates measured on the same case, each over the core-seconds of a whole study (the client's and its
worker processes' CPU time: the search algorithms, the evaluations, the finalists, the report) with the
sensitivity step off: designs per core-second of the study that sweeps (its chunks start without an incumbent
and lower their force limit as their best improves, as the default study's sweep runs) over evaluations per
core-second of the study that runs the default searches (CMA-ES, particle swarm, annealing, the baselines). The
ratio is how many designs a sweep screens in the core-time one search evaluation costs; the orchestrator's constant
``SWEEP_DESIGNS_PER_SEARCH_EVALUATION`` is that ratio rounded down, and its threshold is the constant times the
evaluations the default searches would make. Then the default study itself (every step at its default) with the
searches it ran before and as it runs now, wall time. Case: the study's first 8 materials over an 11 x 5 lattice
(a catalogue of 6,720 arrangements), both diagonal rules, through ``run_in_folder`` (the command line's path).
"""

from __future__ import annotations

import math
import resource
import tempfile
import time
from pathlib import Path

from fmu_src.materials import study_materials, write_materials_csv
from orchestrator.exhaustive import SWEEP_METHOD
from orchestrator.runner import RunConfig, run_in_folder
from orchestrator.scene import resolve
from orchestrator.steps import STEPS, Answers, Exhaustive, Searches, Sensitivity
from orchestrator.steps.exhaustive import SWEEP_DESIGNS_PER_SEARCH_EVALUATION
from orchestrator.steps.searches import SINGLE_DEFAULT, SearchesConfig, default_evaluations
from orchestrator.steps.sensitivity import SensitivityConfig
from orchestrator.study import CaseConfig

from .common import order_text
from .measurements import Page, Run, Table, write_page

MATERIALS, COLUMNS = 8, 5


def core_seconds() -> float:
    """CPU seconds of this process and of its finished children (a study's worker processes end with it)."""
    own, children = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def study(folder: Path, table: Path, methods: tuple[str, ...], workers: int, sensitivity: bool):
    """The study of the catalogue with ``methods``: (the outcome, wall seconds, core-seconds)."""
    started, cpu = time.perf_counter(), core_seconds()
    configs = {Searches: SearchesConfig(methods=methods)}
    if not sensitivity:
        configs[Sensitivity] = SensitivityConfig(enabled=False)
    outcome = run_in_folder(
        RunConfig(out=str(folder), workers=workers, progress=False),
        CaseConfig(materials=str(table), cols=COLUMNS),
        configs,
        STEPS,
    )
    return outcome, time.perf_counter() - started, core_seconds() - cpu


def fastest(folder: Path, table: Path, methods, workers: int, repeats: int, name: str, sensitivity: bool):
    """The run of the study that took the least core-time (the shared machine's load only adds to it)."""
    runs = [study(folder / f"{name}{k}", table, methods, workers, sensitivity) for k in range(repeats)]
    return min(runs, key=lambda run: run[2])


def answer_text(outcome) -> str:
    return "; ".join(
        f"{a.diagonal_rule}: {order_text(a.order)} {a.peak:.4f} N, {a.evidence.status.replace('_', ' ')}"
        for a in outcome.study.result(Answers).answers
    )


def main(argv=None) -> int:
    run = Run.start(__file__, argv)
    parser = run.parser(__doc__, quick="each study once")
    parser.add_argument("--workers", type=int, default=2, help="worker processes of the studies")
    parser.add_argument("--repeats", type=int, default=3, help="runs of each study (the one of least core-time counts)")
    args = parser.parse_args(argv)
    repeats = 1 if args.quick else args.repeats
    with tempfile.TemporaryDirectory(prefix="bench_crossover_") as folder:
        folder = Path(folder)
        table = write_materials_csv(study_materials(MATERIALS), folder / "catalogue.csv")
        resolve(CaseConfig(materials=str(table), cols=COLUMNS))  # its FMU built first
        searched, searched_wall, searched_cpu = fastest(
            folder, table, SINGLE_DEFAULT, args.workers, repeats, "searched", False
        )
        swept, swept_wall, swept_cpu = fastest(folder, table, (SWEEP_METHOD,), args.workers, repeats, "swept", False)
        before, before_wall, _ = fastest(folder, table, SINGLE_DEFAULT, args.workers, repeats, "before", True)
        now, now_wall, _ = fastest(folder, table, (), args.workers, repeats, "now", True)
    evaluations = sum(r.n_evaluations for r in searched.study.result(Searches).runs)
    search_rate = evaluations / searched_cpu
    sweep_designs = sum(s.certificate.designs for s in swept.study.result(Exhaustive).sweeps)
    sweep_rate = sweep_designs / swept_cpu
    ratio = sweep_rate / search_rate
    config = SearchesConfig()
    per_rule = default_evaluations(config)
    threshold = SWEEP_DESIGNS_PER_SEARCH_EVALUATION * per_rule
    space = math.perm(MATERIALS, COLUMNS)
    holds = SWEEP_DESIGNS_PER_SEARCH_EVALUATION <= ratio
    certified = all(a.evidence.status == "certified" for a in now.study.result(Answers).answers)
    headline = (
        f"a sweep screens {ratio:.1f} designs in the core-time of one search evaluation (constant "
        f"{SWEEP_DESIGNS_PER_SEARCH_EVALUATION}: spaces up to {threshold:,} designs are swept by default); "
        f"the {space:,}-design catalogue's default study: {now_wall:.0f} s "
        f"({'certified' if certified else 'not certified'}), "
        f"{before_wall:.0f} s with the searches"
    )
    crossover_rows = (
        (
            "the default searches (" + " ".join(SINGLE_DEFAULT) + ")",
            f"{evaluations:,} evaluations",
            f"{searched_cpu:.1f}",
            f"{search_rate:,.0f} evaluations",
            f"{searched_wall:.1f}",
            answer_text(searched),
        ),
        (
            "the exhaustive sweep",
            f"{sweep_designs:,} designs",
            f"{swept_cpu:.1f}",
            f"{sweep_rate:,.0f} designs",
            f"{swept_wall:.1f}",
            answer_text(swept),
        ),
    )
    default_rows = (
        ("with the default searches (" + " ".join(SINGLE_DEFAULT) + ")", f"{before_wall:.1f}", answer_text(before)),
        ("as the default study runs now (no --method)", f"{now_wall:.1f}", answer_text(now)),
    )
    page = Page(
        name=run.name,
        title="Sweep or search: the crossover",
        headline=headline,
        summary=(
            f"The study's first {MATERIALS} materials over an 11 x {COLUMNS} lattice ({space:,} arrangements), "
            f"both diagonal rules, budget {config.budget}, {config.repeats} seeds, {args.workers} worker "
            f"process(es); of {repeats} run(s) of each study, the one of least core-time. Core-seconds: CPU "
            "time of the client and its worker processes over the whole study."
        ),
        tables=(
            Table(
                ("study (sensitivity off)", "work", "core-seconds", "per core-second", "wall s", "answers"),
                crossover_rows,
                caption="**The crossover, measured:**",
            ),
            Table(
                (
                    "measured ratio (sweep designs per search evaluation)",
                    "constant in the orchestrator",
                    "the constant at or below the ratio",
                    "default searches' evaluations per rule",
                    "spaces swept by default",
                ),
                (
                    (
                        f"{ratio:.2f}",
                        SWEEP_DESIGNS_PER_SEARCH_EVALUATION,
                        "yes" if holds else "NO",
                        f"{per_rule:,}",
                        f"up to {threshold:,} designs",
                    ),
                ),
                caption="**The threshold:**",
            ),
            Table(
                ("default study (every step at its default)", "wall s", "answers"),
                default_rows,
                caption="**The catalogue's default study:**",
            ),
        ),
        notes=(
            (
                "The constant holds: a space at the threshold costs a sweep no more core-time than the default "
                "searches."
                if holds
                else "The constant is above the measured ratio: lower "
                "SWEEP_DESIGNS_PER_SEARCH_EVALUATION in orchestrator/steps/exhaustive.py."
            ),
        ),
    )
    write_page(run, page)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
