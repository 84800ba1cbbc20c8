"""The study's Dask workers as SLURM batch jobs (``--cluster slurm``).

The ``slurm``-marked tests run against a real SLURM (``.ci/slurm-up`` starts a one-node one, as ``.ci/run`` does
before ``python -m pytest -m slurm``): an 11 x 8 sweep through SLURM jobs gives the process pool's certificate;
so does one whose jobs' walltime is shorter than the sweep (their workers leave, new jobs replace them), one
whose job is cancelled mid-sweep (``scancel``) and one whose jobs scale between one and two with its calls; none
simulates a design twice. Where sbatch or munge is absent,
the tests are not run as root or the node is not up, they skip with the reason. The other tests check the
options and their refusals without SLURM.
"""

from __future__ import annotations

import functools
import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

from orchestrator import run as run_cli
from orchestrator.cluster import ClusterConfig, walltime_seconds, worker_lifetime
from orchestrator.studyfile import read_study_file

ROOT = Path(__file__).resolve().parents[1]
SWEEP = ["--cols", "8", "--method", "exhaustive", "--diagonal-rule", "receiver", "--no-sensitivity", "--no-progress"]
JOB_NAME = "lattice-dask"


@functools.cache
def slurm_missing() -> str | None:
    """Why the SLURM tests cannot run here, or None (asked once: sinfo waits a while for a controller that is
    not there)."""
    for tool in ("sbatch", "squeue", "scancel", "sinfo", "munged"):
        if shutil.which(tool) is None and not Path("/usr/sbin", tool).exists():
            return f"{tool} not found (Debian: apt-get install slurm-wlm munge; then .ci/slurm-up as root)"
    if os.geteuid() != 0:
        return "not root: .ci/slurm-up runs SLURM's daemons as root, and the tests submit jobs to that SLURM"
    try:
        state = subprocess.run(["sinfo", "-h", "-o", "%t"], capture_output=True, text=True, timeout=60)
    except subprocess.TimeoutExpired:
        return "sinfo did not answer within 60 s: run .ci/slurm-up"
    if state.returncode != 0 or not {"idle", "mix", "alloc"} & set(state.stdout.split()):
        return f"no SLURM node up (sinfo: {(state.stdout + state.stderr).strip() or 'nothing'}): run .ci/slurm-up"
    return None


def needs_slurm(test):
    """Skips ``test`` with the reason where SLURM cannot run it (asked when the test runs, not when collected)."""

    @functools.wraps(test)
    def run(*args, **kwargs):
        if slurm_missing():
            pytest.skip(slurm_missing())
        return test(*args, **kwargs)

    return run


