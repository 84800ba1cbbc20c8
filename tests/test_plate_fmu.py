"""The FMU built as a plate (docs/model.md section 10): a 5 x 5 x 5 FMU against the independent
numpy/scipy reference (reference/plate_5x5x5_reference.json, written by reference/lattice3d.py), the mirror
symmetry in y and z against the whole plate, both FMI versions through fmpy's validator, Model Exchange through
fmpy's CVode, and the refusals of load_patch. Depth 1 keeps its numbers: tests/test_recorded_outputs.py.
"""

from __future__ import annotations

import json
import zipfile
from xml.etree import ElementTree
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu
from fmpy.validation import validate_fmu

from builder import build as build_fmu
from fmu_src.variables import make_interface
from orchestrator.simulation import LatticeFMU, SimulationError, model_description, start_values
from scenes import Scene

REFERENCE = json.loads((Path(__file__).resolve().parents[1] / "reference" / "plate_5x5x5_reference.json").read_text())
CASES = REFERENCE["cases"]
ROWS = COLS = DEPTH = 5
PEAKS = ("peak_backplate_force", "peak_backplate_force_continuous", "max_compression")
ENERGIES = ("kinetic_energy", "external_work", "dissipated_energy", "nonreciprocal_work")
# The reference integrates at rtol 1e-12; the FMU's DOP853 at the same tolerance agrees to far better than 1e-7.
TIGHT = {"rtol": 1e-12, "atol": 1e-12}


@pytest.fixture(scope="module")
def plate_fmu(tmp_path_factory):
    return build_fmu.build_fmu(
        "armour_11x11",
        tmp_path_factory.mktemp("plate") / "Plate5x5x5.fmu",
        rows=ROWS,
        cols=COLS,
        depth=DEPTH,
        werror=True,
    )


@pytest.fixture(scope="module")
def plate_fmu3(tmp_path_factory):
    return build_fmu.build_fmu(
        "armour_11x11",
        tmp_path_factory.mktemp("plate3") / "Plate5x5x5-fmi3.fmu",
        rows=ROWS,
        cols=COLS,
        depth=DEPTH,
        werror=True,
        fmi_version=3,
    )


def case_start(case) -> dict:
    scene = case["scene"]
    assert (scene["rows"], scene["cols"], scene["depth"]) == (ROWS, COLS, DEPTH)
    start = {f"material[{j}]": m for j, m in enumerate(scene["order"], start=1)}
    start.update(load_patch=scene["load_patch"], diagonal_rule={"receiver": 0, "mean": 1}[scene["diagonal_rule"]])
    return start


def co_simulation(fmu, start: dict, names=PEAKS + ENERGIES) -> dict:
    result = simulate_fmu(
        str(fmu),
        stop_time=REFERENCE["horizon"],
        output_interval=REFERENCE["horizon"],
        start_values=start_values(model_description(fmu), start),
        output=list(names),
    )
    return {name: float(result[name][-1]) for name in names}


def test_the_plate_fmu_is_built_from_the_reference_scene():
    """The reference's scene is the study's first five materials with the FMU's defaults: same table, same load."""
    scene = CASES[0]["scene"]
    values = Scene(name="plate", rows=ROWS, cols=COLS, depth=DEPTH).parameter_values()
    assert values["k"] == pytest.approx(scene["k"], rel=1e-15)
    assert values["k_diag"] == pytest.approx(scene["k_diag"], rel=1e-15)
    assert values["c"] == pytest.approx(scene["c"], rel=1e-15)
    for name, key in (
        ("F_total", "F_total"),
        ("t_active", "t_active"),
        ("k_wall", "k_wall"),
        ("c_wall", "c_wall"),
        ("backplate_gap", "backplate_gap"),
        ("k_horizontal", "k0"),
        ("alpha_horizontal", "alpha0"),
        ("c_horizontal", "c0"),
        ("load_angle", "load_angle"),
    ):
        assert values[name] == scene[key], name
    assert values["mass"] == (scene["mass"],) * len(values["k"])  # every material's node mass, the scene's one


