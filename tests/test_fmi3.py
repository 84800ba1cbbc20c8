"""The FMI 3.0 FMU (`build_fmu.py --fmi-version 3`): same model code; the parameter arrays are FMI 3 arrays.

Checked through fmpy: validation, the model description derived from the same table as FMI 2 (`material` an
Int32 array of 11, `k` ... `damping_exponent` Float64 arrays of M, with FMI 2's elements as their values; every
other variable a scalar with FMI 2's name; value reference = position in <ModelVariables>, so a `derivative`
read as an index finds its state), bit-identical peaks and outputs to the FMI 2 FMU, the error handling of
fmi3/fmi3_glue.c (nValues counts an array's elements), and FMU states. fmi-sim runs it in
tests/test_importers.py.
"""

from __future__ import annotations

import shutil
import zipfile

import pytest
from fmpy import extract, read_model_description, simulate_fmu
from fmpy.fmi1 import FMICallException
from fmpy.fmi3 import FMU3Slave, fmi3LogMessageCallback
from fmpy.validation import validate_fmu

from fmu_src.published import SEQUENTIAL_ORDER as PUBLISHED_SEQUENTIAL, STUDY_BEST_ORDER as PUBLISHED_BEST
from fmu_src.variables import TABLE_PARAMETERS, seed_name
from orchestrator.simulation import LatticeFMU

HORIZON, STEP = 8.0, 0.01


class Instance:
    """One FMU3Slave with its variables by name and the messages it logged."""

    def __init__(self, fmu3_path, name="lattice3"):
        self.description = read_model_description(str(fmu3_path))
        self.variables = {v.name: v for v in self.description.modelVariables}
        self.messages: list[str] = []
        self.unzip_dir = extract(str(fmu3_path))
        self.slave = FMU3Slave(
            guid=self.description.guid,
            unzipDirectory=self.unzip_dir,
            modelIdentifier=self.description.coSimulation.modelIdentifier,
            instanceName=name,
        )
        self._callback = fmi3LogMessageCallback(self._log)
        self.slave.instantiate(logMessage=self._callback)

    def _log(self, environment, status, category, message):
        self.messages.append(message.decode())

    def vr(self, name):
        return self.variables[name].valueReference

    def start(self, order=None, stop=HORIZON):
        self.slave.enterInitializationMode(startTime=0.0, stopTime=stop)
        if order is not None:
            self.slave.setInt32([self.vr("material")], list(order))
        self.slave.exitInitializationMode()

    def run(self, order, horizon=HORIZON, step=STEP):
        self.slave.reset()
        self.start(order, horizon)
        steps = round(horizon / step)
        for i in range(steps):
            self.slave.doStep(i * step, step)
        return self.outputs()

    def outputs(self):
        values = {}
        for name, variable in self.variables.items():
            if variable.causality != "output":
                continue
            if variable.type == "Int32":
                values[name] = self.slave.getInt32([variable.valueReference])[0]
            else:
                values[name] = self.slave.getFloat64([variable.valueReference])[0]
        return values

    def close(self):
        self.slave.freeInstance()
        shutil.rmtree(self.unzip_dir, ignore_errors=True)


@pytest.fixture()
def instance(fmu3_path):
    fmu = Instance(fmu3_path)
    yield fmu
    fmu.close()


def test_fmpy_validation_finds_no_problem(fmu3_path):
    assert validate_fmu(str(fmu3_path)) == []


