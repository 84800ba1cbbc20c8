"""The compatibility table: one row per importer x version x platform x FMI version x interface, recorded by the
importer tests (tests/compatibility.py), and the page docs/compatibility.md they make (written by
``python -m bench.compatibility``). Here, below both, so that neither the tests nor the benchmarks import the
other.

One row is one JSON file in tests/compatibility_results/ (committed, so the page can be written on any
machine), named after the row's key (``row_file_name``), with exactly these fields:

    importer          the tool that imported the FMU ("FMPy", "libcosim", "fmusim", ...)
    importer_version  its version, as the tool or its package says it
    platform          the FMI 3 platform tuple it ran on: x86_64-linux, x86_64-windows, aarch64-linux, ...
    fmi_version       "2.0" or "3.0"
    interface         "CS" (Co-Simulation), "ME" (Model Exchange) or "SSP" (the armour system's three FMUs
                      from models/ArmourSystem.ssp, co-simulated by the importer as one system)
    result            {"status": "pass" or "fail", "message": one line: what was checked, or what failed}
    worst_error       the largest relative error |peak - published| / published over the published orders
                      the run reached (fmu_src/published.py); for the armour system, against the one-model
                      reference (reference/system.py); null where the run produced no peak
    date              the day it ran, YYYY-MM-DD (UTC)
    commit            the project's commit it ran at (git hash, 7 to 40 hex digits)
    command           the command that runs it again
    note              optional: one line a reader needs (a tolerance, an emulator, a known limit)

Why written here rather than taken from a library: the FMI Cross-Check's repository layout and FMPy's validator
of it are retired with it, and no library renders a tool-by-tool compatibility table.
"""

from __future__ import annotations

import json
import math
import re
import subprocess
from dataclasses import asdict, dataclass, fields
from pathlib import Path

from builder import rendering
from fmu_src.published import PUBLISHED_PEAKS

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "tests" / "compatibility_results"
PAGE = ROOT / "docs" / "compatibility.md"

FMI_VERSIONS = ("2.0", "3.0")
INTERFACES = {
    "CS": "Co-Simulation",
    "ME": "Model Exchange",
    "SSP": "Co-Simulation of the armour system (ArmourSystem.ssp: projectile, lattice, hull)",
}
STATUSES = ("pass", "fail")


class RowError(ValueError):
    """A results file that is not a row of the format above, with the file and the field, in one line."""


@dataclass(frozen=True)
class Result:
    status: str  # pass or fail
    message: str

    @property
    def passed(self) -> bool:
        return self.status == "pass"


@dataclass(frozen=True)
class CompatibilityRow:
    """One importer x version x platform x FMI version x interface, and how the FMU did in it."""

    importer: str
    importer_version: str
    platform: str
    fmi_version: str
    interface: str
    result: Result
    worst_error: float | None
    date: str
    commit: str
    command: str
    note: str | None = None

    @property
    def key(self) -> tuple[str, ...]:
        return (self.importer.lower(), self.importer_version, self.platform, self.fmi_version, self.interface)

    def to_json(self) -> dict:
        data = asdict(self)
        if self.note is None:
            del data["note"]
        return data


FIELDS = tuple(f.name for f in fields(CompatibilityRow))
REQUIRED = tuple(name for name in FIELDS if name != "note")


def row_file_name(row: CompatibilityRow) -> str:
    """``importer_version_platform_fmiX.Y_interface.json``, lower case, anything but [a-z0-9._-] as ``-``: one
    file per row, so a newer run of the same row replaces the older one."""
    parts = [row.importer, row.importer_version, row.platform, f"fmi{row.fmi_version}", row.interface]
    return "_".join(re.sub(r"[^a-z0-9._-]+", "-", part.lower()).strip("-") for part in parts) + ".json"


def _text(data: dict, name: str, where: str, pattern: str | None = None, allowed=None) -> str:
    value = data.get(name)
    if not isinstance(value, str) or not value.strip() or "\n" in value:
        raise RowError(f"{where}: field {name!r} must be one line of text, got {value!r}")
    if allowed is not None and value not in allowed:
        raise RowError(f"{where}: field {name!r} is {value!r}; allowed: {', '.join(allowed)}")
    if pattern is not None and not re.fullmatch(pattern, value):
        raise RowError(f"{where}: field {name!r} is {value!r}; expected {pattern}")
    return value


