"""The peers' plate kernels (bench/peer_models.py) compute reference/lattice3d.py's right-hand side: the check
``python -m bench.peers`` runs before it times anything, on small plates. numba and jax are benchmark-only
(``pip install -e ".[bench]"``): the tests are skipped without them."""
from __future__ import annotations

import dataclasses

import pytest

pytest.importorskip("numba")

from bench import peer_models  # noqa: E402


def test_the_plate_kernel_and_backplate_force_agree_with_the_reference_on_every_check_scene():
    worst = peer_models.check_plate_against_reference(with_jax=False)
    assert set(worst) == {"numba", "backplate force"}
    assert all(value <= peer_models.KERNEL_TOLERANCE for value in worst.values()), worst


def test_the_plate_jax_kernel_agrees_with_the_reference():
    pytest.importorskip("jax")
    scenes = [s for s in peer_models.plate_check_scenes() if s[0].startswith("5x4x3")]
    worst = peer_models.check_plate_against_reference(scenes=scenes)
    assert worst["jax"] <= peer_models.KERNEL_TOLERANCE, worst


@pytest.mark.parametrize("wrong", [
    {"diagonal_rule": "mean"},  # the other diagonal rule
    {"load_patch": 0},  # the whole face instead of the patch
    {"c0": 4.0},  # another damping between columns
], ids=lambda wrong: next(iter(wrong)))
def test_the_check_refuses_a_kernel_that_computes_another_plate(monkeypatch, wrong):
    packed_from = peer_models.pack_plate

    def pack_another(scene):
        changed = {key: value for key, value in wrong.items() if getattr(scene, key) != value}
        return packed_from(dataclasses.replace(scene, **changed))

    monkeypatch.setattr(peer_models, "pack_plate", pack_another)
    with pytest.raises(ValueError, match="differs from reference/lattice3d.py"):
        peer_models.check_plate_against_reference(with_jax=False)


def test_the_face_weights_are_the_models_and_sum_to_one():
    whole = peer_models.face_weights(rows=3, depth=5, patch=0)
    assert whole.shape == (5, 3)
    assert whole.sum() == pytest.approx(1.0, rel=1e-15)
    assert whole[0, 0] == pytest.approx(whole[2, 1] / 4, rel=1e-15)  # a corner a quarter of an inner mass
    patch = peer_models.face_weights(rows=5, depth=3, patch=3)
    assert (patch[:, 1:4] > 0).all() and patch[:, [0, 4]].sum() == 0