def test_model_description_comes_from_the_same_table_as_fmi2(fmu_path, fmu3_path):
    fmi2 = {v.name: v for v in read_model_description(str(fmu_path)).modelVariables}
    description = read_model_description(str(fmu3_path))
    variables = description.modelVariables
    fmi3 = {v.name: v for v in variables}
    assert description.fmiVersion == "3.0"
    assert description.coSimulation is not None and description.modelExchange is not None

    # FMI 2's names and order (its Enumeration aliases aside), each parameter array's elements as one array,
    # time last
    arrays = {
        "material": 11,
        **{name: 11 for name in TABLE_PARAMETERS},
        **{seed_name(name): 11 for name in TABLE_PARAMETERS},  # the sensitivity's seeds, arrays as the properties
    }
    expected = []
    for name, variable in fmi2.items():
        base = name.partition("[")[0]
        if variable.type == "Enumeration" or (base in arrays and base in expected):
            continue
        expected.append(base if base in arrays else name)
    assert [v.name for v in variables] == expected + ["time"]
    assert {v.name: v.shape for v in variables if v.dimensions} == {name: (n,) for name, n in arrays.items()}
    for name, length in arrays.items():
        elements = [fmi2[f"{name}[{m}]"] for m in range(1, length + 1)]
        assert fmi3[name].start.split() == [e.start for e in elements], name  # the same literals
        assert (fmi3[name].causality, fmi3[name].min, fmi3[name].max) == (
            "parameter",
            elements[0].min,
            elements[0].max,
        ), name
    assert fmi3["material"].type == "Int32" and fmi3["material"].start.split() == [str(m) for m in range(1, 12)]
    units = {name: fmi3[name].declaredType.unit for name in ("k", "c", "F_total", "peak_backplate_force", "time")}
    assert units == {
        "k": fmi2["k[1]"].unit,
        "c": fmi2["c[1]"].unit,
        "F_total": fmi2["F_total"].unit,
        "peak_backplate_force": fmi2["peak_backplate_force"].unit,
        "time": "s",
    }  # via declared types
    for name, variable in fmi3.items():
        if name == "time":
            assert variable.causality == "independent" and variable.type == "Float64"
            continue
        if name in arrays:
            name = f"{name}[1]"
        fmi2_type = (
            "Enumeration"
            if any(a.type == "Enumeration" and a.valueReference == fmi2[name].valueReference for a in fmi2.values())
            else fmi2[name].type
        )
        assert (variable.type, variable.causality) == (
            {"Real": "Float64", "Integer": "Int32", "Enumeration": "Enumeration"}[fmi2_type],
            fmi2[name].causality,
        )

    with zipfile.ZipFile(fmu3_path) as archive:
        names = archive.namelist()
        build_description = archive.read("sources/buildDescription.xml").decode()
    assert "binaries/x86_64-linux/MassSpringLattice.so" in names
    assert 'name="fmi3_glue.c"' in build_description and 'name="model.c"' in build_description


def test_a_derivative_read_as_an_index_finds_its_state(fmu3_path):
    """OMSimulator 3 takes a derivative's `derivative` attribute (the state's value reference) as the state's
    1-based position in the variable list: both readings give the same variable."""
    description = read_model_description(str(fmu3_path))
    variables = description.modelVariables
    derivatives = [v for v in variables if v.derivative is not None]
    # ux, uy, vx, vy, three energy integrals, projectile mode's body
    assert len(derivatives) == description.numberOfContinuousStates == 4 * 121 + 3 + 2
    for variable in derivatives:
        state = variable.derivative
        assert variables[state.valueReference - 1] is state and variable.name == f"der({state.name})"
    assert all(v.valueReference == position for position, v in enumerate(variables, 1))


@pytest.fixture(scope="module")
def fmi2_results(fmu_path):
    with LatticeFMU(fmu_path) as fmu:
        return {
            order: fmu.simulate(order, horizon=HORIZON, communication_step=STEP).values
            for order in (PUBLISHED_BEST, PUBLISHED_SEQUENTIAL)
        }


@pytest.mark.parametrize("order", [PUBLISHED_BEST, PUBLISHED_SEQUENTIAL], ids=["published_best", "sequential"])
def test_same_numbers_as_fmi2_to_the_last_bit(instance, fmi2_results, order):
    outputs = instance.run(order)
    assert outputs == fmi2_results[order]  # every output, bit for bit, the peak included
    assert instance.slave.getFloat64([instance.vr("time")]) == [HORIZON]


def test_fmpy_simulate_fmu_sets_the_order_as_an_array(fmu3_path, fmi2_results):
    result = simulate_fmu(
        str(fmu3_path),
        stop_time=HORIZON,
        output_interval=STEP,
        start_values={"material": list(PUBLISHED_BEST)},
        output=["peak_backplate_force"],
    )
    assert result["peak_backplate_force"][-1] == fmi2_results[PUBLISHED_BEST]["peak_backplate_force"]


