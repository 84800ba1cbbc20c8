"""The C physics core against the independent numpy oracle (reference/), on random states."""

import dataclasses

import numpy as np
import pytest

from fmu_src.core import Core, params_from_scene
from reference import Scene, backplate_force, energies, rhs_with_powers


@pytest.fixture(scope="module")
def core(core_library):
    return Core(core_library)


def random_state(scene, rng, scale=0.05):
    """Displacements of a few cm (springs well into their exponential range), some masses past the wall."""
    n = scene.rows * scene.cols
    y = rng.normal(0.0, scale, 4 * n)
    y[2 * n :] = rng.normal(0.0, 1.0, 2 * n)  # velocities
    last_column = np.arange(scene.cols - 1, n, scene.cols)
    y[last_column] = rng.uniform(-0.01, 0.02, len(last_column))  # straddle the 1 mm gap
    return y


SCENES = [
    dict(),
    dict(diagonal_rule="mean"),
    dict(load_angle=30.0),
    dict(rows=3, cols=4),
    dict(rows=1, cols=2, spring_law="linear"),
    dict(rows=5, cols=5, wall=False),
    dict(rows=7, cols=9, diagonal_rule="mean", spring_law="linear"),
]


@pytest.mark.parametrize("settings", SCENES, ids=lambda s: ",".join(f"{k}={v}" for k, v in s.items()) or "default")
@pytest.mark.parametrize("load_on", [True, False])
def test_right_hand_side_matches_the_oracle(core, settings, load_on):
    rng = np.random.default_rng(len(str(settings)) + load_on)
    scene = Scene(**settings)
    for _ in range(5):
        scene = dataclasses.replace(scene, order=tuple(int(m) for m in rng.permutation(scene.cols) + 1))
        params = params_from_scene(scene)
        y = random_state(scene, rng)
        expected, expected_powers = rhs_with_powers(scene, 0.0, y, load_on=load_on)
        got, got_powers = core.rhs(params, y, load_on)
        scale = np.max(np.abs(expected))
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12 * scale)
        np.testing.assert_allclose(got_powers, expected_powers, rtol=1e-11, atol=1e-11 * scale)
        assert core.backplate_force(params, y) == pytest.approx(backplate_force(scene, y), rel=1e-13, abs=1e-12)
        kinetic, potential = energies(scene, y)
        got_kinetic, got_potential = core.energies(params, y)
        assert got_kinetic == pytest.approx(kinetic, rel=1e-13)
        assert got_potential == pytest.approx(potential, rel=1e-11)


def test_receiver_rule_is_not_reciprocal_and_mean_rule_is(core):
    rng = np.random.default_rng(7)
    table = dict(Scene.default_material_table(11), c=np.zeros(11))
    scene = Scene(
        order=(1, 7, 5, 9, 3, 6, 11, 8, 2, 4, 10), wall=False, c0=0.0, **table
    )  # springs only: the internal forces of a reciprocal lattice sum to zero
    y = random_state(scene, rng)
    n = scene.rows * scene.cols
    receiver, _ = core.rhs(params_from_scene(scene), y, load_on=False)
    mean, _ = core.rhs(params_from_scene(dataclasses.replace(scene, diagonal_rule="mean")), y, load_on=False)
    assert abs(receiver[2 * n : 3 * n].sum()) > 1e-3
    assert abs(mean[2 * n : 3 * n].sum()) < 1e-9 * np.abs(mean).max()


def mirror_symmetric_state(scene, rng):
    """A random state symmetric about the middle row: row R-1-i as row i with uy, vy negated, the middle row's
    uy and vy zero."""
    y = random_state(scene, rng).reshape(4, scene.rows, scene.cols)
    half = (scene.rows + 1) // 2
    for block, sign in zip(range(4), (1.0, -1.0, 1.0, -1.0)):
        y[block, scene.rows - half + 1 :] = sign * y[block, : half - 1][::-1]
        if sign < 0:
            y[block, half - 1] = 0.0
    return y.reshape(-1), half


@pytest.mark.parametrize(
    "settings",
    [dict(load_angle=30.0), dict(rows=4, cols=4), dict(rows=1, cols=2)],
    ids=lambda s: ",".join(f"{k}={v}" for k, v in s.items()),
)
def test_only_a_symmetric_lattice_is_mirrored(core, settings):
    params = params_from_scene(Scene(**settings))
    assert core.mirror_rows(params) == 0
    with pytest.raises(ValueError, match="params: the lattice does not move along x alone.*or is not mirror-symmetric"):
        core.rhs_along_x(params, np.zeros(3), True, mirrored=True)


def along_x_state(scene, rng, mirrored):
    """A random state with uy = vy = 0 (mirror-symmetric if asked), whole, and in the along-x layout."""
    if mirrored:
        y, rows = mirror_symmetric_state(scene, rng)
    else:
        y, rows = random_state(scene, rng), scene.rows
    blocks = y.reshape(4, scene.rows, scene.cols).copy()
    blocks[1] = blocks[3] = 0.0
    along = np.concatenate([blocks[0, :rows].reshape(-1), blocks[2, :rows].reshape(-1), np.zeros(3)])
    return blocks.reshape(-1), along, rows


@pytest.mark.parametrize(
    "settings",
    [
        dict(),
        dict(diagonal_rule="mean"),
        dict(rows=3, cols=4),
        dict(rows=5, cols=5, wall=False),
        dict(rows=7, cols=9, spring_law="linear"),
        dict(rows=4, cols=6),
    ],
    ids=lambda s: ",".join(f"{k}={v}" for k, v in s.items()) or "default",
)
@pytest.mark.parametrize("mirrored", [False, True])
@pytest.mark.parametrize("load_on", [True, False])
def test_the_along_x_layout_is_the_x_part_of_the_whole_lattice(core, settings, mirrored, load_on):
    rng = np.random.default_rng(23 + load_on + 2 * mirrored + len(str(settings)))
    scene = Scene(**settings)
    if mirrored and scene.rows % 2 == 0:
        pytest.skip("an even number of rows has no middle row to mirror about")
    for _ in range(5):
        scene = dataclasses.replace(scene, order=tuple(int(m) for m in rng.permutation(scene.cols) + 1))
        params = params_from_scene(scene)
        assert core.along_x(params)
        y, along, rows = along_x_state(scene, rng, mirrored)
        whole, whole_powers = core.rhs(params, y, load_on)
        got, got_powers = core.rhs_along_x(params, along, load_on, mirrored=mirrored)
        blocks = whole.reshape(4, scene.rows, scene.cols)
        assert np.all(blocks[3] == 0.0)  # nothing pushes in y
        expected = np.concatenate([blocks[0, :rows].reshape(-1), blocks[2, :rows].reshape(-1)])
        scale = np.max(np.abs(whole))
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12 * scale)
        np.testing.assert_allclose(got_powers, whole_powers, rtol=1e-11, atol=1e-11 * scale)
        if mirrored:
            assert core.mirror_rows(params) == rows
            assert core.backplate_force_mirrored(params, along) == pytest.approx(
                core.backplate_force(params, y), rel=1e-13, abs=1e-12
            )


def test_a_load_at_an_angle_does_not_move_along_x_alone(core):
    params = params_from_scene(Scene(load_angle=30.0))
    assert not core.along_x(params)
    with pytest.raises(ValueError, match="params: the lattice does not move along x alone"):
        core.rhs_along_x(params, np.zeros(3), True)
