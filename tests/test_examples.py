"""examples/backplate_support.py: the lattice FMU feeding a second FMU under libcosim, on a short horizon."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from fmpy.validation import validate_fmu
from scipy.linalg import expm

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
if str(EXAMPLES) not in sys.path:
    sys.path.insert(0, str(EXAMPLES))

import backplate_support  # noqa: E402

HORIZON = 0.6  # the impact and the peak are over by then


@pytest.fixture(scope="module")
def support_fmu(tmp_path_factory):
    return backplate_support.build_support_fmu(tmp_path_factory.mktemp("support") / "BackplateSupport.fmu")


def test_support_fmu_is_valid(support_fmu):
    assert validate_fmu(str(support_fmu)) == []


def test_the_master_feeds_the_backplate_force_into_the_support(fmu_path, support_fmu):
    parameters = {"m": 20.0, "k": 2.0e4, "c": 200.0}
    result = backplate_support.run(fmu_path, support_fmu, horizon=HORIZON, support_parameters=parameters)
    assert len(result.time) == round(HORIZON / 0.01) + 1
    # a fixed-step master: over each step the support holds the force of the previous communication point
    assert np.array_equal(result.support_input[1:], result.backplate_force[:-1])
    assert result.backplate_force.max() == result.peak_backplate_force > 1000.0

    # the support's response to that piecewise-constant force, exactly (matrix exponential per step)
    m, k, c = parameters["m"], parameters["k"], parameters["c"]
    a = np.array([[0.0, 1.0], [-k / m, -c / m]])
    h = 0.01
    phi = expm(a * h)
    gamma = np.linalg.solve(a, (phi - np.eye(2)) @ np.array([0.0, 1.0 / m]))
    state, expected = np.zeros(2), [0.0]
    for force in result.support_input[1:]:
        state = phi @ state + gamma * force
        expected.append(state[0])
    scale = np.abs(expected).max()
    assert scale > 0.01  # centimetres: the plate really pushes the support
    assert np.abs(result.support_displacement - expected).max() <= 1e-6 * scale


def test_example_writes_the_picture(fmu_path, tmp_path, capsys):
    picture = tmp_path / "support.png"
    assert backplate_support.main(["--horizon", str(HORIZON), "--lattice-fmu", str(fmu_path),
                                   "-o", str(picture)]) == 0
    assert picture.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and picture.stat().st_size > 20_000
    assert "peak force on the backplate" in capsys.readouterr().out
