"""The README's recipes run as written: the route to a design file in FMPy (here) and the Dask recipe with a worker
in another folder (tests/test_cluster.py)."""
from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from fmu_src.published import STUDY_BEST_ORDER
from orchestrator.simulation import LatticeFMU
from orchestrator.ssp import write_best_design_ssp

ROOT = Path(__file__).resolve().parents[1]


def python_blocks(text: str) -> list[str]:
    return re.findall(r"```python\n(.*?)```", text, flags=re.S)


def fmpy_design_snippet(text: str) -> str:
    snippet, = [block for block in python_blocks(text) if "simulate_ssp" in block]
    return snippet


def test_the_readme_runs_a_design_file_in_fmpy_as_written(fmu_path, tmp_path):
    snippet = fmpy_design_snippet((ROOT / "README.md").read_text())
    assert snippet == fmpy_design_snippet((ROOT / "docs" / "other-tools.md").read_text())
    write_best_design_ssp(fmu_path, {"material": list(STUDY_BEST_ORDER), "F_total": 1100.0},
                          tmp_path / "best_design.ssp", stop_time=8.0)
    (tmp_path / "tmp").mkdir()  # fmpy extracts into TMPDIR: the test's own, so nothing is left in the real one
    done = subprocess.run([sys.executable, "-c", snippet], cwd=tmp_path, capture_output=True, text=True, timeout=600,
                          env={**os.environ, "TMPDIR": str(tmp_path / "tmp")})
    assert done.returncode == 0, done.stderr
    peak = float(done.stdout.split()[-1])
    with LatticeFMU(fmu_path) as lattice:
        design = lattice.simulate(STUDY_BEST_ORDER, 8.0, {"F_total": 1100.0})["peak_backplate_force"]
        default = lattice.simulate(None, 8.0)["peak_backplate_force"]
    assert peak == pytest.approx(design, rel=1e-9)
    assert abs(peak - default) > 1.0  # the design's order and load, not the FMU's defaults
