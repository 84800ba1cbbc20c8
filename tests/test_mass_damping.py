"""Each material's mass and non-linear dampers (docs/model.md section 12) in the lattice FMU and its core.

mass[m] and damping_exponent[m] beside k[m] ... (FMI 2: indexed scalars; FMI 3: arrays of M, set at run time
through fmpy), Co-Simulation and Model Exchange, the lattice and a plate: the energy balance closes with unequal
masses and n != 1, the mirrored half still carries the whole lattice, a run below peak_force_limit is the run
without it, the damper pushes as section 12 writes it, and a material table carries the two columns (checked in
one line). The defaults' published figures are tests/test_recorded_outputs.py's.
"""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu

from builder import build
from fmu_src.core import Core, params_from_scene
from fmu_src.materials import (
    FIELDS,
    Material,
    MaterialTable,
    MaterialTableError,
    load_materials,
    study_materials,
    write_materials_csv,
)
from fmu_src.variables import make_interface
from orchestrator.simulation import COUNTER_OUTPUTS, SimulationError
from reference import Scene as ReferenceScene
from scenes import Scene

MASSES = (0.5, 2.0, 1.0, 3.0)
EXPONENTS = (1.5, 1.0, 1.5, 2.0)  # a linear column among non-linear ones
# the study's first four materials, each with a mass and a damping exponent of its own
TABLE = MaterialTable(
    tuple(
        dataclasses.replace(material, mass=mass, damping_exponent=exponent)
        for material, mass, exponent in zip(study_materials(4).materials, MASSES, EXPONENTS)
    )
)
ORDER = (2, 4, 1, 3)
ROWS, COLS = 5, 4
PLATE_ROWS, PLATE_COLS, PLATE_DEPTH = 3, 3, 3
PLATE_TABLE = MaterialTable(TABLE.materials[:3])
PLATE_ORDER = (3, 1, 2)
HORIZON = 1.0  # through the load, the contact with the plate and the rebound
# the balance closes to the solver's accuracy: rtol 1e-8 keeps these small lattices' error well below 1e-6 of W_ext
# (the default 5e-8 is chosen for the armour scene, which the test below runs at it)
ACCURATE = {"rtol": 1e-8}
BALANCE = (
    "energy_balance_error",
    "external_work",
    "dissipated_energy",
    "kinetic_energy",
    "stack_mass",
    "peak_backplate_force",
)


def order_start(order) -> dict:
    return {f"material[{j}]": m for j, m in enumerate(order, start=1)}


def stack_mass(table: MaterialTable, order, masses_per_column: int) -> float:
    return masses_per_column * sum(table.materials[m - 1].mass for m in order)


@pytest.fixture(scope="module")
def lattice_fmu(tmp_path_factory):
    return build.build_fmu(
        rows=ROWS, cols=COLS, materials=TABLE, werror=True, output=tmp_path_factory.mktemp("unequal") / "Unequal.fmu"
    )


@pytest.fixture(scope="module")
def lattice_fmu3(tmp_path_factory):
    return build.build_fmu(
        rows=ROWS,
        cols=COLS,
        materials=TABLE,
        werror=True,
        fmi_version=3,
        output=tmp_path_factory.mktemp("unequal3") / "Unequal-fmi3.fmu",
    )


@pytest.fixture(scope="module")
def plate_fmu(tmp_path_factory):
    return build.build_fmu(
        rows=PLATE_ROWS,
        cols=PLATE_COLS,
        depth=PLATE_DEPTH,
        materials=PLATE_TABLE,
        werror=True,
        output=tmp_path_factory.mktemp("unequal_plate") / "UnequalPlate.fmu",
    )


@pytest.fixture()
def unequal(lattice_fmu):
    from orchestrator.simulation import LatticeFMU

    with LatticeFMU(lattice_fmu) as fmu:
        yield fmu


@pytest.fixture(scope="module")
def core(core_library):
    return Core(core_library)


# ---------------------------------------------------------------- the variables


