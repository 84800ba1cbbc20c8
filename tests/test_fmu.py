"""The FMU through fmpy: validation, published numbers, step independence, energy, errors, FMI states."""

import math

import pytest
from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave
from fmpy.validation import validate_fmu

from fmu_src.published import PUBLISHED_PEAKS
from fmu_src.published import SEQUENTIAL_ORDER as PUBLISHED_SEQUENTIAL
from fmu_src.published import STUDY_BEST_ORDER as PUBLISHED_BEST
from orchestrator.simulation import COUNTER_OUTPUTS, ENERGY_OUTPUTS, PEAK_OUTPUTS, SimulationError

ALL_OUTPUTS = (
    PEAK_OUTPUTS
    + ENERGY_OUTPUTS
    + COUNTER_OUTPUTS
    + (
        "backplate_force",
        "ux_corner",
        "uy_corner",
        "ux_left_edge",
        "uy_left_edge",
        "ux_centre",
        "uy_centre",
        "ux_right_edge",
        "uy_right_edge",
    )
)


def test_fmpy_validation_finds_no_problem(fmu_path):
    assert validate_fmu(str(fmu_path)) == []


def test_model_description_carries_sources_and_public_names(fmu_path):
    description = read_model_description(str(fmu_path))
    names = {v.name for v in description.modelVariables}
    assert {f"material[{j}]" for j in range(1, 12)} <= names
    for name in (
        "k[1]",
        "k_diag[11]",
        "c[5]",
        "alpha[3]",
        "alpha_diag[7]",
        "F_total",
        "load_angle",
        "t_active",
        "k_wall",
        "c_wall",
        "backplate_gap",
        "peak_sample_interval",
        "rtol",
        "atol",
        "fixed_step",
        "diagonal_rule",
        "solver",
    ) + ALL_OUTPUTS:
        assert name in names, name
    starts = {v.name: v.start for v in description.modelVariables}
    assert [int(starts[f"material[{j}]"]) for j in range(1, 12)] == list(range(1, 12))
    assert math.isclose(float(starts["k[2]"]), 100 * 2 / 3, rel_tol=1e-15)
    sources = description.buildConfigurations[0].sourceFileSets[0].sourceFiles
    assert "fmi2_glue.c" in sources and "model.c" in sources


@pytest.mark.parametrize("order", [PUBLISHED_SEQUENTIAL, PUBLISHED_BEST])
def test_published_peaks_at_default_settings(lattice, order):
    result = lattice.simulate(order, horizon=8.0)
    assert result["peak_backplate_force"] == pytest.approx(PUBLISHED_PEAKS[order], rel=1e-6)
    # the samples can only miss the true maximum, never exceed it
    assert result["peak_backplate_force_continuous"] >= result["peak_backplate_force"]
    assert 0.15 < result["peak_time"] < 0.6


def _without_evaluations(result) -> dict:
    return {name: value for name, value in result.values.items() if name != "rhs_evaluations"}


def test_one_do_step_equals_800_of_them(lattice):
    whole = lattice.simulate(PUBLISHED_BEST, horizon=8.0, outputs=ALL_OUTPUTS)
    stepped = lattice.simulate(PUBLISHED_BEST, horizon=8.0, communication_step=0.01, outputs=ALL_OUTPUTS)
    # bit for bit the same numbers; only the evaluations spent on dense output at communication points differ
    assert stepped["rhs_evaluations"] >= whole["rhs_evaluations"]
    assert _without_evaluations(stepped) == _without_evaluations(whole)


def test_stepping_with_an_awkward_communication_step_changes_nothing(lattice):
    whole = lattice.simulate(PUBLISHED_SEQUENTIAL, horizon=1.0, outputs=ALL_OUTPUTS)
    stepped = lattice.simulate(PUBLISHED_SEQUENTIAL, horizon=1.0, communication_step=0.0173, outputs=ALL_OUTPUTS)
    # the same steps and numbers; only the dense-output evaluations spent on extra communication points differ
    assert stepped["rhs_evaluations"] >= whole["rhs_evaluations"]
    assert _without_evaluations(stepped) == _without_evaluations(whole)


@pytest.mark.parametrize("rule", ["receiver", "mean"])
def test_energy_balance_closes(lattice, rule):
    result = lattice.simulate(PUBLISHED_BEST, horizon=8.0, parameters={"diagonal_rule": rule})
    assert abs(result["energy_balance_error"]) <= 1e-6 * result["external_work"]
    if rule == "mean":
        assert result["nonreciprocal_work"] == 0.0  # a reciprocal pair does no non-reciprocal work
    else:  # docs/model.md section 2: about 303 J in, about -114 J taken out by the unequal diagonal forces
        assert result["external_work"] == pytest.approx(303, rel=0.01)
        assert result["nonreciprocal_work"] == pytest.approx(-114, rel=0.01)


