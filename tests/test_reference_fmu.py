"""The reference FMU (pythonfmu over the numpy/scipy model of reference/) against the C FMU.

Both FMUs are driven through the same fmpy code path (orchestrator.simulation.LatticeFMU), at tight
tolerances, over a short horizon (0.6 s: the peak is near 0.32 s and the lattice leaves the plate before
0.6 s for these orders), so the numpy route stays quick enough for CI.
"""

import json
import math
import subprocess
import sys
import zipfile

import pytest
from fmpy import read_model_description
from fmpy.validation import validate_fmu

from conftest import ROOT
from fmu_src.published import STUDY_BEST_ORDER as PUBLISHED_BEST
from orchestrator.simulation import COUNTER_OUTPUTS, ENERGY_OUTPUTS, PEAK_OUTPUTS, LatticeFMU, SimulationError

OUTPUTS = PEAK_OUTPUTS + ENERGY_OUTPUTS + COUNTER_OUTPUTS + ("last_contact_time",)
HORIZON = 0.6
TIGHT = {"rtol": 1e-10, "atol": 1e-12}
REVERSED = tuple(range(11, 0, -1))


@pytest.fixture(scope="module")
def reference_fmu_path(tmp_path_factory):
    from reference.fmu import build_reference_fmu

    return build_reference_fmu(tmp_path_factory.mktemp("reference_fmu") / "MassSpringLatticeReference.fmu")


@pytest.fixture(scope="module")
def reference(reference_fmu_path):
    with LatticeFMU(reference_fmu_path, instance_name="reference") as fmu:
        yield fmu


@pytest.fixture()
def fresh_reference(reference_fmu_path):
    """An instance of its own, for tests that read the FMU's log: fmpy's logger proxy keeps one global logger,
    so the messages of every instance go to the LatticeFMU created last."""
    with LatticeFMU(reference_fmu_path, instance_name="fresh") as fmu:
        yield fmu


@pytest.fixture(scope="module")
def c_fmu(fmu_path):
    with LatticeFMU(fmu_path, instance_name="c") as fmu:
        yield fmu


def test_reference_fmu_is_valid_and_has_the_c_fmus_names(reference_fmu_path, fmu_path):
    assert validate_fmu(str(reference_fmu_path)) == []
    ref = {v.name: v for v in read_model_description(str(reference_fmu_path)).modelVariables}
    c = {v.name: v for v in read_model_description(str(fmu_path)).modelVariables}
    required = [f"material[{j}]" for j in range(1, 12)] + [
        "F_total",
        "diagonal_rule",
        "rtol",
        "atol",
        "peak_sample_interval",
        "k[1]",
        "k_diag[11]",
        *OUTPUTS,
        "last_contact_time",
    ]
    for name in required:
        assert name in ref, name
    for name, variable in ref.items():  # every name it has means the same in the C FMU
        assert name in c, f"{name} is not a variable of the C FMU"
        # pythonfmu declares no enumeration types: the C FMU's enumerations are its Integers
        c_type = "Integer" if c[name].type == "Enumeration" else c[name].type
        assert (variable.type, variable.causality) == (c_type, c[name].causality), name
        if variable.causality == "parameter" and name not in ("solver",):
            assert float(variable.start) == pytest.approx(float(c[name].start), rel=1e-15), name


@pytest.mark.parametrize("order", [PUBLISHED_BEST, REVERSED], ids=["study_best", "reversed"])
def test_c_fmu_and_reference_fmu_agree(reference, c_fmu, order):
    ref = reference.simulate(order, horizon=HORIZON, parameters=TIGHT, outputs=OUTPUTS)
    c = c_fmu.simulate(order, horizon=HORIZON, parameters=TIGHT, outputs=OUTPUTS)
    for name in ("peak_backplate_force", "peak_backplate_force_continuous"):
        assert ref[name] == pytest.approx(c[name], rel=1e-6), name
    assert ref["peak_time"] == pytest.approx(c["peak_time"], abs=1e-6)
    assert ref["last_contact_time"] == pytest.approx(c["last_contact_time"], abs=1e-6)
    work = c["external_work"]
    for name in ENERGY_OUTPUTS:
        assert ref[name] == pytest.approx(c[name], abs=1e-6 * work), name
    assert abs(ref["energy_balance_error"]) < 1e-6 * work
    assert ref["rhs_evaluations"] > 0 and ref["steps_accepted"] > 0


