"""The orchestrator under a projectile (docs/model.md section 11): the same study, the load a body that answers
back; options of the other load refused in one line, the pulse's known optima never claimed for it."""

from __future__ import annotations

import json
import tomllib
from types import SimpleNamespace

import pytest

from orchestrator import run as cli
from command_line import main, one_line
from orchestrator.fmu import describe
from orchestrator.known_optima import known_optimum
from orchestrator.options import config_from
from orchestrator.objective import SEARCH_HORIZON, SEARCH_RTOL
from orchestrator.scene import departures_from_the_study, resolve
from orchestrator.ssp import read_design_parameters
from orchestrator.study import PROJECTILE, CaseConfig, resolve_case, search_fidelity
from orchestrator.studyfile import read_study_file, write_study_file
from scenes import PROJECTILE_SCENE, Scene

QUICK = [
    "--budget",
    "12",
    "--repeats",
    "1",
    "--method",
    "cmaes",
    "sequential",
    "--no-sensitivity",
    "--no-progress",
    "--executor",
    "serial",
]


def case_of(fmu_path, **options):
    """The case ``options`` give on the armour FMU, resolved as a run resolves it."""
    parser = cli.build_parser()
    argv = ["--fmu", str(fmu_path)]
    for name, value in options.items():
        argv += [f"--{name.replace('_', '-')}", str(value)]
    config = config_from(CaseConfig, parser.parse_args(argv))
    return resolve_case(config, resolve(config))


@pytest.mark.parametrize(
    "argv, named",
    [
        (["--load-mode", "input"], "--load-mode input: input mode needs a co-simulation master"),
        (["--projectile-mass", "60"], "--projectile-mass: only under a projectile"),
        (["--contact-damping", "0.1", "--load-mode", "pulse"], "--contact-damping: only under a projectile"),
        (["--load-mode", "projectile", "--load", "600"], "--load: the pulse's F_total does nothing under a projectile"),
        (["--load-mode", "projectile", "--case", "t_active=0.1,0.2"], "--case t_active: the pulse's t_active"),
        (["--case", "load_mode=pulse,input"], "--case load_mode input"),
        (["--load-mode", "projectile", "--projectile-speed", "-1"], "--projectile-speed"),
        (["--load-mode", "projectile", "--projectile-mass", "0"], "--projectile-mass"),
    ],
)
def test_options_of_the_other_load_are_refused_in_one_line(fmu_path, tmp_path, capfd, argv, named):
    code = main(*argv, "--fmu", fmu_path, "--out", tmp_path / "out", *QUICK)
    line = one_line(capfd)
    assert code == 2 and named in line, line
    assert not (tmp_path / "out").exists()


def test_the_case_names_the_projectile_and_claims_no_known_optimum_of_the_pulse(fmu_path):
    pulse = case_of(fmu_path)
    assert known_optimum(pulse, "receiver") is not None  # the study's own case: its certified optimum
    struck = case_of(fmu_path, load_mode=PROJECTILE, projectile_mass=60)
    assert struck.load_mode == PROJECTILE and struck.parameters["load_mode"] == PROJECTILE
    assert struck.parameters["projectile_mass"] == 60.0
    for rule in ("receiver", "mean"):
        assert known_optimum(struck, rule) is None
    description = struck.describe(describe(fmu_path, 11))
    assert "F_total" not in description.load and description.load["projectile_mass"] == 60.0
    line = description.line()
    speed = describe(fmu_path, 11).start("projectile_speed")
    assert f"struck by a 60 kg projectile at {speed:g} m/s" in line and "load 1200 N" not in line