@pytest.mark.parametrize("case", CASES, ids=[case["name"] for case in CASES])
def test_the_plate_fmu_reproduces_the_numpy_reference(plate_fmu, case):
    """Both rules, whole face and patch, both orders: peaks and energies to 1e-7 of the reference's."""
    outputs = co_simulation(plate_fmu, {**case_start(case), **TIGHT})
    for name in PEAKS + ENERGIES:
        assert outputs[name] == pytest.approx(case[name], rel=1e-7), name


@pytest.mark.parametrize("case", CASES, ids=[case["name"] for case in CASES])
def test_the_quarter_plate_gives_the_whole_plates_peaks(plate_fmu, case):
    """use_symmetry integrates a quarter of the plate (mirrored in y and z) with the whole plate's steps."""
    start = case_start(case)
    quarter = co_simulation(plate_fmu, {**start, "use_symmetry": 1})
    whole = co_simulation(plate_fmu, {**start, "use_symmetry": 0})
    for name in PEAKS:
        assert quarter[name] == pytest.approx(whole[name], rel=1e-9), name


def test_a_plate_declares_six_components_per_mass_and_one_indicator_pair_per_face_mass(plate_fmu, plate_fmu3):
    masses = ROWS * COLS * DEPTH
    for fmu in (plate_fmu, plate_fmu3):
        description = read_model_description(str(fmu))
        assert description.modelExchange is not None and description.coSimulation is not None
        assert len(description.derivatives) == 6 * masses + 3 + 2  # with projectile mode's body
        assert description.numberOfEventIndicators == 2 * ROWS * DEPTH + 1  # and the impact
        names = {variable.name for variable in description.modelVariables}
        assert {"uz[5,5,5]", "vz[1,1,1]", "der(vz[3,3,3])", "contact_indicator[25]", "load_patch"} <= names


@pytest.mark.parametrize("which", ["fmi2", "fmi3"])
def test_fmpy_validates_the_plate_fmu(plate_fmu, plate_fmu3, which):
    assert validate_fmu(str(plate_fmu if which == "fmi2" else plate_fmu3)) == []


def test_the_plotted_masses_are_in_the_middle_slice(plate_fmu):
    """ux_centre is the middle mass of the middle slice along z: mass (k R + i) C + j with i, j, k the middles."""
    names = (
        "ux_centre",
        "ux_left_edge",
        "ux_corner",
        "ux_right_edge",
        "ux[3,3,3]",
        "ux[3,3,1]",
        "ux[3,1,1]",
        "ux[3,3,5]",
    )
    result = simulate_fmu(str(plate_fmu), stop_time=0.2, output_interval=0.05, output=list(names))
    assert np.array_equal(result["ux_centre"], result["ux[3,3,3]"])
    assert np.array_equal(result["ux_left_edge"], result["ux[3,3,1]"])
    assert np.array_equal(result["ux_corner"], result["ux[3,1,1]"])
    assert np.array_equal(result["ux_right_edge"], result["ux[3,3,5]"])
    assert np.abs(result["ux_centre"]).max() > 0.0


def model_exchange_peak(fmu, start: dict, stop_time: float) -> float:
    result = simulate_fmu(
        str(fmu),
        fmi_type="ModelExchange",
        solver="CVode",
        relative_tolerance=1e-9,
        output_interval=0.01,
        stop_time=stop_time,
        start_values=start_values(model_description(fmu), start),
        output=["backplate_force"],
    )
    on_grid = np.abs(result["time"] / 0.01 - np.round(result["time"] / 0.01)) < 1e-9
    return float(result["backplate_force"][on_grid].max())


# The peaks come at about 0.15 s: a 1 s run reaches them.
EXCHANGE_CASES = [
    pytest.param(case, marks=[] if index == 1 else pytest.mark.slow, id=case["name"])
    for index, case in enumerate(CASES)
]