def test_one_do_step_equals_many(reference):
    params = {"rtol": 1e-6, "atol": 1e-8}
    one = reference.simulate(PUBLISHED_BEST, horizon=0.4, parameters=params, outputs=OUTPUTS)
    many = reference.simulate(PUBLISHED_BEST, horizon=0.4, parameters=params, outputs=OUTPUTS, communication_step=0.01)
    assert one == many


@pytest.mark.parametrize(
    "parameters, order, expected",
    [
        ({}, (1, 1, 3, 4, 5, 6, 7, 8, 9, 10, 11), "permutation of 1..11"),
        ({"rtol": 0.5}, None, "rtol"),
        ({"solver": 1}, None, "solver"),
        ({"diagonal_rule": 2}, None, "diagonal_rule"),
    ],
)
def test_bad_parameters_are_refused_with_a_clear_message(fresh_reference, parameters, order, expected):
    # reported at the first doStep: pythonfmu can only make exitInitializationMode fatal (see the slave)
    with pytest.raises(SimulationError, match="fmi2DoStep failed: parameters refused") as info:
        fresh_reference.simulate(order or PUBLISHED_BEST, horizon=0.1, parameters=parameters)
    assert expected in str(info.value)
    # and the instance still works after a reset
    assert fresh_reference.simulate(PUBLISHED_BEST, horizon=0.05)["peak_backplate_force"] == 0.0


@pytest.mark.parametrize("which", ["reference", "c"])
def test_a_start_pressed_into_the_plate_is_physics_not_divergence(reference_fmu_path, fmu_path, which):
    """Column C starting 0.5 m inside the plate: the start state's potential energy is energy put in, so
    both FMUs simulate it (they once called it divergence) and agree."""
    results = {}
    for name, path in (("reference", reference_fmu_path), ("c", fmu_path)):
        with LatticeFMU(path, instance_name=name) as fmu:
            results[name] = fmu.simulate(
                PUBLISHED_BEST, horizon=0.05, parameters={"backplate_gap": -0.5, "rtol": 1e-10, "atol": 1e-12}
            )
    assert results[which]["peak_backplate_force"] > 1e4
    assert results["c"]["peak_backplate_force"] == pytest.approx(results["reference"]["peak_backplate_force"], rel=1e-6)


def test_stepping_past_the_stop_time_is_refused(reference_fmu_path, tmp_path):
    from fmpy import extract
    from fmpy.fmi2 import FMU2Slave

    md = read_model_description(str(reference_fmu_path))
    slave = FMU2Slave(
        guid=md.guid,
        unzipDirectory=extract(str(reference_fmu_path), str(tmp_path / "unzipped")),
        modelIdentifier=md.coSimulation.modelIdentifier,
        instanceName="stop",
    )
    slave.instantiate()
    try:
        slave.setupExperiment(startTime=0.0, stopTime=0.05)
        slave.enterInitializationMode()
        slave.exitInitializationMode()
        slave.doStep(0.0, 0.05)
        with pytest.raises(Exception, match="fmi2DoStep"):
            slave.doStep(0.05, 0.01)
    finally:
        slave.freeInstance()


def test_the_fmu_bundles_what_it_imports(reference_fmu_path, tmp_path):
    """The slave runs from the FMU's resources alone (the repo off the path): reference is bundled."""
    with zipfile.ZipFile(reference_fmu_path) as archive:
        archive.extractall(tmp_path)
    resources = tmp_path / "resources"
    script = f"""
import json, sys
sys.path = [p for p in sys.path if p not in ('', {str(ROOT)!r})]
sys.path.insert(0, {str(resources)!r})
module = open({str(resources / "slavemodule.txt")!r}).read().strip()
slave = __import__(module).MassSpringLatticeReference(instance_name='x', resources={str(resources)!r})
import reference
slave.setup_experiment(0.0, 0.35, None)
slave.exit_initialization_mode()
assert slave.do_step(0.0, 0.35)
print(json.dumps({{'file': reference.__file__, 'peak': slave.outputs['peak_backplate_force']}}))
"""
    result = subprocess.run(
        [sys.executable, "-c", script],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=120,
        env={"PATH": "/usr/bin:/bin", "HOME": str(tmp_path)},
    )
    assert result.returncode == 0, result.stderr
    found = json.loads(result.stdout.strip().splitlines()[-1])
    assert found["file"].startswith(str(resources))
    assert math.isfinite(found["peak"]) and found["peak"] > 1000
