"""The FMU's section 11 (the ports) against the independent reference (reference/system.py).

The FMU in Co-Simulation holds F_front over each communication step and moves the backplate from x_back with
v_back over it; the reference is given exactly those inputs, piece by piece (each step's start a restart of its
solver), so the two integrate one problem and agree to their tolerances: 1e-7 on the peaks, the port's work and
x_front, v_front; both balances close to 1e-6.

    python -m pytest tests/test_reference_section11.py
"""

from __future__ import annotations

import math
import shutil

import numpy as np
import pytest
from fmpy import extract, read_model_description, simulate_fmu
from fmpy.fmi2 import FMU2Slave

from builder import build
from fmu_src.variables import enumeration_values
from reference.lattice3d import PlateScene
from reference.system import PiecewiseSignal, Projectile, SystemScene, simulate_system

STEP = 0.01
HORIZON = 1.0  # through the load, the contact with the plate and the rebound
TIGHT = {"rtol": 1e-12, "atol": 1e-12}
INPUT = enumeration_values("load_mode")["input"]
OUTPUTS = (
    "peak_backplate_force",
    "peak_backplate_force_continuous",
    "external_work",
    "energy_balance_error",
    "x_front",
    "v_front",
    "backplate_force",
)
STEPS = round(HORIZON / STEP)
STEP_STARTS = tuple(i * STEP for i in range(STEPS))


def front_force(t: float) -> float:
    """A half-sine push of 0.3 s peaking at 1500 N, as the importer samples it at a step's start."""
    return 1500.0 * math.sin(math.pi * t / 0.3) if t < 0.3 else 0.0


def backplate_path(t: float) -> float:
    """A backplate swaying by 2 mm at 1.5 Hz."""
    return 2e-3 * math.sin(2 * math.pi * 1.5 * t)


def backplate_inputs(i: int) -> tuple[float, float]:
    """The (x_back, v_back) an importer sets before step i: the path's point and the chord's slope to the next,
    so the FMU's backplate (x_back + v_back (t - t_i) over the step) is a continuous broken line."""
    t = STEP_STARTS[i]
    return backplate_path(t), (backplate_path(t + STEP) - backplate_path(t)) / STEP


def front_inputs(i: int, interpolated: bool) -> tuple[float, float]:
    """(F_front, its rate) an importer sets before step i: held, or first-order interpolated along the chord to
    the next step's value (a continuous broken line)."""
    t = STEP_STARTS[i]
    return front_force(t), (front_force(t + STEP) - front_force(t)) / STEP if interpolated else 0.0


def fmu_run(path, backplate_moves: bool, interpolated: bool = False, backplate=None) -> dict[str, float]:
    """A run over HORIZON in steps of STEP; ``backplate(i)``, if given, sets (x_back, v_back) before step i."""
    description = read_model_description(str(path))
    vr = {v.name: v.valueReference for v in description.modelVariables}
    unzipped = extract(str(path))
    slave = FMU2Slave(
        guid=description.guid,
        unzipDirectory=unzipped,
        modelIdentifier=description.coSimulation.modelIdentifier,
        instanceName="section11",
    )
    try:
        slave.instantiate()
        slave.setupExperiment(startTime=0.0, stopTime=HORIZON)
        slave.enterInitializationMode()
        slave.setInteger([vr["load_mode"]], [INPUT])
        slave.setReal([vr["rtol"], vr["atol"]], [TIGHT["rtol"], TIGHT["atol"]])
        slave.exitInitializationMode()
        for i, t in enumerate(STEP_STARTS):
            x_back, v_back = (backplate or backplate_inputs)(i) if backplate_moves or backplate else (0.0, 0.0)
            force, rate = front_inputs(i, interpolated)
            slave.setReal([vr["F_front"], vr["x_back"], vr["v_back"]], [force, x_back, v_back])
            if interpolated:
                slave.setRealInputDerivatives([vr["F_front"]], [1], [rate])
            slave.doStep(t, STEP)
        values = slave.getReal([vr[name] for name in OUTPUTS])
        slave.terminate()
        return dict(zip(OUTPUTS, values))
    finally:
        slave.freeInstance()
        shutil.rmtree(unzipped, ignore_errors=True)


def line(start: float, rate: float, t0: float):
    """The piece ``start + rate (t - t0)`` of a given input."""
    return lambda t: start + rate * (t - t0)