# An order whose balance the step sequence around its backplate events once left above the promise.
ADVERSARIAL_ORDER = (9, 11, 10, 5, 4, 6, 3, 2, 7, 1, 8)
BALANCE_OUTPUTS = ("kinetic_energy", "potential_energy", "external_work", "dissipated_energy", "nonreciprocal_work")


@pytest.mark.parametrize("rule", ["receiver", "mean"])
@pytest.mark.parametrize(
    "order",
    [PUBLISHED_SEQUENTIAL, PUBLISHED_BEST, ADVERSARIAL_ORDER],
    ids=["sequential", "published_best", "adversarial"],
)
def test_the_balance_of_the_outputs_closes_at_every_communication_point(lattice, order, rule):
    """docs/model.md §7 from the outputs alone, every 0.01 s over 2 s (through contact and release), at the
    defaults."""
    result = lattice.simulate(
        order,
        horizon=2.0,
        communication_step=0.01,
        record=BALANCE_OUTPUTS,
        outputs=BALANCE_OUTPUTS,
        parameters={"diagonal_rule": rule},
    )
    v = result.trajectory.values
    balance = (
        v["external_work"]
        + v["nonreciprocal_work"]
        - v["kinetic_energy"]
        - v["potential_energy"]
        - v["dissipated_energy"]
    )
    assert max(abs(balance)) <= 1e-6 * v["external_work"][-1]


def test_a_plate_pressed_from_the_start_counts_its_energy_in_the_balance(lattice):
    """A negative backplate_gap stores wall energy at t = 0: the balance counts it as energy put in."""
    result = lattice.simulate(
        PUBLISHED_BEST,
        horizon=1.0,
        parameters={"backplate_gap": -1e-3},
        outputs=("energy_balance_error", "external_work", "potential_energy"),
    )
    stored = 0.5 * 1e4 * 1e-3**2 * 11  # every column-C mass 1 mm into the plate (docs/model.md section 5)
    assert stored > 1e3 * abs(result["energy_balance_error"])
    assert abs(result["energy_balance_error"]) <= 1e-6 * (result["external_work"] + stored)


def test_mean_rule_changes_the_ranking_as_spec_says(lattice):
    best = lattice.simulate(PUBLISHED_BEST, parameters={"diagonal_rule": "mean"})["peak_backplate_force"]
    sequential = lattice.simulate(PUBLISHED_SEQUENTIAL, parameters={"diagonal_rule": "mean"})["peak_backplate_force"]
    assert best == pytest.approx(3096, rel=0.01)
    assert sequential == pytest.approx(2911, rel=0.01)


@pytest.mark.parametrize(
    "parameters, order, expected",
    [
        ({}, (1, 1, 3, 4, 5, 6, 7, 8, 9, 10, 11), "permutation of 1..11"),
        ({}, (0, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11), "material[1]"),
        ({"rtol": 0.0}, None, "rtol"),
        ({"rtol": 0.5}, None, "rtol"),
        ({"diagonal_rule": 2}, None, "0 (receiver) or 1 (mean)"),
        ({"solver": 7}, None, "solver"),
        ({"alpha[3]": 0.0}, None, "alpha[3]"),
        ({"peak_sample_interval": -0.01}, None, "peak_sample_interval"),
        ({"F_total": float("nan")}, None, "F_total"),
    ],
)
def test_bad_parameters_are_refused_with_a_clear_message(lattice, parameters, order, expected):
    with pytest.raises(SimulationError) as error:
        lattice.simulate(order, horizon=0.1, parameters=parameters)
    assert expected in str(error.value)
    assert "allowed" in str(error.value)
    # the instance is usable again after the failure
    assert lattice.simulate(PUBLISHED_SEQUENTIAL, horizon=0.05)["external_work"] > 0


def test_unknown_parameter_and_wrong_order_length_are_refused(lattice):
    with pytest.raises(ValueError, match="unknown parameter 'F_tot'"):
        lattice.simulate(None, horizon=0.1, parameters={"F_tot": 1.0})
    with pytest.raises(ValueError, match=r"order: expected one material per column \(11\), got 3"):
        lattice.simulate((1, 2, 3), horizon=0.1)