def test_fmi2_declares_each_materials_mass_and_exponent_and_no_scalar_mass(lattice_fmu):
    variables = {v.name: v for v in read_model_description(str(lattice_fmu)).modelVariables}
    assert [float(variables[f"mass[{m}]"].start) for m in range(1, 5)] == list(MASSES)
    assert [float(variables[f"damping_exponent[{m}]"].start) for m in range(1, 5)] == list(EXPONENTS)
    assert "mass" not in variables and "mass[5]" not in variables
    assert variables["mass[1]"].unit == "kg" and variables["mass[1]"].causality == "parameter"
    assert variables["stack_mass"].causality == "output" and variables["stack_mass"].unit == "kg"


def test_fmi3_declares_them_as_it_declares_k(lattice_fmu3):
    """FMI 3 declares each column of the material table as one Float64 array of M (builder/fmi3_description.py),
    so mass and damping_exponent sit beside k there, with the table's values as their start."""
    variables = {v.name: v for v in read_model_description(str(lattice_fmu3)).modelVariables}
    for name, values in (("mass", MASSES), ("damping_exponent", EXPONENTS)):
        assert [float(text) for text in variables[name].start.split()] == list(values), name
        assert variables[name].type == variables["k"].type == "Float64"
        assert variables[name].shape == variables["k"].shape == (len(TABLE),), name
    assert "mass[1]" not in variables and variables["stack_mass"].causality == "output"


def test_a_scalar_mass_of_an_older_scene_is_every_materials_mass():
    """Scenes gave one mass for every node before each material had its own: it still reads, as the table's
    mass column; a table with masses of its own as well is refused in one line rather than one winning."""
    values = Scene(name="older", parameters={"mass": 2.5}).parameter_values()
    assert values["mass"] == (2.5,) * 11
    exposed = {v.name: v for v in Scene(name="older", parameters={"mass": 2.5}).interface().exposed}
    assert exposed["mass"].element_starts() == [2.5] * 11  # the FMU's mass[1..11] start with it
    with pytest.raises(ValueError) as refusal:
        make_interface(ROWS, COLS, {"mass": 2.0}, materials=TABLE)
    assert "mass" in str(refusal.value) and "\n" not in str(refusal.value)
    with pytest.raises(ValueError, match=r"parameter mass = 0 is not allowed"):
        make_interface(ROWS, COLS, {"mass": 0})


# ---------------------------------------------------------------- the energy balance, co-simulation and exchange


def test_co_simulation_closes_the_energy_balance_with_unequal_masses_and_n_1_5(unequal):
    result = unequal.simulate(ORDER, horizon=HORIZON, parameters=ACCURATE, outputs=BALANCE)
    assert result["external_work"] > 1.0
    assert abs(result["energy_balance_error"]) <= 1e-6 * result["external_work"]
    assert result["stack_mass"] == pytest.approx(stack_mass(TABLE, ORDER, ROWS), rel=1e-15)
    # the dampers and the masses are in the physics: linear dampers and 1 kg masses give another run
    linear = unequal.simulate(
        ORDER,
        horizon=HORIZON,
        outputs=BALANCE,
        parameters={**ACCURATE, **{f"damping_exponent[{m}]": 1.0 for m in range(1, 5)}},
    )
    light = unequal.simulate(
        ORDER, horizon=HORIZON, outputs=BALANCE, parameters={**ACCURATE, **{f"mass[{m}]": 1.0 for m in range(1, 5)}}
    )
    # (a load along x moves a column's rows nearly alike: its own dampers take a small part of the dissipation)
    assert abs(linear["dissipated_energy"] / result["dissipated_energy"] - 1.0) > 1e-4
    assert abs(light["peak_backplate_force"] / result["peak_backplate_force"] - 1.0) > 1e-2
    assert light["stack_mass"] == pytest.approx(ROWS * COLS, rel=1e-15)
    for run in (linear, light):
        assert abs(run["energy_balance_error"]) <= 1e-6 * run["external_work"]


