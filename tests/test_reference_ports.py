"""The reference of docs/model.md sections 11 and 12 (reference/system.py) checked against physics and against the
references it extends.

Each test can fail if the physics is wrong: the input port driven with the pulse is the pulse of the
three-dimensional reference (another program); a projectile on one free mass is a two-body collision solved by
hand; a projectile too heavy to slow down is a wall moving at its speed (the back port of a mirrored lattice);
a very stiff hull tends to the fixed wall as 1/k; a wall moved by a constant is a wider gap; momentum and
energy balance in every mode; section 12's damper force is the formula and masses carry the momentum.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from reference.lattice3d import PlateScene, simulate_plate
from reference.system import (
    Hull,
    Phase,
    PiecewiseSignal,
    Projectile,
    SystemModel,
    SystemScene,
    simulate_system,
)

SMALL = PlateScene(rows=5, cols=5, depth=1, order=(3, 1, 5, 2, 4))
PLATE = PlateScene(rows=3, cols=3, depth=3, order=(2, 3, 1), load_patch=1)
PROJECTILE = Projectile(mass=20.0, speed=3.0, contact_stiffness=2e4, contact_exponent=1.5, contact_damping=0.2)


def pulse_as_input(lattice: PlateScene) -> PiecewiseSignal:
    """Section 4's pulse as the front port's force: F_total until t_active, then 0 (angle 0: along +x)."""
    return PiecewiseSignal.held((0.0, lattice.t_active), (lattice.F_total, 0.0))


def relative(a, b):
    return abs(a - b) / abs(b)


# ------------------------------------------------------------------------------------------- the front port
@pytest.mark.parametrize("lattice", [SMALL, PLATE], ids=["5x5", "3x3x3-patch"])
def test_input_mode_driven_with_the_pulse_is_the_pulse(lattice):
    """Another program (reference.lattice3d) integrates the pulse; the input port with the same force agrees."""
    horizon = 1.5
    pulse = simulate_plate(lattice, horizon=horizon)
    driven = simulate_system(
        SystemScene(lattice, load_mode="input", front_force=pulse_as_input(lattice)), horizon=horizon
    )
    assert relative(driven.peak_backplate_force, pulse.peak_backplate_force) < 1e-9
    assert relative(driven.peak_backplate_force_continuous, pulse.peak_backplate_force_continuous) < 1e-9
    assert np.max(np.abs(driven.backplate_force - pulse.backplate_force)) < 1e-9 * pulse.peak_backplate_force
    # the port's work is the pulse's external work, and both balances close
    assert relative(driven.energy.front_work, pulse.external_work) < 1e-9
    assert abs(driven.energy.lattice_error) < 1e-8 * driven.energy.front_work
    assert abs(driven.energy.system_error) < 1e-8 * driven.energy.front_work


def test_pulse_mode_with_the_default_masses_and_exponents_is_the_existing_reference():
    lattice = replace(SMALL, diagonal_rule="mean")
    existing = simulate_plate(lattice, horizon=1.5)
    explicit = simulate_system(SystemScene(lattice, material_mass=(1.0,) * 5, damping_exponent=(1.0,) * 5), horizon=1.5)
    assert relative(explicit.peak_backplate_force, existing.peak_backplate_force) < 1e-9
    assert relative(explicit.energy.lattice_dissipation, existing.dissipated_energy) < 1e-9


def test_x_front_and_v_front_are_the_weighted_face():
    """Section 11: x_front = Σ w_a ux_a with section 10's weights normalised to 1 (a corner weighs 1/4 of a
    middle mass on the whole face)."""
    lattice = PlateScene(rows=3, cols=2, depth=3)
    model = SystemModel(SystemScene(lattice))
    rng = np.random.default_rng(3)
    z = np.zeros(model.size)
    z[: 6 * model.N] = rng.normal(size=6 * model.N)
    weight = {1: 0.5, 2: 1.0, 3: 0.5}
    face = [(weight[i] * weight[k], lattice.index(i, 1, k)) for i in (1, 2, 3) for k in (1, 2, 3)]
    total = sum(w for w, _ in face)
    x_front, v_front = model.front(z)
    assert x_front == pytest.approx(sum(w * z[n] for w, n in face) / total, rel=1e-13)
    assert v_front == pytest.approx(sum(w * z[3 * model.N + n] for w, n in face) / total, rel=1e-13)


# ------------------------------------------------------------------------------------------- the projectile
@pytest.mark.parametrize("exponent", [1.0, 1.5])
def test_a_projectile_on_one_free_mass_is_an_elastic_two_body_collision(exponent):
    """One mass, no wall, no contact damping: the contact is a conservative spring between two bodies. Its peak
    is where the relative motion stops: ``k δ^(n+1)/(n+1) = μ v0²/2``; afterwards the velocities are those of an
    elastic collision; for n = 1 the contact lasts half a period of ``sqrt(k/μ)``."""
    m_p, m, v0, k = 3.0, 2.0, 2.0, 1e4
    lattice = PlateScene(rows=1, cols=1, depth=1, has_backplate=False)
    result = simulate_system(
        SystemScene(
            lattice,
            load_mode="projectile",
            material_mass=(m,),
            projectile=Projectile(m_p, v0, k, contact_exponent=exponent),
        ),
        horizon=0.2,
    )
    mu = m_p * m / (m_p + m)
    deepest = ((exponent + 1) * mu * v0**2 / (2 * k)) ** (1 / (exponent + 1))
    assert relative(result.peak_contact_force_continuous, k * deepest**exponent) < 1e-9
    assert relative(result.projectile_velocity[-1], (m_p - m) / (m_p + m) * v0) < 1e-9
    assert relative(result.v_front[-1], 2 * m_p / (m_p + m) * v0) < 1e-9
    assert result.n_switches == 1  # the contact opens once, and the bodies never meet again
    if exponent == 1.0:
        assert abs(result.peak_contact_time - 0.5 * math.pi * math.sqrt(mu / k)) < 1e-6
    assert abs(result.energy.system_error) < 1e-9 * result.energy.projectile_initial_kinetic


def test_contact_damping_dissipates_what_the_bodies_lose():
    m_p, m, v0 = 3.0, 2.0, 2.0
    lattice = PlateScene(rows=1, cols=1, depth=1, has_backplate=False)
    result = simulate_system(
        SystemScene(
            lattice,
            load_mode="projectile",
            material_mass=(m,),
            projectile=Projectile(m_p, v0, 1e4, 1.5, contact_damping=0.3),
        ),
        horizon=0.2,
    )
    energy = result.energy
    lost = energy.projectile_initial_kinetic - energy.projectile_kinetic - energy.lattice_kinetic
    assert energy.contact_dissipation > 0.01 * energy.projectile_initial_kinetic
    assert energy.contact_potential == 0.0  # the bodies have parted
    assert relative(energy.contact_dissipation, lost) < 1e-9
    # momentum crosses the contact exactly
    assert relative(m_p * result.projectile_velocity[-1] + m * result.v_front[-1], m_p * v0) < 1e-12


def test_a_projectile_too_heavy_to_slow_down_is_a_wall_moving_at_its_speed():
    """A 1 x C lattice struck by a projectile whose mass dwarfs it (linear contact, no damping) is the mirrored
    lattice pushed by its back port's wall moving at the projectile's speed (gap 0, wall stiffness = contact
    stiffness, no wall damper): two different paths of the reference, one the limit of the other."""
    v0, k_contact, horizon = 1.0, 1e4, 0.3
    masses = (1.0, 2.0, 0.5, 1.5)
    struck = PlateScene(rows=1, cols=4, depth=1, has_backplate=False)
    mirrored = replace(
        struck,
        order=tuple(reversed(struck.order)),
        has_backplate=True,
        k_wall=k_contact,
        c_wall=0.0,
        backplate_gap=0.0,
        F_total=0.0,
    )
    wall = simulate_system(
        SystemScene(
            mirrored,
            material_mass=masses,
            back_position=PiecewiseSignal((0.0,), (lambda t: -v0 * t,)),
            back_velocity=PiecewiseSignal.constant(-v0),
        ),
        horizon=horizon,
    )
    differences = []
    for heavy in (1e6, 1e9):
        hit = simulate_system(
            SystemScene(
                struck, load_mode="projectile", material_mass=masses, projectile=Projectile(heavy, v0, k_contact)
            ),
            horizon=horizon,
        )
        differences.append(np.max(np.abs(hit.contact_force - wall.backplate_force)))
        assert abs(hit.energy.lattice_error) < 1e-8 * hit.energy.front_work
    assert wall.peak_backplate_force_continuous > 10.0  # the wall did push
    assert differences[1] < 1e-6 * wall.peak_backplate_force_continuous
    assert differences[1] < differences[0] / 100  # it converges as 1 / mass
    assert abs(wall.energy.lattice_error) < 1e-8 * abs(wall.energy.back_work)


@pytest.mark.parametrize("lattice", [SMALL, PLATE], ids=["5x5", "3x3x3-patch"])
def test_projectile_energy_closes_with_wall_and_with_hull(lattice):
    """Sections 7 and 11 with the projectile's kinetic energy, the contact potential and dissipation (n = 1.5,
    λ > 0), the non-reciprocal work of the receiver rule, and the hull's energy."""
    for hull in (None, Hull(mass=100.0, stiffness=1e4, damping=300.0)):
        result = simulate_system(
            SystemScene(lattice, load_mode="projectile", projectile=PROJECTILE, hull=hull), horizon=1.0
        )
        energy = result.energy
        assert result.peak_contact_force_continuous > 100.0 and result.peak_backplate_force > 100.0
        assert energy.contact_dissipation > 0 and energy.lattice_dissipation > 0
        assert abs(energy.nonreciprocal_work) > 1e-3 * energy.projectile_initial_kinetic
        assert energy.system_error_relative < 1e-6
        assert abs(energy.lattice_error) < 1e-6 * energy.projectile_initial_kinetic
        if hull is not None:
            assert energy.hull_dissipation > 0 and abs(energy.back_work) > 0
            assert np.max(np.abs(result.hull_position)) > 1e-3