def test_outputs_are_defined_right_after_initialisation(fmu_path, unzipped):
    description, slave = _slave(fmu_path, unzipped)
    try:
        _start(description, slave, PUBLISHED_BEST)
        values = slave.getReal([_vr(description, name) for name in ALL_OUTPUTS if name not in COUNTER_OUTPUTS])
        assert all(math.isfinite(v) for v in values)
        assert slave.getReal([_vr(description, "kinetic_energy"), _vr(description, "peak_backplate_force")]) == [0, 0]
    finally:
        slave.freeInstance()


def test_outputs_cannot_be_set(fmu_path, unzipped):
    description, slave = _slave(fmu_path, unzipped)
    try:
        slave.setupExperiment(startTime=0.0)
        slave.enterInitializationMode()
        with pytest.raises(FMICallException):
            slave.setReal([_vr(description, "peak_backplate_force")], [1.0])
    finally:
        slave.freeInstance()


def test_reset_gives_bit_identical_results(lattice):
    first = lattice.simulate(PUBLISHED_BEST, horizon=2.0, outputs=ALL_OUTPUTS)
    lattice.simulate(PUBLISHED_SEQUENTIAL, horizon=1.0, parameters={"F_total": 3000.0, "solver": "rk4"})
    assert lattice.simulate(PUBLISHED_BEST, horizon=2.0, outputs=ALL_OUTPUTS) == first


@pytest.fixture(scope="module")
def unzipped(fmu_path, tmp_path_factory):
    """The FMU extracted once for this module's instances (removed with the session's temporary folders)."""
    return extract(str(fmu_path), str(tmp_path_factory.mktemp("unzipped")))


def _slave(fmu_path, unzip_dir, name="instance"):
    description = read_model_description(str(fmu_path))
    slave = FMU2Slave(
        guid=description.guid,
        unzipDirectory=unzip_dir,
        modelIdentifier=description.coSimulation.modelIdentifier,
        instanceName=name,
    )
    slave.instantiate()
    return description, slave


def _vr(description, name):
    return next(v.valueReference for v in description.modelVariables if v.name == name)


def _start(description, slave, order, stop=2.0):
    slave.setupExperiment(startTime=0.0, stopTime=stop)
    slave.enterInitializationMode()
    slave.setInteger([_vr(description, f"material[{j}]") for j in range(1, 12)], list(order))
    slave.exitInitializationMode()


def test_instances_in_one_process_are_independent(fmu_path, unzipped):
    unzip_dir = unzipped  # one shared library, two instances: no global state may leak
    description, first = _slave(fmu_path, unzip_dir, "first")
    _, second = _slave(fmu_path, unzip_dir, "second")
    peak = [_vr(description, "peak_backplate_force"), _vr(description, "external_work")]
    try:
        _start(description, first, PUBLISHED_SEQUENTIAL)
        _start(description, second, PUBLISHED_BEST)
        for i in range(100):  # interleaved
            first.doStep(i * 0.02, 0.02)
            second.doStep(i * 0.02, 0.02)
        interleaved = first.getReal(peak), second.getReal(peak)
    finally:
        first.freeInstance()
        second.freeInstance()
    description, alone = _slave(fmu_path, unzip_dir, "alone")
    try:
        _start(description, alone, PUBLISHED_BEST)
        alone.doStep(0.0, 2.0)
        assert alone.getReal(peak) == interleaved[1]
        assert interleaved[0][0] == pytest.approx(PUBLISHED_PEAKS[PUBLISHED_SEQUENTIAL], rel=1e-6)
    finally:
        alone.freeInstance()


def test_get_set_and_serialize_fmu_state(fmu_path, unzipped):
    description, slave = _slave(fmu_path, unzipped)
    outputs = [_vr(description, name) for name in PEAK_OUTPUTS + ENERGY_OUTPUTS]
    try:
        _start(description, slave, PUBLISHED_BEST)
        slave.doStep(0.0, 0.2)
        state = slave.getFMUstate()
        serialized = slave.serializeFMUstate(state)
        slave.doStep(0.2, 0.8)
        straight = slave.getReal(outputs)
        slave.setFMUstate(state)
        slave.doStep(0.2, 0.8)
        assert slave.getReal(outputs) == straight
        restored = slave.deSerializeFMUstate(serialized)
        slave.setFMUstate(restored)
        slave.doStep(0.2, 0.8)
        assert slave.getReal(outputs) == straight
        slave.freeFMUstate(state)
        slave.freeFMUstate(restored)
    finally:
        slave.freeInstance()


