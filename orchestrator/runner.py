"""One run of a study in a report folder, from options to a published report.

``run_in_folder`` is what the command line calls: it takes the folder's lock, asks ``orchestrator.scene`` for
the scene, its table and its FMU, resolves the case, refuses (before any simulation) options that mean nothing
in this run and work beyond a stated bound, opens the journal and the executor, runs the study's steps, renders
the report and swaps the finished folder in (``orchestrator.runfolder``).
"""

from __future__ import annotations

import logging
import os
import shutil
import sys
import tempfile
from dataclasses import dataclass
from importlib.util import find_spec
from pathlib import Path


from .cluster import JOB_LOGS, ClusterConfig, SlurmJobs, check_cluster
from .executors import EXECUTORS, SerialExecutor, make_executor
from .exhaustive import ChunkResult
from .fmu import PreparedFMU
from .journal import Journal
from .loop import Evaluator
from .objective import Trajectory, close_instances, count_cases
from .options import NO_NUMBER, NOT_KEPT, check_options, given, integer, number, option
from .progress import Progress
from .records import to_record
from .runfolder import RunFolder, make_temp_root
from .scene import narrowed_table_note, resolve
from .studyfile import write_study_file
from .steps.searches import SearchesConfig
from .interruption import raise_if_requested
from .study import MAX_RUNS_PER_DESIGN, CaseConfig, StudyContext, StudyResult, resolve_case, run_study
from .types import Evaluation

RESULT_KINDS = {cls.kind: cls for cls in (Evaluation, ChunkResult, Trajectory)}
SETTINGS_FORMAT = 1
MAX_WORKERS_PER_CORE = 4


@dataclass(frozen=True)
class RunConfig:
    """Where and how a study runs (none of it changes a result)."""

    out: str = option(
        "results",
        "report folder; while the run works it writes OUT.partial, swapped in as a whole when the run finishes",
        metavar="DIR",
        study=NOT_KEPT,
        path=True,
    )
    resume: bool = option(
        False,
        "continue the run of --out from its journal (same settings), simulating nothing it finished",
        action="store_true",
        study=NOT_KEPT,
    )
    overwrite: bool = option(
        False,
        "start anew although --out holds an unfinished run (its journal is kept as journal-RUNID.jsonl)",
        action="store_true",
        study=NOT_KEPT,
    )
    executor: str = option("process", "where evaluations run", choices=EXECUTORS, study=NO_NUMBER)
    workers: int | None = option(
        None,
        "worker processes",
        type=integer("--workers", 1, 10**6),
        show_default=f"all cores ({os.cpu_count()})",
        study=NO_NUMBER,
    )
    scheduler: str | None = option(
        None,
        "address of a Dask scheduler (only with --executor dask)",
        show_default="a local Dask cluster of --workers processes",
        metavar="ADDRESS",
        study=NO_NUMBER,
    )
    time_limit: float = option(
        120.0,
        "seconds one evaluation may run (its own run time, not its time in a queue) "
        "before it is failed; it runs again on --resume",
        type=number("--time-limit", 0),
        metavar="S",
    )
    confirm_cost: bool = option(
        False,
        "run work beyond the stated bounds (an exhaustive sweep beyond 10! designs "
        "on Dask, more than 1000 FMU runs per design, more workers than 4 per core)",
        action="store_true",
    )
    progress: bool = option(True, "no progress bars", flag="--no-progress", action="store_false", study=NOT_KEPT)
    debug: bool = option(False, "tracebacks instead of one-line errors", action="store_true", study=NOT_KEPT)

    def __post_init__(self):
        check_options(self)
        if self.resume and self.overwrite:
            raise ValueError("--resume and --overwrite: give one of them (continue the run, or start anew)")
        if self.scheduler is not None and self.executor != "dask":
            raise ValueError("--scheduler: only with --executor dask")
        if self.executor == "dask" and find_spec("distributed") is None:  # before the FMU is built
            raise ValueError("--executor dask: needs Dask, the project's dask extra (python -m pip install '.[dask]')")


class NoResult(RuntimeError):
    """The study finished without an answer (every evaluation failed, or nothing touched the backplate)."""


@dataclass(frozen=True)
class Outcome:
    study: StudyResult
    report: Path
    folder: Path
    resumed: bool


def check_same_fmu(run: RunConfig, folder: RunFolder, fmu: PreparedFMU) -> None:
    """A run resumes only with the FMU it started with (its numbers stay one model's): another build, the scene's
    FMU rebuilt since, is refused by name, saying what to do."""
    previous = folder.previous
    if not run.resume or previous is None or previous.settings.get("fmu_sha256") in (None, fmu.sha256):
        return
    raise ValueError(
        f"--resume: {fmu.path} is another build than the FMU the run in {run.out} started with (it was "
        "rebuilt since, or another file was given): a run resumes only with the FMU it started with; "
        "start anew with --overwrite, or resume with that FMU (--fmu FILE)"
    )


def check_bounds(run: RunConfig, case, beyond: list[str]) -> None:
    """Work beyond a stated bound is refused with its projected size unless confirmed (what was beyond a bound
    goes into ``beyond``)."""
    cores = os.cpu_count() or 1
    workers = run.workers or cores
    if run.scheduler is None and workers > MAX_WORKERS_PER_CORE * cores:
        beyond.append("workers")
        if not run.confirm_cost:
            raise ValueError(
                f"--workers {workers}: more than {MAX_WORKERS_PER_CORE} per core ({cores} cores here) "
                f"would slow every evaluation down; give at most {MAX_WORKERS_PER_CORE * cores}, or "
                "confirm with --confirm-cost"
            )
    runs = count_cases(case.case_lists)
    if runs > MAX_RUNS_PER_DESIGN:
        beyond.append("case")
        if not run.confirm_cost:
            budget = SearchesConfig.budget  # the default searches' designs per run
            raise ValueError(
                f"--case: {runs:,} FMU runs per design (the product of the lists) is beyond "
                f"{MAX_RUNS_PER_DESIGN:,}; a search of {budget} designs would run {budget * runs:,}; "
                "give shorter lists, or confirm with --confirm-cost"
            )


