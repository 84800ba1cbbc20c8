"""A run as a journal: every finished evaluation appended to the report folder as it arrives.

Why: an interruption (Ctrl-C, SIGTERM, a crash, a killed machine) must cost at most the evaluations in
flight. The searches are deterministic given their seeds and the values they are told, so a resumed run
replays them with the journal as its cache: every order already simulated is answered from the journal,
the rest are simulated, and the run ends with the same results as one that was never interrupted.

The first line holds the settings that decide the results (and the FMU's checksum); ``--resume`` with
other settings is refused, never mixed.
"""
from __future__ import annotations

import hashlib
import json
import math
import os
from pathlib import Path
from typing import Any

from .types import Evaluation, Order, as_order

JOURNAL_NAME = "journal.jsonl"
FORMAT = "lattice-journal/1"


class JournalError(ValueError):
    """A journal that cannot be resumed (missing, other settings, unreadable)."""


def file_sha256(path: str | os.PathLike) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def _finite_or_none(value: Any) -> Any:
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


class Journal:
    """``journal.jsonl`` in the report folder: a header line, then one line per finished evaluation."""

    def __init__(self, folder: str | os.PathLike, settings: dict, resume: bool = False):
        self.path = Path(folder) / JOURNAL_NAME
        self.settings = json.loads(json.dumps(settings, default=str))
        self._loaded: dict[tuple[str, Order], Evaluation] = {}
        if resume:
            self._loaded = self._read()
            self._handle = self.path.open("a", encoding="utf-8")
        else:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._handle = self.path.open("w", encoding="utf-8")
            self._write({"format": FORMAT, "settings": self.settings})

    def _read(self) -> dict[tuple[str, Order], Evaluation]:
        if not self.path.is_file():
            raise JournalError(f"--resume: no journal in {self.path.parent} (start the run without --resume)")
        entries: dict[tuple[str, Order], Evaluation] = {}
        with self.path.open(encoding="utf-8") as handle:
            lines = handle.read().splitlines()
        if not lines:
            raise JournalError(f"--resume: {self.path} is empty (start the run without --resume)")
        try:
            header = json.loads(lines[0])
        except json.JSONDecodeError:
            raise JournalError(f"--resume: {self.path} has no readable header (start the run without --resume)") \
                from None
        if header.get("format") != FORMAT:
            raise JournalError(f"--resume: {self.path} is not a journal of this program ({FORMAT})")
        theirs = header.get("settings", {})
        differ = sorted(k for k in set(theirs) | set(self.settings) if theirs.get(k) != self.settings.get(k))
        if differ:
            key = differ[0]
            raise JournalError(f"--resume: the run in {self.path.parent} used {key}={theirs.get(key)!r}, this one "
                               f"{key}={self.settings.get(key)!r}; resume with the same settings or use another --out")
        for number, line in enumerate(lines[1:], start=2):
            try:
                entry = json.loads(line)
                evaluation = Evaluation(as_order(entry["order"]), entry["peak"], entry["status"],
                                        entry.get("message", ""), float(entry.get("seconds", 0.0)),
                                        entry.get("details", {}))
            except (json.JSONDecodeError, KeyError, TypeError, ValueError):
                if number == len(lines):
                    break  # the line being written when the run was killed: that evaluation runs again
                raise JournalError(f"--resume: {self.path} line {number} is unreadable") from None
            entries[(entry["task"], evaluation.order)] = evaluation
        return entries

    def load(self) -> dict[tuple[str, Order], Evaluation]:
        return dict(self._loaded)

    def _write(self, entry: dict) -> None:
        self._handle.write(json.dumps(entry, default=_json_value) + "\n")
        self._handle.flush()  # in the OS's hands: survives the process being killed

    def append(self, task: str, evaluation: Evaluation) -> None:
        self._write({"task": task, "order": list(evaluation.order), "peak": evaluation.peak,
                     "status": evaluation.status, "message": evaluation.message, "seconds": evaluation.seconds,
                     "details": {k: _finite_or_none(v) for k, v in evaluation.details.items()}})

    def close(self) -> None:
        if not self._handle.closed:
            self._handle.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc_info):
        self.close()


def _json_value(value: Any) -> Any:
    if hasattr(value, "item"):
        return value.item()
    if isinstance(value, tuple):
        return list(value)
    return str(value)
