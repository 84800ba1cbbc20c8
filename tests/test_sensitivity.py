"""The FMU's forward sensitivity: the derivative of the backplate-force trace along a seeded parameter direction.

Every material property p of the FMU moves as p + epsilon d, d given by the seeds d_k[m], d_c[m], d_mass[m] ...;
backplate_force_derivative is d backplate_force / d epsilon and peak_backplate_force_derivative the derivative at
the sample that holds the sampled peak. Checked against central differences of the ordinary outputs over runs at
a tight tolerance, on a small lattice of unequal masses and dampers of exponent 1.5 under both diagonal rules; a
zero seed is the ordinary run, a seed leaves the run's own outputs as they are, a non-finite seed is refused in one
line naming it, and Model Exchange (whose state count is fixed) refuses a seed that is not 0.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from fmpy import extract, read_model_description, simulate_fmu
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Model, FMU2Slave

from builder import build
from fmu_src.materials import FIELD_NAMES, MaterialTable, study_materials
from fmu_src.variables import seed_name
from orchestrator.codesign import CoDesignObjective, CoDesignSpace, finite_difference_jacobian, scaled_parameter_names
from orchestrator.design import DesignSpace
from orchestrator.executors import SerialExecutor
from orchestrator.loop import Evaluator
from orchestrator.objective import FULL, LatticeObjective
from orchestrator.sensitivity import directional_jacobian
from orchestrator.simulation import _CALLBACKS, _MESSAGES, LatticeFMU, SimulationError

MASSES = (0.5, 2.0, 1.0, 3.0)
TABLE = MaterialTable(
    tuple(
        dataclasses.replace(material, mass=mass, damping_exponent=1.5)
        for material, mass in zip(study_materials(4).materials, MASSES)
    )
)
ORDER = (2, 4, 1, 3)
ROWS, COLS = 5, 4
HORIZON = 1.0  # through the load, the contact with the plate and the rebound
STEP = 0.01
TIGHT = {"rtol": 1e-12, "atol": 1e-14}  # the finite differences' runs: as tight as the FMU's error control goes
DERIVATIVE = {"rtol": 1e-10, "atol": 1e-12}
RELATIVE_STEP = 1e-3  # the central differences' step, relative to the property: smaller ones see the runs' noise
# The derivative and the central differences agree to this fraction of the trace's largest derivative: the
# differences' own error (their step's truncation, their runs' tolerance and event locations) and the quotient's
# near the dampers' zero relative velocity, where |dv|^0.5 bends, stay below it.
AGREEMENT = 5e-4
TRACE = ("backplate_force", "backplate_force_derivative")


@pytest.fixture(scope="module")
def unequal_fmu(tmp_path_factory):
    return build.build_fmu(
        rows=ROWS, cols=COLS, materials=TABLE, werror=True, output=tmp_path_factory.mktemp("sens") / "Sens.fmu"
    )


@pytest.fixture()
def unequal(unequal_fmu):
    with LatticeFMU(unequal_fmu) as fmu:
        yield fmu


def trace(fmu: LatticeFMU, parameters: dict, outputs=TRACE):
    result = fmu.simulate(ORDER, horizon=HORIZON, parameters=parameters, communication_step=STEP, record=outputs)
    return result, result.trajectory.values


@pytest.mark.parametrize("rule", ["receiver", "mean"])
@pytest.mark.parametrize("name", FIELD_NAMES)
def test_the_derivative_trace_is_the_central_differences_of_the_trace(unequal, rule, name):
    material = ORDER[1]  # the second column's
    settings = {"diagonal_rule": rule}
    differences = central_differences(unequal, settings, name, material)
    seeded, values = trace(unequal, {**settings, **DERIVATIVE, f"{seed_name(name)}[{material}]": 1.0})
    derivative = values["backplate_force_derivative"]
    scale = float(np.max(np.abs(differences)))
    assert scale > 0.0
    assert float(np.max(np.abs(derivative - differences))) <= AGREEMENT * scale
    # the sampled peak's derivative is the trace's at the peak's sample
    at_peak = int(np.argmax(values["backplate_force"]))
    assert seeded["peak_backplate_force_derivative"] == pytest.approx(derivative[at_peak], rel=1e-12, abs=1e-12)


def central_differences(fmu: LatticeFMU, settings: dict, name: str, material: int, table=TABLE) -> np.ndarray:
    value = getattr(table.materials[material - 1], name)
    h = RELATIVE_STEP * value
    _, plus = trace(fmu, {**settings, **TIGHT, f"{name}[{material}]": value + h}, ("backplate_force",))
    _, minus = trace(fmu, {**settings, **TIGHT, f"{name}[{material}]": value - h}, ("backplate_force",))
    return (plus["backplate_force"] - minus["backplate_force"]) / (2.0 * h)


@pytest.mark.parametrize(
    "settings",
    [
        {"solver": "rkn5"},  # the Nystrom pair: the sensitivity a second-order block of its own
        {"solver": "tsit5"},
        {"solver": "rk4", "fixed_step": 1e-4},
        {"solver": "semi_implicit_euler", "fixed_step": 1e-5},
        {"use_symmetry": 0},  # the whole lattice, not its upper half
        {"load_mode": "projectile"},  # the body integrated with the lattice
    ],
)
@pytest.mark.parametrize("name", ["k", "mass"])
def test_every_solver_layout_and_load_carries_the_derivative(unequal, settings, name):
    material = ORDER[1]
    differences = central_differences(unequal, settings, name, material)
    _, values = trace(unequal, {**settings, **DERIVATIVE, f"{seed_name(name)}[{material}]": 1.0})
    scale = float(np.max(np.abs(differences)))
    assert float(np.max(np.abs(values["backplate_force_derivative"] - differences))) <= AGREEMENT * scale


@pytest.fixture(scope="module")
def plate_fmu(tmp_path_factory):
    return build.build_fmu(
        rows=3,
        cols=3,
        depth=3,
        materials=MaterialTable(TABLE.materials[:3]),
        werror=True,
        output=tmp_path_factory.mktemp("sens_plate") / "SensPlate.fmu",
    )


def test_a_plate_carries_the_derivative_too(plate_fmu):
    """The plate is the lattice with a depth (one model): its quarter, mirrored in y and z, carries the derivative
    as it carries the state."""
    order, table = (3, 1, 2), MaterialTable(TABLE.materials[:3])
    with LatticeFMU(plate_fmu) as fmu:
        value = table.materials[0].k
        h = RELATIVE_STEP * value
        runs = [
            fmu.simulate(
                order,
                horizon=HORIZON,
                parameters={**TIGHT, "k[1]": v},
                communication_step=STEP,
                record=("backplate_force",),
            ).trajectory.values["backplate_force"]
            for v in (value + h, value - h)
        ]
        differences = (runs[0] - runs[1]) / (2.0 * h)
        seeded = fmu.simulate(
            order,
            horizon=HORIZON,
            parameters={**DERIVATIVE, "d_k[1]": 1.0},
            communication_step=STEP,
            record=("backplate_force_derivative",),
        )
    derivative = seeded.trajectory.values["backplate_force_derivative"]
    scale = float(np.max(np.abs(differences)))
    assert scale > 0.0 and float(np.max(np.abs(derivative - differences))) <= AGREEMENT * scale


def test_a_seed_scales_the_derivative_and_seeds_add_up(unequal):
    """epsilon moves every seeded property at once: twice a seed is twice the derivative, and two seeds give the sum
    of each one's derivative (to the quotient's error)."""
    k, c = f"{seed_name('k')}[{ORDER[0]}]", f"{seed_name('c')}[{ORDER[2]}]"
    _, one_k = trace(unequal, {**DERIVATIVE, k: 1.0})
    _, two_k = trace(unequal, {**DERIVATIVE, k: 2.0})
    _, one_c = trace(unequal, {**DERIVATIVE, c: 1.0})
    _, both = trace(unequal, {**DERIVATIVE, k: 1.0, c: 1.0})
    scale = float(np.max(np.abs(both["backplate_force_derivative"])))
    derivative = "backplate_force_derivative"
    doubled = two_k[derivative] - 2.0 * one_k[derivative]
    added = both[derivative] - one_k[derivative] - one_c[derivative]
    assert float(np.max(np.abs(doubled))) <= 1e-5 * scale  # the quotient's error: its step differs
    assert float(np.max(np.abs(added))) <= 1e-5 * scale


def test_a_zero_seed_is_the_ordinary_run_and_a_seed_leaves_its_outputs_as_they_are(unequal):
    outputs = ("backplate_force", "peak_backplate_force", "max_compression", "energy_balance_error")
    ordinary, ordinary_trace = trace(unequal, DERIVATIVE, outputs)
    zero, zero_trace = trace(unequal, {**DERIVATIVE, **{f"{seed_name('k')}[{m}]": 0.0 for m in range(1, 5)}}, outputs)
    seeded, seeded_trace = trace(unequal, {**DERIVATIVE, f"{seed_name('mass')}[1]": 1.0}, outputs)
    for name in outputs:
        assert np.array_equal(zero_trace[name], ordinary_trace[name]), name
        assert np.array_equal(seeded_trace[name], ordinary_trace[name]), name  # the nominal run's own steps
    assert zero["rhs_evaluations"] == ordinary["rhs_evaluations"]
    assert zero["backplate_force_derivative"] == 0.0 and zero["peak_backplate_force_derivative"] == 0.0
    # the sensitivity costs a perturbed right-hand side for each of the run's, and a few at each backplate switch
    assert 2 * ordinary["rhs_evaluations"] <= seeded["rhs_evaluations"] <= 2.2 * ordinary["rhs_evaluations"]


@pytest.mark.parametrize("value", [float("nan"), float("inf"), -float("inf")])
def test_a_seed_that_is_not_finite_is_refused_naming_it(unequal, value):
    name = f"{seed_name('c')}[3]"
    with pytest.raises((SimulationError, ValueError)) as refusal:
        unequal.simulate(ORDER, horizon=0.1, parameters={name: value})
    message = str(refusal.value)
    assert name in message and "a finite number" in message and "\n" not in message


def test_model_exchange_refuses_a_seed_in_one_line(unequal_fmu, tmp_path):
    description = read_model_description(str(unequal_fmu))
    vr = {v.name: v.valueReference for v in description.modelVariables}
    messages: list[str] = []
    _MESSAGES["seeded"] = messages
    model = FMU2Model(
        guid=description.guid,
        unzipDirectory=extract(str(unequal_fmu), str(tmp_path / "unzipped")),
        modelIdentifier=description.modelExchange.modelIdentifier,
        instanceName="seeded",
    )
    model.instantiate(callbacks=_CALLBACKS, loggingOn=True)
    try:
        model.setupExperiment(startTime=0.0)
        model.enterInitializationMode()
        model.setReal([vr["d_k[2]"]], [1.0])
        with pytest.raises(FMICallException):
            model.exitInitializationMode()
    finally:
        model.freeInstance()
        _MESSAGES.pop("seeded", None)
    refusals = [m for m in messages if "d_k[2]" in m]
    assert refusals and "Model Exchange" in refusals[0] and "\n" not in refusals[0]


# ------------------------------------------------------------------------ the co-design's source of gradients


def test_the_directional_jacobian_is_the_finite_differences_one_for_a_run_less(armour_fmu_of_width):
    """orchestrator.sensitivity.directional_jacobian against codesign.finite_difference_jacobian at a point off the
    table's values on the 11 x 3 lattice, both at a tight tolerance: the same trace, the same derivatives to the
    differences' error (forward steps of 1e-5 of each parameter: a larger step's first-order truncation is large
    near the sample where a mass meets the plate, where the trace bends hardest), one run per parameter instead of
    one more."""
    space = CoDesignSpace(DesignSpace.permutations(3), study_materials(3), ("k", "c", "mass"), 0.5, 2.0, 11)
    lattice = LatticeObjective(armour_fmu_of_width(3), space.space, 2.0, parameters={"rtol": 1e-12, "atol": 1e-14})
    objective = CoDesignObjective(lattice, space)
    evaluator = Evaluator(SerialExecutor())
    point = space.with_factors((2, 3, 1), [0.8, 1.3, 1.1, 1.2, 0.7, 0.9, 1.0, 1.1, 1.4])
    names = scaled_parameter_names(space, point.order)
    directional = directional_jacobian(objective, evaluator, point, names, FULL)
    differences = finite_difference_jacobian(objective, evaluator, point, names, FULL, 1e-5)
    assert directional.names == differences.names == names and directional.times == differences.times
    assert np.array_equal(directional.values, differences.values)  # a seed leaves the run's own trace as it is
    for column, name in enumerate(names):
        scale = float(np.max(np.abs(differences.jacobian[:, column])))
        error = float(np.max(np.abs(directional.jacobian[:, column] - differences.jacobian[:, column])))
        assert scale > 0.0 and error <= 1e-3 * scale, name
    assert directional.evaluations == len(names) and differences.evaluations == len(names) + 1


def test_the_directional_jacobian_refuses_a_name_that_is_no_property_in_one_line(armour_fmu_of_width):
    space = CoDesignSpace(DesignSpace.permutations(3), study_materials(3), ("k",), 0.5, 2.0, 11)
    objective = CoDesignObjective(LatticeObjective(armour_fmu_of_width(3), space.space, 1.0), space)
    for name in ("F_total", "k", "k[x]", "stiffness[1]"):
        with pytest.raises(ValueError) as refusal:
            directional_jacobian(objective, Evaluator(SerialExecutor()), space.unit_point((1, 2, 3)), (name,), FULL)
        assert repr(name) in str(refusal.value) and "\n" not in str(refusal.value)


def test_fmi3_takes_the_seeds_as_arrays_and_gives_fmi2s_derivative(fmu_path, fmu3_path):
    """FMI 3 declares each seed as an array of M, as it declares the property (fmpy sets it as a list): the same
    model code as FMI 2's indexed scalars, so the same derivative trace."""
    seeds = [0.0] * 11
    seeds[4] = 1.0
    common = dict(stop_time=HORIZON, output_interval=STEP, output=["backplate_force_derivative"])
    fmi3 = simulate_fmu(str(fmu3_path), start_values={"d_mass": seeds}, **common)
    fmi2 = simulate_fmu(str(fmu_path), start_values={"d_mass[5]": 1.0}, **common)
    derivative = np.asarray(fmi2["backplate_force_derivative"])
    assert float(np.max(np.abs(derivative))) > 0.0
    np.testing.assert_allclose(fmi3["backplate_force_derivative"], derivative, rtol=1e-12, atol=1e-12)


