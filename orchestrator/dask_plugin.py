"""What a Dask worker holds for a run: the FMU itself, and what it frees when it closes.

Why the FMU travels as bytes: a cluster's workers do not share the client's folder (another machine, another
working directory), so a path means nothing there. ``ShipFMU`` carries the FMU's bytes and their SHA-256; each
worker writes them once into its own local directory under that hash (a worker that already has them keeps its
copy), instantiates the FMU once, and from then on runs every task naming that hash on its copy. Dask sends a
registered worker plugin to every worker, including the ones that join later. A worker that cannot run the FMU
(another platform, no room for the copy) says why at once: registering the plugin raises its reason on the
client, and a worker that joins later fails every task with that reason.

A module of its own so that importing the orchestrator never imports Dask (an optional extra, slow to import);
workers import it to unpickle the plugins.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

from distributed import WorkerPlugin


class TaskRunner:
    """A Dask actor, one per worker: runs each call the client sends it (``DaskActors``), one at a time. A call
    goes from the client to the worker and back, never through the scheduler."""

    def call(self, function, args, kwargs):
        return function(*args, **kwargs)


class CloseFMUs(WorkerPlugin):
    def teardown(self, worker) -> None:
        from .objective import close_instances

        close_instances()


class ShipFMU(WorkerPlugin):
    """The FMU at ``path`` (read on the client), for every worker of the cluster."""

    def __init__(self, path: str | Path) -> None:
        path = Path(path)
        self.data = path.read_bytes()
        self.sha256 = hashlib.sha256(self.data).hexdigest()
        self.file_name = path.name

    @property
    def plugin_name(self) -> str:
        return f"lattice-fmu-{self.sha256[:16]}"

    def setup(self, worker) -> None:
        from .objective import fmu_instance, register_shipped_fmu

        try:
            folder = Path(worker.local_directory) / "lattice-fmus" / self.sha256
            target = folder / self.file_name
            if not target.is_file() or hashlib.sha256(target.read_bytes()).hexdigest() != self.sha256:
                folder.mkdir(parents=True, exist_ok=True)
                partial = folder / f".{self.file_name}.{os.getpid()}.partial"
                partial.write_bytes(self.data)
                os.replace(partial, target)
            register_shipped_fmu(self.sha256, str(target))
            fmu_instance(str(target), self.sha256)  # a binary this worker cannot load fails here, with its reason
        except Exception as exc:  # noqa: BLE001 - the worker's reason, for the client and for its tasks
            reason = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            message = f"Dask worker {worker.address} cannot run {self.file_name}: {reason}"
            register_shipped_fmu(self.sha256, None, message)
            raise RuntimeError(message) from None