def test_arrays_and_scalars_are_read_and_written_several_at_a_time(instance):
    """nValues counts values: an array moves all its elements, in order, between the scalars around it."""
    material = [instance.vr("material")]
    assert instance.slave.getInt32(material, 11) == list(range(1, 12))
    instance.slave.enterInitializationMode(startTime=0.0, stopTime=1.0)
    instance.slave.setInt32(material, list(PUBLISHED_BEST))
    assert instance.slave.getInt32(material, 11) == list(PUBLISHED_BEST)
    k, mass = instance.vr("k"), instance.vr("mass")
    values = instance.slave.getFloat64([instance.vr("F_total"), k, instance.vr("time"), mass], 24)
    assert values[0] == 1200.0 and values[1] == 100.0 and values[12] == 0.0 and values[13:] == [1.0] * 11
    instance.slave.setFloat64([k, instance.vr("F_total"), mass], [50.0] * 11 + [600.0] + [2.0] * 11)
    assert instance.slave.getFloat64([mass, k], 22) == [2.0] * 11 + [50.0] * 11
    assert instance.slave.getFloat64([instance.vr("F_total")]) == [600.0]


@pytest.mark.parametrize(
    "call, expected",
    [
        (lambda f: f.slave.getInt32([0]), "not an Int32 variable of this FMU"),  # before the first variable
        (lambda f: f.slave.getInt32([f.vr("time") + 1]), "not an Int32 variable of this FMU"),  # after time
        (lambda f: f.slave.getInt32([f.vr("material")], 5), "nValues is 5 but the 1 value references move 11"),
        (lambda f: f.slave.getInt32([f.vr("material")]), "nValues is 1"),  # fmpy's default: one per reference
        (lambda f: f.slave.setFloat64([f.vr("k")], [1.0] * 10), "nValues is 10"),
        (lambda f: f.slave.getFloat64([f.vr("material")], 11), "not a Float64"),
        (lambda f: f.slave.getInt32([f.vr("time")]), "is time"),
        (lambda f: f.slave.setFloat64([f.vr("peak_backplate_force")], [1.0]), "output"),
        (lambda f: f.slave.setFloat64([f.vr("time")], [1.0]), "independent"),
        (lambda f: f.slave.getBoolean([0]), "no Boolean"),
    ],
)
def test_wrong_calls_are_refused_with_a_reason(instance, call, expected):
    with pytest.raises(FMICallException):
        call(instance)
    assert any(expected in message for message in instance.messages), instance.messages


def test_a_wrong_step_is_refused_with_a_reason_and_the_instance_steps_on(instance):
    """communicationStepSize < 0 and a communication point that is not the FMU's time are the importer's
    mistakes: refused with a reason, without putting the instance in the error state."""
    instance.start(PUBLISHED_BEST, stop=1.0)
    with pytest.raises(FMICallException):
        instance.slave.doStep(0.0, -0.1)
    with pytest.raises(FMICallException):
        instance.slave.doStep(0.5, 0.1)
    assert any("communicationStepSize = -0.1 is not allowed" in m for m in instance.messages), instance.messages
    assert any("does not match the FMU's time" in m for m in instance.messages), instance.messages
    instance.slave.doStep(0.0, 0.1)
    assert instance.slave.getFloat64([instance.vr("time")]) == [0.1]


def test_an_instantiation_token_of_another_build_is_refused(fmu3_path, tmp_path):
    description = read_model_description(str(fmu3_path))
    messages = []
    callback = fmi3LogMessageCallback(lambda environment, status, category, message: messages.append(message.decode()))
    slave = FMU3Slave(
        guid="{00000000-0000-0000-0000-000000000000}",
        unzipDirectory=extract(str(fmu3_path), str(tmp_path / "unzipped")),
        modelIdentifier=description.coSimulation.modelIdentifier,
        instanceName="stranger",
    )
    with pytest.raises(Exception, match="Failed to instantiate"):  # fmpy's words for a NULL instance
        slave.instantiate(logMessage=callback)
    assert any("instantiation token" in m and "different builds" in m for m in messages), messages


def test_a_bad_material_order_is_refused_and_reset_recovers(instance):
    instance.slave.enterInitializationMode(startTime=0.0, stopTime=1.0)
    instance.slave.setInt32([instance.vr("material")], [1, 1, 3, 4, 5, 6, 7, 8, 9, 10, 11])
    with pytest.raises(FMICallException):
        instance.slave.exitInitializationMode()
    assert any("permutation of 1..11" in message for message in instance.messages), instance.messages
    assert instance.run(PUBLISHED_SEQUENTIAL, horizon=0.3)["external_work"] > 0


