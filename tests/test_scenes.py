"""The study's scenes as scene files: each builds, validates, carries only what it needs, and is right."""
import json

import numpy as np
import pytest
from fmpy import read_model_description
from fmpy.validation import validate_fmu
from scipy.linalg import expm

import build_fmu
from orchestrator.simulation import LatticeFMU
from orchestrator.study import StudyConfig, run_study

SCENES = sorted(p.stem for p in build_fmu.SCENE_DIR.glob("*.json"))


@pytest.fixture(scope="module")
def scene_fmus(tmp_path_factory):
    folder = tmp_path_factory.mktemp("scenes")
    return {name: build_fmu.build_fmu(name, folder / f"{name}.fmu", werror=True) for name in SCENES}


def test_the_study_scenes_are_all_there():
    assert {"armour_11x11", "two_masses_linear", "two_masses_exponential", "free_5x5"} <= set(SCENES)


@pytest.mark.parametrize("name", SCENES)
def test_scene_builds_validates_and_hides_what_it_does_not_need(scene_fmus, name):
    path = scene_fmus[name]
    assert validate_fmu(str(path)) == []
    scene = build_fmu.Scene.load(name)
    names = {v.name for v in read_model_description(str(path)).modelVariables}
    for hidden in scene.hidden:
        assert hidden not in names and f"{hidden}[1]" not in names
    assert float(read_model_description(str(path)).defaultExperiment.stopTime) == scene.horizon


def test_two_masses_with_a_linear_spring_follow_the_exact_solution(scene_fmus):
    """Linear springs and dampers: the solution is a matrix exponential, independent of any integrator."""
    k, c, mass, force, duration, horizon = 100.0, 5.0, 1.0, 100.0, 0.15, 2.0
    with LatticeFMU(scene_fmus["two_masses_linear"]) as fmu:
        result = fmu.simulate(None, horizon=horizon, outputs=("ux_corner", "ux_right_edge", "kinetic_energy",
                                                               "external_work", "energy_balance_error"))
    # state (x1, x2, v1, v2): x1'' = (k (x2 - x1) + c (v2 - v1) + F) / m, x2'' = -(same internal force) / m
    system = np.array([[0, 0, 1, 0], [0, 0, 0, 1], [-k, k, -c, c], [k, -k, c, -c]]) / np.array([1, 1, mass, mass])[:, None]
    augmented = np.zeros((5, 5))  # the constant force as a fifth state
    augmented[:4, :4] = system
    augmented[2, 4] = force / mass
    loaded = expm(augmented * duration) @ np.array([0, 0, 0, 0, 1.0])
    final = expm(system * (horizon - duration)) @ loaded[:4]
    assert result["ux_corner"] == pytest.approx(final[0], rel=1e-6)
    assert result["ux_right_edge"] == pytest.approx(final[1], rel=1e-6)
    # momentum F t_active is shared by both masses: the centre of mass moves at F t / (2 m)
    assert result["kinetic_energy"] >= 0.5 * 2 * mass * (force * duration / (2 * mass)) ** 2 * (1 - 1e-9)
    assert abs(result["energy_balance_error"]) < 1e-6 * result["external_work"]


@pytest.mark.parametrize("name", ["two_masses_exponential", "free_5x5"])
def test_free_scenes_conserve_momentum_and_energy(scene_fmus, name):
    scene = build_fmu.Scene.load(name)
    with LatticeFMU(scene_fmus[name]) as fmu:
        result = fmu.simulate(None, horizon=scene.horizon)
    total_mass = scene.rows * scene.cols
    impulse = scene.parameters.get("F_total", 1200.0) * 0.15
    translation = 0.5 * impulse ** 2 / total_mass  # kinetic energy of the centre of mass alone
    assert result["kinetic_energy"] >= translation * (1 - 1e-9)
    assert result["kinetic_energy"] < translation + result["external_work"]
    assert abs(result["energy_balance_error"]) < 1e-6 * result["external_work"]
    assert result["peak_backplate_force"] == 0.0  # no backplate in a free scene


def test_a_scene_without_materials_to_order_is_refused_by_the_orchestrator(scene_fmus, tmp_path):
    config = StudyConfig(methods=("random",), budget=2, repeats=1, executor="serial", out=str(tmp_path),
                         fmu=str(scene_fmus["free_5x5"]), scene="free_5x5", progress=False)
    with pytest.raises(ValueError, match="no material order to search"):
        run_study(config)


def test_unknown_scene_names_the_known_ones():
    with pytest.raises(ValueError, match="armour_11x11"):
        build_fmu.Scene.load("armour_12x12")


def test_scene_files_have_only_known_keys():
    for name in SCENES:
        data = json.loads((build_fmu.SCENE_DIR / f"{name}.json").read_text())
        assert set(data) <= set(build_fmu.Scene.__dataclass_fields__)
