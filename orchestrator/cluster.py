"""Dask workers as batch jobs of a SLURM cluster (dask-jobqueue's ``SLURMCluster``).

Why batch jobs: a university or company cluster runs work only through its scheduler, so the study's Dask
workers are jobs that start when the queue lets them, end at their walltime and may be cancelled. Each job
runs one single-threaded worker per core it asks for (each takes calls, ``executors.DaskWorkers``), receives the
FMU as bytes as any Dask worker does (``dask_plugin.ShipFMU``), and leaves before its walltime, as dask-jobqueue
advises: ``--lifetime`` a margin short of the walltime, staggered so that the jobs do not all leave at once,
and adaptive scaling that keeps ``jobs`` jobs queued or running, so a job that left (its lifetime, ``scancel``,
a crash) is replaced. A call in flight on a worker that left runs again on another worker (``DaskWorkers``); the
journal keeps every finished result, so a sweep longer than one job's walltime finishes with nothing lost and
nothing simulated twice.

The settings are command-line options (``--cluster slurm --jobs N --walltime HH:MM:SS``) and the study file's
``[cluster]`` section (queue, account, cores and memory per job, the job's environment set-up lines).
"""

from __future__ import annotations

import contextlib
import logging
import re
import shutil
from dataclasses import dataclass
from importlib.util import find_spec
from pathlib import Path
from typing import Callable, Iterator

from .options import NO_NUMBER, NOT_KEPT, check_options, given, integer, number, option

CLUSTERS = ("none", "slurm")
WALLTIME = re.compile(r"^(\d+):([0-5]\d):([0-5]\d)$")
MAX_STAGGER = 240.0  # s: dask-jobqueue's example staggers the workers' lifetimes by up to four minutes
JOB_LOGS = "slurm-jobs"  # the jobs' output files, in the run's folder
JOB_NAME = "lattice-dask"  # the jobs' name in squeue


def walltime_seconds(text: str) -> int:
    """``HH:MM:SS`` in seconds; ValueError names the option and the form."""
    found = WALLTIME.match(text.strip()) if isinstance(text, str) else None
    if found is None or sum(int(part) for part in found.groups()) == 0:
        raise ValueError(f"--walltime {text}: give a job's time limit as HH:MM:SS (e.g. 01:00:00), more than zero")
    hours, minutes, seconds = (int(part) for part in found.groups())
    return 3600 * hours + 60 * minutes + seconds


def worker_lifetime(walltime: int) -> tuple[int, int]:
    """(lifetime, stagger) in seconds for a job of ``walltime``: a worker leaves after lifetime +- stagger, so it
    leaves before SLURM ends its job even at the stagger's end, with a margin for the job's own start-up."""
    stagger = int(min(MAX_STAGGER, walltime / 12))
    margin = int(min(60.0, walltime / 12))
    return max(1, walltime - 2 * stagger - margin), stagger