def check_confirmation(run: RunConfig, beyond: list[str]) -> None:
    """A confirmation with nothing to confirm is named, not refused: the run it allows is the run asked for,
    and the line shows a user who expected a larger run that this one is not."""
    if run.confirm_cost and not beyond:
        print(nothing_to_confirm(), file=sys.stderr)


def nothing_to_confirm() -> str:
    from .exhaustive import MAX_LOCAL_DESIGNS

    return (
        "--confirm-cost: nothing in this run is beyond a bound (an exhaustive sweep beyond "
        f"{MAX_LOCAL_DESIGNS:,} designs, more than {MAX_RUNS_PER_DESIGN} FMU runs per design, more "
        f"than {MAX_WORKERS_PER_CORE} workers per core), so it changes nothing"
    )


def settings(case, fmu: PreparedFMU, steps) -> dict:
    """What decides the results, by value (a resumed run must match it): the FMU by its hash, never its path."""
    return {
        "format": SETTINGS_FORMAT,
        "fmu_sha256": fmu.sha256,
        "case": to_record(case),
        "steps": {step.name: to_record(step.config) for step in steps},
    }


def run_in_folder(
    run: RunConfig,
    case_config: CaseConfig,
    step_configs: dict,
    step_types,
    study_file=None,
    cluster: ClusterConfig | None = None,
) -> Outcome:
    """``study_file``: the ``orchestrator.studyfile.StudyFile`` the options came from, if any; ``cluster``:
    where Dask's workers run (a local cluster without it)."""
    cluster = cluster or ClusterConfig()
    check_cluster(cluster, run.executor, run.scheduler)
    if cluster.slurm and "workers" in given(run):
        raise ValueError("--workers: not with --cluster slurm (its workers are --jobs x --job-cores)")
    folder = RunFolder.open(run.out, resume=run.resume, overwrite=run.overwrite)
    temp_root = make_temp_root()
    previous_tempdir = tempfile.tempdir
    tempfile.tempdir = temp_root  # this process's extractions too; removed with the run
    try:
        resolved = resolve(case_config)
        fmu, table = resolved.fmu, resolved.table
        note = narrowed_table_note(case_config)
        if note:  # once the case is runnable: a refused run says only why, in one line
            print(note, file=sys.stderr)
        check_same_fmu(run, folder, fmu)
        if study_file is not None:
            study_file.check_materials(table)
        case = resolve_case(case_config, resolved)
        steps = [step_type(step_configs.get(step_type)) for step_type in step_types]
        context = StudyContext(
            fmu=fmu,
            case=case,
            evaluator=Evaluator(SerialExecutor()),
            steps=steps,
            progress=Progress(run.progress),
            executor_kind=run.executor,
            confirm_cost=run.confirm_cost,
        )
        check_bounds(run, case, context.beyond_bounds)
        for step in steps:
            step.check(context)
        check_confirmation(run, context.beyond_bounds)
        jobs = SlurmJobs(cluster, str(folder.partial / JOB_LOGS)) if cluster.slurm else None
        write_study_file(
            folder.partial,
            {
                RunConfig: run,
                CaseConfig: case_config,
                ClusterConfig: cluster,
                **{type(step).Config: step.config for step in steps},
            },
            table.sha256(),
            fmu.sha256,
        )
        with (
            Journal(
                folder.partial, settings(case, fmu, steps), RESULT_KINDS, resume=folder.previous is not None
            ) as journal,
            make_executor(run.executor, run.workers, run.scheduler, temp_root, (fmu.path,), jobs) as executor,
        ):
            context.evaluator = Evaluator(executor, journal, run.time_limit)
            if journal.repaired:
                print(
                    f"{journal.path}: its last line was cut off (the run was killed); that task runs again",
                    file=sys.stderr,
                )
            study = run_study(context, journal.run_id)
            report = write(study, folder.partial, steps, table)
            raise_if_requested()  # a SIGTERM swallowed while drawing: the run stays partial, for --resume
            journal.finish()
        published = folder.publish()
        check_answer(study, steps)
        return Outcome(study, published / report.name, published, folder.previous is not None)
    finally:
        tempfile.tempdir = previous_tempdir
        close_instances()
        shutil.rmtree(temp_root, ignore_errors=True)
        folder.release()


def write(study: StudyResult, out: Path, steps, table) -> Path:
    from .report import write_report

    logging.getLogger("matplotlib").setLevel(logging.WARNING)
    return write_report(study, out, steps, table)


def check_answer(study: StudyResult, steps) -> None:
    """A finished study without a usable answer exits non-zero, saying why, after its report was written: each
    step in order gives its verdict, until one holds the answer or one refuses it."""
    for step in steps:
        verdict = step.verdict(study.result(type(step)), study)
        if verdict.refusal is not None:
            raise NoResult(verdict.refusal)
        if verdict.answered:
            return


__all__ = ["NoResult", "Outcome", "RESULT_KINDS", "RunConfig", "run_in_folder", "settings"]
