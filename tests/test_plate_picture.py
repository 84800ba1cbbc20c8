"""The plate as the report and the docs draw it (docs/model.md section 10): which masses of column 1's face the
load pushes, the same as the numpy reference's weights; the report's lattice picture of a plate shows its layers
as a stack, the loaded patch and the backplate, while the 2-D lattice keeps its picture; the explore page's
data of a plate carries its depth and patch; the model page's figure draws one mass's eighteen springs and is
written by the command the page states."""

from __future__ import annotations

import time
from collections import Counter
from pathlib import Path
from types import SimpleNamespace

import matplotlib
import numpy as np
import pytest
from matplotlib.colors import LogNorm
from test_explore import browser, console_errors, needs_browser  # noqa: F401 (browser: a fixture)

from fmu_src.materials import study_materials
from fmu_src.variables import loaded_face
from orchestrator.objective import ObjectiveDescription
from orchestrator import charts
from orchestrator import plate_picture as plate
from orchestrator.report.explore import EXPLORE_FILE, explore_data, write_explore
from orchestrator.steps.answers import Answers, draw_lattice
from orchestrator.study import CaseDescription
from reference.lattice3d import load_weights


def test_a_3x3_patch_on_an_11x11_face_is_its_nine_middle_masses():
    face = loaded_face(11, 11, 3)
    assert not face.whole_face
    assert face.masses() == {(i, k) for i in (4, 5, 6) for k in (4, 5, 6)}


def test_load_patch_0_is_the_whole_face():
    face = loaded_face(11, 5, 0)
    assert face.whole_face and len(face.masses()) == 55
    assert face.row_range == range(11) and face.depth_range == range(5)


@pytest.mark.parametrize("rows, depth, patch", [(11, 11, 3), (11, 5, 5), (5, 5, 1), (7, 3, 3), (11, 11, 0), (4, 6, 0)])
def test_the_loaded_masses_are_those_the_reference_loads(rows, depth, patch):
    """The independent numpy model (reference/lattice3d.py) puts weight on exactly these masses."""
    weights = load_weights(rows, depth, patch)  # (depth, rows)
    loaded = {(i, k) for k in range(depth) for i in range(rows) if weights[k, i] > 0}
    assert loaded_face(rows, depth, patch).masses() == loaded


@pytest.mark.parametrize(
    "rows, depth, patch",
    [(11, 11, 2), (11, 11, 4), (11, 5, 7), (10, 11, 3), (11, 4, 1), (11, 11, -1), (11, 11, True), (11, 11, 3.0)],
)
def test_a_patch_the_model_cannot_centre_is_refused_in_one_line(rows, depth, patch):
    with pytest.raises(ValueError) as error:
        loaded_face(rows, depth, patch)
    message = str(error.value)
    assert message.startswith(f"load_patch = {patch!r} is not allowed") and "\n" not in message
    assert "0 (the whole face) or an odd P" in message


# ------------------------------------------------------------------------------------------- the report's picture


def plate_case(rows: int, columns: int, depth: int, patch: int | None, cases: dict | None = None) -> CaseDescription:
    """A case as a study describes it (the default scene's load; only the picture's inputs matter)."""
    load = {"F_total": 1200.0, "load_angle": 0.0, "t_active": 0.15}
    if patch is not None:
        load["load_patch"] = patch
    objective = ObjectiveDescription(
        ("peak_backplate_force",),
        ("peak backplate force",),
        ("peak force",),
        ("N",),
        "mean",
        {},
        ({},),
        None,
        8.0,
        1.0,
        None,
        "rkn5",
    )
    return CaseDescription(
        scene="armour_11x11",
        rows=rows,
        columns=columns,
        space="every order",
        design_kind="permutation",
        design_count=120,
        materials=tuple(study_materials().rows()),
        rules=("mean", "receiver"),
        objective=objective,
        load=load,
        parameters={},
        cases=cases or {},
        aggregate=None,
        horizon=8.0,
        depth=depth,
    )


ORDERS = {"mean": (1, 3, 4, 5, 2), "receiver": (1, 4, 3, 2, 5)}


def study_of(case: CaseDescription) -> SimpleNamespace:
    """A finished study as draw_lattice and the explore page read it: the case and each rule's answer."""
    answers = SimpleNamespace(
        answers=[
            SimpleNamespace(diagonal_rule=rule, order=order, peak=2000.0 + len(rule), design_file=f"design_{rule}.ssp")
            for rule, order in ORDERS.items()
        ]
    )
    return SimpleNamespace(case=case, result=lambda step: answers if step is Answers else None)


@pytest.fixture()
def drawn(monkeypatch, tmp_path):
    """draw_lattice's figure as saved (not closed)."""
    monkeypatch.setattr(charts.plt, "close", lambda *args: None)

    def draw(case):
        assert draw_lattice(study_of(case), tmp_path / "lattice.png") == "lattice.png"
        assert (tmp_path / "lattice.png").stat().st_size > 0
        return charts.plt.gcf()

    yield draw
    charts.plt.close("all")