def test_momentum_crosses_the_lattice_into_the_backplate():
    """With reciprocal springs (the mean rule) the lattice's internal forces cancel: what the projectile loses is
    the lattice's momentum plus the backplate's impulse ``∫ F_bp dt``, at every mass ratio."""
    lattice = replace(SMALL, diagonal_rule="mean")
    scene = SystemScene(lattice, load_mode="projectile", projectile=PROJECTILE, material_mass=(1.0, 0.5, 2.0, 1.5, 0.8))
    result = simulate_system(scene, horizon=1.0)
    model = SystemModel(scene)
    z = result.final_state
    lattice_momentum = float(model.node_mass @ z[3 * model.N : 4 * model.N])
    lost = PROJECTILE.mass * (PROJECTILE.speed - result.projectile_velocity[-1])
    assert result.backplate_impulse > 0.1 * lost
    assert abs(lost - lattice_momentum - result.backplate_impulse) < 1e-8 * PROJECTILE.mass * PROJECTILE.speed


# ------------------------------------------------------------------------------------------- the back port
def test_a_very_stiff_hull_tends_to_the_fixed_wall_as_one_over_its_stiffness():
    lattice = PlateScene(rows=3, cols=3, depth=1, order=(2, 3, 1))
    scene = SystemScene(lattice, load_mode="projectile", projectile=PROJECTILE)
    fixed = simulate_system(scene, horizon=0.6)
    gaps = []
    for stiffness in (1e7, 1e8):
        hull = Hull(mass=100.0, stiffness=stiffness, damping=2 * math.sqrt(stiffness * 100.0))
        carried = simulate_system(replace(scene, hull=hull), horizon=0.6)
        gaps.append(abs(carried.peak_backplate_force_continuous - fixed.peak_backplate_force_continuous))
        # the hull gives way by about F_bp / k, and each of the R masses on the wall pushes k_w times that less
        assert gaps[-1] < 2 * lattice.rows * lattice.k_wall / stiffness * fixed.peak_backplate_force_continuous
    assert 3 < gaps[0] / gaps[1] < 30


