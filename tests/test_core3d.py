"""The C physics core as a plate (docs/model.md section 10), through its ctypes binding.

Against the independent numpy reference of section 10 (reference/lattice3d.py: index arrays of springs, no
rows, no sweeps), and against the physics every right-hand side must obey: Newton's third law where the
springs are reciprocal, forces that are minus the gradient of the potential, the along-x and mirrored layouts
that carry the whole plate's solution, and an energy balance that closes. Depth 1 is the lattice the other
core tests check against the two-dimensional reference.
"""

import dataclasses

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from fmu_src.core import WHOLE_FACE, Core, params_from_plate, params_from_scene
from reference import Scene
from reference.lattice3d import PlateModel, PlateScene


@pytest.fixture(scope="module")
def core(core_library):
    return Core(core_library)


def mass_index(scene, depth, i, j, k):
    """lattice.h's numbering: mass (i, j, k) (row, column, slice) is (k R + i) C + j."""
    return (k * scene.rows + i) * scene.cols + j


# ---------------------------------------------------------------- states


def random_plate_state(scene, depth, rng, scale=0.05):
    """Displacements of a few cm, velocities of about 1 m/s, column-C masses straddling the 1 mm gap."""
    n = scene.rows * scene.cols * depth
    y = np.concatenate([rng.normal(0.0, scale, 3 * n), rng.normal(0.0, 1.0, 3 * n)])
    last_column = np.arange(scene.cols - 1, n, scene.cols)
    y[last_column] = rng.uniform(-0.01, 0.02, len(last_column))
    return y


def plate(scene, depth, load_patch=WHOLE_FACE):
    return params_from_scene(scene, depth=depth, load_patch=load_patch)


def with_order(scene, rng):
    return dataclasses.replace(scene, order=tuple(int(m) for m in rng.permutation(scene.cols) + 1))


# ---------------------------------------------------------------- the right-hand side against the reference

REFERENCE_PLATES = [
    dict(rows=5, cols=5, depth=5),
    dict(rows=5, cols=5, depth=5, load_patch=3, diagonal_rule="mean"),
    dict(rows=3, cols=4, depth=2, load_angle=30.0),
    dict(rows=4, cols=3, depth=3, spring_law="linear"),
    dict(rows=5, cols=4, depth=1, load_angle=15.0),
    dict(rows=3, cols=5, depth=1, load_patch=1, mass=2.0),
    dict(rows=3, cols=3, depth=3, has_backplate=False, diagonal_rule="mean", load_angle=-40.0),
    dict(rows=1, cols=4, depth=3),
    dict(rows=5, cols=6, depth=3, load_patch=1, load_angle=30.0),
]


def own_alphas(cols, rng):
    """The study's table with each material's alpha_diag its own: a diagonal's two ends then differ in alpha."""
    table = Scene(cols=cols)
    return dict(
        k=tuple(table.k),
        k_diag=tuple(table.k_diag),
        c=tuple(table.c),
        alpha=tuple(table.alpha),
        alpha_diag=tuple(rng.uniform(5.0, 15.0, cols)),
    )


@pytest.mark.parametrize("settings", REFERENCE_PLATES, ids=lambda s: ",".join(f"{k}={v}" for k, v in s.items()))
@pytest.mark.parametrize("load_on", [True, False])
def test_plate_right_hand_side_matches_the_numpy_reference(core, settings, load_on):
    """reference/lattice3d.py, the colleague's oracle of section 10: the same numbering; its state is always
    [ux, uy, uz, vx, vy, vz], the core's has no z parts at depth 1."""
    rng = np.random.default_rng(97 + load_on + len(str(settings)))
    for trial in range(4):
        table = own_alphas(settings["cols"], rng) if trial == 3 else {}
        reference = PlateScene(order=tuple(int(m) for m in rng.permutation(settings["cols"]) + 1), **settings, **table)
        params = params_from_plate(reference)
        assert core.params_error(params) is None
        model, n = PlateModel(reference), reference.n_masses
        y = random_plate_state(reference, reference.depth, rng)
        if reference.depth == 1:
            y[2 * n : 3 * n] = y[5 * n :] = 0.0  # no z motion to drop
        penetration, vx = y[model.wall_index] - reference.backplate_gap, y[3 * n + model.wall_index]
        contact, damper_on = penetration > 0, (penetration > 0) & (vx > 0)
        expected = model.derivative(np.concatenate([y, np.zeros(3)]), load_on, contact, damper_on)
        kinetic, potential = model.energies(y, contact)
        wall = model.backplate_force(y, contact, damper_on)
        if reference.depth == 1:
            y = np.delete(y, np.r_[2 * n : 3 * n, 5 * n : 6 * n])
            expected = np.delete(expected, np.r_[2 * n : 3 * n, 5 * n : 6 * n])
        got, got_powers = core.rhs(params, y, load_on)
        scale = np.max(np.abs(expected[:-3]))
        np.testing.assert_allclose(got, expected[:-3], rtol=0, atol=1e-12 * scale)
        np.testing.assert_allclose(got_powers, expected[-3:], rtol=1e-11, atol=1e-11 * scale)
        got_kinetic, got_potential = core.energies(params, y)
        assert got_kinetic == pytest.approx(kinetic, rel=1e-13)
        assert got_potential == pytest.approx(potential, rel=1e-11)
        assert core.backplate_force(params, y) == pytest.approx(wall, rel=1e-13, abs=1e-12)