@pytest.mark.parametrize("exponent", [0.5, 1.5, 2.0])
def test_the_armour_scene_at_its_default_settings_closes_the_balance_with_unequal_masses(lattice, exponent):
    """The study's 11 x 11 lattice over its 8 s, each material's mass drawn in [0.5, 2] kg, every damper inside a
    column non-linear: the balance closes to 1e-6 of the work put in at the FMU's default tolerance, over the
    half lattice and the whole one."""
    rng = np.random.default_rng(12)
    masses = rng.uniform(0.5, 2.0, 11)
    parameters = {
        **{f"mass[{m}]": float(mass) for m, mass in enumerate(masses, start=1)},
        **{f"damping_exponent[{m}]": exponent for m in range(1, 12)},
    }
    order = (1, 7, 5, 9, 3, 6, 11, 8, 2, 4, 10)
    for symmetry in (1, 0):
        result = lattice.simulate(
            order, horizon=8.0, parameters={**parameters, "use_symmetry": symmetry}, outputs=BALANCE
        )
        assert abs(result["energy_balance_error"]) <= 1e-6 * result["external_work"], symmetry
        assert result["stack_mass"] == pytest.approx(11 * sum(masses), rel=1e-14)


def test_under_a_projectile_the_balance_closes_with_unequal_masses_and_n_1_5(lattice):
    """docs/model.md section 11's projectile mode: the body's kinetic energy is what is put in."""
    rng = np.random.default_rng(11)
    parameters = {
        **{f"mass[{m}]": float(mass) for m, mass in enumerate(rng.uniform(0.5, 2.0, 11), start=1)},
        **{f"damping_exponent[{m}]": 1.5 for m in range(1, 12)},
        "load_mode": "projectile",
        "projectile_mass": 50.0,
        "projectile_speed": 3.6,
    }
    put_in = 0.5 * 50.0 * 3.6**2
    for symmetry in (1, 0):
        result = lattice.simulate(
            (1, 7, 5, 9, 3, 6, 11, 8, 2, 4, 10),
            horizon=2.0,
            parameters={**parameters, "use_symmetry": symmetry},
            outputs=BALANCE,
        )
        assert result["peak_backplate_force"] > 0.0
        assert abs(result["energy_balance_error"]) <= 1e-6 * put_in, symmetry


@pytest.fixture(scope="module")
def equal_fmu3(tmp_path_factory):
    """The lattice of the study's first four materials as they are (1 kg, n = 1), FMI 3."""
    return build.build_fmu(
        rows=ROWS,
        cols=COLS,
        materials=study_materials(COLS),
        werror=True,
        fmi_version=3,
        output=tmp_path_factory.mktemp("equal3") / "Equal-fmi3.fmu",
    )


@pytest.mark.parametrize("interface", ["CoSimulation", "ModelExchange"])
def test_fmi3_arrays_set_through_fmpy_give_the_built_tables_run(equal_fmu3, lattice_fmu3, interface):
    """A table of the same length is a parameter set, not a rebuild: the FMU built with 1 kg and n = 1 and given
    the unequal masses and exponents as FMI 3 arrays in fmpy's start values runs what the FMU built with them
    runs (bit for bit: the same model code and numbers), and closes the energy balance to 1e-6 of the work."""
    options = {"solver": "CVode", "relative_tolerance": 1e-9} if interface == "ModelExchange" else {}
    common = dict(fmi_type=interface, stop_time=HORIZON, output_interval=0.01, output=list(BALANCE), **options)
    order = {"material": list(ORDER)}
    arrays = {"mass": list(MASSES), "damping_exponent": list(EXPONENTS)}
    given = simulate_fmu(str(equal_fmu3), start_values={**ACCURATE, **order, **arrays}, **common)
    built = simulate_fmu(str(lattice_fmu3), start_values={**ACCURATE, **order}, **common)
    unset = simulate_fmu(str(equal_fmu3), start_values={**ACCURATE, **order}, **common)
    final = {name: float(given[name][-1]) for name in BALANCE}
    assert abs(final["energy_balance_error"]) <= 1e-6 * final["external_work"]
    assert final["stack_mass"] == pytest.approx(stack_mass(TABLE, ORDER, ROWS), rel=1e-15)
    for name in BALANCE:
        assert np.array_equal(given[name], built[name]), name
    assert abs(float(unset["peak_backplate_force"][-1]) / final["peak_backplate_force"] - 1.0) > 1e-2


