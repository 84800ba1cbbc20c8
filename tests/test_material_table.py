"""The FMU built with a designer's material table: M materials for C columns, with or without repeats, and the
max_compression output, against the reference model (reference/, numpy + scipy)."""

from __future__ import annotations

import json

import pytest
from fmpy import read_model_description, simulate_fmu

import build_fmu
import reference
from builder import build
from fmu_src.materials import Material, MaterialTable, write_materials_csv
from fmu_src.published import PUBLISHED_PEAKS, STUDY_BEST_ORDER
from orchestrator.simulation import LatticeFMU, SimulationError
from scenes import Scene

HORIZON = 1.0  # through the peak and the contact phase
TIGHT = {"rtol": 1e-10, "atol": 1e-12}

# eight materials of a designer's own (not the study's formula), each with its own exponents
CATALOGUE = MaterialTable(
    tuple(
        Material(f"foam{m}", 40.0 + 17.0 * m, 15.0 + 9.0 * m, 1.0 + 0.7 * m, 6.0 + 0.9 * m, 7.0 + 0.6 * m)
        for m in range(1, 9)
    )
)
TRIO = MaterialTable(CATALOGUE.materials[:3])


@pytest.fixture(scope="module")
def catalogue_fmu(tmp_path_factory):
    """8 materials over an 11 x 5 lattice: the designs are arrangements of 5 of the 8."""
    return build.build_fmu(
        rows=11, cols=5, materials=CATALOGUE, werror=True, output=tmp_path_factory.mktemp("catalogue") / "Catalogue.fmu"
    )


@pytest.fixture(scope="module")
def trio_fmu(tmp_path_factory):
    """3 materials over an 11 x 7 lattice: fewer materials than columns, so repeats."""
    return build.build_fmu(
        rows=11, cols=7, materials=TRIO, werror=True, output=tmp_path_factory.mktemp("trio") / "Trio.fmu"
    )


def oracle(table: MaterialTable, rows: int, cols: int, order) -> reference.SimulationResult:
    scene = reference.Scene(
        rows=rows,
        cols=cols,
        order=tuple(order),
        **{f: table.column(f) for f in ("k", "k_diag", "c", "alpha", "alpha_diag")},
    )
    return reference.simulate(scene, horizon=HORIZON, rtol=1e-10, atol=1e-12)


def test_the_fmu_declares_its_table_and_design_space(catalogue_fmu, trio_fmu):
    variables = {v.name: v for v in read_model_description(str(catalogue_fmu)).modelVariables}
    assert [float(variables[f"k[{m}]"].start) for m in range(1, 9)] == list(CATALOGUE.column("k"))
    assert "k[9]" not in variables and "material[6]" not in variables
    assert [int(variables[f"material[{j}]"].start) for j in range(1, 6)] == [1, 2, 3, 4, 5]
    assert int(variables["material[1]"].max) == 8 and int(variables["repeat_materials"].start) == 0
    trio = {v.name: v for v in read_model_description(str(trio_fmu)).modelVariables}
    assert [int(trio[f"material[{j}]"].start) for j in range(1, 8)] == [1, 2, 3, 1, 2, 3, 1]
    assert int(trio["repeat_materials"].start) == 1  # fewer materials than columns: repeats by default


@pytest.mark.parametrize(
    "fixture, table, cols, order",
    [
        ("catalogue_fmu", CATALOGUE, 5, (8, 2, 5, 1, 7)),
        ("trio_fmu", TRIO, 7, (3, 3, 1, 2, 2, 1, 3)),
    ],
    ids=["arrangement_of_5_of_8", "repeats_of_3_over_7"],
)
def test_peak_and_compression_agree_with_the_reference_model(request, fixture, table, cols, order):
    expected = oracle(table, 11, cols, order)
    with LatticeFMU(request.getfixturevalue(fixture)) as fmu:
        result = fmu.simulate(
            order,
            horizon=HORIZON,
            parameters=TIGHT,
            outputs=("peak_backplate_force", "max_compression", "external_work"),
        )
    assert expected.peak_backplate_force > 0 and expected.max_compression > 0
    assert result["peak_backplate_force"] == pytest.approx(expected.peak_backplate_force, rel=1e-6)
    assert result["max_compression"] == pytest.approx(expected.max_compression, rel=1e-6)
    assert result["external_work"] == pytest.approx(expected.external_work, rel=1e-6)


def test_model_exchange_samples_the_compression_as_co_simulation_does(catalogue_fmu):
    order = (8, 2, 5, 1, 7)
    me = simulate_fmu(
        str(catalogue_fmu),
        fmi_type="ModelExchange",
        solver="CVode",
        relative_tolerance=1e-10,
        output_interval=0.01,
        stop_time=HORIZON,
        output=["max_compression"],
        start_values={f"material[{j}]": m for j, m in enumerate(order, 1)},
    )
    with LatticeFMU(catalogue_fmu) as fmu:
        cs = fmu.simulate(order, horizon=HORIZON, parameters=TIGHT, outputs=("max_compression",))
    assert me["max_compression"][-1] == pytest.approx(cs["max_compression"], rel=1e-6)


