"""What a Dask worker does when it closes: free its FMU instances and their extracted folders.

A module of its own so that importing the orchestrator never imports Dask (an optional extra, slow to
import); workers import it to unpickle the plugin.
"""
from __future__ import annotations

from distributed import WorkerPlugin


class CloseFMUs(WorkerPlugin):
    def teardown(self, worker) -> None:
        from .objective import close_instances

        close_instances()
