"""The FMU's interface as an FMI tool sees it: enumeration types, self-contained descriptions."""

from __future__ import annotations

import re
import shutil
import zipfile

import pytest
from fmpy import read_model_description, simulate_fmu

from fmu_src.published import STUDY_BEST_ORDER as PUBLISHED_BEST
from fmu_src.variables import all_variables
from orchestrator.simulation import enumeration_items
from test_fmi3 import Instance

ENUMERATIONS = {v.name: v for v in all_variables(11, 11) if v.enumeration}


def test_the_enumerations_name_the_tables_items_in_both_versions(fmu_path, fmu3_path):
    assert set(ENUMERATIONS) == {"diagonal_rule", "solver", "load_mode"}
    expected = {
        "diagonal_rule": {"receiver": 0, "mean": 1},
        "solver": {"dop853": 0, "rk4": 1, "semi_implicit_euler": 2, "tsit5": 3, "dopri5": 4, "rkn5": 5},
        "load_mode": {"pulse": 0, "input": 1, "projectile": 2},
    }
    for path in (fmu_path, fmu3_path):
        description = read_model_description(str(path))
        for name, variable in ENUMERATIONS.items():
            assert (
                enumeration_items(description, name)
                == expected[name]
                == {item: code for code, (item, _) in enumerate(variable.items)}
            )
    fmi2 = {v.name: v for v in read_model_description(str(fmu_path)).modelVariables}
    fmi3 = {v.name: v for v in read_model_description(str(fmu3_path)).modelVariables}
    for name, variable in ENUMERATIONS.items():
        # FMI 2: an Integer parameter, which every importer sets, and a local Enumeration alias naming the items
        parameter, alias = fmi2[name], fmi2[f"{name}_item"]
        assert (parameter.type, parameter.causality, int(parameter.start)) == ("Integer", "parameter", 0)
        assert (alias.type, alias.causality, alias.variability, alias.initial, alias.start) == (
            "Enumeration",
            "local",
            "fixed",
            "calculated",
            None,
        )
        assert alias.valueReference == parameter.valueReference and alias.declaredType.name == variable.enumeration
        # FMI 3: the parameter is the Enumeration itself
        assert fmi3[name].type == "Enumeration" and fmi3[name].declaredType.name == variable.enumeration
        assert f"{name}_item" not in fmi3


def test_libcosim_sets_the_fmi2_diagonal_rule_as_an_integer(fmu_path, lattice):
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver
    from libcosimpy.CosimSlave import CosimLocalSlave

    log_output_level(CosimLogLevel.ERROR)
    horizon, step = 1.0, 0.01
    code = enumeration_items(read_model_description(str(fmu_path)), "diagonal_rule")["mean"]
    execution = CosimExecution.from_step_size(step_size=int(round(step * 1e9)))
    index = execution.add_local_slave(CosimLocalSlave(fmu_path=str(fmu_path), instance_name="lattice"))
    references = {v.name.decode(): v.reference for v in execution.slave_variables(index)}
    for column, material in enumerate(PUBLISHED_BEST, 1):
        assert execution.integer_initial_value(index, references[f"material[{column}]"], material)
    assert execution.integer_initial_value(index, references["diagonal_rule"], code)
    observer = CosimObserver.create_last_value()
    execution.add_observer(observer)
    assert execution.simulate_until(target_time=int(round(horizon * 1e9))), execution.status()
    peak = observer.last_real_values(index, [references["peak_backplate_force"]])[0]
    mean = lattice.simulate(
        PUBLISHED_BEST, horizon=horizon, communication_step=step, parameters={"diagonal_rule": "mean"}
    )["peak_backplate_force"]
    receiver = lattice.simulate(PUBLISHED_BEST, horizon=horizon, communication_step=step)["peak_backplate_force"]
    assert peak == pytest.approx(mean, rel=1e-9) and abs(mean - receiver) > 0.1 * receiver