def test_repeats_are_refused_unless_repeat_materials_is_1(catalogue_fmu, trio_fmu):
    with LatticeFMU(catalogue_fmu) as fmu:
        with pytest.raises(
            SimulationError,
            match=r"material = \[1, 1, 2, 3, 4\] is not allowed: the columns' "
            r"materials must be 5 different ones of 1\.\.8",
        ):
            fmu.simulate((1, 1, 2, 3, 4), horizon=0.05)
        assert fmu.simulate((1, 1, 2, 3, 4), horizon=0.05, parameters={"repeat_materials": 1})["external_work"] > 0
        with pytest.raises(
            SimulationError,
            match=r"material\[2\] = 9 is not allowed: allowed values are each an "
            r"integer in \[1, 8\]",
        ):
            fmu.simulate((1, 9, 2, 3, 4), horizon=0.05)
    with LatticeFMU(trio_fmu) as fmu:
        with pytest.raises(SimulationError, match="the table has 3 materials for 7 columns: set repeat_materials = 1"):
            fmu.simulate((1, 2, 3, 1, 2, 3, 1), horizon=0.05, parameters={"repeat_materials": 0})


def test_the_study_table_keeps_the_published_peak(lattice):
    """M = C = 11, the study's materials: repeat_materials = 0 makes the design space the study's permutations."""
    result = lattice.simulate(STUDY_BEST_ORDER, horizon=1.0, outputs=("peak_backplate_force", "max_compression"))
    assert result["peak_backplate_force"] == pytest.approx(PUBLISHED_PEAKS[STUDY_BEST_ORDER], rel=1e-6)
    assert 0.0 < result["max_compression"] < 1.0


def test_the_command_line_builds_with_a_table_file(tmp_path, capsys):
    table = write_materials_csv(CATALOGUE, tmp_path / "catalogue.csv")
    assert build_fmu.main(["--materials", str(table), "--cols", "5", "-o", str(tmp_path / "cli.fmu")]) == 0
    variables = {v.name: v for v in read_model_description(str(tmp_path / "cli.fmu")).modelVariables}
    assert [float(variables[f"alpha[{m}]"].start) for m in range(1, 9)] == list(CATALOGUE.column("alpha"))
    assert int(variables["material[1]"].max) == 8
    capsys.readouterr()
    bad = tmp_path / "bad.csv"
    bad.write_text("name,k,k_diag,c,alpha,alpha_diag\nfoam,1,1,1,0,1\n")
    assert build_fmu.main(["--materials", str(bad)]) == 2
    assert "row 1 (foam), field alpha" in capsys.readouterr().err


def test_a_scene_carries_its_table_as_rows_or_as_a_file(tmp_path):
    rows = CATALOGUE.rows()
    inline = Scene(name="inline", rows=3, cols=4, materials=rows)
    write_materials_csv(CATALOGUE, tmp_path / "table.csv")
    (tmp_path / "by_file.json").write_text(
        json.dumps({"name": "by_file", "rows": 3, "cols": 4, "materials": "table.csv"})
    )
    by_file = Scene.load(str(tmp_path / "by_file.json"))
    for scene in (inline, by_file):
        assert scene.material_table() == CATALOGUE
        assert scene.interface().material_count == 8
        assert scene.parameter_values()["k_diag"] == CATALOGUE.column("k_diag")
    with pytest.raises(ValueError, match=r"parameters \['k'\] are the material table's"):
        Scene(name="old_style", parameters={"k": [1.0] * 11}).interface()


def test_a_lattice_wider_than_the_study_table_invents_no_material(tmp_path):
    """The armour scene over 12 columns keeps the study's eleven materials (the FMU may repeat them); the study's
    formula is never extrapolated to a twelfth, and the orchestrator refuses 12 columns without --repeat."""
    from scenes import resolve_scene
    from fmu_src.materials import STUDY_MATERIAL_COUNT, study_materials
    from orchestrator.scene import check_table_size
    from orchestrator.study import CaseConfig

    wide = resolve_scene("armour_11x11", cols=12)
    interface = wide.interface()
    assert interface.material_count == STUDY_MATERIAL_COUNT == 11
    assert wide.parameter_values()["k"] == study_materials(11).column("k")
    assert wide.parameter_values()["repeat_materials"] == 1
    with pytest.raises(ValueError, match=r"the study's table has 11"):
        study_materials(12)
    with pytest.raises(ValueError, match=r"^--cols 12: the study's table has 11 materials"):
        check_table_size(CaseConfig(cols=12), Scene.load("armour_11x11"), None)
    check_table_size(CaseConfig(cols=12, repeat=True), Scene.load("armour_11x11"), None)
    with pytest.raises(ValueError, match=r"^--cols 9: --materials t.csv has 8 materials"):
        check_table_size(CaseConfig(cols=9, materials="t.csv"), Scene.load("armour_11x11"), CATALOGUE)
