"""Material-order search for the mass-spring lattice.

Its levels, from the ground up: ``types`` (Order, Evaluation), ``objective`` (what is minimised), ``search`` (ask/tell
strategies), ``loop`` (the Evaluator: the one guarded evaluation path; run_search), ``executors``
(serial, process, dask), ``journal`` (resume), ``study`` (what a run is), ``report``, ``run`` (the CLI).
"""

from __future__ import annotations

from .types import Evaluation, Order, check_evaluation, safe_call

__all__ = ["Evaluation", "Order", "check_evaluation", "safe_call"]
