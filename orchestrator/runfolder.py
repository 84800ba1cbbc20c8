"""Where a run writes, so that no command can lose what a run computed.

- A run works in ``OUT.partial/`` (its journal, then its report) and, once finished, swaps it with ``OUT/`` in
  one atomic rename (Linux ``renameat2(RENAME_EXCHANGE)``; elsewhere, or where the C library lacks it, two
  renames, between which ``OUT/`` is absent): ``OUT/`` always holds a whole finished run, or nothing, never a
  mix of two runs.
- ``OUT.partial/`` holding an unfinished run is refused without ``--resume`` (continue it) or ``--overwrite``
  (start anew, keeping the old journal under another name).
- One run per folder: ``.OUT.lock`` beside it is held for the run's life (portalocker: ``flock`` on POSIX,
  ``msvcrt.locking`` on Windows), with the holder's pid and host in it; a second run or resume is refused,
  naming them (on Windows the locked file cannot be read, so it says "another process"); a dead run's lock
  does not block (the system drops a dead process's lock). The run removes its lock file when it ends, so a
  finished run leaves nothing beside ``OUT/`` (the lock holds only if the file it locked is still the one at
  that path: a run that locked a file another run had just removed tries again).
- A folder that holds files but no run of this program is never replaced.
- Each run has a temporary folder (``lattice-run-<pid>-*`` in TMPDIR) removed when it ends; a run also
  removes those of dead predecessors (a SIGKILL leaves one behind).
"""

from __future__ import annotations

import errno
import os
import shutil
import socket
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TextIO

import portalocker
import psutil

from .journal import JOURNAL_NAME, Journal, JournalError, JournalState

TEMP_PREFIX = "lattice-run-"
RENAME_EXCHANGE = 2


class FolderError(ValueError):
    """A folder a run may not use, with why and what to do, in one line."""


def _option(out: Path) -> str:
    return f"--out {out}"


@dataclass
class RunFolder:
    """The folders and the lock of one run on ``out``."""

    out: Path
    partial: Path
    lock_path: Path
    resume: bool
    previous: JournalState | None = None  # the run being resumed or replaced
    _lock_handle: TextIO | None = None

    @classmethod
    def open(cls, out: str | os.PathLike, *, resume: bool, overwrite: bool) -> "RunFolder":
        """Take the lock and prepare ``OUT.partial`` for a new run, a resumed one, or the replay of a finished one."""
        out = Path(os.path.abspath(out))
        if out == Path(out.anchor):
            raise FolderError(f"{_option(out)}: the root folder cannot hold a run; give a folder for the report")
        partial = out.with_name(out.name + ".partial")
        folder = cls(out, partial, out.with_name(f".{out.name}.lock"), resume)
        folder._lock()
        try:
            folder._prepare(resume, overwrite)
        except BaseException:
            folder.release()
            raise
        return folder

    # ------------------------------------------------------------------------------------------ lock
    def _lock(self) -> None:
        while True:
            try:
                self.out.parent.mkdir(parents=True, exist_ok=True)
                handle = open(self.lock_path, "a+")
            except OSError as exc:
                raise FolderError(
                    f"{_option(self.out)}: cannot write in {self.out.parent} ({exc.strerror or exc})"
                ) from None
            try:
                portalocker.lock(handle, portalocker.LOCK_EX | portalocker.LOCK_NB)
            except (portalocker.exceptions.LockException, OSError):
                holder = _holder(handle)
                handle.close()
                raise FolderError(
                    f"{_option(self.out)} is in use by a running run ({holder}); wait for it to end "
                    "or give another --out"
                ) from None
            if self._still_at_path(handle):
                break
            handle.close()  # the run that held it removed it as we opened it: lock the file now at the path
        handle.seek(0)
        handle.truncate()
        handle.write(f"pid {os.getpid()} on {socket.gethostname()} since {time.strftime('%Y-%m-%d %H:%M:%S')}\n")
        handle.flush()
        self._lock_handle = handle

    def _still_at_path(self, handle) -> bool:
        try:
            at_path = os.stat(self.lock_path)
        except FileNotFoundError:
            return False
        held = os.fstat(handle.fileno())
        return (at_path.st_dev, at_path.st_ino) == (held.st_dev, held.st_ino)

    def release(self) -> None:
        if self._lock_handle is not None:
            handle, self._lock_handle = self._lock_handle, None
            try:
                handle.seek(0)
                handle.truncate()
                if os.name == "posix" and self._still_at_path(handle):
                    self.lock_path.unlink()  # removed while held: a run waiting on it tries the path again
                portalocker.unlock(handle)
            finally:
                handle.close()
            if os.name != "posix":  # Windows removes no open file: after closing, a run may hold it already
                try:
                    self.lock_path.unlink()
                except OSError:
                    pass

    # ------------------------------------------------------------------------------------------ prepare
    def _prepare(self, resume: bool, overwrite: bool) -> None:
        pending = Journal.inspect(self.partial) if self.partial.is_dir() else None
        if pending is not None and pending.finished:  # finished, but killed before it was swapped in
            self._finished_run()
            self.publish()
            pending = None
        if pending is not None:
            if resume:
                self.previous = pending
                return
            if not overwrite:
                raise FolderError(
                    f"{_option(self.out)}: {self.partial} holds an unfinished run ({pending.entries} results, "
                    f"started {pending.created}); continue it with --resume, or start anew with --overwrite "
                    f"(which keeps its journal as journal-{pending.run_id}.jsonl)"
                )
            pending.path.rename(self.partial / f"journal-{pending.run_id}.jsonl")
            return
        started = self.partial.exists()
        if started:
            shutil.rmtree(self.partial)  # a run stopped before its journal was written: nothing to keep
        finished = self._finished_run()
        if resume and finished is None and started:
            print(
                f"nothing to resume in {self.partial} (the run stopped before its first result): starting it",
                file=sys.stderr,
            )
            resume = False
        if resume and finished is None:
            raise FolderError(
                f"{_option(self.out)}: there is no run to resume (no journal in {self.out} or "
                f"{self.partial}); start the run without --resume"
            )
        self.partial.mkdir(parents=True)
        if resume and finished is not None:  # a finished run: replayed from its journal, the report written again
            self.previous = finished
            shutil.copy2(finished.path, self.partial / JOURNAL_NAME)

    def _finished_run(self) -> JournalState | None:
        if not self.out.exists():
            return None
        if not self.out.is_dir():
            raise FolderError(f"{_option(self.out)} is a file; give a folder for the report")
        try:
            state = Journal.inspect(self.out)
        except JournalError as exc:
            raise FolderError(f"{_option(self.out)}: {exc}; give another --out") from None
        if state is None:
            if any(self.out.iterdir()):
                raise FolderError(
                    f"{_option(self.out)} holds files that are not a run of this program; give an empty or new folder"
                )
            return None
        return state

    # ------------------------------------------------------------------------------------------ publish
    def publish(self) -> Path:
        """Swap the finished ``OUT.partial`` in as ``OUT`` (the previous run goes as a whole)."""
        if not self.out.exists():
            os.rename(self.partial, self.out)
            return self.out
        previous = self.partial  # where the exchange leaves the previous run
        if not _exchange(self.partial, self.out):
            previous = self.out.with_name(f".{self.out.name}.previous-{os.getpid()}")
            os.rename(self.out, previous)
            os.rename(self.partial, self.out)
        shutil.rmtree(previous, ignore_errors=True)
        return self.out


