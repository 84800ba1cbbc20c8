"""The compatibility page (docs/compatibility.md) is exactly what builder.compatibility makes from the committed
rows, a row that is not of the format is refused in one line, and FMPy's rows: FMI 2.0 and 3.0, Co-Simulation
and Model Exchange, through fmpy.simulate_fmu as a user calls it.

FMPy's runs are in the default suite (they are quick); with --record-compatibility they write their rows.
"""

from __future__ import annotations

import importlib.metadata
import subprocess
import sys

import pytest
from fmpy import simulate_fmu

from orchestrator.simulation import model_description, start_values

from builder import compatibility
from builder.compatibility import ROOT, Result, RowError, load_rows, parse_row, row_file_name, write_row
from compatibility import compatibility_row, reproducing_command
from fmu_src.published import PUBLISHED_PEAKS

ORDERS = tuple(PUBLISHED_PEAKS)
TOLERANCE = 1e-6  # relative, on the published peaks
CS_HORIZON, STEP = 8.0, 0.01
ME_HORIZON = 1.0  # the peak comes near 0.3 s and the lattice has left the backplate before 1 s (horizon study)
ME_TOLERANCE = 1e-9  # CVode's relative tolerance


def test_the_page_is_what_the_committed_rows_make():
    rows = load_rows()
    assert compatibility.PAGE.read_text(encoding="utf-8") == compatibility.render(rows), (
        "docs/compatibility.md differs from the rows in tests/compatibility_results: run python -m bench.compatibility"
    )
    check = subprocess.run(
        [sys.executable, "-m", "bench.compatibility", "--check"], cwd=ROOT, capture_output=True, text=True, timeout=120
    )
    assert check.returncode == 0, check.stderr


def a_row(**changes) -> dict:
    row = {
        "importer": "FMPy",
        "importer_version": "0.3.22",
        "platform": "x86_64-linux",
        "fmi_version": "2.0",
        "interface": "CS",
        "result": {"status": "pass", "message": "checked"},
        "worst_error": 1.5e-8,
        "date": "2026-12-02",
        "commit": "0123456789abcdef",
        "command": "python -m pytest tests/x.py",
    }
    row.update(changes)
    return {k: v for k, v in row.items() if v is not ...}


@pytest.mark.parametrize(
    "changes, named",
    [
        ({"interface": "cs"}, "'interface' is 'cs'; allowed: CS, ME"),
        ({"fmi_version": "2"}, "'fmi_version' is '2'; allowed: 2.0, 3.0"),
        ({"result": "pass"}, "field 'result' must be"),
        ({"result": {"status": "ok", "message": "x"}}, "'status' is 'ok'; allowed: pass, fail"),
        ({"worst_error": -1.0}, "'worst_error' must be a finite relative error"),
        ({"worst_error": "1e-8"}, "'worst_error' must be a finite relative error"),
        ({"date": "2 Dec 2026"}, "field 'date'"),
        ({"commit": "unknown"}, "field 'commit'"),
        ({"command": ""}, "field 'command' must be one line"),
        ({"command": ...}, "missing field(s) command"),
        ({"error": 1.0}, "unknown field(s) error"),
    ],
)
def test_a_row_not_of_the_format_is_refused_in_one_line_naming_the_field(changes, named):
    with pytest.raises(RowError) as caught:
        parse_row(a_row(**changes), "rows/x.json")
    assert named in str(caught.value) and str(caught.value).startswith("rows/x.json: ")
    assert "\n" not in str(caught.value)


def test_rows_round_trip_one_file_per_row_and_a_misnamed_file_is_refused(tmp_path):
    row = parse_row(a_row(note="under Wine"), "x")
    path = write_row(row, tmp_path)
    assert path.name == "fmpy_0.3.22_x86_64-linux_fmi2.0_cs.json" == row_file_name(row)
    assert load_rows(tmp_path) == [row]
    write_row(parse_row(a_row(worst_error=None, result={"status": "fail", "message": "no peak"}), "x"), tmp_path)
    (reloaded,) = load_rows(tmp_path)  # the same row again: replaced, not added
    assert reloaded.result == Result("fail", "no peak") and reloaded.worst_error is None
    path.rename(tmp_path / "other.json")
    with pytest.raises(RowError, match="this row's file is named fmpy_0.3.22_x86_64-linux_fmi2.0_cs.json"):
        load_rows(tmp_path)


