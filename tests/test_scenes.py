"""The study's scenes as scene files: each builds, validates, carries only what it needs, and is right."""

import json

import numpy as np
import pytest
from fmpy import read_model_description
from fmpy.validation import validate_fmu
from scipy.linalg import expm

from builder import build as build_library
import reference
from orchestrator.simulation import LatticeFMU
from orchestrator import run as cli
from scenes import SCENE_DIR, Scene, scene_names

SCENES = scene_names()
# A plate (depth > 1) takes minutes to build and validate on a 2-core machine: the slow suite's.
SCENE_CASES = [pytest.param(name, marks=pytest.mark.slow) if Scene.load(name).depth > 1 else name for name in SCENES]


class BuiltScenes(dict):
    """Each scene's FMU, built the first time a test asks for it."""

    def __init__(self, folder):
        super().__init__()
        self.folder = folder

    def __missing__(self, name):
        self[name] = build_library.build_fmu(name, self.folder / f"{name}.fmu", werror=True)
        return self[name]


@pytest.fixture(scope="module")
def scene_fmus(tmp_path_factory):
    return BuiltScenes(tmp_path_factory.mktemp("scenes"))


def test_the_study_scenes_are_all_there():
    assert {"armour_11x11", "two_masses_linear", "two_masses_exponential", "free_5x5"} <= set(SCENES)


@pytest.mark.parametrize("name", SCENE_CASES)
def test_scene_builds_validates_and_hides_what_it_does_not_need(scene_fmus, name):
    path = scene_fmus[name]
    assert validate_fmu(str(path)) == []
    scene = Scene.load(name)
    names = {v.name for v in read_model_description(str(path)).modelVariables}
    for hidden in scene.hidden:
        assert hidden not in names and f"{hidden}[1]" not in names
    assert float(read_model_description(str(path)).defaultExperiment.stopTime) == scene.horizon


def test_two_masses_with_a_linear_spring_follow_the_exact_solution(scene_fmus):
    """Linear springs and dampers: the solution is a matrix exponential, independent of any integrator."""
    k, c, mass, force, duration, horizon = 100.0, 5.0, 1.0, 100.0, 0.15, 2.0
    with LatticeFMU(scene_fmus["two_masses_linear"]) as fmu:
        result = fmu.simulate(
            None,
            horizon=horizon,
            outputs=("ux_corner", "ux_right_edge", "kinetic_energy", "external_work", "energy_balance_error"),
        )
    # state (x1, x2, v1, v2): x1'' = (k (x2 - x1) + c (v2 - v1) + F) / m, x2'' = -(same internal force) / m
    masses = np.array([1, 1, mass, mass])[:, None]
    system = np.array([[0, 0, 1, 0], [0, 0, 0, 1], [-k, k, -c, c], [k, -k, c, -c]]) / masses
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
    scene = Scene.load(name)
    with LatticeFMU(scene_fmus[name]) as fmu:
        result = fmu.simulate(None, horizon=scene.horizon)
    total_mass = scene.rows * scene.cols
    impulse = scene.parameters.get("F_total", 1200.0) * 0.15
    translation = 0.5 * impulse**2 / total_mass  # kinetic energy of the centre of mass alone
    assert result["kinetic_energy"] >= translation * (1 - 1e-9)
    assert result["kinetic_energy"] < translation + result["external_work"]
    assert abs(result["energy_balance_error"]) < 1e-6 * result["external_work"]
    assert result["peak_backplate_force"] == 0.0  # no backplate in a free scene


def test_a_scene_without_materials_to_order_is_refused_by_the_orchestrator(scene_fmus, tmp_path, capfd):
    code = cli.main(
        [
            "--method",
            "random",
            "--budget",
            "2",
            "--repeats",
            "1",
            "--executor",
            "serial",
            "--out",
            str(tmp_path / "out"),
            "--fmu",
            str(scene_fmus["free_5x5"]),
            "--scene",
            "free_5x5",
            "--no-progress",
        ]
    )
    err = capfd.readouterr().err
    assert code == 2 and "no material order to search" in err and len(err.strip().splitlines()) == 1, err


def test_unknown_scene_names_the_known_ones():
    with pytest.raises(ValueError, match="armour_11x11"):
        Scene.load("armour_12x12")


