"""A run as a journal: every finished task appended as it arrives, each line checksummed.

An interruption (Ctrl-C, SIGTERM, a crash, a killed machine, a full disk) must cost at most the tasks in
flight. The searches are deterministic given their seeds and the values they are told, so a resumed run
replays them with the journal as its cache and ends with the same results as a run never interrupted.

Format (JSON lines): a header ``{"format", "run", "created", "settings", "sum"}`` (the settings that decide
the results, the FMU by its hash), then one line per finished task ``{"run", "key", "kind", "result",
"sum"}``, and ``{"run", "finished", "sum"}`` when the run finished. ``sum`` is a SHA-256 of the rest of the
line and the run's id: a line changed outside this program, or copied from another run, is refused with its
number. A last line cut off by a kill or a full disk is removed before anything is appended, so the journal
stays readable for every later resume.
"""

from __future__ import annotations

import hashlib
import json
import os
import time
import uuid
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping

from .records import from_record, to_record

JOURNAL_NAME = "journal.jsonl"
FORMAT = "lattice-journal/2"


class JournalError(ValueError):
    """A journal that cannot be resumed (missing, other settings, changed, unreadable)."""


def file_sha256(path: str | os.PathLike) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def _canonical(entry: dict) -> str:
    return json.dumps(entry, sort_keys=True, separators=(",", ":"), allow_nan=False)


def _sum(entry: dict) -> str:
    return hashlib.sha256(_canonical(entry).encode()).hexdigest()[:32]


def _line(entry: dict) -> str:
    return json.dumps({**entry, "sum": _sum(entry)}, separators=(",", ":"), allow_nan=False) + "\n"


@dataclass(frozen=True)
class JournalState:
    """What a journal on disk holds, read without resuming it (to decide what a new run may do)."""

    path: Path
    run_id: str
    created: str
    settings: dict
    entries: int
    finished: bool


def difference(theirs: dict, ours: dict, prefix: str = "") -> str | None:
    """The first setting (dotted name) whose value differs, with both values, or None."""
    for key in sorted(set(theirs) | set(ours)):
        a, b = theirs.get(key), ours.get(key)
        if isinstance(a, dict) and isinstance(b, dict):
            found = difference(a, b, f"{prefix}{key}.")
            if found:
                return found
        elif a != b:
            return f"{prefix}{key}={a!r} there, {b!r} here"
    return None