def test_the_page_shows_each_row_with_its_verdict_error_commit_and_command():
    rows = [
        parse_row(a_row(), "x"),
        parse_row(
            a_row(
                importer="fmusim",
                importer_version="0.0.39",
                platform="x86_64-windows",
                result={"status": "fail", "message": "peak | off"},
                worst_error=None,
                note="under Wine",
            ),
            "x",
        ),
    ]
    page = compatibility.render(rows)
    lines = [line for line in page.splitlines() if line.startswith("| FMPy") or line.startswith("| fmusim")]
    assert lines == [
        "| FMPy | 0.3.22 | x86_64-linux | 2.0 | Co-Simulation | pass: checked | 1.5e-08 | 2026-12-02 | `0123456` | "
        "`python -m pytest tests/x.py` |",
        "| fmusim | 0.0.39 | x86_64-windows | 2.0 | Co-Simulation | **fail**: peak \\| off (under Wine) |  | "
        "2026-12-02 | `0123456` | `python -m pytest tests/x.py` |",
    ]
    assert "1 of 2 rows pass" in page


def test_the_reproducing_command_names_the_test_and_its_marker(request):
    assert reproducing_command(request) == (
        "python -m pytest tests/test_compatibility.py::test_the_reproducing_command_names_the_test_and_its_marker"
    )


# ------------------------------------------------------------------------------------------------------ FMPy

FMPY_VERSION = importlib.metadata.version("fmpy")


def fmpy_peak(fmu, order, interface: str) -> float:
    start = start_values(model_description(fmu), {f"material[{j}]": material for j, material in enumerate(order, 1)})
    if interface == "CS":
        result = simulate_fmu(
            str(fmu),
            fmi_type="CoSimulation",
            stop_time=CS_HORIZON,
            output_interval=STEP,
            start_values=start,
            output=["peak_backplate_force"],
        )
    else:
        result = simulate_fmu(
            str(fmu),
            fmi_type="ModelExchange",
            solver="CVode",
            relative_tolerance=ME_TOLERANCE,
            stop_time=ME_HORIZON,
            output_interval=STEP,
            start_values=start,
            output=["peak_backplate_force"],
        )
    return float(result["peak_backplate_force"][-1])


CHECKED = {
    "CS": f"both published orders' peak_backplate_force within {TOLERANCE:g} of the published peaks "
    f"(fmpy.simulate_fmu, {CS_HORIZON:g} s in {STEP:g} s communication steps)",
    "ME": f"both published orders' peak_backplate_force within {TOLERANCE:g} of the published peaks "
    f"(fmpy.simulate_fmu with CVode at rtol {ME_TOLERANCE:g}, {ME_HORIZON:g} s on a {STEP:g} s output grid)",
}


@pytest.mark.parametrize("interface", ["CS", "ME"])
@pytest.mark.parametrize("fmi_version", ["2.0", "3.0"])
def test_fmpy_reaches_the_published_peaks(request, fmi_version, interface):
    fmu = request.getfixturevalue("fmu_path" if fmi_version == "2.0" else "fmu3_path")
    with compatibility_row(
        request, "FMPy", FMPY_VERSION, fmi_version=fmi_version, interface=interface, checked=CHECKED[interface]
    ) as row:
        for order in ORDERS:
            peak = fmpy_peak(fmu, order, interface)
            assert row.reached(order, peak) <= TOLERANCE, (
                f"FMPy FMI {fmi_version} {interface}: {peak!r} N for {list(order)}, published "
                f"{PUBLISHED_PEAKS[order]!r} N"
            )


def test_the_reproducing_command_selects_an_opt_in_test_by_its_markers(request):
    class Node:  # an opt-in test of another file, as pytest describes it
        nodeid = "tests/test_platforms.py::test_fmusim[x86_64-windows]"

        @staticmethod
        def get_closest_marker(name):
            return name if name in ("platforms", "slow") else None

    class Request:
        node = Node()

    assert reproducing_command(Request()) == (
        "python -m pytest -m 'platforms and slow' 'tests/test_platforms.py::test_fmusim[x86_64-windows]'"
    )