@pytest.mark.parametrize("case", EXCHANGE_CASES)
def test_model_exchange_through_cvode_gives_the_reference_peak(plate_fmu, case):
    assert case["peak_sample_time"] < 1.0
    peak = model_exchange_peak(plate_fmu, case_start(case), stop_time=1.0)
    assert peak == pytest.approx(case["peak_backplate_force"], rel=1e-6)


@pytest.mark.slow
def test_fmi3_model_exchange_through_cvode_gives_the_reference_peak(plate_fmu3):
    case = CASES[1]
    peak = model_exchange_peak(plate_fmu3, case_start(case), stop_time=1.0)
    assert peak == pytest.approx(case["peak_backplate_force"], rel=1e-6)


@pytest.mark.parametrize(
    "patch, why",
    [(2, "load_patch = 2: allowed 0 (the whole face) or an odd side P"), (6, "load_patch = 6 is not allowed")],
)
def test_a_patch_the_plate_cannot_take_is_refused_in_one_line(plate_fmu, patch, why):
    with LatticeFMU(plate_fmu) as fmu, pytest.raises(SimulationError) as error:
        fmu.simulate(horizon=0.1, parameters={"load_patch": patch})
    assert why in str(error.value) and "\n" not in str(error.value), str(error.value)


def test_a_patch_needs_odd_rows_and_depth_at_build_time():
    with pytest.raises(ValueError, match=r"load_patch = 3 is not allowed for 4 rows and depth 5"):
        make_interface(4, 5, {"load_patch": 3}, depth=5)
    assert make_interface(5, 5, {"load_patch": 3}, depth=5).depth == 5


def test_the_plate_scene_is_the_study_in_eleven_layers_under_a_3x3_patch():
    scene = Scene.load("plate_11x11x11")
    assert (scene.rows, scene.cols, scene.depth) == (11, 11, 11)
    values = scene.parameter_values()
    assert values["load_patch"] == 3
    armour = Scene.load("armour_11x11").parameter_values()
    assert {k: v for k, v in values.items() if k != "load_patch"} == {
        k: v for k, v in armour.items() if k != "load_patch"
    }
    interface = scene.interface()
    states = sum(v.count for v in interface.exposed if v.role == "state")
    assert states == 6 * 11 * 11 * 11 + 3 + 2
    assert interface.event_indicator_count() == 2 * 11 * 11 + 1


def test_the_depth_one_fmu_reads_load_patch_and_keeps_its_sizes(fmu_path):
    description = read_model_description(str(fmu_path))
    assert len(description.derivatives) == 4 * 11 * 11 + 3 + 2
    assert description.numberOfEventIndicators == 2 * 11 + 1
    with zipfile.ZipFile(fmu_path) as archive:
        header = archive.read("sources/model_variables.h").decode()
    assert "#define LATTICE_DEPTH 1" in header


def test_run_refuses_a_given_fmu_whose_plate_is_not_the_scenes(plate_fmu, tmp_path, capfd):
    """--fmu of a 5 x 5 x 5 plate with the scene resized to 5 columns but 11 rows and depth 1: refused in one line."""
    from orchestrator.run import main

    code = main(
        [
            "--fmu",
            str(plate_fmu),
            "--cols",
            "5",
            "--out",
            str(tmp_path / "out"),
            "--no-progress",
            "--no-sensitivity",
            "--budget",
            "1",
        ]
    )
    line = capfd.readouterr().err.strip()
    assert code == 2 and "\n" not in line, line
    assert "its lattice is 5 x 5 x 5 (rows x columns x depth), scene armour_11x11's 11 x 5" in line, line
    assert "a scene of 5 rows" in line, line
    assert not (tmp_path / "out").exists()


