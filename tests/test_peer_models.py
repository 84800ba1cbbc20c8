"""The peers benchmark's right-hand sides (bench/peer_models.py) against reference/lattice.py, to 1e-12.

bench/peers.py times scipy and diffrax over these kernels against the FMU; the comparison only means
something if they compute SPEC.md (the receiver diagonal rule included). Skipped when numba or JAX is not
installed (they are the optional `bench` extra: `pip install -e .[bench]`).
"""
from __future__ import annotations

import dataclasses
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from bench.peer_models import backplate_force, pack
from reference import Scene, backplate_force as reference_backplate_force, rhs as reference_rhs

SCENES = [
    ("published sequential", Scene()),
    ("study's best", Scene(order=(1, 7, 5, 9, 3, 6, 11, 8, 2, 4, 10))),
    ("mean rule", Scene(order=(3, 1, 11, 2, 10, 4, 9, 5, 8, 6, 7), diagonal_rule="mean")),
    ("7 x 5, angled load, mass 2", Scene(rows=7, cols=5, order=(2, 5, 1, 4, 3), load_angle=30.0, mass=2.0)),
    # unequal alpha at the two ends of a diagonal: the second exp is needed
    ("4 x 6, own table", Scene(rows=4, cols=6, order=(6, 1, 5, 2, 4, 3), k=np.linspace(50, 150, 6),
                               k_diag=np.linspace(10, 60, 6), c=np.linspace(1, 6, 6),
                               alpha=np.linspace(5, 12, 6), alpha_diag=np.linspace(4, 14, 6))),
    ("no wall", Scene(rows=5, cols=5, wall=False)),
]


def random_states(scene, count=6, seed=7):
    """Displacements up to 0.1 m (exp(alpha |r|) well away from 1) with the last column pushed past the wall
    in about half the rows, velocities of both signs."""
    rng = np.random.default_rng(seed)
    N = scene.n_masses
    states = []
    for _ in range(count):
        y = np.concatenate([rng.uniform(-0.1, 0.1, 2 * N), rng.uniform(-3.0, 3.0, 2 * N)])
        wall = np.arange(scene.rows) * scene.cols + scene.cols - 1
        y[wall] += rng.choice([0.0, 0.05], scene.rows)
        y[0] = y[1]  # one spring of (near) zero length: the force must be exactly zero there, not nan
        y[N] = y[N + 1]
        states.append(y)
    return states


def assert_close(got, want):
    scale = np.max(np.abs(want))
    assert np.all(np.isfinite(got))
    assert np.max(np.abs(got - want)) <= 1e-12 * scale, np.max(np.abs(got - want)) / scale


@pytest.mark.parametrize("label, scene", SCENES, ids=[s[0] for s in SCENES])
def test_numba_rhs_matches_the_reference(label, scene):
    pytest.importorskip("numba")
    from bench.peer_models import numba_kernels

    rhs_odeint, rhs_solve_ivp, _ = numba_kernels()
    packed = pack(scene)
    for y in random_states(scene):
        for load_on in (True, False):
            want = reference_rhs(scene, 0.0, y, load_on=load_on)
            flag = 1.0 if load_on else 0.0
            assert_close(rhs_odeint(y, 0.0, flag, *packed.kernel_args()), want)
            assert_close(rhs_solve_ivp(0.0, y, flag, *packed.kernel_args()), want)


def jax_relative_errors() -> dict[str, float]:
    """Max |JAX - reference| / max |reference| per scene (run in a child process by the test below)."""
    import jax

    jax.config.update("jax_enable_x64", True)
    from bench.peer_models import jax_rhs

    compiled, errors = {}, {}
    for label, scene in SCENES:
        packed = pack(scene)
        key = (scene.rows, scene.cols, packed.equal_diagonal_alphas)
        if key not in compiled:  # one compilation per lattice shape, whatever the order or table
            compiled[key] = jax.jit(jax_rhs(*key))
        worst = 0.0
        for y in random_states(scene, count=3):
            for load_on in (True, False):
                want = reference_rhs(scene, 0.0, y, load_on=load_on)
                got = np.asarray(compiled[key](y, 1.0 if load_on else 0.0, *packed.kernel_args()))
                worst = max(worst, float(np.max(np.abs(got - want)) / np.max(np.abs(want))))
        errors[label] = worst
    return errors


def test_jax_rhs_matches_the_reference():
    """In a child process: JAX starts threads, and a later test that forks must not inherit them."""
    pytest.importorskip("jax")
    root = Path(__file__).resolve().parents[1]
    script = ("import json, sys; sys.path.insert(0, sys.argv[1]); "
              "from tests.test_peer_models import jax_relative_errors; print(json.dumps(jax_relative_errors()))")
    done = subprocess.run([sys.executable, "-c", script, str(root)], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    errors = json.loads(done.stdout.strip().splitlines()[-1])
    assert set(errors) == {label for label, _ in SCENES}
    for label, error in errors.items():
        assert error <= 1e-12, (label, error)


def test_pack_gives_the_receiver_rule_by_default_and_the_mean_on_request():
    """The diagonal constants of column pair (j, j+1): each end its own column's under the receiver rule."""
    order = (1, 7, 5, 9, 3, 6, 11, 8, 2, 4, 10)
    receiver = pack(Scene(order=order))
    mean = pack(Scene(order=order, diagonal_rule="mean"))
    k_diag = 50.0 * (2.0 / 3.0) ** (np.array(order) - 1)
    np.testing.assert_array_equal(receiver.diagonals[0], k_diag[:-1])
    np.testing.assert_array_equal(receiver.diagonals[2], k_diag[1:])
    np.testing.assert_allclose(mean.diagonals[0], 0.5 * (k_diag[:-1] + k_diag[1:]))
    np.testing.assert_array_equal(mean.diagonals[0], mean.diagonals[2])


def test_backplate_force_matches_the_reference():
    scene = dataclasses.replace(Scene(), order=(2, 1, 3, 4, 5, 6, 7, 8, 9, 10, 11))
    states = np.array(random_states(scene))
    np.testing.assert_allclose(backplate_force(pack(scene), states), reference_backplate_force(scene, states.T),
                               rtol=1e-14)
