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

import asyncio
import hashlib
import os
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from distributed import WorkerPlugin
from distributed.protocol import pickle


CALL_HANDLER = "lattice_call"  # the operation a worker answers with ``RunCalls``'s handler


def run_call(payload: bytes) -> bytes:
    """One call the client sent: ``(function, args, kwargs)`` pickled, answered with ``(True, result)`` or
    ``(False, exception)`` pickled (an exception that cannot be pickled travels as a RuntimeError naming it)."""
    function, args, kwargs = pickle.loads(payload)
    try:
        answer = (True, function(*args, **kwargs))
    except Exception as exc:  # noqa: BLE001 - delivered to the client's future
        answer = (False, exc)
    try:
        return pickle.dumps(answer)
    except Exception:  # noqa: BLE001 - a result or an exception that cannot travel
        kind = "exception" if not answer[0] else "result"
        return pickle.dumps((False, RuntimeError(f"the call's {kind} cannot be pickled: {answer[1]!r:.200}")))


class RunCalls(WorkerPlugin):
    """Runs the client's calls on every worker (``executors.DaskWorkers``), one at a time in a thread of their
    own, and frees the worker's FMU instances when it closes.

    Why a handler of the worker's own server, not a Dask task or an actor: a search asks a few designs at a time
    and waits for them, so what a call costs is its round trip and the handling of its messages; a call to this
    handler is one request to the worker and its reply, with its arguments and result as one pickled payload,
    never through the scheduler and without a task's or an actor's bookkeeping on either side.
    """

    def setup(self, worker) -> None:
        calls = self._calls = ThreadPoolExecutor(1, thread_name_prefix="lattice-call")

        async def lattice_call(payload: bytes) -> bytes:
            return await asyncio.get_running_loop().run_in_executor(calls, run_call, payload)

        worker.handlers[CALL_HANDLER] = lattice_call

    def teardown(self, worker) -> None:
        from .objective import close_instances

        worker.handlers.pop(CALL_HANDLER, None)
        self._calls.shutdown(wait=False)
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
