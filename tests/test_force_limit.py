"""peak_force_limit: the FMU stops a run as soon as its sampled peak exceeds the limit (FMI 2: fmi2Discard with
fmi2Terminated and fmi2LastSuccessfulTime; FMI 3: terminateSimulation, with an early return when allowed),
its outputs valid at the time reached; a run below the limit is bit-identical to one without it; and
orchestrator.simulation reports such a run as censored, never as a peak."""

import math

import pytest
from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave, fmi2Discard, fmi2LastSuccessfulTime, fmi2Terminated
from fmpy.fmi3 import FMU3Slave, fmi3LogMessageCallback

from builder import build as build_library
from scenes import Scene
from fmu_src.published import SEQUENTIAL_ORDER as PUBLISHED_SEQUENTIAL, STUDY_BEST_ORDER as PUBLISHED_BEST
from orchestrator.simulation import LatticeFMU, SimulationError

OUTPUTS = (
    "peak_backplate_force",
    "peak_backplate_force_continuous",
    "peak_time",
    "last_contact_time",
    "backplate_force",
    "kinetic_energy",
    "potential_energy",
    "external_work",
    "dissipated_energy",
    "nonreciprocal_work",
    "energy_balance_error",
    "ux_right_edge",
    "uy_centre",
    "rhs_evaluations",
    "steps_accepted",
    "steps_rejected",
)
SEARCH = {"rtol": 1e-5, "atol": 1e-7}


@pytest.mark.parametrize("order", [PUBLISHED_SEQUENTIAL, PUBLISHED_BEST], ids=["sequential", "study_best"])
def test_a_run_below_the_limit_is_bit_identical_to_one_without(lattice, order):
    free = lattice.simulate(order, horizon=1.0, parameters=SEARCH, outputs=OUTPUTS)
    limited = lattice.simulate(
        order, horizon=1.0, parameters=SEARCH, outputs=OUTPUTS, peak_force_limit=free["peak_backplate_force"]
    )  # exceeded means strictly above
    assert limited.stopped_early is False and limited.stop_time == 1.0
    assert limited == free


def test_a_run_above_the_limit_stops_at_the_first_sample_above_it(lattice):
    limit = 1500.0
    stopped = lattice.simulate(
        PUBLISHED_SEQUENTIAL, horizon=1.0, parameters=SEARCH, outputs=OUTPUTS, peak_force_limit=limit
    )
    assert stopped.stopped_early is True
    reached = stopped.stop_time
    assert 0.15 < reached < 0.45
    assert stopped["peak_backplate_force"] > limit
    # the same run without the limit, read at every 0.01 s sample: the outputs where the limited run stopped
    # are those of the full run at that time, bit for bit, and no earlier sample exceeded the limit
    full = lattice.simulate(
        PUBLISHED_SEQUENTIAL,
        horizon=1.0,
        parameters=SEARCH,
        outputs=("rhs_evaluations",),
        communication_step=0.01,
        record=OUTPUTS,
    )
    times = list(full.trajectory.time)
    index = times.index(reached)
    for name in OUTPUTS:
        if name in ("rhs_evaluations", "steps_accepted", "steps_rejected"):
            continue  # counters: the full run's step ending at a communication point may have gone further
        assert stopped[name] == full.trajectory.values[name][index], name
    assert full.trajectory.values["peak_backplate_force"][index - 1] <= limit
    assert stopped["rhs_evaluations"] < 0.6 * full["rhs_evaluations"]


def test_the_limit_among_the_parameters_is_the_same_as_the_argument(lattice):
    argument = lattice.simulate(
        PUBLISHED_SEQUENTIAL, horizon=1.0, parameters=SEARCH, outputs=OUTPUTS, peak_force_limit=1500.0
    )
    parameter = lattice.simulate(
        PUBLISHED_SEQUENTIAL, horizon=1.0, parameters={**SEARCH, "peak_force_limit": 1500.0}, outputs=OUTPUTS
    )
    assert parameter == argument and parameter.stopped_early is True


