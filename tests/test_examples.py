"""examples/armour_system.py: the armour system of three FMUs (projectile, lattice, hull) under libcosim, on a
short horizon."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from builder.system import build_system

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
if str(EXAMPLES) not in sys.path:
    sys.path.insert(0, str(EXAMPLES))

import armour_system  # noqa: E402


@pytest.fixture(scope="module")
def system_ssp(fmu_path, tmp_path_factory):
    return build_system(tmp_path_factory.mktemp("system") / "ArmourSystem.ssp", werror=True, lattice_fmu=fmu_path)


def test_the_example_prints_each_port_s_limit_beside_the_step_and_writes_the_picture(system_ssp, tmp_path, capsys):
    picture = tmp_path / "system.png"
    assert armour_system.main(["--ssp", str(system_ssp), "--horizon", "0.05", "-o", str(picture)]) == 0
    assert picture.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    out = capsys.readouterr().out
    assert "front port" in out and "back port" in out and "predicted limit" in out and "stable" in out
    assert "peak force on the backplate" in out


def test_the_example_refuses_a_bad_step_in_one_line(system_ssp, capsys):
    with pytest.raises(SystemExit) as exit_:
        armour_system.main(["--ssp", str(system_ssp), "--step", "-1"])
    assert exit_.value.code == 2
    assert "--step -1.0: allowed 0 < step <= horizon" in capsys.readouterr().err
