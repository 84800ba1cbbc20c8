"""SIGTERM handled like Ctrl-C, and kept when a library swallows it.

The handler raises ``Interrupted`` where the signal lands. Python drops an exception raised inside a weakref
or ``__del__`` callback, and a library may turn it into an error of its own (matplotlib does while drawing),
so the request is also remembered: the Evaluator raises it again before its next batch, the study before its
next step, and the command line reports any error after a request as the interruption it is.
"""

from __future__ import annotations

import signal
from contextlib import contextmanager
from typing import Iterator


class Interrupted(BaseException):
    """SIGTERM (a BaseException, so no evaluation guard swallows it)."""


_requested = False


def requested() -> bool:
    """Whether SIGTERM arrived while ``terminate_on_sigterm`` was in force."""
    return _requested


def raise_if_requested() -> None:
    if _requested:
        raise Interrupted()


def _on_sigterm(signum, frame):
    global _requested
    _requested = True
    raise Interrupted()


@contextmanager
def terminate_on_sigterm() -> Iterator[None]:
    """SIGTERM raises Interrupted inside the block; the previous handler comes back after it."""
    global _requested
    _requested = False
    previous = signal.signal(signal.SIGTERM, _on_sigterm)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)