def test_a_wall_moved_by_a_constant_is_a_wider_gap():
    offset = 0.002
    wider = simulate_system(SystemScene(replace(SMALL, backplate_gap=SMALL.backplate_gap + offset)), horizon=1.0)
    moved = simulate_system(
        SystemScene(SMALL, back_position=PiecewiseSignal.constant(offset), back_velocity=PiecewiseSignal.constant(0.0)),
        horizon=1.0,
    )
    assert relative(moved.peak_backplate_force, wider.peak_backplate_force) < 1e-10
    assert moved.energy.back_work == 0.0


def test_a_wall_given_pressed_into_the_lattice_starts_with_its_potential():
    """x_back(0) beyond the gap: the wall masses start in contact, the wall's potential is there at t = 0, and
    the balance counts it."""
    offset = -3 * SMALL.backplate_gap
    pressed = simulate_system(
        SystemScene(SMALL, back_position=PiecewiseSignal.constant(offset), back_velocity=PiecewiseSignal.constant(0.0)),
        horizon=1.0,
    )
    energy = pressed.energy
    assert energy.lattice_initial_potential == pytest.approx(
        SMALL.rows * 0.5 * SMALL.k_wall * (offset + SMALL.backplate_gap) ** 2, rel=1e-12
    )
    assert pressed.backplate_force[0] == pytest.approx(
        SMALL.rows * SMALL.k_wall * -(offset + SMALL.backplate_gap), rel=1e-12
    )
    assert abs(energy.lattice_error) < 1e-8 * energy.front_work