def test_scene_files_have_only_known_keys():
    for name in SCENES:
        data = json.loads((SCENE_DIR / f"{name}.json").read_text())
        assert set(data) <= set(Scene.__dataclass_fields__)


def crafted_scene(tmp_path, key, value):
    """The two-mass scene's file with one key set to ``value``."""
    data = json.loads((SCENE_DIR / "two_masses_linear.json").read_text())
    data[key] = value
    path = tmp_path / "crafted.json"
    path.write_text(json.dumps(data))
    return path


@pytest.mark.parametrize(
    "key, value",
    [
        ("model_identifier", "../../outside"),
        ("model_identifier", "a/b"),
        ("model_identifier", "9lives"),
        ("model_identifier", ""),
        ("name", "x.json"),
        ("name", ".."),
    ],
)
def test_scene_names_and_identifiers_must_be_identifiers(tmp_path, key, value):
    path = crafted_scene(tmp_path, key, value)
    with pytest.raises(ValueError, match=rf"^scene {key} .* must be .*\[A-Za-z_\]\[A-Za-z0-9_\]\*") as refused:
        Scene.load(path)
    assert "\n" not in str(refused.value)


@pytest.mark.parametrize(
    "key, value, allowed",
    [
        ("cols", 65, "an integer from 1 to 64"),
        ("cols", 0, "from 1 to 64"),
        ("cols", 2.5, "an integer"),
        ("rows", 0, "at least 1"),
        ("depth", 0, "at least 1"),
    ],
)
def test_a_scene_file_with_a_lattice_size_out_of_range_is_refused_in_one_line(tmp_path, key, value, allowed):
    path = crafted_scene(tmp_path, key, value)
    with pytest.raises(ValueError, match=rf"^scene two_masses_linear: {key} must be .*{allowed}") as refused:
        Scene.load(path)
    assert "\n" not in str(refused.value)


def test_build_fmu_refuses_an_identifier_changed_after_loading():
    scene = Scene.load("two_masses_linear")
    scene.model_identifier = "../../outside"
    with pytest.raises(ValueError, match="model_identifier '../../outside' is not allowed"):
        build_library.build_fmu(scene)
    assert not (build_library.MODELS_DIR / "../../outside.fmu").exists()


@pytest.mark.parametrize("name", ["../scenes/armour_11x11", "/etc/passwd", "armour 11x11"])
def test_a_scene_name_that_is_not_an_identifier_is_refused(name):
    with pytest.raises(ValueError, match="is not allowed: give one of"):
        Scene.load(name)


def test_a_scene_file_outside_the_scenes_folder_loads_by_its_path(tmp_path):
    data = dict(
        json.loads((SCENE_DIR / "two_masses_linear.json").read_text()), name="mine", model_identifier="MyTwoMasses"
    )
    (tmp_path / "mine.json").write_text(json.dumps(data))
    scene = Scene.load(str(tmp_path / "mine.json"))
    assert (scene.name, scene.model_identifier, scene.rows, scene.cols) == ("mine", "MyTwoMasses", 1, 2)


def test_the_reference_model_reads_the_same_scene_descriptions():
    """reference.Scene.from_description: the oracle's parameters are the scene's (and the FMU's defaults)."""
    assert reference.Scene.from_description("armour_11x11").__dict__.keys() == reference.Scene().__dict__.keys()
    armour, default = reference.Scene.from_description("armour_11x11"), reference.Scene()
    for field in (
        "rows",
        "cols",
        "order",
        "k0",
        "alpha0",
        "c0",
        "mass",
        "F_total",
        "load_angle",
        "t_active",
        "wall",
        "k_wall",
        "c_wall",
        "backplate_gap",
        "diagonal_rule",
        "spring_law",
    ):
        assert getattr(armour, field) == getattr(default, field), field
    for field in ("k", "k_diag", "c", "alpha", "alpha_diag"):
        np.testing.assert_array_equal(getattr(armour, field), getattr(default, field))
    linear = reference.Scene.from_description(Scene.load("two_masses_linear"))
    assert (linear.rows, linear.cols, linear.spring_law, linear.wall, linear.F_total) == (1, 2, "linear", False, 100.0)
    free = reference.Scene.from_description("free_5x5")  # one material in every column
    assert free.order == (1,) * 5 and not free.wall and list(free.k_diag) == [50.0]
