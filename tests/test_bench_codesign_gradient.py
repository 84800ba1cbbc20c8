"""The co-design gradient's benchmark (bench/codesign_gradient.py) in its quick mode, run as a user runs it, in a
child process (tests import nothing from bench/), printing its tables instead of writing its page: every source
gives the whole Jacobian, forward differences at one run more than the directional derivatives, and the
directional derivatives at full fidelity are the more accurate."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_the_quick_benchmark_measures_both_sources_and_writes_no_page():
    page = ROOT / "docs" / "measurements" / "codesign_gradient.md"
    before = page.read_text() if page.exists() else None
    done = subprocess.run(
        [sys.executable, "-m", "bench.codesign_gradient", "--quick", "--print-only", "--no-polish"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    assert (page.read_text() if page.exists() else None) == before
    rows = [line.split(" | ") for line in done.stdout.splitlines() if line.count(" | ") == 7]
    measured = [row for row in rows if row[1].startswith(("forward differences", "directional derivatives"))]
    assert {row[1].split(",")[0] for row in measured} == {"forward differences", "directional derivatives"}
    for point in {row[0] for row in measured}:
        full = {row[1].split(",")[0]: row for row in measured if row[0] == point and row[2].startswith("full")}
        differences, directional = full["forward differences"], full["directional derivatives"]
        assert int(differences[3]) == int(directional[3]) + 1  # the point's own run
        assert float(directional[7]) < float(differences[7])  # the error over the samples near the peak
