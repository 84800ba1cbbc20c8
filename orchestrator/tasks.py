"""What the Evaluator (``orchestrator.loop``) runs: the task protocol, and the task of one design.

A *task* is a picklable object with a ``key`` (what it computes: the cache and journal identity), a call that
computes it in a worker, ``failure(message, seconds)`` (its result when it could not run) and ``keep(result)``
(whether the result belongs in the journal). Design evaluations, exhaustive chunks and recorded runs are
tasks; a new kind of work is a new task, never a new loop. This module imports nothing that runs them, so an
objective can build tasks without knowing the Evaluator.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any, Callable, Protocol

from .types import Evaluation, Order, failed, safe_call


class Task(Protocol):
    """What the evaluator runs (see the module docstring)."""

    @property
    def key(self) -> str: ...

    def __call__(self) -> Any: ...

    def failure(self, message: str, seconds: float) -> Any: ...

    def keep(self, result: Any) -> bool: ...


def function_key(function: Any) -> str:
    """The identity of an evaluation function: its own ``key`` (an FMU run's settings), else its repr."""
    key = getattr(function, "key", None)
    return key if isinstance(key, str) else f"{type(function).__module__}.{type(function).__qualname__}:{function!r}"


@dataclass(frozen=True)
class EvaluateDesign:
    """One design through one evaluation function (``order -> Evaluation``)."""

    function: Callable[[Order], Any]
    order: Order

    @property
    def key(self) -> str:
        return f"{function_key(self.function)}#{','.join(map(str, self.order))}"

    def __call__(self) -> Evaluation:
        return safe_call(self.function, self.order)

    def failure(self, message: str, seconds: float) -> Evaluation:
        return failed(self.order, message, seconds)

    def keep(self, result: Any) -> bool:
        return True

    batchable = True  # a design's run is short: several go to a Dask worker in one call, as a TaskBatch


@dataclass(frozen=True)
class TaskBatch:
    """Several short tasks as one submission (a call to a Dask worker costs a round trip): the list of
    their results, each as ``run_task`` gives it. The Evaluator caches and journals each member on its own."""

    tasks: tuple[Any, ...]

    @property
    def key(self) -> str:
        return "batch:" + "|".join(task.key for task in self.tasks)

    def __call__(self) -> list[Any]:
        return [run_task(task) for task in self.tasks]

    def failure(self, message: str, seconds: float) -> list[Any]:
        return [task.failure(message, seconds) for task in self.tasks]

    def keep(self, result: Any) -> bool:
        return False


def run_task(task: Task) -> Any:
    """What a worker runs: the task, or its failure when it raised (a task must never kill its worker)."""
    start = time.perf_counter()
    try:
        return task()
    except MemoryError:
        return task.failure("out of memory (free memory, or use fewer --workers)", time.perf_counter() - start)
    except Exception as exc:  # noqa: BLE001 - a task's error is its failed result
        return task.failure(f"{type(exc).__name__}: {exc}", time.perf_counter() - start)


__all__ = ["EvaluateDesign", "Task", "TaskBatch", "function_key", "run_task"]