def panels(figure) -> list:
    """The answers' panels (the colour bar's axes left out)."""
    return [axis for axis in figure.axes if axis.get_label() != "<colorbar>"]


def colour_of(case: CaseDescription, material: int):
    """The colour the picture gives a material: viridis over log k of the case's materials."""
    k = [m["k"] for m in case.materials]
    return matplotlib.colormaps["viridis"](LogNorm(min(k), max(k))(case.materials[material - 1]["k"]))


def gids(axis, prefix: str) -> list[str]:
    return [artist.get_gid() for artist in axis.get_children() if (artist.get_gid() or "").startswith(prefix)]


def face_masses_inside(axis, outline, rows: int, depth: int) -> set[tuple[int, int]]:
    """The masses of layer 1's face, as drawn, that an outline on the page encloses."""
    i, k = np.meshgrid(np.arange(rows), np.arange(depth), indexing="ij")
    page = plate.project(plate.layer_x(0, plate.layer_pitch(rows, depth)), i.ravel(), k.ravel())
    inside = outline.get_path().contains_points(page)
    return {(int(a), int(b)) for a, b, hit in zip(i.ravel(), k.ravel(), inside) if hit}


def test_the_report_draws_a_plate_as_its_layers_with_the_patch_and_the_backplate(drawn):
    case = plate_case(11, 5, 5, 3)
    figure = drawn(case)
    assert "5 layers along x, each 11 x 5 masses" in figure._suptitle.get_text()
    assert "centred 3 x 3 patch" in figure._suptitle.get_text()
    assert len(panels(figure)) == len(ORDERS)
    for axis, (rule, order) in zip(panels(figure), ORDERS.items()):
        assert axis.get_title() == f"{rule} rule's answer"
        assert sorted(gids(axis, "layer ")) == [f"layer {j}" for j in range(1, 6)]
        assert gids(axis, plate.BACKPLATE_GID) == [plate.BACKPLATE_GID]
        slabs = {
            artist.get_gid(): artist for artist in axis.collections if (artist.get_gid() or "").startswith("layer")
        }
        for j, material in enumerate(order, start=1):  # the face of each layer in its material's colour
            assert tuple(slabs[f"layer {j}"].get_facecolors()[0]) == pytest.approx(colour_of(case, material))
        names = [text.get_text() for text in axis.texts if text.get_rotation() == 60]
        assert names == [case.materials[m - 1]["name"] for m in order]
        (outline,) = [p for p in axis.patches if p.get_gid() == plate.LOAD_GID]
        assert face_masses_inside(axis, outline, 11, 5) == {(i, k) for i in (4, 5, 6) for k in (1, 2, 3)}
        red = [
            c
            for c in axis.collections
            if c.get_offsets().shape[0]
            and tuple(c.get_facecolors()[0]) == pytest.approx(matplotlib.colors.to_rgba(plate.LOAD_COLOUR))
        ]
        assert len(red) == 1 and len(red[0].get_offsets()) == 9
        (arrow,) = [a for a in axis.texts if isinstance(a, matplotlib.text.Annotation) and a.arrow_patch]
        assert outline.get_path().contains_point(arrow.xy)  # the load's arrow strikes the patch


def test_a_plate_loaded_over_its_whole_face_outlines_the_whole_face(drawn):
    figure = drawn(plate_case(7, 5, 3, 0))
    assert "over its whole face" in figure._suptitle.get_text()
    for axis in panels(figure):
        (outline,) = [p for p in axis.patches if p.get_gid() == plate.LOAD_GID]
        assert face_masses_inside(axis, outline, 7, 3) == {(i, k) for i in range(7) for k in range(3)}


def test_a_face_too_large_for_dots_shows_the_loaded_region_filled(drawn):
    side = plate.MAX_DOTS_SIDE + 2  # odd
    figure = drawn(plate_case(side, 5, side, 3))
    for axis in panels(figure):
        assert not [c for c in axis.collections if not (c.get_gid() or "").startswith(("layer", "backplate"))]
        (outline,) = [p for p in axis.patches if p.get_gid() == plate.LOAD_GID]
        assert outline.get_facecolor()[3] > 0
        middle = (side - 1) // 2
        assert face_masses_inside(axis, outline, side, side) == {
            (i, k) for i in range(middle - 1, middle + 2) for k in range(middle - 1, middle + 2)
        }


def test_each_load_cases_patch_is_outlined(drawn):
    figure = drawn(plate_case(11, 5, 5, None, cases={"load_patch": [1, 3]}))
    assert "a centred 1 x 1 patch or a centred 3 x 3 patch" in figure._suptitle.get_text()
    axis = panels(figure)[0]
    outlines = [p for p in axis.patches if p.get_gid() == plate.LOAD_GID]
    assert sorted(len(face_masses_inside(axis, o, 11, 5)) for o in outlines) == [1, 9]