def test_frozen_wall_modes_are_one_per_column_c_mass(core):
    """wall_mode[k R + i] switches the backplate of mass (i, C, k), whatever its state."""
    scene = Scene(rows=3, cols=3)
    depth, rng = 2, np.random.default_rng(5)
    params = plate(scene, depth)
    y = random_plate_state(scene, depth, rng)
    n = scene.rows * scene.cols * depth
    face = [mass_index(scene, depth, i, scene.cols - 1, k) for k in range(depth) for i in range(scene.rows)]
    y[face] = scene.backplate_gap + 0.01  # every one in contact
    free, _ = core.rhs(params, y, False, wall_mode=np.zeros(len(face)))
    for f, mass in enumerate(face):
        modes = np.zeros(len(face))
        modes[f] = 1  # WALL_RECEDING: the spring of the wall alone
        pushed, _ = core.rhs(params, y, False, wall_mode=modes)
        change = pushed - free
        assert change[3 * n + mass] == pytest.approx(-scene.k_wall * 0.01 / scene.mass, rel=1e-9)
        assert np.count_nonzero(change) == 1


# ---------------------------------------------------------------- physics


def springs_only(scene):
    """No damping, no wall: the forces are the springs' alone."""
    return dataclasses.replace(scene, wall=False, c0=0.0, c=np.zeros(len(scene.c)))


@pytest.mark.parametrize("patch", [WHOLE_FACE, 3])
def test_mean_rule_conserves_momentum_and_receiver_rule_breaks_it_on_diagonals_only(core, patch):
    """Sum of m a = the external load under the mean rule; under the receiver rule only unequal diagonals add."""
    rng = np.random.default_rng(11)
    scene = springs_only(with_order(Scene(rows=5, cols=5, load_angle=20.0), rng))
    depth, n = 3, 5 * 5 * 3
    y = random_plate_state(scene, depth, rng)
    load = scene.F_total * np.array([np.cos(np.radians(20.0)), np.sin(np.radians(20.0)), 0.0])

    def total_force(s):
        dydt, _ = core.rhs(plate(s, depth, patch), y, True)
        return scene.mass * dydt[3 * n :].reshape(3, n).sum(axis=1)

    mean = total_force(dataclasses.replace(scene, diagonal_rule="mean"))
    np.testing.assert_allclose(mean, load, rtol=0, atol=1e-9 * scene.F_total)
    receiver = total_force(scene)
    assert np.max(np.abs(receiver - load)) > 1e-3
    no_diagonals = dataclasses.replace(scene, k_diag=np.zeros(len(scene.k_diag)))
    np.testing.assert_allclose(total_force(no_diagonals), load, rtol=0, atol=1e-9 * scene.F_total)


@pytest.mark.parametrize("spring_law", ["exponential", "linear"])
def test_forces_are_minus_the_gradient_of_the_potential(core, spring_law):
    """Mean rule, springs only: m a = -dU/du, by central differences on every displacement."""
    rng = np.random.default_rng(3)
    scene = springs_only(with_order(Scene(rows=3, cols=4, diagonal_rule="mean", spring_law=spring_law), rng))
    depth = 3
    params = plate(scene, depth)
    n = scene.rows * scene.cols * depth
    y = random_plate_state(scene, depth, rng)
    dydt, _ = core.rhs(params, y, False)
    h = 1e-6
    gradient = np.empty(3 * n)
    for component in range(3 * n):
        up, down = y.copy(), y.copy()
        up[component] += h
        down[component] -= h
        gradient[component] = (core.energies(params, up)[1] - core.energies(params, down)[1]) / (2 * h)
    force = scene.mass * dydt[3 * n :]
    np.testing.assert_allclose(force, -gradient, rtol=0, atol=1e-6 * np.max(np.abs(force)))


# ---------------------------------------------------------------- the along-x and mirrored layouts