def test_a_foreign_or_truncated_serialized_state_is_refused(fmu_path, unzipped):
    """A serialised state is checked before it becomes an FMU state: its size, then its magic number."""
    description, slave = _slave(fmu_path, unzipped)
    try:
        _start(description, slave, PUBLISHED_BEST)
        state = slave.getFMUstate()
        serialized = bytes(slave.serializeFMUstate(state))
        slave.freeFMUstate(state)
        with pytest.raises(FMICallException):
            slave.deSerializeFMUstate(serialized[:-1])
        with pytest.raises(FMICallException):
            slave.deSerializeFMUstate(bytes(4) + serialized[4:])  # the magic number of another FMU (version)
        slave.doStep(0.0, 0.1)  # the instance is unharmed
    finally:
        slave.freeInstance()


def test_a_diverging_fixed_step_solver_ends_in_an_error_not_a_number(lattice):
    with pytest.raises(SimulationError, match="diverged|non-finite"):
        lattice.simulate(PUBLISHED_SEQUENTIAL, horizon=1.0, parameters={"solver": "rk4", "fixed_step": 0.05})


def test_stepping_past_the_stop_time_is_refused(fmu_path, unzipped):
    description, slave = _slave(fmu_path, unzipped)
    try:
        _start(description, slave, PUBLISHED_SEQUENTIAL, stop=0.5)
        with pytest.raises(FMICallException):
            slave.doStep(0.0, 0.6)
    finally:
        slave.freeInstance()


# use_symmetry: the armour scene is mirror-symmetric about its middle row (11 rows, load along them), so the
# solver integrates the upper half; the whole lattice's answer must come out of it.
SEARCH_SETTINGS = {"solver": "tsit5", "rtol": 1e-5, "atol": 1e-7}


@pytest.mark.parametrize("order", [PUBLISHED_SEQUENTIAL, PUBLISHED_BEST])
def test_the_upper_half_gives_the_whole_lattice(lattice, order):
    whole = lattice.simulate(order, horizon=1.0, parameters={**SEARCH_SETTINGS, "use_symmetry": 0}, outputs=ALL_OUTPUTS)
    half = lattice.simulate(order, horizon=1.0, parameters={**SEARCH_SETTINGS, "use_symmetry": 1}, outputs=ALL_OUTPUTS)
    # the error norms weight the half's rows as the whole lattice's, so the steps are the same
    for name in COUNTER_OUTPUTS:
        assert half[name] == whole[name], name
    for name in set(ALL_OUTPUTS) - set(COUNTER_OUTPUTS):
        scale = max(abs(whole[name]), 1e-6 if name.startswith(("ux", "uy")) else 1e-3)
        assert abs(half[name] - whole[name]) <= 1e-9 * scale, (name, half[name], whole[name])
    # a load along x moves every mass along x only: r = u_b - u_a (docs/model.md section 2) keeps no y part
    assert all(half[name] == 0.0 for name in ALL_OUTPUTS if name.startswith("uy"))


def test_the_upper_half_reproduces_the_published_peaks_over_8_s(lattice):
    for order in (PUBLISHED_SEQUENTIAL, PUBLISHED_BEST):
        result = lattice.simulate(
            order,
            horizon=8.0,
            parameters={"use_symmetry": 1},
            outputs=("peak_backplate_force", "energy_balance_error", "external_work"),
        )
        assert result["peak_backplate_force"] == pytest.approx(PUBLISHED_PEAKS[order], rel=1e-7)
        assert abs(result["energy_balance_error"]) <= 1e-6 * result["external_work"]


def test_an_asymmetric_load_integrates_the_whole_lattice(lattice):
    parameters = {**SEARCH_SETTINGS, "load_angle": 30.0}
    with_symmetry = lattice.simulate(
        PUBLISHED_BEST, horizon=0.5, parameters={**parameters, "use_symmetry": 1}, outputs=ALL_OUTPUTS
    )
    without = lattice.simulate(
        PUBLISHED_BEST, horizon=0.5, parameters={**parameters, "use_symmetry": 0}, outputs=ALL_OUTPUTS
    )
    assert with_symmetry == without  # bit for bit: nothing to mirror
    assert with_symmetry["uy_centre"] != 0.0


def test_use_symmetry_outside_0_or_1_is_refused_by_name(lattice):
    with pytest.raises(SimulationError, match=r"use_symmetry.*0 or 1"):
        lattice.simulate(PUBLISHED_BEST, horizon=0.1, parameters={"use_symmetry": 2})
