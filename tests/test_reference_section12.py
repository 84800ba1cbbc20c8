"""The FMU's section 12 (each material's mass, non-linear dampers) against the independent reference
(reference/system.py): unequal masses and n = 1.5 agree to 1e-7 on the peaks and the energy terms, on a small
lattice and a small plate, and both close their energy balances to 1e-6.

    python -m pytest tests/test_reference_section12.py
"""

from __future__ import annotations

import dataclasses

import pytest
from fmpy import simulate_fmu

from builder import build
from fmu_src.materials import MaterialTable, study_materials
from reference.lattice3d import MATERIAL_FIELDS, PlateScene
from reference.system import SystemScene, simulate_system

MASSES = (0.5, 2.0, 1.0, 3.0)
EXPONENTS = (1.5, 1.0, 1.5, 2.0)  # a linear column among non-linear ones
TABLE = MaterialTable(
    tuple(
        dataclasses.replace(material, mass=mass, damping_exponent=exponent)
        for material, mass, exponent in zip(study_materials(4).materials, MASSES, EXPONENTS)
    )
)
ROWS, COLS, ORDER = 5, 4, (2, 4, 1, 3)
PLATE_TABLE = MaterialTable(TABLE.materials[:3])
PLATE_SIZE, PLATE_ORDER = 3, (3, 1, 2)
HORIZON = 1.0  # through the load, the contact with the plate and the rebound
# the reference integrates at rtol 1e-12; the FMU's DOP853 at the same tolerance agrees far better than 1e-7
TIGHT = {"rtol": 1e-12, "atol": 1e-12}
PEAKS = ("peak_backplate_force", "peak_backplate_force_continuous")
ENERGIES = ("external_work", "dissipated_energy", "kinetic_energy", "nonreciprocal_work")


def reference_run(table: MaterialTable, rows: int, cols: int, depth: int, order, rule: str):
    lattice = PlateScene(
        rows=rows,
        cols=cols,
        depth=depth,
        order=order,
        diagonal_rule=rule,
        **{name: tuple(table.column(name)) for name in MATERIAL_FIELDS},
    )
    scene = SystemScene(
        lattice, material_mass=tuple(table.column("mass")), damping_exponent=tuple(table.column("damping_exponent"))
    )
    return simulate_system(scene, horizon=HORIZON)


def fmu_run(fmu, order, rule: str) -> dict:
    start = {
        **{f"material[{j}]": m for j, m in enumerate(order, start=1)},
        **TIGHT,
        "diagonal_rule": {"receiver": 0, "mean": 1}[rule],
    }
    names = PEAKS + ENERGIES + ("energy_balance_error", "stack_mass")
    result = simulate_fmu(str(fmu), stop_time=HORIZON, output_interval=HORIZON, start_values=start, output=list(names))
    return {name: float(result[name][-1]) for name in names}


def compare(fmu_figures: dict, reference) -> None:
    energy = reference.energy
    figures = {
        "peak_backplate_force": reference.peak_backplate_force,
        "peak_backplate_force_continuous": reference.peak_backplate_force_continuous,
        "external_work": energy.front_work,
        "dissipated_energy": energy.lattice_dissipation,
        "kinetic_energy": energy.lattice_kinetic,
        "nonreciprocal_work": energy.nonreciprocal_work,
    }
    for name in PEAKS:
        assert fmu_figures[name] == pytest.approx(figures[name], rel=1e-7), name
    # energy terms relative to the work put in (a term near zero is meaningless relative to itself)
    for name in ENERGIES:
        assert abs(fmu_figures[name] - figures[name]) <= 1e-7 * energy.front_work, name
    assert abs(fmu_figures["energy_balance_error"]) <= 1e-6 * fmu_figures["external_work"]
    assert abs(energy.lattice_error) <= 1e-6 * energy.front_work
    assert fmu_figures["stack_mass"] == pytest.approx(reference.scene.total_mass, rel=1e-14)


@pytest.fixture(scope="module")
def lattice_fmu(tmp_path_factory):
    return build.build_fmu(
        rows=ROWS,
        cols=COLS,
        materials=TABLE,
        werror=True,
        output=tmp_path_factory.mktemp("section12") / "Section12.fmu",
    )


@pytest.fixture(scope="module")
def plate_fmu(tmp_path_factory):
    return build.build_fmu(
        rows=PLATE_SIZE,
        cols=PLATE_SIZE,
        depth=PLATE_SIZE,
        materials=PLATE_TABLE,
        werror=True,
        output=tmp_path_factory.mktemp("section12_plate") / "Section12Plate.fmu",
    )


@pytest.mark.parametrize("rule", ["receiver", "mean"])
def test_unequal_masses_and_non_linear_dampers_agree_with_the_reference(lattice_fmu, rule):
    compare(fmu_run(lattice_fmu, ORDER, rule), reference_run(TABLE, ROWS, COLS, 1, ORDER, rule))


def test_a_plate_with_unequal_masses_and_non_linear_dampers_agrees_with_the_reference(plate_fmu):
    compare(
        fmu_run(plate_fmu, PLATE_ORDER, "receiver"),
        reference_run(PLATE_TABLE, PLATE_SIZE, PLATE_SIZE, PLATE_SIZE, PLATE_ORDER, "receiver"),
    )


def test_the_masses_and_exponents_change_the_figures_compared():
    """The comparison above is not blind to section 12: the study's masses and linear dampers give another peak."""
    unequal = reference_run(TABLE, ROWS, COLS, 1, ORDER, "receiver")
    plain = MaterialTable(tuple(dataclasses.replace(m, mass=1.0, damping_exponent=1.0) for m in TABLE.materials))
    study = reference_run(plain, ROWS, COLS, 1, ORDER, "receiver")
    assert abs(unequal.peak_backplate_force / study.peak_backplate_force - 1) > 1e-3