def _holder(handle) -> str:
    """Who holds the lock, as its holder wrote it; Windows forbids reading a file another process locked."""
    try:
        handle.seek(0)
        return handle.read().strip() or "another process"
    except OSError:
        return "another process"


def _exchange(a: Path, b: Path) -> bool:
    """Atomically swap two paths (Linux renameat2); False where the system cannot."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        renameat2 = libc.renameat2
    except (OSError, AttributeError):
        return False
    renameat2.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_uint]
    at_fdcwd = -100
    if renameat2(at_fdcwd, os.fsencode(a), at_fdcwd, os.fsencode(b), RENAME_EXCHANGE) == 0:
        return True
    if ctypes.get_errno() in (errno.ENOSYS, errno.EINVAL, errno.EXDEV):
        return False
    raise OSError(ctypes.get_errno(), os.strerror(ctypes.get_errno()), str(b))


# ---------------------------------------------------------------------------------------------- temp folders
def make_temp_root() -> str:
    """This run's temporary folder, after removing those of runs that died without removing theirs."""
    remove_dead_temp_roots()
    try:
        return tempfile.mkdtemp(prefix=f"{TEMP_PREFIX}{os.getpid()}-")
    except OSError as exc:
        raise FolderError(
            f"cannot create a temporary folder in {tempfile.gettempdir()} ({exc.strerror or exc}); "
            "free space there or set TMPDIR to another folder"
        ) from None


def remove_dead_temp_roots() -> int:
    """Removes the temporary folders of runs whose process is gone; returns how many."""
    removed = 0
    for path in Path(tempfile.gettempdir()).glob(f"{TEMP_PREFIX}*"):
        pid_text = path.name[len(TEMP_PREFIX) :].split("-", 1)[0]
        if not pid_text.isdigit() or not path.is_dir():
            continue
        pid = int(pid_text)
        if pid == os.getpid() or _alive(pid):
            continue
        shutil.rmtree(path, ignore_errors=True)
        removed += 1
    return removed


def _alive(pid: int) -> bool:
    """Whether a process ``pid`` exists (psutil: ``os.kill(pid, 0)`` would send Ctrl-C on Windows)."""
    return psutil.pid_exists(pid)


__all__ = ["FolderError", "RunFolder", "TEMP_PREFIX", "make_temp_root", "remove_dead_temp_roots"]