def test_run_names_a_given_plates_size_read_from_the_fmu(plate_fmu, tmp_path, capfd):
    """--fmu of a 5 x 5 x 5 plate with the default 11 x 11 scene: the FMU's own size, as its model description
    declares it."""
    from orchestrator.run import main

    code = main(
        ["--fmu", str(plate_fmu), "--out", str(tmp_path / "out"), "--no-progress", "--no-sensitivity", "--budget", "1"]
    )
    line = capfd.readouterr().err.strip()
    assert code == 2 and "\n" not in line, line
    assert "its lattice is 5 x 5 x 5 (rows x columns x depth), scene armour_11x11's 11 x 11 (rows x columns)" in line
    assert not (tmp_path / "out").exists()


def test_a_design_file_of_a_plate_carries_its_patch(plate_fmu, tmp_path):
    """The design a run writes opens in another tool with the same patch (the run's parameters go in it)."""
    from orchestrator.ssp import read_design_parameters, write_best_design_ssp

    path = tmp_path / "best_design.ssp"
    write_best_design_ssp(
        plate_fmu,
        {"material": [3, 1, 5, 2, 4], "load_patch": 3, "diagonal_rule": "mean"},
        path,
        stop_time=REFERENCE["horizon"],
    )
    design = read_design_parameters(path)
    assert design["load_patch"] == 3 and design["material[1]"] == 3


@pytest.mark.parametrize(
    "case",
    [c for c in CASES if c["scene"]["load_patch"] and c["scene"]["diagonal_rule"] == "mean"],
    ids=lambda case: case["name"],
)
def test_libcosim_runs_a_plates_design_file_to_the_reference_peak(plate_fmu, tmp_path, case):
    """An importer we did not write (libcosim, through libcosimpy) opens the design file of a plate struck over a
    patch under the mean rule (neither is the FMU's default) and reaches the numpy reference's peak."""
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver

    from orchestrator.ssp import COMPONENT, write_best_design_ssp

    scene = case["scene"]
    parameters = {"material": list(scene["order"]), "load_patch": scene["load_patch"], "diagonal_rule": "mean", **TIGHT}
    design = write_best_design_ssp(plate_fmu, parameters, tmp_path / "plate.ssp", stop_time=REFERENCE["horizon"])
    log_output_level(CosimLogLevel.ERROR)
    execution = CosimExecution.from_ssp_file(str(design))
    observer = CosimObserver.create_last_value()
    execution.add_observer(observer)
    index = execution.slave_index_from_instance_name(COMPONENT)
    references = {v.name.decode(): v.reference for v in execution.slave_variables(index)}
    assert execution.simulate_until(target_time=int(round(REFERENCE["horizon"] * 1e9))), execution.status()
    (peak,) = observer.last_real_values(index, [references["peak_backplate_force"]])
    assert peak == pytest.approx(case["peak_backplate_force"], rel=1e-7)
    whole_face = next(
        c
        for c in CASES
        if c["scene"]["order"] == scene["order"]
        and not c["scene"]["load_patch"]
        and c["scene"]["diagonal_rule"] == "mean"
    )
    assert abs(peak / whole_face["peak_backplate_force"] - 1) > 1e-3  # the patch was applied, not the default


def test_a_study_of_a_plate_says_it_is_a_plate_and_where_it_is_struck(tmp_path, capfd):
    """The first screen, the console and results.json name the plate's layers and the patch, and the sweep
    certifies its answer as it does for the 2-D lattice (the armour scene's 11 rows, 5 columns, 5 layers)."""
    from orchestrator.run import main

    plate = build_fmu.build_fmu("armour_11x11", tmp_path / "Plate11x5x5.fmu", cols=5, depth=5, werror=True)
    out = tmp_path / "out"
    code = main(
        [
            "--fmu",
            str(plate),
            "--cols",
            "5",
            "--depth",
            "5",
            "--load-patch",
            "3",
            "--out",
            str(out),
            "--method",
            "exhaustive",
            "--diagonal-rule",
            "receiver",
            "--no-progress",
            "--no-sensitivity",
            "--workers",
            "2",
        ]
    )
    console = capfd.readouterr()
    assert code == 0, console.err
    assert "11 x 5 x 5 plate (5 layers of 11 x 5 masses)" in console.out and "over a centred 3 x 3 patch" in console.out
    results = json.loads((out / "results.json").read_text())
    assert results["case"]["depth"] == 5 and results["case"]["load"]["load_patch"] == 3
    assert results["answers"][0]["evidence"]["status"] == "certified"
    report = (out / "report.html").read_text()
    assert "11 x 5 x 5 plate" in report and "the answers' plates: the layers as a stack" in report
    assert (out / "lattice.png").stat().st_size > 0
    explore = (out / "explore.html").read_text()
    assert '"depth":5,"loaded_faces":[{"load_patch":3,"whole_face":false,"rows":[4,6],"depth":[1,3]}]' in explore


