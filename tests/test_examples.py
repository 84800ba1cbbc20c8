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


def test_the_support_is_a_model_folder_of_the_shared_glue(support_fmu):
    """examples/support_fmu/ holds the model alone (the model API of fmu_src/common/model_api.h); the FMI glue in
    the FMU is the lattice's own, file for file."""
    import zipfile

    from builder.sources import SourceTree

    assert sorted(p.name for p in backplate_support.SUPPORT_MODEL_DIR.iterdir()) == ["model.c", "model.h"]
    with zipfile.ZipFile(support_fmu) as archive:
        for path in SourceTree(fmi_version=2).files():
            if path.parent.name != "lattice":
                assert archive.read(f"sources/{path.name}") == path.read_bytes(), path.name


def test_the_support_refuses_a_parameter_after_initialisation(support_fmu, tmp_path):
    from fmpy import extract, read_model_description
    from fmpy.fmi1 import FMICallException
    from fmpy.fmi2 import FMU2Slave

    description = read_model_description(str(support_fmu))
    references = {v.name: v.valueReference for v in description.modelVariables}
    slave = FMU2Slave(guid=description.guid, unzipDirectory=extract(str(support_fmu), str(tmp_path / "unzipped")),
                      modelIdentifier=description.coSimulation.modelIdentifier, instanceName="support",
                      fmiCallLogger=None)
    slave.instantiate(loggingOn=True, callbacks=None)
    slave.setupExperiment(startTime=0.0)
    slave.enterInitializationMode()
    slave.exitInitializationMode()
    slave.setReal([references["F"]], [100.0])  # the input: any time
    slave.doStep(0.0, 0.01)
    assert slave.getReal([references["x"]])[0] > 0.0
    with pytest.raises(FMICallException):
        slave.setReal([references["k"]], [1.0])
    slave.terminate()
    slave.freeInstance()