def parse_row(data, where: str) -> CompatibilityRow:
    """The row of a results file's JSON object; a RowError naming ``where`` and the field otherwise."""
    if not isinstance(data, dict):
        raise RowError(f"{where}: a row is a JSON object with the fields {', '.join(FIELDS)}")
    unknown = sorted(set(data) - set(FIELDS))
    missing = [name for name in REQUIRED if name not in data]
    if unknown or missing:
        raise RowError(
            f"{where}: "
            + "; ".join(
                filter(
                    None,
                    [
                        f"unknown field(s) {', '.join(unknown)}" if unknown else "",
                        f"missing field(s) {', '.join(missing)}" if missing else "",
                    ],
                )
            )
            + f"; the fields are {', '.join(FIELDS)}"
        )
    result = data["result"]
    if not isinstance(result, dict) or set(result) != {"status", "message"}:
        raise RowError(
            f'{where}: field \'result\' must be {{"status": "pass" or "fail", "message": "..."}}, got {result!r}'
        )
    error = data["worst_error"]
    if error is not None and (
        isinstance(error, bool) or not isinstance(error, (int, float)) or not math.isfinite(error) or error < 0
    ):
        raise RowError(f"{where}: field 'worst_error' must be a finite relative error >= 0 or null, got {error!r}")
    note = data.get("note")
    return CompatibilityRow(
        importer=_text(data, "importer", where),
        importer_version=_text(data, "importer_version", where),
        platform=_text(data, "platform", where, pattern=r"[a-z0-9_]+-[a-z0-9_]+"),
        fmi_version=_text(data, "fmi_version", where, allowed=FMI_VERSIONS),
        interface=_text(data, "interface", where, allowed=tuple(INTERFACES)),
        result=Result(
            _text(result, "status", f"{where}: result", allowed=STATUSES), _text(result, "message", f"{where}: result")
        ),
        worst_error=None if error is None else float(error),
        date=_text(data, "date", where, pattern=r"\d{4}-\d{2}-\d{2}"),
        commit=_text(data, "commit", where, pattern=r"[0-9a-f]{7,40}"),
        command=_text(data, "command", where),
        note=None if note is None else _text(data, "note", where),
    )


def load_rows(folder: Path = RESULTS) -> list[CompatibilityRow]:
    """Every row in ``folder``, in the page's order; a file that is not a row, or not under its row's name, is
    refused."""
    rows = []
    for path in sorted(Path(folder).glob("*.json")):
        where = f"{path.parent.name}/{path.name}"
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise RowError(f"{where}: not a JSON row ({exc})") from None
        row = parse_row(data, where)
        if path.name != row_file_name(row):
            raise RowError(f"{where}: this row's file is named {row_file_name(row)} (one file per row)")
        rows.append(row)
    return sorted(rows, key=lambda r: r.key)


def write_row(row: CompatibilityRow, folder: Path = RESULTS) -> Path:
    """Writes (or replaces) the row's file, after checking it reads back as the same row."""
    data = row.to_json()
    if parse_row(json.loads(json.dumps(data)), row_file_name(row)) != row:
        raise RowError(f"{row_file_name(row)}: the row does not read back as written")
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / row_file_name(row)
    partial = path.with_name(path.name + ".partial")
    partial.write_text(json.dumps(data, indent=2) + "\n", encoding="utf-8")
    partial.replace(path)
    return path


def error_text(error: float | None) -> str:
    return "" if error is None else f"{error:.1e}"


def render(rows: list[CompatibilityRow]) -> str:
    """The page docs/compatibility.md of ``rows``."""
    environment = rendering.environment()
    environment.filters["error"] = error_text  # a worst error as the page's table shows it
    importers = sorted({(r.importer, r.importer_version) for r in rows}, key=lambda pair: pair[0].lower())
    platforms = sorted({r.platform for r in rows})
    published = [(list(order), peak) for order, peak in sorted(PUBLISHED_PEAKS.items(), key=lambda item: item[1])]
    return environment.get_template("compatibility.md.j2").render(
        rows=rows,
        interfaces=INTERFACES,
        importers=importers,
        platforms=platforms,
        published=published,
        passed=sum(r.result.passed for r in rows),
    )


def git_output(*arguments: str, folder: Path = ROOT) -> str | None:
    """What git says of the checkout at ``folder`` (None outside one): the commit a row or a measurement page
    names."""
    try:
        done = subprocess.run(["git", "-C", str(folder), *arguments], capture_output=True, text=True, timeout=30)
    except (OSError, subprocess.TimeoutExpired):
        return None
    return done.stdout.strip() if done.returncode == 0 else None


__all__ = [
    "CompatibilityRow",
    "FIELDS",
    "INTERFACES",
    "PAGE",
    "RESULTS",
    "ROOT",
    "Result",
    "RowError",
    "git_output",
    "load_rows",
    "parse_row",
    "render",
    "row_file_name",
    "write_row",
]
