"""The one way a test records its row of the compatibility page (builder/compatibility.py defines the row).

    with compatibility_row(request, "libcosim", version, fmi_version="2.0", interface="CS",
                           checked="...") as row:
        for order in ORDERS:
            peak = ...
            row.reached(order, peak)     # its relative error on the published peak
            assert ...

The test's checks run as always; only under ``python -m pytest --record-compatibility`` is the row written to
tests/compatibility_results/: "pass" with ``checked`` as its message when the block ends, "fail" with the
first line of the error when a check fails (and the test still fails). A skipped test writes nothing.
Recording is refused while the code differs from its commit, since a row names the commit it ran at.
"""

from __future__ import annotations

import contextlib
import datetime
import shlex
from dataclasses import dataclass, field

import pytest

from builder.compatibility import RESULTS, CompatibilityRow, Result, git_output, write_row
from builder.fmi3_description import platform_folder
from fmu_src.published import PUBLISHED_PEAKS

RECORD_OPTION = "--record-compatibility"
# What a row depends on: a change anywhere but in the rows, the docs and the notes makes the commit a lie.
NOT_CODE = (":(exclude)tests/compatibility_results", ":(exclude)docs", ":(exclude)*.md")


def add_option(parser) -> None:
    parser.addoption(
        RECORD_OPTION,
        action="store_true",
        help="write each importer test's row to tests/compatibility_results/ (the compatibility page's "
        "source; then run python -m bench.compatibility)",
    )


def check_recording(config) -> None:
    """Refuses --record-compatibility where the rows could not name the commit they ran at."""
    if not config.getoption(RECORD_OPTION):
        return
    status = git_output("status", "--porcelain", "--", ".", *NOT_CODE)
    if status is None:
        raise pytest.UsageError(f"{RECORD_OPTION}: this is not a git checkout; a row names the commit it ran at")
    if status:
        raise pytest.UsageError(
            f"{RECORD_OPTION}: the code differs from its commit ({status.splitlines()[0].strip()}"
            " ...); commit first, since a row names the commit it ran at"
        )


@dataclass
class RowRecorder:
    """What the test reached: the relative error of each peak against the published one."""

    errors: list[float] = field(default_factory=list)

    def reached(self, order, peak: float) -> float:
        published = PUBLISHED_PEAKS[tuple(order)]
        error = abs(peak - published) / published
        self.errors.append(error)
        return error

    def reached_reference(self, peak: float, reference: float) -> float:
        """A run without a published peak (the armour system): its relative error on a reference's."""
        error = abs(peak - reference) / reference
        self.errors.append(error)
        return error


@contextlib.contextmanager
def compatibility_row(
    request,
    importer: str,
    importer_version: str,
    *,
    fmi_version: str,
    interface: str,
    checked: str,
    note: str | None = None,
    platform: str | None = None,
    environment: tuple[str, ...] = (),
):
    """``platform``: where the importer ran (default: this machine's); ``environment``: the ``NAME=value``
    settings the reproducing command needs before it (an importer found through an environment variable)."""
    recorder = RowRecorder()
    record = request.config.getoption(RECORD_OPTION)
    try:
        yield recorder
    except (pytest.skip.Exception, KeyboardInterrupt):
        raise
    except BaseException as exc:
        if record:
            message = (str(exc).strip().splitlines() or [type(exc).__name__])[0][:300]
            _write(
                request,
                importer,
                importer_version,
                fmi_version,
                interface,
                Result("fail", message),
                recorder,
                note,
                platform,
                environment,
            )
        raise
    if record:
        _write(
            request,
            importer,
            importer_version,
            fmi_version,
            interface,
            Result("pass", checked),
            recorder,
            note,
            platform,
            environment,
        )


# The markers the default run leaves out (pyproject's addopts): a test carrying one runs only when -m names it.
OPT_IN = ("importers", "platforms", "slow", "vdmcheck")


def reproducing_command(request, environment: tuple[str, ...] = ()) -> str:
    """The command that runs this test again, from the checkout's root."""
    markers = [name for name in OPT_IN if request.node.get_closest_marker(name)]
    selection = f" -m {shlex.quote(' and '.join(markers))}" if markers else ""
    return " ".join([*environment, f"python -m pytest{selection} {shlex.quote(request.node.nodeid)}"])


def _write(
    request, importer, importer_version, fmi_version, interface, result, recorder, note, platform, environment
) -> None:
    row = CompatibilityRow(
        importer=importer,
        importer_version=importer_version,
        platform=platform or platform_folder()[0],
        fmi_version=fmi_version,
        interface=interface,
        result=result,
        worst_error=max(recorder.errors) if recorder.errors else None,
        date=datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d"),
        commit=git_output("rev-parse", "HEAD") or "unknown",
        command=reproducing_command(request, environment),
        note=note,
    )
    write_row(row, RESULTS)