def test_communication_steps_end_at_the_time_reached(lattice):
    stopped = lattice.simulate(
        PUBLISHED_SEQUENTIAL,
        horizon=1.0,
        parameters=SEARCH,
        communication_step=0.05,
        outputs=("peak_backplate_force",),
        record=("peak_backplate_force",),
        peak_force_limit=1500.0,
    )
    whole = lattice.simulate(
        PUBLISHED_SEQUENTIAL, horizon=1.0, parameters=SEARCH, outputs=("peak_backplate_force",), peak_force_limit=1500.0
    )
    trajectory = stopped.trajectory
    assert stopped.stopped_early and stopped.stop_time == whole.stop_time == trajectory.time[-1]
    assert trajectory.time[-2] < stopped.stop_time
    assert (
        stopped["peak_backplate_force"]
        == whole["peak_backplate_force"]
        == trajectory.values["peak_backplate_force"][-1]
    )


@pytest.mark.parametrize("value", [-1.0, math.inf, math.nan])
def test_a_negative_or_non_finite_limit_is_refused_by_name(lattice, value):
    with pytest.raises(SimulationError, match="peak_force_limit"):
        lattice.simulate(PUBLISHED_SEQUENTIAL, horizon=0.1, peak_force_limit=value)
    assert lattice.simulate(PUBLISHED_SEQUENTIAL, horizon=0.1)["peak_backplate_force"] >= 0  # usable again


def test_a_compiled_in_negative_limit_is_refused_at_exit_initialization(tmp_path):
    scene = Scene.load("two_masses_linear")
    scene.parameters = {**scene.parameters, "peak_force_limit": -2.0}
    scene.hidden = [*scene.hidden, "peak_force_limit"]
    path = build_library.build_fmu(scene, output=tmp_path / "NegativeLimit.fmu", werror=True)
    with LatticeFMU(path) as fmu:
        with pytest.raises(SimulationError, match=r"fmi2ExitInitializationMode failed: .*peak_force_limit = -2"):
            fmu.simulate(None, horizon=0.1)


def test_fmi2_status_after_the_limit(fmu_path, tmp_path):
    description = read_model_description(str(fmu_path))
    vr = {v.name: v.valueReference for v in description.modelVariables}
    slave = FMU2Slave(
        guid=description.guid,
        unzipDirectory=extract(str(fmu_path), str(tmp_path / "unzipped")),
        modelIdentifier=description.coSimulation.modelIdentifier,
        instanceName="limit",
    )
    slave.instantiate()
    slave.setupExperiment(startTime=0.0, stopTime=1.0)
    slave.enterInitializationMode()
    slave.setReal([vr["peak_force_limit"]], [1500.0])
    slave.exitInitializationMode()
    slave.doStep(0.0, 0.1)  # no contact yet
    assert slave.getBooleanStatus(fmi2Terminated) is False
    with pytest.raises(FMICallException) as discarded:
        slave.doStep(0.1, 0.9)
    assert discarded.value.status == fmi2Discard
    assert slave.getBooleanStatus(fmi2Terminated) is True
    reached = slave.getRealStatus(fmi2LastSuccessfulTime)
    assert 0.1 < reached < 0.45
    assert slave.getReal([vr["peak_backplate_force"]])[0] > 1500.0
    with pytest.raises(FMICallException):  # the run is over: no further step ...
        slave.doStep(reached, 0.1)
    slave.terminate()  # ... but the instance is not in the error state
    slave.reset()
    slave.freeInstance()