def reference_run(backplate_moves: bool, interpolated: bool = False):
    front = PiecewiseSignal(
        STEP_STARTS, tuple(line(*front_inputs(i, interpolated), STEP_STARTS[i]) for i in range(STEPS))
    )
    if not backplate_moves:
        scene = SystemScene(PlateScene(rows=11, cols=11, depth=1), load_mode="input", front_force=front)
        return simulate_system(scene, horizon=HORIZON, sample_interval=STEP)
    pieces = [backplate_inputs(i) for i in range(STEPS)]
    position = PiecewiseSignal(STEP_STARTS, tuple(line(x, v, t0) for (x, v), t0 in zip(pieces, STEP_STARTS)))
    velocity = PiecewiseSignal(STEP_STARTS, tuple(line(v, 0.0, t0) for (_, v), t0 in zip(pieces, STEP_STARTS)))
    scene = SystemScene(
        PlateScene(rows=11, cols=11, depth=1),
        load_mode="input",
        front_force=front,
        back_position=position,
        back_velocity=velocity,
    )
    return simulate_system(scene, horizon=HORIZON, sample_interval=STEP)


@pytest.fixture(scope="module", params=[False, True], ids=["front-port", "both-ports"])
def runs(request, fmu_path):
    """The study's 11 x 11 FMU and the reference driven through the front port (a held force on the face), with
    the fixed wall or a swaying backplate."""
    return request.param, fmu_run(fmu_path, request.param), reference_run(request.param)


def test_the_ports_agree_with_the_reference(runs):
    backplate_moves, fmu, reference = runs
    energy = reference.energy
    assert (abs(energy.back_work) > 1e-3 * energy.front_work) == backplate_moves
    assert fmu["peak_backplate_force"] == pytest.approx(reference.peak_backplate_force, rel=1e-7)
    assert fmu["external_work"] == pytest.approx(energy.front_work - energy.back_work, rel=1e-7)
    assert fmu["x_front"] == pytest.approx(reference.x_front[-1], rel=1e-7)
    assert fmu["v_front"] == pytest.approx(reference.v_front[-1], rel=1e-7, abs=1e-9)
    assert abs(fmu["energy_balance_error"]) <= 1e-6 * fmu["external_work"]
    assert abs(energy.lattice_error) <= 1e-6 * energy.front_work
    assert np.isclose(reference.times[-1], HORIZON)


def test_the_continuous_peak_agrees_with_the_reference(runs):
    """Also under a backplate whose speed changes from one communication step to the next: a sample or a peak
    found inside a step reads the back port where the backplate is at that time."""
    _, fmu, reference = runs
    assert fmu["peak_backplate_force_continuous"] == pytest.approx(reference.peak_backplate_force_continuous, rel=1e-7)


@pytest.mark.parametrize("offset, speed", [(-5e-4, 0.0), (0.0, -4e-3)], ids=["offset", "constant-speed"])
def test_a_backplate_at_an_offset_or_a_constant_speed_agrees_with_the_reference_continuous_peak_too(
    fmu_path, offset, speed
):
    """Where v_back keeps one value from step to step the FMU's continuous peak agrees as well."""
    fmu = fmu_run(fmu_path, backplate_moves=False, backplate=lambda i: (offset + speed * STEP_STARTS[i], speed))
    front = PiecewiseSignal(STEP_STARTS, tuple(line(*front_inputs(i, False), STEP_STARTS[i]) for i in range(STEPS)))
    scene = SystemScene(
        PlateScene(rows=11, cols=11, depth=1),
        load_mode="input",
        front_force=front,
        back_position=PiecewiseSignal((0.0,), (line(offset, speed, 0.0),)),
        back_velocity=PiecewiseSignal.constant(speed),
    )
    reference = simulate_system(scene, horizon=HORIZON, sample_interval=STEP)
    for name in ("peak_backplate_force", "peak_backplate_force_continuous"):
        assert fmu[name] == pytest.approx(getattr(reference, name), rel=1e-7), name
    assert fmu["external_work"] == pytest.approx(reference.energy.front_work - reference.energy.back_work, rel=1e-7)