@pytest.mark.parametrize("interface", ["CoSimulation", "ModelExchange"])
def test_fmi3_closes_the_balance_too(lattice_fmu3, interface):
    options = {"solver": "CVode", "relative_tolerance": 1e-9} if interface == "ModelExchange" else {}
    result = simulate_fmu(
        str(lattice_fmu3),
        fmi_type=interface,
        stop_time=HORIZON,
        output_interval=0.01,
        output=list(BALANCE),
        start_values=ACCURATE,
        **options,
    )
    final = {name: float(result[name][-1]) for name in BALANCE}
    assert abs(final["energy_balance_error"]) <= 1e-6 * final["external_work"]
    assert final["stack_mass"] == pytest.approx(stack_mass(TABLE, (1, 2, 3, 4), ROWS), rel=1e-15)


@pytest.mark.parametrize("interface", ["CoSimulation", "ModelExchange"])
def test_a_plate_closes_the_balance_with_unequal_masses_and_n_1_5(plate_fmu, interface):
    options = {"solver": "CVode", "relative_tolerance": 1e-9} if interface == "ModelExchange" else {}
    result = simulate_fmu(
        str(plate_fmu),
        fmi_type=interface,
        stop_time=HORIZON,
        output_interval=0.01,
        start_values={**order_start(PLATE_ORDER), **ACCURATE},
        output=list(BALANCE),
        **options,
    )
    final = {name: float(result[name][-1]) for name in BALANCE}
    assert final["external_work"] > 1.0 and final["peak_backplate_force"] > 0.0
    assert abs(final["energy_balance_error"]) <= 1e-6 * final["external_work"]
    assert final["stack_mass"] == pytest.approx(
        stack_mass(PLATE_TABLE, PLATE_ORDER, PLATE_ROWS * PLATE_DEPTH), rel=1e-15
    )


@pytest.fixture(scope="module")
def equal_plate_fmu3(tmp_path_factory):
    """The plate of the study's first three materials as they are (1 kg, n = 1), FMI 3."""
    return build.build_fmu(
        rows=PLATE_ROWS,
        cols=PLATE_COLS,
        depth=PLATE_DEPTH,
        materials=study_materials(PLATE_COLS),
        werror=True,
        fmi_version=3,
        output=tmp_path_factory.mktemp("equal_plate3") / "EqualPlate-fmi3.fmu",
    )


@pytest.mark.parametrize("interface", ["CoSimulation", "ModelExchange"])
def test_a_plate_of_fmi3_given_the_masses_and_exponents_as_arrays_closes_the_balance(equal_plate_fmu3, interface):
    """The plate built with the study's materials as they are and given the unequal masses and exponents as FMI 3
    arrays at run time: the balance closes, and the stack weighs what the arrays say."""
    options = {"solver": "CVode", "relative_tolerance": 1e-9} if interface == "ModelExchange" else {}
    arrays = {"mass": list(MASSES[:PLATE_COLS]), "damping_exponent": list(EXPONENTS[:PLATE_COLS])}
    result = simulate_fmu(
        str(equal_plate_fmu3),
        fmi_type=interface,
        stop_time=HORIZON,
        output_interval=0.01,
        start_values={"material": list(PLATE_ORDER), **arrays, **ACCURATE},
        output=list(BALANCE),
        **options,
    )
    final = {name: float(result[name][-1]) for name in BALANCE}
    assert final["external_work"] > 1.0 and final["peak_backplate_force"] > 0.0
    assert abs(final["energy_balance_error"]) <= 1e-6 * final["external_work"]
    assert final["stack_mass"] == pytest.approx(
        stack_mass(PLATE_TABLE, PLATE_ORDER, PLATE_ROWS * PLATE_DEPTH), rel=1e-15
    )


