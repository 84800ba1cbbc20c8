"""A design as an .ssp: libcosim co-simulates it to fmpy's peak, FMPy reads it, a foreign parameter is refused."""

from __future__ import annotations

import zipfile

import pytest
from fmpy.ssp.ssd import read_ssd, read_ssv

from fmu_src.published import STUDY_BEST_ORDER as PUBLISHED_BEST
from orchestrator.ssp import SSV_NAME, read_design_parameters, write_best_design_ssp

HORIZON = 1.0  # the peak and the last contact come before 1 s (README, horizon study)
DESIGN = {"material": list(PUBLISHED_BEST), "F_total": 1100.0, "c_wall": 12.0}  # order + non-default parameters


@pytest.fixture(scope="module")
def design_ssp(fmu_path, tmp_path_factory):
    return write_best_design_ssp(
        fmu_path, DESIGN, tmp_path_factory.mktemp("ssp") / "best_design.ssp", stop_time=HORIZON
    )


def test_libcosim_runs_the_ssp_to_fmpys_peak(design_ssp, lattice):
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver

    log_output_level(CosimLogLevel.WARNING)
    execution = CosimExecution.from_ssp_file(str(design_ssp))  # the step comes from the .ssd
    observer = CosimObserver.create_last_value()
    execution.add_observer(observer)
    index = execution.slave_index_from_instance_name("lattice")
    vr = {v.name.decode(): v.reference for v in execution.slave_variables(index)}
    execution.simulate_until(target_time=int(HORIZON * 1e9))
    peak = observer.last_real_values(index, [vr["peak_backplate_force"]])[0]
    expected = lattice.simulate(PUBLISHED_BEST, horizon=HORIZON, parameters={"F_total": 1100.0, "c_wall": 12.0})
    default = lattice.simulate(PUBLISHED_BEST, horizon=HORIZON)
    assert peak == pytest.approx(expected["peak_backplate_force"], rel=1e-9)
    assert abs(peak - default["peak_backplate_force"]) > 1.0  # the parameter set was applied, not ignored


def test_fmpy_reads_the_system_and_the_parameter_set(design_ssp):
    system = read_ssd(str(design_ssp)).system  # validated against the SSP schema
    (component,) = system.elements
    assert component.name == "lattice" and component.source.endswith(".fmu")
    (binding,) = component.parameterBindings
    values = {p.name: p.value for p in read_ssv(str(design_ssp), resource=SSV_NAME).parameters}
    assert values == {p.name: p.value for p in binding.parameterValues[0].parameters}
    assert [int(values[f"material[{j}]"]) for j in range(1, 12)] == list(PUBLISHED_BEST)
    assert float(values["F_total"]) == 1100.0
    assert read_design_parameters(design_ssp)["material[3]"] == PUBLISHED_BEST[2]


def test_a_parameter_set_naming_a_variable_the_fmu_lacks_is_refused(design_ssp, tmp_path, fmu_path):
    tampered = tmp_path / "tampered.ssp"
    with zipfile.ZipFile(design_ssp) as source, zipfile.ZipFile(tampered, "w") as target:
        for item in source.infolist():
            data = source.read(item)
            if item.filename == SSV_NAME:
                data = data.replace(b"material[11]", b"material[12]")
            target.writestr(item, data)
    with pytest.raises(ValueError, match=r"'material\[12\]' is not a parameter of MassSpringLattice"):
        read_design_parameters(tampered)
    with pytest.raises(ValueError, match="'stiffness' is not a parameter"):
        write_best_design_ssp(fmu_path, {"stiffness": 1.0}, tmp_path / "x.ssp", stop_time=1.0)
    with pytest.raises(ValueError, match=r"allowed values are \['mean', 'receiver'\]"):
        write_best_design_ssp(fmu_path, {"diagonal_rule": "average"}, tmp_path / "x.ssp", stop_time=1.0)