def along_x_plate_state(scene, depth, rng):
    """A random plate state with every y and z part 0, whole and in the along-x layout [ux, vx, 0, 0, 0]."""
    n = scene.rows * scene.cols * depth
    y = random_plate_state(scene, depth, rng)
    y[n : 3 * n] = 0.0
    y[4 * n :] = 0.0
    return y, np.concatenate([y[:n], y[3 * n : 4 * n], np.zeros(3)])


def mirror_symmetric_x(scene, depth, rng):
    """ux and vx as (D, R, C) blocks, symmetric about the middle row (odd R) and the middle slice along z (odd D)."""
    blocks = []
    for scale in (0.05, 1.0):
        block = rng.normal(0.0, scale, (depth, scene.rows, scene.cols))
        if scale < 1.0:
            block[:, :, -1] = rng.uniform(-0.01, 0.02, (depth, scene.rows))
        if scene.rows % 2:
            block = 0.5 * (block + block[:, ::-1, :])
        if depth % 2:
            block = 0.5 * (block + block[::-1, :, :])
        blocks.append(block)
    return blocks


PLATES = [
    (dict(rows=3, cols=4), 3, WHOLE_FACE),
    (dict(rows=5, cols=5, diagonal_rule="mean"), 5, 3),
    (dict(rows=3, cols=5, spring_law="linear", wall=False), 4, WHOLE_FACE),
    (dict(rows=1, cols=3, mass=2.0), 3, WHOLE_FACE),
]


def plate_id(case):
    settings, depth, patch = case
    return ",".join([f"{k}={v}" for k, v in settings.items()] + [f"depth={depth}", f"patch={patch}"])


MIRRORED = [
    (dict(rows=5, cols=5), 5, WHOLE_FACE),
    (dict(rows=5, cols=4, diagonal_rule="mean"), 3, 3),
    (dict(rows=4, cols=5), 3, WHOLE_FACE),
    (dict(rows=3, cols=6, spring_law="linear"), 2, WHOLE_FACE),
    (dict(rows=7, cols=5, wall=False, mass=2.0), 5, 1),
    (dict(rows=3, cols=3), 1, WHOLE_FACE),
]


@pytest.mark.parametrize("case", PLATES + MIRRORED[:2], ids=plate_id)
@pytest.mark.parametrize("load_on", [True, False])
def test_the_along_x_layout_is_the_x_part_of_the_whole_plate(core, case, load_on):
    settings, depth, patch = case
    rng = np.random.default_rng(41 + load_on + len(plate_id(case)))
    scene = Scene(**settings)
    n = scene.rows * scene.cols * depth
    for _ in range(3):
        scene = with_order(scene, rng)
        params = plate(scene, depth, patch)
        assert core.along_x(params)
        y, along = along_x_plate_state(scene, depth, rng)
        whole, whole_powers = core.rhs(params, y, load_on)
        assert np.all(whole[3 * n + n :] == 0.0)  # nothing pushes in y or z
        got, got_powers = core.rhs_along_x(params, along, load_on)
        expected = np.concatenate([whole[:n], whole[3 * n : 4 * n]])
        scale = np.max(np.abs(whole))
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12 * scale)
        np.testing.assert_allclose(got_powers, whole_powers, rtol=1e-11, atol=1e-11 * scale)


@pytest.mark.parametrize("case", MIRRORED, ids=plate_id)
@pytest.mark.parametrize("load_on", [True, False])
def test_the_mirrored_part_carries_the_whole_plate(core, case, load_on):
    """The half (or quarter) along y and z, expanded, is the whole plate's along-x right-hand side."""
    settings, depth, patch = case
    rng = np.random.default_rng(59 + load_on + len(plate_id(case)))
    scene = Scene(**settings)
    rows, slices = (scene.rows + 1) // 2 if scene.rows % 2 else scene.rows, (depth + 1) // 2 if depth % 2 else depth
    for _ in range(3):
        scene = with_order(scene, rng)
        params = plate(scene, depth, patch)
        assert core.mirrored_extent(params) == (rows, slices)
        ux, vx = mirror_symmetric_x(scene, depth, rng)
        whole_x = np.concatenate([ux.reshape(-1), vx.reshape(-1), np.zeros(3)])
        part = np.concatenate([ux[:slices, :rows].reshape(-1), vx[:slices, :rows].reshape(-1), np.zeros(3)])
        face = np.concatenate([ux[:, :, -1].reshape(-1) - scene.backplate_gap, vx[:, :, -1].reshape(-1)])
        modes = np.where(face[: depth * scene.rows] > 0, np.where(face[depth * scene.rows :] > 0, 2, 1), 0)
        for wall_mode in (None, modes):
            whole, whole_powers = core.rhs_along_x(params, whole_x, load_on, wall_mode=wall_mode)
            got, got_powers = core.rhs_along_x(params, part, load_on, mirrored=True, wall_mode=wall_mode)
            expected = np.concatenate(
                [
                    block.reshape(depth, scene.rows, scene.cols)[:slices, :rows].reshape(-1)
                    for block in np.split(whole, 2)
                ]
            )
            scale = np.max(np.abs(whole))
            np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12 * scale)
            np.testing.assert_allclose(got_powers, whole_powers, rtol=1e-11, atol=1e-11 * scale)
        others = np.zeros((2 if depth > 1 else 1) * ux.size)  # the y (and z) parts of the whole state
        whole_state = np.concatenate([ux.reshape(-1), others, vx.reshape(-1), others])
        assert core.backplate_force_mirrored(params, part) == pytest.approx(
            core.backplate_force(params, whole_state), rel=1e-13, abs=1e-12
        )