def test_model_exchange_closes_the_balance_and_agrees_with_co_simulation(lattice_fmu, unequal):
    result = simulate_fmu(
        str(lattice_fmu),
        fmi_type="ModelExchange",
        solver="CVode",
        relative_tolerance=1e-9,
        stop_time=HORIZON,
        output_interval=0.01,
        start_values=order_start(ORDER),
        output=list(BALANCE),
    )
    final = {name: float(result[name][-1]) for name in BALANCE}
    assert abs(final["energy_balance_error"]) <= 1e-6 * final["external_work"]
    co_simulation = unequal.simulate(ORDER, horizon=HORIZON, parameters=ACCURATE, outputs=BALANCE)
    for name in ("external_work", "dissipated_energy"):
        assert final[name] == pytest.approx(co_simulation[name], rel=1e-6), name


# ---------------------------------------------------------------- symmetry and the force limit

SEARCH_SETTINGS = {"solver": "tsit5", "rtol": 1e-5, "atol": 1e-7}
TIGHT = {"rtol": 1e-10, "atol": 1e-12}


def test_the_upper_half_gives_the_whole_lattice_with_non_linear_dampers(unequal):
    """The half's right-hand side is the whole's to rounding (the core tests below); over a run the two take
    their own adaptive steps (rounding decides a rejection here and there), so they agree to the solver's
    accuracy."""
    names = (
        "peak_backplate_force",
        "peak_backplate_force_continuous",
        "external_work",
        "dissipated_energy",
        "max_compression",
    )
    whole = unequal.simulate(ORDER, horizon=HORIZON, parameters={**TIGHT, "use_symmetry": 0}, outputs=names)
    half = unequal.simulate(ORDER, horizon=HORIZON, parameters={**TIGHT, "use_symmetry": 1}, outputs=names)
    for name in names:
        assert half[name] == pytest.approx(whole[name], rel=1e-7), name


def test_the_quarter_plate_gives_the_whole_plate_with_non_linear_dampers(plate_fmu):
    def run(symmetry):
        result = simulate_fmu(
            str(plate_fmu),
            stop_time=HORIZON,
            output_interval=HORIZON,
            output=list(BALANCE),
            start_values={**order_start(PLATE_ORDER), **TIGHT, "use_symmetry": symmetry},
        )
        return {name: float(result[name][-1]) for name in BALANCE}

    quarter, whole = run(1), run(0)
    for name in ("peak_backplate_force", "external_work", "dissipated_energy"):
        assert quarter[name] == pytest.approx(whole[name], rel=1e-7), name


def test_a_run_below_the_force_limit_is_the_run_without_it(unequal):
    free = unequal.simulate(ORDER, horizon=HORIZON, parameters=SEARCH_SETTINGS, outputs=BALANCE + COUNTER_OUTPUTS)
    limited = unequal.simulate(
        ORDER,
        horizon=HORIZON,
        parameters=SEARCH_SETTINGS,
        outputs=BALANCE + COUNTER_OUTPUTS,
        peak_force_limit=free["peak_backplate_force"],
    )
    assert limited.stopped_early is False and limited == free
    stopped = unequal.simulate(
        ORDER,
        horizon=HORIZON,
        parameters=SEARCH_SETTINGS,
        outputs=BALANCE,
        peak_force_limit=0.5 * free["peak_backplate_force"],
    )
    assert stopped.stopped_early is True and stopped.stop_time < HORIZON


def test_a_mass_or_exponent_out_of_range_is_refused_naming_it(unequal):
    for name in ("mass[2]", "damping_exponent[3]"):
        for value in (0.0, -1.0):
            with pytest.raises((SimulationError, ValueError)) as refusal:
                unequal.simulate(ORDER, horizon=0.1, parameters={name: value})
            assert name in str(refusal.value) and "\n" not in str(refusal.value)