def test_the_projectile_scene_departs_from_the_study_and_carries_its_search_fidelity(fmu_path, tmp_path):
    from builder import build

    scene = Scene.load(PROJECTILE_SCENE)
    assert scene.parameters["load_mode"] == 2 and scene.model_identifier != Scene.load("armour_11x11").model_identifier
    struck = build.build_fmu(PROJECTILE_SCENE, tmp_path / "projectile.fmu")
    prepared = describe(struck, 11)
    assert prepared.start("load_mode") == PROJECTILE
    assert departures_from_the_study(prepared) == ("load_mode",)
    own_config = CaseConfig(scene=PROJECTILE_SCENE, fmu=str(struck))
    own = resolve_case(own_config, resolve(own_config))
    assert own.load_mode == PROJECTILE and own.parameters == {} and known_optimum(own, "receiver") is None
    fidelity = search_fidelity(PROJECTILE)
    assert (fidelity.horizon, fidelity.rtol) == (scene.search_horizon, scene.search_rtol)
    assert (own.search_horizon, own.search_rtol) == (scene.search_horizon, scene.search_rtol)
    # the same projectile on the armour FMU, by --load-mode: the projectile's search fidelity, not the pulse's
    struck = case_of(fmu_path, load_mode=PROJECTILE)
    assert (struck.search_horizon, struck.search_rtol) == (scene.search_horizon, scene.search_rtol)
    pulse = case_of(fmu_path)
    assert (pulse.search_horizon, pulse.search_rtol) == (SEARCH_HORIZON, SEARCH_RTOL)
    given = case_of(fmu_path, load_mode=PROJECTILE, search_horizon=0.5, search_rtol=1e-5)
    assert (given.search_horizon, given.search_rtol) == (0.5, 1e-5)
    mixed = case_of(fmu_path, case="load_mode=pulse,projectile")  # the longest horizon, the tightest tolerance
    assert (mixed.search_horizon, mixed.search_rtol) == (scene.search_horizon, scene.search_rtol)


def test_the_projectile_options_round_trip_through_the_study_file(tmp_path):
    case = CaseConfig(
        load_mode=PROJECTILE,
        projectile_mass=60.0,
        projectile_speed=3.0,
        contact_stiffness=2e6,
        contact_exponent=1.5,
        contact_damping=0.1,
    )
    path = write_study_file(tmp_path, {CaseConfig: case}, "0" * 64, "1" * 64)
    written = tomllib.loads(path.read_text())["case"]
    assert written["load-mode"] == PROJECTILE and written["projectile-mass"] == 60.0
    assert read_study_file(path).values == {
        "CaseConfig.load_mode": PROJECTILE,
        "CaseConfig.projectile_mass": 60.0,
        "CaseConfig.projectile_speed": 3.0,
        "CaseConfig.contact_stiffness": 2e6,
        "CaseConfig.contact_exponent": 1.5,
        "CaseConfig.contact_damping": 0.1,
    }


def test_a_study_under_a_projectile_answers_and_draws_the_contact_force_on_its_first_screen(fmu_path, tmp_path, capfd):
    out = tmp_path / "results"
    code = main(
        "--fmu",
        fmu_path,
        "--out",
        out,
        "--load-mode",
        "projectile",
        "--projectile-mass",
        "60",
        "--diagonal-rule",
        "receiver",
        *QUICK,
    )
    printed = capfd.readouterr()
    assert code == 0, printed.err
    results = json.loads((out / "results.json").read_text())
    (answer,) = results["answers"]
    assert answer["evidence"]["status"] == "best_found"  # the pulse's certificate is not the projectile's
    assert results["case"]["load"]["load_mode"] == PROJECTILE and results["case"]["load"]["projectile_mass"] == 60.0
    assert "60 kg projectile" in printed.out
    from orchestrator.simulation import LatticeFMU

    with LatticeFMU(fmu_path) as fmu:  # the answer is the FMU's peak under that projectile
        peak = fmu.simulate(
            answer["order"], 8.0, {"diagonal_rule": "receiver", "load_mode": PROJECTILE, "projectile_mass": 60.0}
        )["peak_backplate_force"]
        pulse = fmu.simulate(answer["order"], 8.0, {"diagonal_rule": "receiver"})["peak_backplate_force"]
    assert peak == pytest.approx(answer["peak"], rel=1e-9) and abs(peak / pulse - 1) > 1e-6
    html = (out / "report.html").read_text()
    first = html[: html.index("<h2", html.index("<h2") + 1)]  # up to the second section's heading
    assert "60 kg projectile" in first and 'data-chart="impact.png"' in first and (out / "impact.png").is_file()
    force = results["steps"]["trajectories"]["force"][0]["trajectory"]["values"]
    assert set(force) == {"backplate_force", "contact_force"} and max(force["contact_force"]) > 0
    speed = describe(fmu_path, 11).start("projectile_speed")  # what is put in: the body's kinetic energy
    energy = answer["energy_by_rule"]["receiver"]
    assert energy["external_work"] == pytest.approx(0, abs=1e-9)
    assert energy["start_energy"] == pytest.approx(0.5 * 60.0 * speed**2)
    assert results["design_files_refused"] == {}  # the design file carries the projectile
    design = read_design_parameters(out / answer["design_file"])
    assert design["load_mode"] == 2 and design["projectile_mass"] == 60.0
    assert [design[f"material[{j}]"] for j in range(1, 12)] == answer["order"]
    study = read_study_file(out / "study.toml")
    assert study.values["CaseConfig.load_mode"] == PROJECTILE
    assert study.values["CaseConfig.projectile_mass"] == 60.0


