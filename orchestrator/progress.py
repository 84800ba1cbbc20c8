"""Progress bars on stderr (tqdm), or nothing: progress never affects a result."""

from __future__ import annotations

import contextlib
import sys
from typing import Callable, Iterator


class Bar:
    """One bar; ``of_run()`` gives a search run's callback (its count on top of the runs before it)."""

    def __init__(self, bar) -> None:
        self._bar = bar
        self.offset = 0
        self.done = 0

    def __call__(self, done: int) -> None:
        self._set(self.offset + done)

    def _set(self, value: int) -> None:
        self.done = value
        if self._bar is not None and value != self._bar.n:
            self._bar.n = value
            self._bar.refresh()

    def of_run(self) -> Callable[[int], None]:
        offset = self.offset
        return lambda done: self._set(offset + done)

    def close_run(self) -> None:
        self.offset = self.done


class Progress:
    """tqdm bars when ``enabled`` and stderr is a terminal (none in CI logs)."""

    def __init__(self, enabled: bool = False) -> None:
        self.enabled = enabled

    @contextlib.contextmanager
    def bar(self, total: int, description: str, unit: str = "eval") -> Iterator[Bar]:
        tqdm_bar = None
        if self.enabled and total > 0:
            from tqdm import tqdm

            tqdm_bar = tqdm(
                total=total, unit=unit, desc=description, file=sys.stderr, mininterval=0.5, disable=None, leave=False
            )
        try:
            yield Bar(tqdm_bar)
        finally:
            if tqdm_bar is not None:
                tqdm_bar.close()


__all__ = ["Bar", "Progress"]