# ---------------------------------------------------------------- the core: the damper law, the mirrored part


def core_params(rows, cols, order, masses, exponents, depth=1, **settings):
    scene = ReferenceScene(rows=rows, cols=cols, order=tuple(order), **settings)
    params = params_from_scene(scene, depth=depth)
    for j, material in enumerate(order):
        params.column[j].mass = masses[material - 1]
        params.column[j].damping_exponent = exponents[material - 1]
    return params


@pytest.mark.parametrize("exponent", [0.5, 1.5, 2.0])
def test_a_damper_inside_a_column_pushes_with_c_dv_to_the_n(core, exponent):
    """Two masses of one column, at rest in place, moving apart: F_a = -c |dv|^(n-1) (v_a - v_b) with |dv| the
    relative velocity's length, each mass accelerated by F / its mass, dissipating c |dv|^(n+1)."""
    params = core_params(2, 1, (1,), (2.5,), (exponent,), wall=False, F_total=0.0)
    c = params.column[0].c
    v_a, v_b = np.array([0.3, -0.7]), np.array([-0.2, 0.5])  # masses 0 (row 1) and 1 (row 2)
    y = np.concatenate([np.zeros(4), [v_a[0], v_b[0], v_a[1], v_b[1]]])
    dydt, powers = core.rhs(params, y, load_on=False)
    dv = v_a - v_b
    speed = float(np.hypot(*dv))
    force_a = -c * speed ** (exponent - 1.0) * dv
    np.testing.assert_allclose(dydt[4:], np.array([force_a[0], -force_a[0], force_a[1], -force_a[1]]) / 2.5, rtol=1e-13)
    assert powers[1] == pytest.approx(c * speed ** (exponent + 1.0), rel=1e-13)


def test_at_zero_relative_velocity_the_damper_is_still_with_n_below_1(core):
    params = core_params(3, 2, (1, 2), (1.0, 1.0), (0.5, 0.5), wall=False, F_total=0.0)
    dydt, powers = core.rhs(params, np.zeros(4 * 6), load_on=False)
    assert np.all(dydt == 0.0) and np.all(powers == 0.0)