def test_an_interpolated_front_force_agrees_with_the_reference(fmu_path):
    """FMI 2's first-order input interpolation (fmi2SetRealInputDerivatives): the FMU ramps F_front over each step
    as the reference's broken line does."""
    fmu = fmu_run(fmu_path, backplate_moves=False, interpolated=True)
    reference = reference_run(backplate_moves=False, interpolated=True)
    held = reference_run(backplate_moves=False)
    assert abs(reference.peak_backplate_force / held.peak_backplate_force - 1) > 1e-4  # the ramp is compared
    for name in ("peak_backplate_force", "peak_backplate_force_continuous"):
        assert fmu[name] == pytest.approx(getattr(reference, name), rel=1e-7), name
    assert fmu["external_work"] == pytest.approx(reference.energy.front_work, rel=1e-7)
    assert abs(fmu["energy_balance_error"]) <= 1e-6 * fmu["external_work"]


# ------------------------------------------------------------------------------------------- projectile mode
PROJECTILE_MODE = enumeration_values("load_mode")["projectile"]
PROJECTILE_PARAMETERS = (
    "projectile_mass",
    "projectile_speed",
    "contact_stiffness",
    "contact_exponent",
    "contact_damping",
)
PROJECTILE_OUTPUTS = (
    "peak_backplate_force",
    "peak_backplate_force_continuous",
    "kinetic_energy",
    "potential_energy",
    "dissipated_energy",
    "external_work",
    "nonreciprocal_work",
    "energy_balance_error",
    "projectile_velocity",
    "x_front",
)


def projectile_of(path, **changed) -> Projectile:
    """The FMU's own projectile (its parameters' start values), with some of them changed."""
    starts = {
        v.name: float(v.start)
        for v in read_model_description(str(path)).modelVariables
        if v.name in PROJECTILE_PARAMETERS
    }
    starts.update(changed)
    return Projectile(
        mass=starts["projectile_mass"],
        speed=starts["projectile_speed"],
        contact_stiffness=starts["contact_stiffness"],
        contact_exponent=starts["contact_exponent"],
        contact_damping=starts["contact_damping"],
    )


def projectile_fmu_run(path, horizon: float, projectile: Projectile, **start) -> dict[str, float]:
    values = {
        "load_mode": PROJECTILE_MODE,
        **TIGHT,
        "projectile_mass": projectile.mass,
        "projectile_speed": projectile.speed,
        "contact_stiffness": projectile.contact_stiffness,
        "contact_exponent": projectile.contact_exponent,
        "contact_damping": projectile.contact_damping,
        **start,
    }
    result = simulate_fmu(
        str(path), stop_time=horizon, output_interval=horizon, start_values=values, output=list(PROJECTILE_OUTPUTS)
    )
    return {name: float(result[name][-1]) for name in PROJECTILE_OUTPUTS}


def compare_projectile(fmu: dict, reference, rel: float) -> None:
    """Peaks to ``rel``; the energy terms (the FMU's hold the body's and the contact's) to ``rel`` of the body's
    energy; both balances closed to 1e-6 of it."""
    energy = reference.energy
    scale = energy.projectile_initial_kinetic
    assert reference.peak_backplate_force > 0 and reference.peak_contact_force_continuous > 0
    assert fmu["peak_backplate_force"] == pytest.approx(reference.peak_backplate_force, rel=rel)
    assert fmu["peak_backplate_force_continuous"] == pytest.approx(reference.peak_backplate_force_continuous, rel=rel)
    figures = {
        "kinetic_energy": energy.lattice_kinetic + energy.projectile_kinetic,
        "potential_energy": energy.lattice_potential + energy.contact_potential,
        "dissipated_energy": energy.lattice_dissipation + energy.contact_dissipation,
        "external_work": -energy.back_work,
        "nonreciprocal_work": energy.nonreciprocal_work,
    }
    for name, value in figures.items():
        assert abs(fmu[name] - value) <= rel * scale, name
    assert fmu["projectile_velocity"] == pytest.approx(reference.projectile_velocity[-1], rel=rel, abs=rel)
    assert abs(fmu["energy_balance_error"]) <= 1e-6 * scale
    assert energy.system_error_relative <= 1e-6


def projectile_reference(lattice: PlateScene, projectile: Projectile, horizon: float, **section12):
    return simulate_system(
        SystemScene(lattice, load_mode="projectile", projectile=projectile, **section12), horizon=horizon
    )


PROJECTILE_HORIZON = 1.0  # the default body's contact, the plate's peak and the rebound