@dataclass(frozen=True)
class ClusterConfig:
    """Where Dask's workers come from with ``--executor dask`` (none of it changes a result)."""

    cluster: str = option(
        "none",
        "where Dask's workers run: none (a local cluster, or --scheduler's), slurm "
        "(batch jobs of a SLURM cluster; with --executor dask)",
        choices=CLUSTERS,
        study=NO_NUMBER,
    )
    jobs: int = option(
        2,
        "SLURM jobs kept queued or running; a job that ends (its walltime, scancel) is replaced",
        type=integer("--jobs", 1, 10**5),
        study=NO_NUMBER,
    )
    min_jobs: int | None = option(
        None,
        "with --max-jobs: adaptive scaling, at least this many jobs (0: none while the run has no work for "
        "them); instead of --jobs",
        type=integer("--min-jobs", 0, 10**5),
        show_default="--jobs, fixed",
        study=NO_NUMBER,
    )
    max_jobs: int | None = option(
        None,
        "with --min-jobs: adaptive scaling, at most this many jobs, as many as the run's calls keep busy",
        type=integer("--max-jobs", 1, 10**5),
        show_default="--jobs, fixed",
        study=NO_NUMBER,
    )
    walltime: str = option(
        "01:00:00",
        "each job's time limit, HH:MM:SS; its workers leave before it, staggered",
        metavar="HH:MM:SS",
        study=NO_NUMBER,
    )
    queue: str | None = option(
        None,
        "the SLURM partition jobs are submitted to",
        show_default="the cluster's default partition",
        study=NO_NUMBER,
    )
    account: str | None = option(None, "the SLURM account jobs are charged to", show_default="yours", study=NO_NUMBER)
    job_cores: int = option(
        1, "cores per job: one single-threaded Dask worker each", type=integer("--job-cores", 1, 4096), study=NO_NUMBER
    )
    job_memory: str = option(
        "2GB", "memory per job (e.g. 2GB, 500MB), shared by its workers", metavar="SIZE", study=NO_NUMBER
    )
    job_setup: tuple[str, ...] = option(
        (),
        "a shell line each job runs before its workers start (e.g. module "
        "load python; source venv/bin/activate); repeat for several",
        action="append",
        metavar="LINE",
        study=NO_NUMBER,
    )
    job_start: float = option(
        3600.0,
        "seconds to wait for the first job to start (the queue) before giving up",
        type=number("--job-start", 0),
        metavar="S",
        study=NO_NUMBER,
    )
    job_directory: str | None = option(
        None,
        "each worker's scratch folder on its node (the FMU's copy goes there)",
        show_default="the node's temporary folder",
        metavar="DIR",
        study=NOT_KEPT,
    )

    def __post_init__(self):
        object.__setattr__(self, "job_setup", tuple(self.job_setup))
        check_options(self)
        walltime_seconds(self.walltime)
        if not re.fullmatch(r"\d+(\.\d+)?\s*[KMGT]i?B", self.job_memory.strip(), re.IGNORECASE):
            raise ValueError(f"--job-memory {self.job_memory}: give a size such as 2GB, 500MB or 4GiB")
        for line in self.job_setup:
            if "\n" in line:
                raise ValueError("--job-setup: one shell line each (repeat the option for several)")
        if (self.min_jobs is None) != (self.max_jobs is None):
            raise ValueError(
                "--min-jobs and --max-jobs: give both (adaptive scaling between them) or neither (--jobs, fixed)"
            )
        if self.adaptive and self.min_jobs > self.max_jobs:
            raise ValueError(
                f"--min-jobs {self.min_jobs} and --max-jobs {self.max_jobs}: the minimum is above the maximum"
            )

    @property
    def adaptive(self) -> bool:
        """Scaled between ``min_jobs`` and ``max_jobs`` jobs with the work, not kept at ``jobs``."""
        return self.min_jobs is not None and self.max_jobs is not None

    @property
    def job_bounds(self) -> tuple[int, int]:
        """The fewest and the most jobs the cluster keeps queued or running."""
        if self.min_jobs is not None and self.max_jobs is not None:
            return self.min_jobs, self.max_jobs
        return self.jobs, self.jobs

    @property
    def slurm(self) -> bool:
        return self.cluster == "slurm"


def check_cluster(cluster: ClusterConfig, executor: str, scheduler: str | None) -> None:
    """Refuses, in one line, a cluster the run cannot use: before any FMU is built."""
    if not cluster.slurm:
        stray = sorted(name for name in given(cluster) if name != "cluster")
        if stray:
            flags = ", ".join("--" + name.replace("_", "-") for name in stray)
            raise ValueError(f"{flags}: only with --cluster slurm")
        return
    if executor != "dask":
        raise ValueError("--cluster slurm: only with --executor dask (the workers are Dask workers in SLURM jobs)")
    if cluster.adaptive and "jobs" in given(cluster):
        raise ValueError(
            "--jobs and --min-jobs/--max-jobs: give a fixed number of jobs or the bounds of adaptive scaling, not both"
        )
    if scheduler is not None:
        raise ValueError(
            "--cluster slurm and --scheduler: give one of them (the jobs' workers join a scheduler this run starts)"
        )
    if shutil.which("sbatch") is None:
        raise ValueError(
            "--cluster slurm: sbatch not found on PATH (run on a SLURM cluster's login node, or load its module)"
        )
    if find_spec("dask_jobqueue") is None:
        raise ValueError(
            "--cluster slurm needs dask-jobqueue: install the project's dask extra (python -m pip install '.[dask]')"
        )


