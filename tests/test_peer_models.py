"""The peers' plate kernels (bench/peer_models.py) compute reference/lattice3d.py's right-hand side: the check
``python -m bench.peers`` runs before it times anything, on small plates, run here as a user runs it,
``python -m bench.peer_models``, in a child process (tests import nothing from bench/, and JAX's threads stay
out of the pytest process). numba and jax are benchmark-only (``pip install -e ".[bench]"``): skipped without."""

from __future__ import annotations

import importlib.util
import json
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

pytestmark = pytest.mark.skipif(
    importlib.util.find_spec("numba") is None, reason='numba is not installed (pip install -e ".[bench]")'
)


def run(*argv: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, *argv], cwd=ROOT, capture_output=True, text=True, timeout=300)


def worst_differences(line: str) -> dict[str, float]:
    """'plate against ...: numba 6.3e-16, backplate force 0.0e+00' -> {'numba': 6.3e-16, ...}."""
    return {name: float(value) for name, value in (item.rsplit(" ", 1) for item in line.split(": ", 1)[1].split(", "))}


def test_the_plate_kernel_and_backplate_force_agree_with_the_reference_on_every_check_scene():
    done = run("-m", "bench.peer_models", "--models", "plate", "--without-jax")
    assert done.returncode == 0, done.stderr[-2000:]
    line = next(line for line in done.stdout.splitlines() if line.startswith("plate against"))
    worst = worst_differences(line)
    assert set(worst) == {"numba", "backplate force"}
    assert all(value <= 1e-12 for value in worst.values()), worst


def test_the_plate_jax_kernel_agrees_with_the_reference():
    if importlib.util.find_spec("jax") is None:
        pytest.skip('jax is not installed (pip install -e ".[bench]")')
    script = textwrap.dedent("""
        from bench import peer_models
        scenes = [s for s in peer_models.plate_check_scenes() if s[0].startswith("5x4x3")]
        print(peer_models.check_plate_against_reference(scenes=scenes)["jax"])
    """)
    done = run("-c", script)
    assert done.returncode == 0, done.stderr[-2000:]
    assert float(done.stdout.split()[-1]) <= 1e-12


# the check given a kernel's arrays of another plate than the reference's, one change at a time: it must refuse
# each, in one line naming the reference (one child process: numba compiles the kernel once)
ANOTHER_PLATE = textwrap.dedent("""
    import contextlib, dataclasses, io, json
    from bench import peer_models
    packed_from = peer_models.pack_plate
    outcomes = []
    for wrong in ({"diagonal_rule": "mean"}, {"load_patch": 0}, {"c0": 4.0}):
        def pack_another(scene, wrong=wrong):
            return packed_from(dataclasses.replace(scene, **{k: v for k, v in wrong.items() if getattr(scene, k) != v}))

        peer_models.pack_plate = pack_another
        errors = io.StringIO()
        with contextlib.redirect_stderr(errors):
            code = peer_models.main(["--models", "plate", "--without-jax"])
        outcomes.append([next(iter(wrong)), code, errors.getvalue()])
    print(json.dumps(outcomes))
""")


def test_the_check_refuses_a_kernel_that_computes_another_plate():
    done = run("-c", ANOTHER_PLATE)
    assert done.returncode == 0, done.stderr[-2000:]
    outcomes = json.loads(done.stdout.splitlines()[-1])
    assert [changed for changed, _, _ in outcomes] == ["diagonal_rule", "load_patch", "c0"]
    for changed, code, message in outcomes:
        assert code == 1, changed
        assert message.startswith("error: the plate's numba right-hand side differs from reference/lattice3d.py"), (
            changed,
            message,
        )
        assert len(message.strip().splitlines()) == 1, (changed, message)
