"""Source-only FMUs: strip binaries/, let `fmpy compile` rebuild them from the sources the FMU carries.

That is what a user on another platform does (FMI 2: <SourceFiles> in modelDescription.xml; FMI 3:
sources/buildDescription.xml). fmpy compiles with CMake (the pip package cmake, an fmpy dependency) with
-Wall -Wextra -Wpedantic, here with warnings as errors, and the rebuilt FMU must give bit-identical results.
"""

from __future__ import annotations

import os
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu
from fmpy.validation import validate_fmu

from orchestrator.simulation import start_values

from fmu_src.published import STUDY_BEST_ORDER as PUBLISHED_BEST

HORIZON, STEP = 8.0, 0.01


def strip_binaries(fmu: Path, output: Path) -> Path:
    with zipfile.ZipFile(fmu) as source, zipfile.ZipFile(output, "w", zipfile.ZIP_DEFLATED) as target:
        for item in source.infolist():
            if not item.filename.startswith("binaries/"):
                target.writestr(item, source.read(item))
    return output


def fmpy_compile(fmu: Path) -> subprocess.CompletedProcess:
    """`fmpy compile` as a user runs it; cmake comes from the same environment as this Python."""
    environment = dict(os.environ)
    environment["PATH"] = os.pathsep.join([str(Path(sys.executable).parent), environment.get("PATH", "")])
    command = [sys.executable, "-m", "fmpy", "compile", "--all-warnings", "--warning-as-error", str(fmu)]
    return subprocess.run(command, capture_output=True, text=True, env=environment, timeout=600)


def run(fmu: Path, order) -> np.ndarray:
    """Every output at every 0.01 s communication point over 8 s, through fmpy's simulate_fmu."""
    description = read_model_description(str(fmu))
    order_start = start_values(description, {f"material[{j}]": m for j, m in enumerate(order, 1)})  # FMI 3: an array
    outputs = [v.name for v in description.modelVariables if v.causality == "output"]
    return simulate_fmu(str(fmu), stop_time=HORIZON, output_interval=STEP, start_values=order_start, output=outputs)


@pytest.mark.parametrize("fixture", ["fmu_path", "fmu3_path"], ids=["fmi2", "fmi3"])
def test_source_only_fmu_rebuilt_by_fmpy_compile_gives_identical_results(request, tmp_path, fixture):
    original = request.getfixturevalue(fixture)
    stripped = strip_binaries(original, tmp_path / original.name)
    with zipfile.ZipFile(stripped) as archive:
        assert not any(name.startswith("binaries/") for name in archive.namelist())
    result = fmpy_compile(stripped)
    assert result.returncode == 0, f"fmpy compile failed:\n{result.stdout[-5000:]}\n{result.stderr[-5000:]}"
    with zipfile.ZipFile(stripped) as archive:
        binaries = [name for name in archive.namelist() if name.startswith("binaries/") and not name.endswith("/")]
    assert len(binaries) == 1, binaries
    assert validate_fmu(str(stripped)) == []

    rebuilt, reference = run(stripped, PUBLISHED_BEST), run(original, PUBLISHED_BEST)
    assert len(reference) == round(HORIZON / STEP) + 1
    assert reference.dtype.names == rebuilt.dtype.names
    for name in reference.dtype.names:  # bit-identical, every output at every communication point
        assert np.array_equal(rebuilt[name], reference[name], equal_nan=True), name
    assert rebuilt["peak_backplate_force"][-1] == reference["peak_backplate_force"][-1]