@dataclass(frozen=True)
class SlurmJobs:
    """A ``ClusterConfig`` made into a running ``SLURMCluster``: what ``executors.make_executor`` opens."""

    config: ClusterConfig
    log_directory: str  # the jobs' output files (a folder the compute nodes can write: the run's own)

    @property
    def workers(self) -> int:
        """The Dask workers of all jobs together, once every job runs (the most jobs, when they adapt)."""
        return self.config.job_bounds[1] * self.config.job_cores

    @property
    def job_start(self) -> float:
        return self.config.job_start

    @contextlib.contextmanager
    def open(self, wanted_workers: Callable[[], int] | None = None) -> Iterator:
        """The cluster, scaled adaptively between the config's job bounds (``jobs`` and ``jobs`` when fixed) to
        ``wanted_workers()``, the workers the run's calls would keep busy (without it, or while it says 0
        before the run's first call, one job's workers); every job cancelled on exit."""
        from dask_jobqueue import SLURMCluster

        Path(self.log_directory).mkdir(parents=True, exist_ok=True)
        # the scheduler runs in this process: every worker that leaves is logged by Dask as errors of connections
        # to it; the jobs' own logs (log_directory) keep the workers' side
        distributed_log = logging.getLogger("distributed")
        level = distributed_log.level
        distributed_log.setLevel(logging.CRITICAL)
        try:
            cluster = SLURMCluster(
                **self.job_options(),
                silence_logs=logging.ERROR,
                scheduler_options={"dashboard": False, "dashboard_address": ":0"},
            )
            try:
                fewest, most = self.config.job_bounds
                cluster.adapt(
                    minimum_jobs=fewest,
                    maximum_jobs=most,
                    Adaptive=adaptive_to_calls(),
                    wanted_workers=wanted_workers,
                    first_workers=self.config.job_cores,
                )
                yield cluster
            finally:
                cluster.close()
        finally:
            distributed_log.setLevel(level)

    def job_options(self) -> dict:
        """What each job asks SLURM for and runs: one single-threaded worker per core, leaving staggered before
        the walltime."""
        config = self.config
        lifetime, stagger = worker_lifetime(walltime_seconds(config.walltime))
        return dict(
            cores=config.job_cores,
            processes=config.job_cores,
            memory=config.job_memory,
            walltime=config.walltime,
            queue=config.queue,
            account=config.account,
            job_script_prologue=list(config.job_setup),
            log_directory=self.log_directory,
            local_directory=config.job_directory,
            job_name=JOB_NAME,
            worker_extra_args=["--lifetime", f"{lifetime}s", "--lifetime-stagger", f"{stagger}s"],
        )

    def wait(self, client) -> None:
        """Until the first worker joined (the queue may hold the jobs a while); refused past ``job_start``."""
        try:
            client.wait_for_workers(1, timeout=self.config.job_start)
        except TimeoutError:
            raise RuntimeError(
                f"--cluster slurm: no job started within {self.config.job_start:g} s (--job-start); "
                "squeue shows why they wait"
            ) from None


def adaptive_to_calls():
    """Dask's ``Adaptive``, with the target the run's calls set: they are requests to the workers, never Dask
    tasks, so the scheduler's own target (from its queue of tasks) would never ask for more than the minimum."""
    from distributed.deploy import Adaptive

    class AdaptiveToCalls(Adaptive):
        def __init__(self, *args, wanted_workers: Callable[[], int] | None = None, first_workers: int = 1, **kwargs):
            self.wanted_workers = wanted_workers
            self.first_workers = first_workers
            super().__init__(*args, **kwargs)

        async def target(self) -> int:
            wanted = self.wanted_workers() if self.wanted_workers is not None else 0
            return wanted or self.first_workers  # clamped to the job bounds by Dask's safe_target

    return AdaptiveToCalls


__all__ = [
    "CLUSTERS",
    "ClusterConfig",
    "SlurmJobs",
    "adaptive_to_calls",
    "check_cluster",
    "walltime_seconds",
    "worker_lifetime",
]