def test_a_seeded_run_saved_and_restored_goes_on_as_it_would_have(unequal_fmu, tmp_path):
    """An FMU state of a seeded run holds its sensitivity (a second block of the solver's state and its moved
    parameters): restored, or serialised and read back, it is accepted and goes on bit for bit as the run did."""
    description = read_model_description(str(unequal_fmu))
    vr = {v.name: v.valueReference for v in description.modelVariables}
    slave = FMU2Slave(
        guid=description.guid,
        unzipDirectory=extract(str(unequal_fmu), str(tmp_path / "unzipped")),
        modelIdentifier=description.coSimulation.modelIdentifier,
    )
    outputs = [vr[name] for name in ("backplate_force_derivative", "peak_backplate_force_derivative")]
    slave.instantiate()
    try:
        slave.setupExperiment(startTime=0.0, stopTime=HORIZON)
        slave.enterInitializationMode()
        slave.setInteger([vr[f"material[{j}]"] for j in range(1, COLS + 1)], list(ORDER))
        slave.setReal([vr["d_c[2]"], vr["d_mass[4]"]], [1.0, -0.5])
        slave.exitInitializationMode()
        slave.doStep(0.0, 0.3)
        state = slave.getFMUstate()
        serialized = slave.serializeFMUstate(state)
        slave.doStep(0.3, 0.3)
        straight = slave.getReal(outputs)
        assert straight[1] != 0.0
        slave.setFMUstate(state)
        slave.doStep(0.3, 0.3)
        assert slave.getReal(outputs) == straight
        restored = slave.deSerializeFMUstate(serialized)
        slave.setFMUstate(restored)
        slave.doStep(0.3, 0.3)
        assert slave.getReal(outputs) == straight
        slave.freeFMUstate(state)
        slave.freeFMUstate(restored)
    finally:
        slave.freeInstance()