def test_the_back_ports_work_closes_the_balance_of_a_moving_wall():
    moving = SystemScene(
        SMALL,
        back_position=PiecewiseSignal((0.0,), (lambda t: 0.002 * math.sin(20 * t),)),
        back_velocity=PiecewiseSignal((0.0,), (lambda t: 0.04 * math.cos(20 * t),)),
    )
    result = simulate_system(moving, horizon=1.0)
    energy = result.energy
    assert abs(energy.back_work) > 1e-3 * energy.front_work
    assert abs(energy.lattice_error) < 1e-8 * energy.front_work


# ------------------------------------------------------------------------------------------- section 12
@pytest.mark.parametrize("exponent", [0.5, 1.0, 1.5, 2.0])
def test_a_column_damper_pushes_with_c_times_the_speed_to_the_n_minus_one(exponent):
    """Two masses of one column (no springs stretched): each feels ``-c |dv|^(n-1) dv``, the full relative
    velocity's length, divided by its material's mass; the dissipation is ``c |dv|^(n+1)``."""
    lattice = PlateScene(rows=2, cols=1, depth=1, has_backplate=False)
    scene = SystemScene(lattice, material_mass=(2.5,), damping_exponent=(exponent,))
    model = SystemModel(scene)
    N, c = model.N, lattice.c[0]
    z = np.zeros(model.size)
    v_low, v_high = np.array([0.3, -0.2, 0.0]), np.array([-0.1, 0.4, 0.0])
    for axis in range(3):
        z[(3 + axis) * N + 0], z[(3 + axis) * N + 1] = v_low[axis], v_high[axis]
    derivative = model.derivative(1.0, z, np.zeros(model.n_modes, bool), _phase_off())
    dv = v_low - v_high
    force_on_low = -c * np.linalg.norm(dv) ** (exponent - 1) * dv
    low = np.array([derivative[(3 + axis) * N + 0] for axis in range(3)])
    high = np.array([derivative[(3 + axis) * N + 1] for axis in range(3)])
    np.testing.assert_allclose(low, force_on_low / 2.5, rtol=1e-13, atol=1e-16)
    np.testing.assert_allclose(high, -force_on_low / 2.5, rtol=1e-13, atol=1e-16)
    assert derivative[model.I + 2] == pytest.approx(c * np.linalg.norm(dv) ** (exponent + 1), rel=1e-13)