def run_sweep(out: Path, *extra: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.run(
        [sys.executable, "-m", "orchestrator.run", *SWEEP, "--out", str(out), *extra],
        capture_output=True,
        text=True,
        env=env,
        cwd=out.parent,
        timeout=900,
    )


def slurm_options(folder: Path, jobs: int, walltime: str) -> list[str]:
    return [
        "--executor",
        "dask",
        "--cluster",
        "slurm",
        "--jobs",
        str(jobs),
        "--walltime",
        walltime,
        "--job-directory",
        str(folder / "scratch"),
    ]


def certificate(out: Path) -> dict:
    return json.loads((out / "exhaustive" / "certificate.json").read_text())


def journal_keys(out: Path) -> list[str]:
    records = [json.loads(line) for line in (out / "journal.jsonl").read_text().splitlines()]
    return [record["key"] for record in records if "key" in record]


def simulated(out: Path) -> int:
    return json.loads((out / "results.json").read_text())["evaluator"]["simulated"]


def assert_same_certificate(out: Path, pool: Path) -> None:
    """The sweep certified the pool's optimum over every design once; what was screened differs (the force limit
    follows the order results arrive in), the optimum, its runner-up and the verdict do not."""
    ours, theirs = certificate(out), certificate(pool)
    assert ours["certified"] and theirs["certified"], ours["reasons"]
    for key in ("designs", "ranks", "covered_once", "failed", "screening_bound_held"):
        assert ours[key] == theirs[key], key
    for place in ("optimum", "runner_up"):
        assert ours[place]["order"] == theirs[place]["order"]
        assert ours[place]["full"] == pytest.approx(theirs[place]["full"], rel=1e-9)
    assert ours["gap"] == pytest.approx(theirs["gap"], rel=1e-6)
    keys = journal_keys(out)
    assert len(keys) == len(set(keys)), "a task journalled twice"
    assert simulated(out) == simulated(pool), "a design simulated twice, or one lost"


def job_logs(out: Path) -> int:
    return len(list((out / "slurm-jobs").glob("*.err")))


@pytest.fixture(scope="module")
def pool_sweep(tmp_path_factory):
    if slurm_missing():
        pytest.skip(slurm_missing())
    out = tmp_path_factory.mktemp("pool") / "sweep"
    done = run_sweep(out, "--workers", "2")
    assert done.returncode == 0, done.stderr
    return out


@pytest.mark.slurm
@pytest.mark.slow
@needs_slurm
def test_a_sweep_through_slurm_jobs_gives_the_process_pools_certificate(pool_sweep, tmp_path):
    out = tmp_path / "sweep"
    done = run_sweep(out, *slurm_options(tmp_path, 2, "00:30:00"))
    assert done.returncode == 0, done.stderr
    assert_same_certificate(out, pool_sweep)
    assert job_logs(out) == 2  # the two jobs ran the whole sweep


@pytest.mark.slurm
@pytest.mark.slow
@needs_slurm
def test_adaptive_jobs_scale_up_to_what_the_sweeps_calls_keep_busy(pool_sweep, tmp_path):
    out = tmp_path / "sweep"
    options = slurm_options(tmp_path, 1, "00:30:00")
    options[options.index("--jobs") : options.index("--jobs") + 2] = ["--min-jobs", "1", "--max-jobs", "2"]
    done = run_sweep(out, *options)
    assert done.returncode == 0, done.stderr
    assert_same_certificate(out, pool_sweep)
    assert job_logs(out) >= 2, "the sweep's calls did not ask for the second job"


@pytest.mark.slurm
@pytest.mark.slow
@needs_slurm
def test_a_sweep_longer_than_a_jobs_walltime_ends_certified(pool_sweep, tmp_path):
    out = tmp_path / "sweep"
    # a walltime of 5 s: its workers leave after 5 s, a few tenths of a second of chunks each after their start,
    # far less than the sweep's core-time on any machine, so jobs must be replaced for the sweep to finish
    done = run_sweep(out, *slurm_options(tmp_path, 2, "00:00:05"))
    assert done.returncode == 0, done.stderr
    assert_same_certificate(out, pool_sweep)
    assert job_logs(out) > 2, "no job reached its walltime: the sweep was shorter than the test means"


@pytest.mark.slurm
@pytest.mark.slow
@needs_slurm
def test_a_job_cancelled_mid_sweep_loses_nothing(pool_sweep, tmp_path):
    out = tmp_path / "sweep"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    log = (tmp_path / "run.log").open("w")
    process = subprocess.Popen(
        [sys.executable, "-m", "orchestrator.run", *SWEEP, "--out", str(out), *slurm_options(tmp_path, 2, "00:30:00")],
        stdout=log,
        stderr=subprocess.STDOUT,
        env=env,
        cwd=tmp_path,
    )
    try:
        journal = out.with_name(out.name + ".partial") / "journal.jsonl"
        deadline = time.monotonic() + 300
        while time.monotonic() < deadline and process.poll() is None:
            if journal.is_file() and len(journal.read_text().splitlines()) > 40:
                break
            time.sleep(0.5)
        jobs = subprocess.run(
            ["squeue", "-h", "-t", "RUNNING", "-n", JOB_NAME, "-o", "%i"], capture_output=True, text=True, check=True
        ).stdout.split()
        assert process.poll() is None and jobs, "the sweep ended before a job could be cancelled"
        subprocess.run(["scancel", jobs[0]], check=True)
        assert process.wait(timeout=600) == 0, (tmp_path / "run.log").read_text()[-2000:]
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
        log.close()
    # nothing lost and nothing simulated twice; whether a job replaces the cancelled one before the other job
    # finishes the sweep depends on the machine's speed, so it is not asserted (the walltime test replaces jobs)
    assert_same_certificate(out, pool_sweep)


# ------------------------------------------------------------------------------- the options, without SLURM
def test_a_walltime_is_hours_minutes_seconds_and_workers_leave_before_it():
    assert walltime_seconds("01:30:00") == 5400
    for wrong in ("90", "1:5", "00:00:00", "01:60:00", "abc"):
        with pytest.raises(ValueError, match="--walltime"):
            walltime_seconds(wrong)
    for walltime in (20, 60, 3600, 86400):
        lifetime, stagger = worker_lifetime(walltime)
        assert 0 < stagger < lifetime
        assert lifetime + stagger < walltime  # even the latest worker leaves before SLURM ends its job


def cli_error(capsys, argv: list[str]) -> str:
    with pytest.raises(SystemExit) as exited:
        code = run_cli.main(argv)
        raise SystemExit(code)
    assert exited.value.code == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1, lines
    return lines[0]


def test_slurm_options_are_refused_in_one_line_where_they_mean_nothing(capsys, tmp_path):
    out = str(tmp_path / "out")
    assert "only with --executor dask" in cli_error(capsys, ["--cluster", "slurm", "--out", out])
    assert "--jobs: only with --cluster slurm" in cli_error(capsys, ["--jobs", "3", "--out", out])
    assert "--walltime" in cli_error(
        capsys, ["--executor", "dask", "--cluster", "slurm", "--walltime", "1h", "--out", out]
    )
    assert "give one of them" in cli_error(
        capsys, ["--executor", "dask", "--cluster", "slurm", "--scheduler", "tcp://127.0.0.1:8786", "--out", out]
    )
    assert "--job-memory" in cli_error(
        capsys, ["--executor", "dask", "--cluster", "slurm", "--job-memory", "lots", "--out", out]
    )
    assert not (tmp_path / "out").exists() and not (tmp_path / "out.partial").exists()


def test_without_sbatch_the_run_is_refused_in_one_line(capsys, tmp_path, monkeypatch):
    monkeypatch.setenv("PATH", str(tmp_path))  # no sbatch on it
    line = cli_error(capsys, ["--executor", "dask", "--cluster", "slurm", "--out", str(tmp_path / "out")])
    assert "sbatch not found" in line


def test_a_study_files_cluster_section_sets_the_cluster(tmp_path):
    study = tmp_path / "study.toml"
    study.write_text(
        '[cluster]\ncluster = "slurm"\njobs = 16\nwalltime = "04:00:00"\nqueue = "short"\n'
        'account = "armour"\njob-cores = 8\njob-memory = "16GB"\n'
        'job-setup = ["module load python/3.11", "source ~/venv/bin/activate"]\n'
    )
    parser = run_cli.build_parser()
    args = read_study_file(study).apply(parser.parse_args(["--jobs", "4"]))  # the command line wins
    from orchestrator.options import config_from

    cluster = config_from(ClusterConfig, args)
    assert cluster == ClusterConfig(
        cluster="slurm",
        jobs=4,
        walltime="04:00:00",
        queue="short",
        account="armour",
        job_cores=8,
        job_memory="16GB",
        job_setup=("module load python/3.11", "source ~/venv/bin/activate"),
    )
    study.write_text("[cluster]\njobs = 0\n")
    with pytest.raises(ValueError, match=r"\[cluster\] jobs"):
        read_study_file(study)


def test_adaptive_job_bounds_come_in_pairs_from_the_command_line_or_the_study_file(capsys, tmp_path):
    assert ClusterConfig(cluster="slurm", jobs=3).job_bounds == (3, 3)
    adaptive = ClusterConfig(cluster="slurm", min_jobs=0, max_jobs=8, job_cores=2)
    assert adaptive.adaptive and adaptive.job_bounds == (0, 8)
    with pytest.raises(ValueError, match="--min-jobs and --max-jobs: give both"):
        ClusterConfig(cluster="slurm", max_jobs=8)
    with pytest.raises(ValueError, match="--min-jobs 5 and --max-jobs 4: the minimum is above the maximum"):
        ClusterConfig(cluster="slurm", min_jobs=5, max_jobs=4)
    out = str(tmp_path / "out")
    slurm = ["--executor", "dask", "--cluster", "slurm", "--out", out]
    assert "give a fixed number of jobs or the bounds" in cli_error(
        capsys, [*slurm, "--jobs", "4", "--min-jobs", "1", "--max-jobs", "8"]
    )
    assert "--max-jobs must be at least 1" in cli_error(capsys, [*slurm, "--min-jobs", "0", "--max-jobs", "0"])
    local = ["--min-jobs", "1", "--max-jobs", "2", "--out", out]
    assert "--max-jobs, --min-jobs: only with --cluster slurm" in cli_error(capsys, local)
    study = tmp_path / "study.toml"
    study.write_text('[cluster]\ncluster = "slurm"\nmin-jobs = 1\nmax-jobs = 16\n')
    from orchestrator.options import config_from

    cluster = config_from(ClusterConfig, read_study_file(study).apply(run_cli.build_parser().parse_args([])))
    assert cluster.job_bounds == (1, 16)


def test_the_job_script_runs_the_setup_lines_and_leaves_before_the_walltime(tmp_path):
    pytest.importorskip("dask_jobqueue")
    from dask_jobqueue.slurm import SLURMJob

    from orchestrator.cluster import SlurmJobs

    config = ClusterConfig(
        cluster="slurm",
        jobs=3,
        walltime="02:00:00",
        queue="short",
        account="armour",
        job_cores=4,
        job_memory="8GB",
        job_setup=("module load python",),
    )
    jobs = SlurmJobs(config, str(tmp_path / "logs"))
    assert jobs.workers == 12
    script = SLURMJob(scheduler="tcp://127.0.0.1:8786", name="x", **jobs.job_options()).job_script()
    for expected in (
        "#SBATCH -p short",
        "#SBATCH -A armour",
        "#SBATCH -t 02:00:00",
        "module load python",
        "--lifetime",
        "--lifetime-stagger",
        "--nworkers 4",
        "--nthreads 1",
    ):
        assert expected in script, expected