def test_the_2d_lattice_keeps_its_picture(drawn):
    """Depth 1: a dot per mass in its column's colour, the backplate bar, the names as ticks; no slab."""
    case = plate_case(11, 5, 1, 0)
    figure = drawn(case)
    assert figure._suptitle.get_text() == "Load from the left on column 1, backplate on the right (grey bar)"
    for axis, (rule, order) in zip(panels(figure), ORDERS.items()):
        assert not gids(axis, "layer ") and not axis.patches
        (dots,) = axis.collections
        x, y = np.meshgrid(np.arange(5), np.arange(11))
        assert np.array_equal(dots.get_offsets(), np.column_stack([x.ravel(), y.ravel()]))
        assert np.array_equal(dots.get_array(), np.tile([case.materials[m - 1]["k"] for m in order], 11))
        (bar,) = axis.lines
        assert tuple(bar.get_xdata()) == (4.5, 4.5)
        assert [t.get_text() for t in axis.get_xticklabels()] == [case.materials[m - 1]["name"] for m in order]


# ------------------------------------------------------------------------------------------- the explore page


def test_the_explore_pages_data_of_a_plate_carries_its_depth_and_patch():
    case = plate_case(11, 5, 5, 3)
    data = explore_data(study_of(case), study_materials(), {})
    assert (data["rows"], data["columns"], data["depth"]) == (11, 5, 5)
    assert data["loaded_faces"] == [{"load_patch": 3, "whole_face": False, "rows": [4, 6], "depth": [1, 3]}]
    whole = explore_data(study_of(plate_case(11, 5, 1, 0)), study_materials(), {})
    assert whole["depth"] == 1 and whole["loaded_faces"] == [
        {"load_patch": 0, "whole_face": True, "rows": [0, 10], "depth": [0, 0]}
    ]


@needs_browser
def test_the_explore_page_shows_a_plates_face_and_layers_offline(browser, tmp_path):  # noqa: F811 (the fixture)
    """Written from a plate's study: opened with the network cut off, it draws layer 1's face with the patch's
    masses in red and names the plate's layers in its title, with no console error."""
    case = plate_case(11, 5, 5, 3)
    write_explore(study_of(case), tmp_path, study_materials(), {})
    browser.get((tmp_path / EXPLORE_FILE).resolve().as_uri())
    for _ in range(100):
        if browser.execute_script("return document.querySelectorAll('#lattice .gtitle').length"):
            break
        time.sleep(0.1)
    title = browser.execute_script("return document.querySelector('#lattice .gtitle').textContent")
    assert "The plate: 5 layers along x, each a sheet of 11 x 5 masses" in title, title
    assert "centred 3 x 3 patch" in title and "backplate right of layer 5" in title, title
    colours = browser.execute_script(
        "return [...document.querySelectorAll('#lattice .scatterlayer .point')].map(p => p.style.fill)"
    )
    assert len(colours) == 11 * 5 and sum(c == "rgb(220, 20, 60)" for c in colours) == 9  # crimson
    assert console_errors(browser) == []


# ------------------------------------------------------------------------------------------- the model page's figure


def test_one_mass_has_six_nearest_neighbours_twelve_face_diagonals_and_no_body_diagonal():
    offsets = [(dx, dy, dz) for dx in (-1, 0, 1) for dy in (-1, 0, 1) for dz in (-1, 0, 1) if (dx, dy, dz) != (0, 0, 0)]
    kinds = Counter(plate.spring_kind(offset) for offset in offsets)
    assert kinds == {0: 2, 1: 4, 2: 8, 3: 4, None: 8}
    assert [plate.spring_kind(o) for o in ((-1, 0, 0), (0, 0, 1), (1, -1, 0), (1, 0, 1), (0, 1, -1), (1, 1, 1))] == [
        0,
        1,
        2,
        2,
        3,
        None,
    ]


def test_the_springs_drawn_are_one_masses_eighteen():
    figure, axis = charts.plt.subplots()
    try:
        plate.draw_springs(axis)
        by_colour = Counter(line.get_color() for line in axis.lines)
    finally:
        charts.plt.close(figure)
    assert by_colour == {colour: count for (_, colour, _), count in zip(plate.SPRING_KINDS, (2, 4, 8, 4))}


def test_the_model_figure_is_written_by_the_command_its_page_states(tmp_path, capsys):
    page = (Path(__file__).resolve().parents[1] / "docs" / "model.md").read_text()
    assert "`python -m orchestrator.plate_picture --write docs/images/plate-model.png`" in page
    assert "(images/plate-model.png)" in page
    assert plate.main(["--write", str(tmp_path / "plate-model.png")]) == 0
    assert (tmp_path / "plate-model.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    capsys.readouterr()
    assert plate.main(["--write", str(tmp_path / "missing" / "plate-model.png")]) == 2
    error = capsys.readouterr().err.strip()
    assert error.startswith("--write") and "does not exist" in error and "\n" not in error