def test_get_set_and_serialize_fmu_state(instance):
    names = ("peak_backplate_force", "kinetic_energy", "external_work")
    outputs = [instance.vr(name) for name in names]
    instance.start(PUBLISHED_BEST, stop=1.0)
    instance.slave.doStep(0.0, 0.2)
    state = instance.slave.getFMUState()
    serialized = instance.slave.serializeFMUState(state)
    instance.slave.doStep(0.2, 0.5)
    straight = instance.slave.getFloat64(outputs)
    instance.slave.setFMUState(state)
    assert instance.slave.getFloat64([instance.vr("time")]) == [0.2]
    instance.slave.doStep(0.2, 0.5)
    assert instance.slave.getFloat64(outputs) == straight
    restored = instance.slave.deserializeFMUState(serialized)
    instance.slave.setFMUState(restored)
    instance.slave.doStep(0.2, 0.5)
    assert instance.slave.getFloat64(outputs) == straight
    instance.slave.freeFMUState(state)
    instance.slave.freeFMUState(restored)


@pytest.fixture(scope="module")
def scalars_fmu3(tmp_path_factory):
    from builder import build

    output = tmp_path_factory.mktemp("scalars3") / "MassSpringLattice-fmi3.fmu"
    return build.build_fmu(output=output, werror=True, fmi_version=3, fmi3_arrays=False)


def test_built_with_scalars_it_declares_fmi2s_names_for_importers_without_arrays(
    fmu_path, fmu3_path, scalars_fmu3, fmi2_results
):
    """build_fmu.py --fmi3-scalars: no FMI 3 array, every element a scalar with FMI 2's name and value reference
    + 1 (OMSimulator 3, fmi-sim 0.7 set these); another layout, so another instantiation token; the same run."""
    fmi2 = {v.name: v for v in read_model_description(str(fmu_path)).modelVariables}
    description = read_model_description(str(scalars_fmu3))
    variables = description.modelVariables
    assert [v.name for v in variables] == [n for n, v in fmi2.items() if v.type != "Enumeration"] + ["time"]
    assert not any(v.dimensions for v in variables)
    assert all(v.valueReference == fmi2[v.name].valueReference + 1 for v in variables if v.name != "time")
    assert description.guid != read_model_description(str(fmu3_path)).guid
    assert validate_fmu(str(scalars_fmu3)) == []
    result = simulate_fmu(
        str(scalars_fmu3),
        stop_time=HORIZON,
        output_interval=STEP,
        start_values={f"material[{j}]": m for j, m in enumerate(PUBLISHED_BEST, 1)},
        output=["peak_backplate_force"],
    )
    assert result["peak_backplate_force"][-1] == fmi2_results[PUBLISHED_BEST]["peak_backplate_force"]


def test_scalars_are_refused_for_fmi2_in_one_line(capsys):
    import build_fmu

    with pytest.raises(SystemExit) as exit_status:
        build_fmu.main(["--fmi3-scalars"])
    assert exit_status.value.code == 2
    (line,) = [line for line in capsys.readouterr().err.splitlines() if "error:" in line]
    assert "--fmi3-scalars: only with --fmi-version 3" in line


def test_fmi2s_element_names_become_fmi3s_arrays_in_our_layer(fmu_path, fmu3_path):
    """orchestrator.simulation.start_values: what answers[i].parameters give (material[j], k[m]) as the FMI 3
    FMU's arrays, the elements not given keeping their start; FMI 2's names pass unchanged to FMI 2. The typed
    Parameter of each element is read from the array."""
    from orchestrator.simulation import declared_parameters, model_description, start_values

    fmi3 = model_description(fmu3_path)
    given = {"material[1]": 3, "material[2]": 1, "material[3]": 2, "k[11]": 2.5, "diagonal_rule": 1}
    values = start_values(fmi3, given)
    assert values["material"] == [3, 1, 2, *range(4, 12)] and values["diagonal_rule"] == 1
    assert values["k"][:10] == [declared_parameters(fmi3)[f"k[{m}]"].start for m in range(1, 11)]
    assert values["k"][10] == 2.5 and set(values) == {"material", "k", "diagonal_rule"}
    assert start_values(model_description(fmu_path), given) == given
    parameter = declared_parameters(fmi3)["mass[2]"]
    assert (parameter.name, parameter.type, parameter.start, parameter.minimum) == ("mass[2]", "Float64", 1.0, 0.0)
    with pytest.raises(ValueError, match=r"k\[12\] is no element of the array k: allowed k\[1\] ... k\[11\]"):
        start_values(fmi3, {"k[12]": 1.0})
    with pytest.raises(ValueError, match="material is given both as an array and by its elements"):
        start_values(fmi3, {"material": list(range(1, 12)), "material[1]": 2})