def _phase_off():
    return Phase(load_on=False, front_force=None, back_position=None, back_velocity=None)


def test_dampers_between_columns_stay_linear():
    lattice = PlateScene(rows=1, cols=2, depth=1, has_backplate=False)
    model = SystemModel(SystemScene(lattice, damping_exponent=(2.0, 0.5)))
    assert np.all(model.damper_exponent == 1.0)  # the one damper of a 1 x 2 lattice runs along x
    column = SystemModel(
        SystemScene(PlateScene(rows=2, cols=2, depth=2, has_backplate=False), damping_exponent=(2.0, 0.5))
    )
    assert sorted(set(column.damper_exponent.tolist())) == [0.5, 1.0, 2.0]


@pytest.mark.parametrize("exponent", [1.5, 2.0, pytest.param(0.5, marks=pytest.mark.slow)])
@pytest.mark.parametrize("lattice", [SMALL, PLATE], ids=["5x5", "3x3x3-patch"])
def test_energy_closes_with_unequal_masses_and_non_linear_dampers(lattice, exponent):
    """n < 1 is slow: its damper force is not Lipschitz where a relative velocity passes zero, so the solver's
    steps shrink at every such passage."""
    count = len(lattice.k)
    scene = SystemScene(
        lattice, material_mass=tuple(np.linspace(0.5, 2.0, count)), damping_exponent=(exponent,) * count
    )
    for mode in (scene, replace(scene, load_mode="projectile", projectile=PROJECTILE)):
        result = simulate_system(mode, horizon=1.0)
        assert result.energy.system_error_relative < 1e-6
        assert result.energy.lattice_dissipation > 0


def test_the_pulses_momentum_is_carried_by_unequal_masses():
    """No wall, reciprocal springs: after the pulse the lattice carries ``F_total t_active`` whatever its
    masses, shared out as Σ m v."""
    lattice = replace(SMALL, has_backplate=False, diagonal_rule="mean")
    scene = SystemScene(lattice, material_mass=(1.0, 0.5, 2.0, 1.5, 0.8), damping_exponent=(1.5,) * 5)
    result = simulate_system(scene, horizon=0.5)
    model = SystemModel(scene)
    momentum = float(model.node_mass @ result.final_state[3 * model.N : 4 * model.N])
    assert relative(momentum, lattice.F_total * lattice.t_active) < 1e-9
    assert scene.total_mass == pytest.approx(5 * (1.0 + 0.5 + 2.0 + 1.5 + 0.8))


# ------------------------------------------------------------------------------------------- bad input
@pytest.mark.parametrize(
    "build, words",
    [
        (lambda: SystemScene(SMALL, load_mode="bullet"), "load_mode must be one of"),
        (lambda: SystemScene(SMALL, load_mode="projectile"), "SystemScene.projectile"),
        (lambda: SystemScene(SMALL, material_mass=(1.0,) * 4), "material_mass must be 5 numbers"),
        (lambda: SystemScene(SMALL, damping_exponent=(0.0,) * 5), "damping_exponent must be a finite number > 0"),
        (lambda: Projectile(mass=-1.0, speed=1.0, contact_stiffness=1.0), "Projectile.mass"),
        (lambda: Hull(mass=1.0, stiffness=-1.0, damping=0.0), "Hull.stiffness"),
        (lambda: PiecewiseSignal((0.5,), (lambda t: 0.0,)), "PiecewiseSignal.breaks"),
    ],
)
def test_bad_input_names_the_parameter(build, words):
    with pytest.raises(ValueError, match=words):
        build()