@pytest.mark.parametrize(
    "settings,depth,patch,rows,slices",
    [
        (dict(rows=5, cols=3), 5, WHOLE_FACE, 3, 3),
        (dict(rows=4, cols=3), 5, WHOLE_FACE, 0, 3),
        (dict(rows=5, cols=3), 4, WHOLE_FACE, 3, 0),
        (dict(rows=5, cols=3, load_angle=30.0), 5, WHOLE_FACE, 0, 0),
        (dict(rows=5, cols=3), 5, 3, 3, 3),
        (dict(rows=5, cols=3), 1, WHOLE_FACE, 3, 0),
    ],
)
def test_which_plates_are_mirror_symmetric(core, settings, depth, patch, rows, slices):
    params = plate(Scene(**settings), depth, patch)
    assert (core.mirror_rows(params), core.mirror_slices(params)) == (rows, slices)


@pytest.mark.parametrize(
    "rows,depth,patch,message",
    [
        (5, 5, 2, r"load_patch = 2: allowed 0 \(the whole face\) or an odd side P .* min\(rows, depth\) = 5"),
        (5, 3, 5, r"load_patch = 5: .*min\(rows, depth\) = 3"),
        (
            4,
            5,
            3,
            r"load_patch = 3: a centred patch needs an odd number of rows and an odd depth \(rows = 4, depth = 5\)",
        ),
        (5, 0, WHOLE_FACE, r"depth = 0: the lattice needs at least 1 slice"),
    ],
)
def test_a_plate_the_core_does_not_compute_is_refused_in_one_line(core, rows, depth, patch, message):
    error = core.params_error(plate(Scene(rows=rows, cols=3), depth, patch))
    assert error is not None and "\n" not in error
    assert __import__("re").fullmatch(message, error)


# ---------------------------------------------------------------- the energy balance over an integration


@pytest.mark.parametrize("diagonal_rule,patch", [("receiver", WHOLE_FACE), ("mean", 3)])
def test_energy_balance_of_a_5x5x5_plate_closes(core, diagonal_rule, patch):
    """W_ext + W_nr = kinetic + potential + dissipated, to 1e-6 of W_ext, over the load and after it."""
    scene = Scene(rows=5, cols=5, order=(1, 4, 2, 5, 3), diagonal_rule=diagonal_rule, t_active=0.05)
    depth = 5
    params = plate(scene, depth, patch)
    y0 = np.zeros(6 * 5 * 5 * depth + 3)

    def rhs(load_on):
        def f(_t, y):
            dydt, powers = core.rhs(params, y, load_on)
            return np.concatenate([dydt, powers])

        return f

    loaded = solve_ivp(rhs(True), (0.0, scene.t_active), y0, method="DOP853", rtol=1e-10, atol=1e-12)
    free = solve_ivp(rhs(False), (scene.t_active, 0.3), loaded.y[:, -1], method="DOP853", rtol=1e-10, atol=1e-12)
    assert loaded.success and free.success
    y = free.y[:, -1]
    external, dissipated, nonreciprocal = y[-3:]
    kinetic, potential = core.energies(params, y)
    assert external > 1.0 and dissipated > 0.0
    assert (nonreciprocal < 0.0) if diagonal_rule == "receiver" else (abs(nonreciprocal) < 1e-12 * external)
    assert abs(external + nonreciprocal - kinetic - potential - dissipated) < 1e-6 * external
    last_column = np.arange(scene.cols - 1, 5 * 5 * depth, scene.cols)
    assert max(np.max(loaded.y[last_column]), np.max(free.y[last_column])) > scene.backplate_gap  # it met the wall