@pytest.mark.parametrize("depth", [1, 2])
def test_a_column_of_n_1_and_1_kg_computes_what_the_linear_1_kg_lattice_does(core, depth):
    """Only the last column's material differs (n = 1.5, 2 kg): every other column's accelerations are the
    all-linear, all-1-kg lattice's bit for bit (the last column's own dampers and mass act on it alone)."""
    rng = np.random.default_rng(7 + depth)
    rows, cols = 4, 4
    order = (1, 2, 3, 4)
    plain = core_params(rows, cols, order, (1.0,) * 4, (1.0,) * 4, depth=depth)
    changed = core_params(rows, cols, order, (1.0, 1.0, 1.0, 2.0), (1.0, 1.0, 1.0, 1.5), depth=depth)
    components = 3 if depth > 1 else 2
    n = rows * cols * depth
    y = np.concatenate([rng.normal(0.0, 0.03, components * n), rng.normal(0.0, 1.0, components * n)])
    y[np.arange(cols - 1, n, cols)] = rng.uniform(-0.01, 0.02, n // cols)
    for load_on in (True, False):
        expected, expected_powers = core.rhs(plain, y, load_on)
        got, got_powers = core.rhs(changed, y, load_on)
        others = np.arange(len(got)) % cols != cols - 1  # every component of the masses of columns 1 .. C-1
        assert np.array_equal(got[others], expected[others])
        assert not np.array_equal(got[~others][components * n // cols :], expected[~others][components * n // cols :])
        assert got_powers[1] != expected_powers[1] and got_powers[0] == expected_powers[0]


@pytest.mark.parametrize("depth", [1, 3])
def test_the_mirrored_part_carries_the_whole_with_unequal_masses_and_n_1_5(core, depth):
    rng = np.random.default_rng(1205 + depth)
    rows, cols = 5, 4
    params = core_params(rows, cols, ORDER, MASSES, EXPONENTS, depth=depth)
    part_rows, slices = core.mirrored_extent(params)
    assert part_rows == 3 and slices == (2 if depth == 3 else 1)
    blocks = []
    for scale in (0.05, 1.0):
        block = rng.normal(0.0, scale, (depth, rows, cols))
        block = 0.5 * (block + block[:, ::-1, :])
        blocks.append(0.5 * (block + block[::-1, :, :]))
    ux, vx = blocks
    whole_x = np.concatenate([ux.reshape(-1), vx.reshape(-1), np.zeros(3)])
    part = np.concatenate([ux[:slices, :part_rows].reshape(-1), vx[:slices, :part_rows].reshape(-1), np.zeros(3)])
    for load_on in (True, False):
        whole, whole_powers = core.rhs_along_x(params, whole_x, load_on)
        got, got_powers = core.rhs_along_x(params, part, load_on, mirrored=True)
        expected = np.concatenate(
            [block.reshape(depth, rows, cols)[:slices, :part_rows].reshape(-1) for block in np.split(whole, 2)]
        )
        scale = np.max(np.abs(whole))
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12 * scale)
        np.testing.assert_allclose(got_powers, whole_powers, rtol=1e-11, atol=1e-11 * scale)
        # and the along-x layout is the x part of the whole lattice's right-hand side
        n = rows * cols * depth
        components = 3 if depth > 1 else 2
        full_state = np.zeros(2 * components * n)
        full_state[:n], full_state[components * n : components * n + n] = ux.reshape(-1), vx.reshape(-1)
        full, full_powers = core.rhs(params, full_state, load_on)
        np.testing.assert_allclose(
            whole, np.concatenate([full[:n], full[components * n : components * n + n]]), rtol=0, atol=1e-12 * scale
        )
        np.testing.assert_allclose(whole_powers, full_powers, rtol=1e-11, atol=1e-11 * scale)


@pytest.mark.parametrize("depth", [1, 2])
def test_the_power_balance_holds_at_any_state(core, depth):
    """d(kinetic + potential)/dt + dissipated power = external + non-reciprocal power, at a random state of a
    lattice (and a plate) with unequal masses and n = 1.5: what makes the integrated balance close."""
    rng = np.random.default_rng(36 + depth)
    params = core_params(4, 4, ORDER, MASSES, EXPONENTS, depth=depth)
    n = 4 * 4 * depth
    components = 3 if depth > 1 else 2
    y = np.concatenate([rng.normal(0.0, 0.03, components * n), rng.normal(0.0, 1.0, components * n)])
    y[np.arange(3, n, 4)] = rng.uniform(-0.01, 0.02, n // 4)  # column C straddling the plate's gap
    dydt, powers = core.rhs(params, y, load_on=True)

    def energy(state):
        kinetic, potential = core.energies(params, state)
        return kinetic + potential

    step = 1e-6
    rate = (energy(y + step * dydt) - energy(y - step * dydt)) / (2 * step)
    external, dissipated, nonreciprocal = powers
    assert dissipated > 0.0
    assert rate + dissipated == pytest.approx(external + nonreciprocal, rel=1e-6, abs=1e-6 * dissipated)


def test_the_core_refuses_a_mass_or_exponent_that_is_not_positive_in_one_line(core):
    for masses, exponents in (((1.0, 0.0, 1.0, 1.0), EXPONENTS), (MASSES, (1.0, 1.0, -2.0, 1.0))):
        params = core_params(ROWS, COLS, (1, 2, 3, 4), masses, exponents)
        error = core.params_error(params)
        assert error is not None and "\n" not in error
        assert error.startswith(f"column {2 if masses[1] == 0 else 3}: mass = ")


# ---------------------------------------------------------------- the material table's new columns


def test_a_table_with_mass_and_damping_exponent_columns_round_trips(tmp_path):
    path = write_materials_csv(TABLE, tmp_path / "table.csv")
    assert path.read_text().splitlines()[0].endswith(",mass,damping_exponent")
    assert load_materials(path) == TABLE
    rows = [{field.name: getattr(m, field.name) for field in FIELDS} | {"name": m.name} for m in TABLE.materials]
    (tmp_path / "t.json").write_text(json.dumps({"materials": rows}))
    toml = "".join("[[material]]\n" + "".join(f"{k} = {json.dumps(v)}\n" for k, v in row.items()) for row in rows)
    (tmp_path / "t.toml").write_text(toml)
    assert load_materials(tmp_path / "t.json") == load_materials(tmp_path / "t.toml") == TABLE
    assert TABLE.stack_mass(ORDER, ROWS) == pytest.approx(ROWS * sum(MASSES), rel=1e-15)


def test_a_table_without_the_columns_is_the_studys_masses_and_dampers_with_its_fingerprint(tmp_path):
    study = study_materials(3)
    assert all(m.mass == 1.0 and m.damping_exponent == 1.0 for m in study.materials)
    path = tmp_path / "old.csv"
    path.write_text(
        "name,k,k_diag,c,alpha,alpha_diag\n"
        + "".join(f"{m.name},{m.k!r},{m.k_diag!r},{m.c!r},{m.alpha!r},{m.alpha_diag!r}\n" for m in study.materials)
    )
    assert load_materials(path) == study
    spelled = load_materials(write_materials_csv(study, tmp_path / "spelled.csv"))
    assert spelled.sha256() == study.sha256()  # a file spelling out the defaults names the same table
    heavier = MaterialTable((dataclasses.replace(study.materials[0], mass=2.0),) + study.materials[1:])
    assert heavier.sha256() != study.sha256()
    assert make_interface(11, 3, materials=study).exposed == make_interface(11, 3).exposed


HEADER = "name,k,k_diag,c,alpha,alpha_diag,mass,damping_exponent\n"


@pytest.mark.parametrize(
    "row, expected",
    [
        ("foam,1,1,1,1,1,0,1", "row 2 (foam), field mass: '0' is not allowed; allowed: a finite number > 0 (kg)"),
        ("foam,1,1,1,1,1,-2,1", "row 2 (foam), field mass: '-2' is not allowed"),
        ("foam,1,1,1,1,1,heavy,1", "row 2 (foam), field mass: 'heavy' is not a number"),
        (
            "foam,1,1,1,1,1,1,0",
            "row 2 (foam), field damping_exponent: '0' is not allowed; allowed: a finite number > 0",
        ),
        ("foam,1,1,1,1,1,1,nan", "row 2 (foam), field damping_exponent: 'nan' is not allowed"),
        ("foam,1,1,1,1,1,1,inf", "row 2 (foam), field damping_exponent: 'inf' is not allowed"),
    ],
)
def test_a_bad_mass_or_exponent_is_refused_in_one_line_naming_row_and_field(tmp_path, row, expected):
    path = tmp_path / "bad.csv"
    path.write_text(HEADER + "steel,2,2,2,2,2,7.8,1\n" + row + "\n")  # the bad row is the second
    with pytest.raises(MaterialTableError) as caught:
        load_materials(path)
    message = str(caught.value)
    assert expected in message and "\n" not in message and str(path) in message
    with pytest.raises(MaterialTableError, match=r"row 1 \(a\), field mass: -1.0 is not allowed"):
        MaterialTable((Material("a", 1.0, 1.0, 1.0, 1.0, 1.0, mass=-1.0),))


def test_an_empty_cell_of_an_optional_column_is_its_default(tmp_path):
    path = tmp_path / "partial.csv"
    path.write_text(HEADER + "foam,1,1,1,1,1,,1.5\nsteel,2,2,2,2,2,7.8,\n")
    table = load_materials(path)
    assert table.column("mass") == (1.0, 7.8) and table.column("damping_exponent") == (1.5, 1.0)