def test_projectile_mode_agrees_with_the_reference(fmu_path):
    """The study's 11 x 11 FMU struck by its default projectile, over the contact and the peak."""
    projectile = projectile_of(fmu_path)
    fmu = projectile_fmu_run(fmu_path, PROJECTILE_HORIZON, projectile)
    reference = projectile_reference(PlateScene(rows=11, cols=11, depth=1), projectile, PROJECTILE_HORIZON)
    compare_projectile(fmu, reference, rel=1e-6)


def test_projectile_mode_under_model_exchange_agrees_with_the_reference(fmu_path):
    """fmpy's CVode over the FMU's Model Exchange interface: the sampled peak and the energy terms to 1e-6. Its
    continuous peak is the largest force at the points the importer stopped at, so it lies between the sampled
    peak and the reference's continuous maximum."""
    projectile = projectile_of(fmu_path)
    result = simulate_fmu(
        str(fmu_path),
        fmi_type="ModelExchange",
        solver="CVode",
        relative_tolerance=1e-10,
        stop_time=PROJECTILE_HORIZON,
        output_interval=STEP,
        start_values={"load_mode": PROJECTILE_MODE},
        output=list(PROJECTILE_OUTPUTS),
    )
    fmu = {name: float(result[name][-1]) for name in PROJECTILE_OUTPUTS}
    reference = projectile_reference(PlateScene(rows=11, cols=11, depth=1), projectile, PROJECTILE_HORIZON)
    energy = reference.energy
    assert fmu["peak_backplate_force"] == pytest.approx(reference.peak_backplate_force, rel=1e-6)
    assert (
        fmu["peak_backplate_force"]
        <= fmu["peak_backplate_force_continuous"]
        <= reference.peak_backplate_force_continuous * (1 + 1e-7)
    )
    assert fmu["dissipated_energy"] == pytest.approx(energy.lattice_dissipation + energy.contact_dissipation, rel=1e-6)
    assert abs(fmu["energy_balance_error"]) <= 1e-6 * energy.projectile_initial_kinetic


@pytest.mark.slow
def test_projectile_mode_agrees_with_the_reference_over_the_study_horizon(fmu_path):
    projectile = projectile_of(fmu_path)
    fmu = projectile_fmu_run(fmu_path, 8.0, projectile)
    reference = projectile_reference(PlateScene(rows=11, cols=11, depth=1), projectile, 8.0)
    compare_projectile(fmu, reference, rel=1e-6)


@pytest.fixture(scope="module")
def small_plate_fmu(tmp_path_factory):
    return build.build_fmu(
        rows=3, cols=3, depth=3, werror=True, output=tmp_path_factory.mktemp("projectile_plate") / "ProjectilePlate.fmu"
    )


@pytest.mark.parametrize("patch", [0, 1], ids=["whole-face", "patch1"])
def test_projectile_mode_on_a_plate_agrees_with_the_reference(small_plate_fmu, patch):
    projectile = projectile_of(small_plate_fmu)
    fmu = projectile_fmu_run(small_plate_fmu, PROJECTILE_HORIZON, projectile, load_patch=patch)
    reference = projectile_reference(
        PlateScene(rows=3, cols=3, depth=3, load_patch=patch), projectile, PROJECTILE_HORIZON
    )
    compare_projectile(fmu, reference, rel=1e-6)


def test_projectile_mode_with_unequal_masses_and_non_linear_dampers_agrees_with_the_reference(fmu_path):
    """Section 12 under the projectile: each material's mass and n = 1.5 inside every column, a stiffer linear
    contact with more damping than the default's."""
    masses = tuple(0.5 + 0.15 * m for m in range(11))
    projectile = projectile_of(fmu_path, contact_exponent=1.0, contact_damping=0.3)
    start = {
        **{f"mass[{m}]": mass for m, mass in enumerate(masses, start=1)},
        **{f"damping_exponent[{m}]": 1.5 for m in range(1, 12)},
    }
    fmu = projectile_fmu_run(fmu_path, PROJECTILE_HORIZON, projectile, **start)
    reference = projectile_reference(
        PlateScene(rows=11, cols=11, depth=1),
        projectile,
        PROJECTILE_HORIZON,
        material_mass=masses,
        damping_exponent=(1.5,) * 11,
    )
    compare_projectile(fmu, reference, rel=1e-7)
