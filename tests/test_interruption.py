"""SIGTERM stops a run even where a library swallows the exception the handler raises."""

from __future__ import annotations

import signal
import sys
import weakref

import pytest

from orchestrator.executors import SerialExecutor
from orchestrator.interruption import Interrupted, requested, terminate_on_sigterm
from orchestrator.loop import Evaluator
from orchestrator.objective import CallableObjective


class _Held:
    """Something a weakref watches; its callback is where Python drops any exception."""


def _sigterm_inside_a_weakref_callback() -> None:
    held = _Held()
    watcher = weakref.ref(held, lambda _: signal.raise_signal(signal.SIGTERM))
    del held  # the callback runs now; the Interrupted it raises is printed and dropped
    assert watcher() is None


def test_a_swallowed_sigterm_still_stops_the_next_evaluations(monkeypatch):
    dropped: list[type] = []
    monkeypatch.setattr(sys, "unraisablehook", lambda unraisable: dropped.append(unraisable.exc_type))
    objective = CallableObjective(lambda order: float(sum(order)), space=4)
    evaluator = Evaluator(SerialExecutor())
    with terminate_on_sigterm():
        _sigterm_inside_a_weakref_callback()
        assert requested()
        with pytest.raises(Interrupted):
            objective.evaluate([[0, 1, 2, 3]], evaluator)
    assert dropped == [Interrupted]  # Python dropped the handler's exception, as it does in any weakref callback


def test_without_a_sigterm_the_evaluations_run_and_the_handler_is_restored():
    before = signal.getsignal(signal.SIGTERM)
    objective = CallableObjective(lambda order: float(sum(order)), space=4)
    with terminate_on_sigterm():
        (evaluation,) = objective.evaluate([[0, 1, 2, 3]], Evaluator(SerialExecutor()))
        assert not requested()
    assert evaluation.ok and evaluation.value == 6.0
    assert signal.getsignal(signal.SIGTERM) is before