@pytest.mark.parametrize("early_return_allowed", [True, False], ids=["early_return", "no_early_return"])
def test_fmi3_terminates_with_an_early_return_when_allowed(fmu3_path, lattice, early_return_allowed, tmp_path):
    description = read_model_description(str(fmu3_path))
    vr = {v.name: v.valueReference for v in description.modelVariables}
    assert description.coSimulation.mightReturnEarlyFromDoStep
    slave = FMU3Slave(
        guid=description.guid,
        unzipDirectory=extract(str(fmu3_path), str(tmp_path / "unzipped")),
        modelIdentifier=description.coSimulation.modelIdentifier,
        instanceName="limit3",
    )
    callback = fmi3LogMessageCallback(lambda *args: None)
    slave.instantiate(logMessage=callback, earlyReturnAllowed=early_return_allowed)
    slave.enterInitializationMode(startTime=0.0, stopTime=1.0)
    slave.setFloat64([vr["peak_force_limit"]], [1500.0])
    slave.setFloat64([vr["rtol"], vr["atol"]], [SEARCH["rtol"], SEARCH["atol"]])
    slave.exitInitializationMode()
    expected = lattice.simulate(
        PUBLISHED_SEQUENTIAL, horizon=1.0, parameters=SEARCH, outputs=OUTPUTS, peak_force_limit=1500.0
    )
    if early_return_allowed:
        _, terminate, early_return, last_time = slave.doStep(0.0, 1.0)
        assert terminate and early_return and last_time == expected.stop_time
    else:
        with pytest.raises(FMICallException) as discarded:
            slave.doStep(0.0, 1.0)
        assert discarded.value.status == 2  # fmi3Discard: only part of the step was computed
    assert slave.getFloat64([vr["peak_backplate_force"]]) == [expected["peak_backplate_force"]]
    assert slave.getFloat64([vr["time"]]) == [expected.stop_time]
    slave.terminate()
    slave.freeInstance()


@pytest.mark.parametrize("solver", [3, 4], ids=["tsit5", "dopri5"])
def test_the_states_of_a_limited_run_are_accepted_and_resume_it(fmu_path, solver, tmp_path):
    """Every state a run with a 5(4) pair saves (its dense output read from the stage rows), up to and after the
    stop at the limit, passes the FMU's state checks; a state from the middle continues to the same stop."""
    description = read_model_description(str(fmu_path))
    vr = {v.name: v.valueReference for v in description.modelVariables}
    slave = FMU2Slave(
        guid=description.guid,
        unzipDirectory=extract(str(fmu_path), str(tmp_path / "unzipped")),
        modelIdentifier=description.coSimulation.modelIdentifier,
        instanceName="states",
    )
    slave.instantiate()
    slave.setupExperiment(startTime=0.0, stopTime=1.0)
    slave.enterInitializationMode()
    slave.setReal([vr["peak_force_limit"], vr["rtol"], vr["atol"]], [1500.0, SEARCH["rtol"], SEARCH["atol"]])
    slave.setInteger([vr["solver"]], [solver])
    slave.exitInitializationMode()

    def run_from(time, step=0.0173):
        saved = []
        while True:
            try:
                slave.doStep(time, step)
            except FMICallException as stopped:
                assert stopped.status == fmi2Discard
                saved.append(slave.getFMUstate())
                return slave.getRealStatus(fmi2LastSuccessfulTime), saved
            time += step
            saved.append((time, slave.getFMUstate()))

    reached, states = run_from(0.0)
    peak = slave.getReal([vr["peak_backplate_force"]])[0]
    for state in [s for _, s in states[:-1]] + [states[-1]]:
        restored = slave.deSerializeFMUstate(bytes(slave.serializeFMUstate(state)))
        slave.setFMUstate(restored)
        slave.freeFMUstate(restored)
    assert slave.getBooleanStatus(fmi2Terminated) is True  # the last state set is the stopped one
    middle_time, middle = states[len(states) // 2]
    slave.setFMUstate(middle)
    again, _ = run_from(middle_time)
    assert again == reached and slave.getReal([vr["peak_backplate_force"]])[0] == peak
    slave.terminate()
    slave.freeInstance()