class Journal:
    """``journal.jsonl`` of one run: created new, or resumed (checked line by line, a cut last line removed).

    ``kinds`` maps each result kind the run journals to its class (``Evaluation``, ...), so that lines read
    back are the typed results that were written.
    """

    def __init__(self, folder: str | os.PathLike, settings: dict, kinds: Mapping[str, type], *, resume: bool = False):
        self.path = Path(folder) / JOURNAL_NAME
        self.settings = json.loads(json.dumps(to_record(settings)))
        self.kinds = dict(kinds)
        self._loaded: dict[str, Any] = {}
        self.repaired = False
        self.appended = 0
        if resume:
            self.run_id = self._read()
            self._handle = self.path.open("a", encoding="utf-8")
        else:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self.run_id = uuid.uuid4().hex[:16]
            self._handle = self.path.open("x", encoding="utf-8")
            self._write(
                {
                    "format": FORMAT,
                    "run": self.run_id,
                    "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
                    "settings": self.settings,
                }
            )

    # ------------------------------------------------------------------------------------------ reading
    @staticmethod
    def _lines(path: Path) -> tuple[list[str], int | None]:
        """The complete lines, and the byte offset where a cut last line starts (None when there is none)."""
        data = path.read_bytes()
        if not data:
            return [], None
        cut = None
        if not data.endswith(b"\n"):
            cut = data.rfind(b"\n") + 1
            data = data[:cut]
        return data.decode("utf-8", errors="replace").splitlines(), cut

    @classmethod
    def inspect(cls, folder: str | os.PathLike) -> JournalState | None:
        """The journal in ``folder`` (None when there is none); raises JournalError when it is not readable."""
        path = Path(folder) / JOURNAL_NAME
        if not path.is_file():
            return None
        lines, _ = cls._lines(path)
        header = cls._header(path, lines)
        finished = False
        for line in lines[1:]:
            try:
                finished = finished or "finished" in json.loads(line)
            except json.JSONDecodeError:
                pass
        entries = sum(1 for line in lines[1:] if '"key"' in line)
        return JournalState(
            path, header["run"], header.get("created", ""), header.get("settings", {}), entries, finished
        )

    @staticmethod
    def _header(path: Path, lines: list[str]) -> dict:
        if not lines:
            raise JournalError(f"{path} is empty: it holds no run to resume")
        try:
            header = json.loads(lines[0])
        except json.JSONDecodeError:
            raise JournalError(f"{path} line 1 is not a journal header") from None
        if not isinstance(header, dict) or header.get("format") != FORMAT:
            found = header.get("format") if isinstance(header, dict) else None
            raise JournalError(f"{path} is not a journal of this program (format {found!r}, expected {FORMAT})")
        if header.get("sum") != _sum({k: v for k, v in header.items() if k != "sum"}):
            raise JournalError(f"{path} line 1 fails its checksum (changed outside this program)")
        return header

    def _read(self) -> str:
        if not self.path.is_file():
            raise JournalError(f"no journal in {self.path.parent} to resume")
        lines, cut = self._lines(self.path)
        header = self._header(self.path, lines)
        run_id = header["run"]
        why = difference(header.get("settings", {}), self.settings)
        if why:
            raise JournalError(
                f"the run in {self.path.parent} has other settings ({why}); resume with the same settings or start anew"
            )
        for number, line in enumerate(lines[1:], start=2):
            try:
                entry = json.loads(line)
            except json.JSONDecodeError:
                raise JournalError(
                    f"{self.path} line {number} is not readable (changed outside this program)"
                ) from None
            if not isinstance(entry, dict) or entry.get("sum") != _sum({k: v for k, v in entry.items() if k != "sum"}):
                raise JournalError(f"{self.path} line {number} fails its checksum (changed outside this program)")
            if entry.get("run") != run_id:
                raise JournalError(f"{self.path} line {number} belongs to another run ({entry.get('run')!r})")
            if "finished" in entry:
                continue
            kind = self.kinds.get(str(entry.get("kind")))
            if kind is None:
                raise JournalError(f"{self.path} line {number}: unknown result kind {entry.get('kind')!r}")
            try:
                self._loaded[entry["key"]] = from_record(kind, entry["result"])
            except (KeyError, TypeError, ValueError) as exc:
                raise JournalError(f"{self.path} line {number} does not hold a {entry.get('kind')} ({exc})") from None
        if cut is not None:  # the line being written when the run died: that task runs again
            with self.path.open("r+b") as handle:
                handle.truncate(cut)
            self.repaired = True
        return run_id

    def load(self) -> dict[str, Any]:
        return dict(self._loaded)

    # ------------------------------------------------------------------------------------------ writing
    def _write(self, entry: dict) -> None:
        self._handle.write(_line(entry))
        self._handle.flush()  # in the OS's hands: survives the process being killed

    def append(self, key: str, result: Any) -> None:
        self._write({"run": self.run_id, "key": key, "kind": type(result).kind, "result": to_record(result)})
        self.appended += 1

    def finish(self) -> None:
        self._write({"run": self.run_id, "finished": time.strftime("%Y-%m-%dT%H:%M:%S%z")})
        os.fsync(self._handle.fileno())

    def close(self) -> None:
        if not self._handle.closed:
            self._handle.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc_info):
        self.close()


__all__ = ["FORMAT", "JOURNAL_NAME", "Journal", "JournalError", "JournalState", "difference", "file_sha256"]