@pytest.mark.parametrize(
    "depth, patch, says",
    [(5, 3, "over a centred 3 x 3 patch for"), (5, 0, "over the whole face for"), (1, 0, "at 0 deg for")],
)
def test_the_case_line_says_where_a_plate_is_struck(depth, patch, says):
    """A plate struck over its whole face says so; the 2-D lattice (always its whole face) keeps its line."""
    from orchestrator.objective import ObjectiveDescription
    from orchestrator.study import CaseDescription

    objective = ObjectiveDescription(
        ("peak_backplate_force",), ("peak",), ("peak",), ("N",), "receiver", {}, (), None, 8.0, 1.0, 8e-6, "rkn5"
    )
    case = CaseDescription(
        scene="plate",
        rows=5,
        columns=5,
        space="permutations",
        design_kind="permutation",
        design_count=120,
        materials=(),
        rules=("receiver",),
        objective=objective,
        load={"F_total": 1200.0, "load_angle": 0.0, "t_active": 0.15, "load_patch": patch},
        parameters={},
        cases={},
        aggregate=None,
        horizon=8.0,
        depth=depth,
    )
    assert says in case.line(), case.line()


def test_a_plate_scenes_fmu_departs_from_the_study_so_no_known_optimum_of_the_lattice_is_claimed(tmp_path):
    """The plate scene's FMU defaults to a 3 x 3 patch: the study's known optima (found on the 2-D lattice
    over its whole face) are not its optima, whatever its columns; the study's own FMU departs in nothing."""
    from orchestrator.fmu import describe
    from orchestrator.scene import departures_from_the_study

    plate = build_fmu.build_fmu("plate_11x11x11", tmp_path / "plate.fmu", cols=8, depth=3)
    lattice = build_fmu.build_fmu("armour_11x11", tmp_path / "lattice.fmu", cols=8)
    assert departures_from_the_study(describe(plate, 11)) == ("load_patch",)
    assert departures_from_the_study(describe(lattice, 11)) == ()


def test_both_model_descriptions_declare_the_lattices_size(plate_fmu, plate_fmu3, fmu_path, tmp_path):
    """An FMU says its lattice's size in its model description, FMI 2 and 3 alike: what an FMU given with --fmu
    is checked against its scene by. A model description that declares none says nothing (None)."""
    from orchestrator.simulation import declared_lattice_size

    assert declared_lattice_size(plate_fmu) == declared_lattice_size(plate_fmu3) == (ROWS, COLS, DEPTH)
    assert declared_lattice_size(fmu_path) == (11, 11, 1)
    with zipfile.ZipFile(plate_fmu3) as archive:  # as text: importers that read an annotation's text only load it
        (annotation,) = ElementTree.fromstring(archive.read("modelDescription.xml")).iter("Annotation")
    assert list(annotation) == [] and annotation.text == f"rows={ROWS} columns={COLS} depth={DEPTH}"
    silent = tmp_path / "silent.fmu"
    with zipfile.ZipFile(fmu_path) as source, zipfile.ZipFile(silent, "w") as target:
        for item in source.infolist():
            data = source.read(item)
            if item.filename == "modelDescription.xml":
                data = data.replace(b'<Tool name="mass-spring-lattice">', b'<Tool name="another-tool">')
            target.writestr(item, data)
    assert declared_lattice_size(silent) is None