def test_fmi3_moves_an_enumeration_as_int64_and_refuses_int32(fmu_path, fmu3_path, lattice):
    result = simulate_fmu(
        str(fmu3_path),
        stop_time=1.0,
        output_interval=0.01,
        start_values={"material": list(PUBLISHED_BEST), "diagonal_rule": 1},
        output=["peak_backplate_force"],
    )
    mean = lattice.simulate(PUBLISHED_BEST, horizon=1.0, parameters={"diagonal_rule": "mean"})
    assert result["peak_backplate_force"][-1] == mean["peak_backplate_force"]  # the same model, bit for bit
    instance = Instance(fmu3_path, name="enumerations")
    try:
        assert instance.slave.getInt64([instance.vr("solver")]) == [0]
        with pytest.raises(Exception):
            instance.slave.setInt32([instance.vr("diagonal_rule")], [1])
        assert "is not an Int32 variable" in instance.messages[-1]
        with pytest.raises(Exception):
            instance.slave.setInt64([instance.vr("diagonal_rule")], [5])
        assert "0 (receiver) or 1 (mean)" in instance.messages[-1]
    finally:
        instance.close()


@pytest.mark.parametrize("which", ["fmi2", "fmi3"])
def test_descriptions_refer_to_nothing_outside_the_fmu(fmu_path, fmu3_path, which):
    with zipfile.ZipFile(fmu_path if which == "fmi2" else fmu3_path) as archive:
        text = archive.read("modelDescription.xml").decode()
    descriptions = re.findall(r'description="([^"]*)"', text)
    assert descriptions
    for description in descriptions:
        assert not re.search(r"\.md\b|SPEC|README|shared/", description), description


@pytest.mark.parametrize("which", ["fmi2", "fmi3"])
def test_documentation_inside_the_fmu_describes_this_fmu(fmu_path, fmu3_path, which):
    from fmu_src.published import PUBLISHED_PEAKS
    from scenes import Scene

    with zipfile.ZipFile(fmu_path if which == "fmi2" else fmu3_path) as archive:
        page = archive.read("documentation/index.html").decode()
    for variable in Scene.load("armour_11x11").interface().exposed:  # every variable, from the table
        assert f"<code>{variable.name}" in page.replace("&lt;", "<"), variable.name
    assert "The diagonal rule" in page and "not reciprocal" in page and "Model Exchange" in page
    assert f"FMI {which[-1]}.0" in page
    for order, peak in PUBLISHED_PEAKS.items():  # the published numbers, from the one table
        assert f"<td><code>{list(order)}</code></td><td>{peak!r}</td>" in page


@pytest.mark.parametrize(
    "version, kind", [(2, "CoSimulation"), (2, "ModelExchange"), (3, "CoSimulation"), (3, "ModelExchange")]
)
def test_a_guid_of_another_build_is_refused_naming_both(fmu_path, fmu3_path, version, kind):
    """fmi2Instantiate and fmi3Instantiate* compare the importer's GUID / instantiation token with the one the
    binary was built with (a hash of its sources and variables) and refuse another, both named in one line."""
    from fmpy import extract
    from fmpy.fmi2 import FMU2Model, FMU2Slave
    from fmpy.fmi3 import FMU3Model, FMU3Slave, fmi3LogMessageCallback

    from orchestrator.simulation import _CALLBACKS, _MESSAGES

    path = fmu_path if version == 2 else fmu3_path
    description = read_model_description(str(path))
    foreign = "{00000000-0000-0000-0000-000000000000}"
    unzip_dir = extract(str(path))
    messages: list[str] = []
    classes = {
        (2, "CoSimulation"): FMU2Slave,
        (2, "ModelExchange"): FMU2Model,
        (3, "CoSimulation"): FMU3Slave,
        (3, "ModelExchange"): FMU3Model,
    }
    interface = description.coSimulation if kind == "CoSimulation" else description.modelExchange
    fmu = classes[version, kind](
        guid=foreign,
        unzipDirectory=unzip_dir,
        modelIdentifier=interface.modelIdentifier,
        instanceName=f"foreign-{version}-{kind}",
    )
    try:
        with pytest.raises(Exception, match="Failed to instantiate"):  # fmpy's words for a NULL instance
            if version == 2:
                _MESSAGES[f"foreign-{version}-{kind}"] = messages
                fmu.instantiate(callbacks=_CALLBACKS)
            else:
                callback = fmi3LogMessageCallback(
                    lambda env, status, category, message: messages.append(message.decode())
                )
                fmu.instantiate(logMessage=callback)
    finally:
        _MESSAGES.pop(f"foreign-{version}-{kind}", None)
        shutil.rmtree(unzip_dir, ignore_errors=True)
    word = "GUID" if version == 2 else "instantiation token"
    assert len(messages) == 1 and "\n" not in messages[0], messages
    assert f"{word} {foreign} does not match this binary's {description.guid}" in messages[0]
