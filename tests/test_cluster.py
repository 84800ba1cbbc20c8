"""A cluster that needs no shared folder: the README's Dask recipe run as written, with a worker that cannot see
the client's folder or the repository, gives the process pool's answer; a worker that cannot run the FMU says
why; the console counts failed evaluations as failed.

The recipe is run as the README writes it, with only what a test must add: the scheduler listens on
127.0.0.1 at a free port (``--host 127.0.0.1 --port 0 --no-dashboard``), ``HOST:8786`` is the address it
prints, and the client's study is a small one (a 5-column FMU, 120 designs): ``--confirm-cost`` is left out
because such a sweep is within every bound (the command refuses a confirmation with nothing to confirm).
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

from builder.build import build_fmu
from orchestrator.dask_plugin import ShipFMU
from orchestrator.exhaustive import ChunkResult
from orchestrator.loop import failures_of
from orchestrator.objective import FMURun, close_instances
from orchestrator.types import Evaluation, failed

pytest.importorskip("distributed")
ROOT = Path(__file__).resolve().parents[1]
SMALL = [
    "--cols",
    "5",
    "--diagonal-rule",
    "receiver",
    "--budget",
    "20",
    "--repeats",
    "1",
    "--no-sensitivity",
    "--no-progress",
]


def readme_recipe() -> list[str]:
    """The README's Dask recipe: the scheduler, the worker and the client's command, as written."""
    text = (ROOT / "README.md").read_text()
    lines = [line.split("#")[0].strip() for line in text.splitlines()]
    scheduler = next(line for line in lines if line.startswith("dask scheduler"))
    worker = next(line for line in lines if line.startswith("dask worker"))
    client = next(line for line in lines if line.startswith("python orchestrator/run.py") and "--executor dask" in line)
    return [scheduler, worker, client]


def can_hide_folders() -> bool:
    """Whether this machine lets a process see other mounts than ours (a mount namespace, as root)."""
    if not shutil.which("unshare") or os.geteuid() != 0:
        return False
    return (
        subprocess.run(["unshare", "--mount", "--propagation", "private", "true"], capture_output=True).returncode == 0
    )


def repository_folders_but_the_interpreters() -> list[Path]:
    """The repository, or, where this Python's environment lives inside it (a virtual environment in the
    checkout), every folder of it but the one holding that environment: the worker keeps its interpreter."""
    prefix = Path(sys.prefix).resolve()
    if not prefix.is_relative_to(ROOT.resolve()):
        return [ROOT]
    return sorted(
        folder for folder in ROOT.iterdir() if folder.is_dir() and not prefix.is_relative_to(folder.resolve())
    )


@pytest.fixture(scope="module")
def fmu5(tmp_path_factory):
    return build_fmu("armour_11x11", tmp_path_factory.mktemp("fmu5") / "MassSpringLattice11x5.fmu", cols=5, werror=True)


def start_scheduler(command: str, folder: Path, env: dict) -> tuple[subprocess.Popen, str]:
    log = (folder / "scheduler.log").open("w")
    process = subprocess.Popen(
        command.split() + ["--host", "127.0.0.1", "--port", "0", "--no-dashboard"],
        cwd=folder,
        env=env,
        stdout=log,
        stderr=subprocess.STDOUT,
    )
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        found = re.search(r"tcp://127\.0\.0\.1:\d+", (folder / "scheduler.log").read_text())
        if found:
            return process, found.group(0)
        if process.poll() is not None:
            break
        time.sleep(0.2)
    process.kill()
    raise AssertionError("the scheduler did not start: " + (folder / "scheduler.log").read_text())


def stop(process: subprocess.Popen) -> None:
    if process.poll() is None:
        process.terminate()
        try:
            process.wait(timeout=30)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()


def test_the_readme_dask_recipe_needs_no_shared_folder(fmu5, tmp_path):
    scheduler_command, worker_command, client_command = readme_recipe()
    assert "HOST:8786" in worker_command and "HOST:8786" in client_command
    client = tmp_path / "client"
    client.mkdir()
    shutil.copy(fmu5, client / "model.fmu")  # the client names it relatively: a path only its own folder knows
    worker_home = tmp_path / "worker"
    (worker_home / "tmp").mkdir(parents=True)
    code = worker_home / "installed"  # the project as installed on another machine: its own copy of the code
    for package in ("orchestrator", "fmu_src", "builder", "scenes"):
        shutil.copytree(ROOT / package, code / package, ignore=shutil.ignore_patterns("__pycache__"))
    env = {**os.environ, "TMPDIR": str(worker_home / "tmp")}
    scheduler, address = start_scheduler(scheduler_command, tmp_path, env)
    worker_env = {**env, "PYTHONPATH": str(code)}
    worker_argv = worker_command.replace("tcp://HOST:8786", address).split()
    if can_hide_folders():  # the client's folder and the repository's code are empty folders for the worker
        hidden = [client, *repository_folders_but_the_interpreters()]
        worker_argv = [
            "unshare",
            "--mount",
            "--propagation",
            "private",
            "sh",
            "-c",
            'n=$1; shift; while [ "$n" -gt 0 ]; do mount -t tmpfs tmpfs "$1" || exit 1; shift; '
            'n=$((n - 1)); done; exec "$@"',
            "sh",
            str(len(hidden)),
            *map(str, hidden),
        ] + worker_argv
    worker_log = (worker_home / "worker.log").open("w")
    worker = subprocess.Popen(worker_argv, cwd=worker_home, env=worker_env, stdout=worker_log, stderr=subprocess.STDOUT)
    try:
        argv = client_command.replace("tcp://HOST:8786", address).split()
        assert argv[:2] == ["python", "orchestrator/run.py"] and "--confirm-cost" in argv
        argv = [sys.executable, str(ROOT / "orchestrator" / "run.py")] + [a for a in argv[2:] if a != "--confirm-cost"]
        dask = subprocess.Popen(
            argv + ["--fmu", "model.fmu", "--out", "dask", *SMALL],
            cwd=client,
            env=env,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        deadline = time.monotonic() + 600
        while dask.poll() is None and worker.poll() is None and time.monotonic() < deadline:
            time.sleep(0.5)
        if dask.poll() is None:  # a dead worker leaves the client waiting for one: say why, at once
            dask.kill()
            _, stderr = dask.communicate()
            raise AssertionError(
                f"the worker {'ended' if worker.poll() is not None else 'hung'}: "
                + (worker_home / "worker.log").read_text()
            )
        _, stderr = dask.communicate()
        assert dask.returncode == 0, stderr + (worker_home / "worker.log").read_text()
    finally:
        stop(worker)
        stop(scheduler)
        worker_log.close()
    pool = subprocess.run(
        [
            sys.executable,
            str(ROOT / "orchestrator" / "run.py"),
            "--method",
            "exhaustive",
            "--executor",
            "process",
            "--workers",
            "2",
            "--fmu",
            "model.fmu",
            "--out",
            "pool",
            *SMALL,
        ],
        cwd=client,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert pool.returncode == 0, pool.stderr
    by_dask = json.loads((client / "dask" / "results.json").read_text())["answers"][0]
    by_pool = json.loads((client / "pool" / "results.json").read_text())["answers"][0]
    assert by_dask["order"] == by_pool["order"] and by_dask["evidence"]["status"] == "certified"
    assert by_dask["peak"] == pytest.approx(by_pool["peak"], rel=1e-12)
    assert not list(client.glob("**/lattice-fmus"))


class FakeWorker:
    def __init__(self, folder: Path):
        self.local_directory = str(folder)
        self.address = "tcp://127.0.0.1:1"


def test_a_worker_that_cannot_run_the_fmu_says_why_and_its_tasks_fail_with_the_reason(tmp_path):
    bad = tmp_path / "client" / "broken.fmu"
    bad.parent.mkdir()
    bad.write_bytes(b"PK\x05\x06" + b"\x00" * 18)  # an empty zip: no model description, no binary
    plugin = ShipFMU(bad)
    bad.unlink()  # the worker never reads the client's file
    with pytest.raises(RuntimeError, match=r"Dask worker tcp://127\.0\.0\.1:1 cannot run broken\.fmu: "):
        plugin.setup(FakeWorker(tmp_path / "worker"))
    evaluation = FMURun(str(bad), 1.0, fmu_sha256=plugin.sha256)((1, 2, 3))
    assert not evaluation.ok and "cannot run broken.fmu" in evaluation.message


def test_a_shipped_fmu_runs_from_the_workers_copy(fmu5, tmp_path):
    client = tmp_path / "client.fmu"
    shutil.copy(fmu5, client)
    plugin = ShipFMU(client)
    client.unlink()
    try:
        plugin.setup(FakeWorker(tmp_path / "worker"))
        (copy,) = (tmp_path / "worker" / "lattice-fmus" / plugin.sha256).glob("*.fmu")
        evaluation = FMURun(str(client), 8.0, fmu_sha256=plugin.sha256)((1, 2, 3, 4, 5))
        assert evaluation.ok and evaluation.value > 0
        plugin.setup(FakeWorker(tmp_path / "worker"))  # a second time: the copy is kept
        assert copy.is_file()
    finally:
        close_instances()


def test_failed_evaluations_are_counted_as_failed():
    assert failures_of(failed((1, 2), "FMU not found", 0.1)) == ["FMU not found"]
    assert failures_of(Evaluation((1, 2), 3.0, "ok")) == []
    chunk = ChunkResult(0, 24, "failed", "worker lost", (), (), False, (), 0, 0, None, None, (), 0.0, 0.0, 0.0)
    assert failures_of(chunk) == ["worker lost"] * 24


def test_adaptive_scaling_follows_the_calls_not_the_schedulers_tasks(tmp_path):
    """The calls are requests to the workers, never Dask tasks: the cluster scales to what they want, within
    its bounds, and back to one job's workers when they want none."""
    from distributed import LocalCluster

    from orchestrator.cluster import adaptive_to_calls

    wanted = [3]
    with LocalCluster(
        n_workers=1, processes=False, threads_per_worker=1, dashboard_address=None, local_directory=tmp_path
    ) as cluster:
        cluster.adapt(
            Adaptive=adaptive_to_calls(),
            minimum=1,
            maximum=4,
            wanted_workers=lambda: wanted[0],
            interval="50ms",
            wait_count=1,
        )
        assert workers_become(cluster, 3)
        wanted[0] = 9
        assert workers_become(cluster, 4)  # at most the maximum
        wanted[0] = 0
        assert workers_become(cluster, 1)


def workers_become(cluster, count: int, timeout: float = 60.0) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if len(cluster.scheduler_info["workers"]) == count:
            return True
        time.sleep(0.1)
    return False


def test_the_workers_wanted_are_those_the_calls_since_the_last_look_kept_busy():
    from orchestrator.executors import make_executor

    with make_executor("dask", workers=2) as executor:
        assert executor.wanted_workers() == 0
        calls = [executor.submit(time.sleep, 0.5) for _ in range(4)]
        assert executor.wanted_workers() == 2  # four calls, two to a worker
        for call in calls:
            call.result()
        assert executor.wanted_workers() == 2  # the peak since the last look
        assert executor.wanted_workers() == 0
