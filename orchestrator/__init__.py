"""Material-order search for the mass-spring lattice.

Layers: ``types`` (Order, Evaluation, safe_call), ``search`` (ask/tell
strategies), ``loop`` (budget, cache, executor), ``executors`` (serial,
process, dask).  Heavy modules are imported on first use so that worker
processes that only unpickle an objective stay quick to start.
"""
from __future__ import annotations

import importlib
from typing import Any

from .types import Evaluation, Order, check_evaluation, safe_call

_LAZY = {
    "SEARCHES": "orchestrator.search",
    "make_search": "orchestrator.search",
    "run_search": "orchestrator.loop",
    "SearchRun": "orchestrator.loop",
    "make_executor": "orchestrator.executors",
    "EXECUTORS": "orchestrator.executors",
}


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'orchestrator' has no attribute {name!r}")


__all__ = ["Evaluation", "Order", "check_evaluation", "safe_call", *_LAZY]
