"""Rows of the compatibility page from the platform tests (tests/test_platforms.py): one JSON file per importer x
version x platform x FMI version x interface in tests/compatibility_results/.

The fields and the file name are the compatibility page's (bench/compatibility.py defines them: importer,
importer_version, platform, fmi_version "2.0"/"3.0", interface "CS"/"ME", result {status, message},
worst_error, date, commit, command, note); this module writes them for runs whose importer is a program run
under an emulator (fmusim under Wine or qemu-user), which the page's own recorder does not start. A row names
the commit it ran at, so a row is written only from a checkout whose code equals its commit; otherwise the test
says so in a warning and writes nothing.
"""
from __future__ import annotations

import datetime
import json
import re
import subprocess
import warnings
from dataclasses import dataclass
from pathlib import Path

from fmu_src.published import PUBLISHED_PEAKS

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "tests" / "compatibility_results"
# A change anywhere but in the rows, the docs and the notes makes the commit a lie.
NOT_CODE = (":(exclude)tests/compatibility_results", ":(exclude)docs", ":(exclude)*.md")


@dataclass(frozen=True)
class PlatformRow:
    """One importer run's outcome on one platform, as the compatibility page reads it."""

    importer: str
    importer_version: str
    platform: str
    fmi_version: str  # "2.0" or "3.0"
    interface: str    # "CS" or "ME"
    passed: bool
    message: str      # what was checked, or the first line of what failed
    worst_error: float | None
    command: str
    note: str | None = None

    def file_name(self) -> str:
        parts = [self.importer, self.importer_version, self.platform, f"fmi{self.fmi_version}", self.interface]
        return "_".join(re.sub(r"[^a-z0-9._-]+", "-", part.lower()).strip("-") for part in parts) + ".json"

    def to_json(self, date: str, commit: str) -> dict:
        data = {"importer": self.importer, "importer_version": self.importer_version, "platform": self.platform,
                "fmi_version": self.fmi_version, "interface": self.interface,
                "result": {"status": "pass" if self.passed else "fail", "message": self.message},
                "worst_error": self.worst_error, "date": date, "commit": commit, "command": self.command}
        if self.note is not None:
            data["note"] = self.note
        return data


def worst_relative_error(peaks: dict[tuple[int, ...], float]) -> float:
    """The largest |peak - published| / published over the published orders run."""
    return max(abs(peak - PUBLISHED_PEAKS[order]) / PUBLISHED_PEAKS[order] for order, peak in peaks.items())


def write_row(row: PlatformRow, folder: Path = RESULTS) -> Path | None:
    """Writes the row (replacing an older run of the same row); None, with a warning, where the checkout's code
    differs from its commit or is not a git checkout."""
    status = _git("status", "--porcelain", "--", ".", *NOT_CODE)
    commit = _git("rev-parse", "HEAD")
    if status is None or commit is None or status:
        warnings.warn(f"compatibility row {row.file_name()} not written: the code differs from its commit "
                      f"(or this is not a git checkout), and a row names the commit it ran at")
        return None
    folder.mkdir(parents=True, exist_ok=True)
    date = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d")
    path = folder / row.file_name()
    partial = path.with_name(path.name + ".partial")
    partial.write_text(json.dumps(row.to_json(date, commit), indent=2) + "\n")
    partial.replace(path)
    return path


def _git(*arguments: str) -> str | None:
    try:
        done = subprocess.run(["git", "-C", str(ROOT), *arguments], capture_output=True, text=True, timeout=30)
    except (OSError, subprocess.TimeoutExpired):
        return None
    return done.stdout.strip() if done.returncode == 0 else None