def test_sensitivity_under_a_projectile_varies_the_projectile_not_the_pulse(fmu_path):
    from orchestrator.steps.sensitivity import variations

    struck = case_of(fmu_path, load_mode=PROJECTILE)
    prepared = describe(fmu_path, 11)
    found = variations(SimpleNamespace(fmu=prepared, case=struck), "mean")
    mass, speed = prepared.start("projectile_mass"), prepared.start("projectile_speed")
    assert found["projectile mass 2x"] == {"projectile_mass": 2 * mass}
    assert found["projectile speed 0.5x"] == {"projectile_speed": 0.5 * speed}
    assert found["receiver diagonal rule"] == {"diagonal_rule": "receiver"}
    assert not any(set(change) & {"F_total", "t_active", "load_angle"} for change in found.values())
    assert "load 2x" in variations(SimpleNamespace(fmu=prepared, case=case_of(fmu_path)), "mean")


def test_a_sweep_under_a_projectile_certifies_its_own_optimum(armour_fmu_of_width, tmp_path, capfd):
    out = tmp_path / "results"
    code = main(
        "--fmu",
        armour_fmu_of_width(5),
        "--cols",
        5,
        "--out",
        out,
        "--load-mode",
        "projectile",
        "--method",
        "exhaustive",
        "--diagonal-rule",
        "mean",
        "--no-sensitivity",
        "--no-progress",
        "--executor",
        "serial",
    )
    assert code == 0, capfd.readouterr().err
    results = json.loads((out / "results.json").read_text())
    (answer,) = results["answers"]
    assert (
        answer["evidence"]["status"] == "certified"
        and "this run's exhaustive sweep" in answer["evidence"]["status_source"]
    )
    certificate = json.loads((out / "exhaustive" / "certificate.json").read_text())
    assert certificate["certified"] and certificate["optimum"]["order"] == answer["order"]


def test_one_order_for_the_pulse_and_the_projectile_is_the_worst_of_both(fmu_path, tmp_path, capfd):
    out = tmp_path / "results"
    code = main(
        "--fmu",
        fmu_path,
        "--out",
        out,
        "--case",
        "load_mode=pulse,projectile",
        "--aggregate",
        "worst",
        "--diagonal-rule",
        "receiver",
        *QUICK,
    )
    assert code == 0, capfd.readouterr().err
    (answer,) = json.loads((out / "results.json").read_text())["answers"]
    from orchestrator.simulation import LatticeFMU

    with LatticeFMU(fmu_path) as fmu:
        peaks = [
            fmu.simulate(answer["order"], 8.0, {"diagonal_rule": "receiver", "load_mode": mode})["peak_backplate_force"]
            for mode in ("pulse", "projectile")
        ]
    assert answer["peak"] == pytest.approx(max(peaks), rel=1e-9)
