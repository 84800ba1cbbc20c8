"""The FMU's interface as an FMI tool sees it: enumeration types, self-contained descriptions."""
from __future__ import annotations

import re
import zipfile

import pytest
from fmpy import read_model_description, simulate_fmu

from fmu_src.published import STUDY_BEST_ORDER as PUBLISHED_BEST
from fmu_src.variables import all_variables
from test_fmi3 import Instance

ENUMERATIONS = {v.name: v for v in all_variables(11, 11) if v.enumeration}


def test_diagonal_rule_and_solver_are_enumerations_with_the_tables_values(fmu_path, fmu3_path):
    assert set(ENUMERATIONS) == {"diagonal_rule", "solver"}
    expected = {"DiagonalRule": [("receiver", 0), ("mean", 1)],
                "Solver": [("dop853", 0), ("rk4", 1), ("semi_implicit_euler", 2), ("tsit5", 3), ("dopri5", 4),
                   ("rkn5", 5)]}
    for path in (fmu_path, fmu3_path):
        description = read_model_description(str(path))
        variables = {v.name: v for v in description.modelVariables}
        for name, variable in ENUMERATIONS.items():
            declared = variables[name].declaredType
            assert variables[name].type == "Enumeration" and declared.name == variable.enumeration
            assert [(item.name, int(item.value)) for item in declared.items] == expected[declared.name]
            assert int(variables[name].start) == 0


def test_fmi3_moves_an_enumeration_as_int64_and_refuses_int32(fmu_path, fmu3_path, lattice):
    result = simulate_fmu(str(fmu3_path), stop_time=1.0, output_interval=0.01,
                          start_values={"material": list(PUBLISHED_BEST), "diagonal_rule": 1},
                          output=["peak_backplate_force"])
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
