"""The plate of layers drawn in an oblique view (docs/model.md section 10): the report's lattice picture of a
plate, and the model page's figure of the plate and the springs of one mass, written by

    python -m orchestrator.plate_picture --write docs/images/plate-model.png

The view is a fixed parallel projection: x (the load's direction, through the thickness; one layer, one column
of one material, per unit) to the right, y (rows) up, z (depth) receding up and to the left, so that the reader
looks from the load's side, from above and from the front (k = 1): the struck face of every layer, its top and
its front edge show. Why drawn on flat axes rather than with mplot3d: mplot3d orders polygons by their mean
depth, which misorders thin slabs beside larger ones; boxes that do not intersect, drawn from the backplate to
the load, are ordered exactly, and text and the colour bar stay where matplotlib puts them on flat axes.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Sequence

import numpy as np
from matplotlib.collections import PolyCollection
from matplotlib.colors import to_rgb
from matplotlib.lines import Line2D
from matplotlib.patches import Polygon
from matplotlib.typing import LineStyleType

from fmu_src.variables import LoadedFace, loaded_face

from .charts import plt

X_SCREEN = np.array([1.0, 0.0])  # one unit along x on the page
Y_SCREEN = np.array([0.0, 1.0])
Z_SCREEN = np.array([-0.5, 0.3])  # along z: up and to the left, shortened as a depth is
SLAB_THICKNESS = 0.45  # of a layer drawn as a slab; this and the next three in units of the pitch
BACKPLATE_GAP = 0.45  # between column C's slab and the backplate
BACKPLATE_THICKNESS = 0.35
LOAD_COLOUR = "crimson"
BACKPLATE_COLOUR = "dimgray"
ARROW_LENGTH = 3.0  # of the load's arrow
PITCH_FACE = 11  # masses along y or z up to which the layers are drawn a spacing apart; beyond, further
MAX_DOTS_SIDE = 25  # a face with more masses along y or z shows the loaded region alone: dots would be a blur
LAYER_GID = "layer {}"  # each slab's gid: what the tests count
LOAD_GID, BACKPLATE_GID = "loaded region", "backplate"


def project(x, y, z) -> np.ndarray:
    """Page coordinates of model points (x, y, z): arrays broadcast, the last axis of the result is (page x,
    page y)."""
    x, y, z = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (x, y, z)))
    return x[..., None] * X_SCREEN + y[..., None] * Y_SCREEN + z[..., None] * Z_SCREEN


def layer_pitch(rows: int, depth: int) -> float:
    """How far apart the layers are drawn along x: the masses' spacing, or more for a face of more than
    PITCH_FACE masses a side, whose layers would otherwise be too thin to see and to name."""
    return max(1.0, max(rows, depth) / PITCH_FACE)


def layer_x(column: int, pitch: float = 1.0) -> float:
    """The x of the struck face of column ``column`` (0-based) drawn as a slab: its masses' x, less half the
    slab."""
    return (column - SLAB_THICKNESS / 2) * pitch


def box_faces(x: tuple[float, float], y: tuple[float, float], z: tuple[float, float]) -> list[np.ndarray]:
    """The three faces of a box the view shows: the one facing the load (-x), the top (+y), the front (-z)."""
    (x0, x1), (y0, y1), (z0, z1) = x, y, z
    return [
        project([x0, x0, x0, x0], [y0, y1, y1, y0], [z0, z0, z1, z1]),
        project([x0, x1, x1, x0], [y1, y1, y1, y1], [z0, z0, z1, z1]),
        project([x0, x1, x1, x0], [y0, y0, y1, y1], [z0, z0, z0, z0]),
    ]


def shaded(colour, amount: float) -> tuple[float, float, float]:
    """``colour`` towards white (amount > 0) or black (amount < 0): the top lit, the front edge in shade."""
    rgb = np.array(to_rgb(colour))
    target = np.ones(3) if amount > 0 else np.zeros(3)
    return tuple(rgb + abs(amount) * (target - rgb))


def draw_slab(
    axis, x: tuple[float, float], y: tuple[float, float], z: tuple[float, float], colour, gid: str
) -> PolyCollection:
    faces = box_faces(x, y, z)
    slab = PolyCollection(
        faces,
        facecolors=[colour, shaded(colour, 0.35), shaded(colour, -0.3)],
        edgecolors="0.15",
        linewidths=0.4,
        gid=gid,
    )
    axis.add_collection(slab)
    return slab


def plate_bounds(rows: int, columns: int, depth: int) -> tuple[np.ndarray, np.ndarray]:
    """The page's lower left and upper right corners around what draw_plate draws (the names below aside): the
    slabs, the backplate, the arrow's tail and the layer numbers above, with a margin."""
    pitch = layer_pitch(rows, depth)
    last = layer_x(columns - 1, pitch) + (SLAB_THICKNESS + BACKPLATE_GAP + BACKPLATE_THICKNESS) * pitch
    corners = project(
        [layer_x(0, pitch), last] * 4,
        [-1.0, -1.0, rows, rows] * 2,
        [-1.0, -1.0, -1.0, -1.0, depth, depth, depth, depth],
    )
    tail = project(layer_x(0, pitch) - ARROW_LENGTH * pitch, (rows - 1) / 2, (depth - 1) / 2)
    points = np.vstack([corners, tail])
    return points.min(axis=0) - 0.3, points.max(axis=0) + np.array([0.3, 1.2])


def face_outline(face: LoadedFace, x: float) -> np.ndarray:
    """The loaded region on the plane x, as a closed polygon around its masses (half a spacing out)."""
    y0, y1 = face.row_range.start - 0.5, face.row_range.stop - 0.5
    z0, z1 = face.depth_range.start - 0.5, face.depth_range.stop - 0.5
    return project([x] * 4, [y0, y1, y1, y0], [z0, z0, z1, z1])


def draw_plate(
    axis,
    rows: int,
    depth: int,
    colours: Sequence,
    names: Sequence[str],
    faces: Sequence[LoadedFace],
    label_size: float = 7,
    numbered: bool = True,
) -> None:
    """The plate on ``axis``: a slab per column (layer), coloured ``colours[j]``, named ``names[j]`` under it and
    numbered over it (``numbered``), the masses of column 1's face as dots (up to MAX_DOTS_SIDE a side), those
    the load pushes (the union of ``faces``) in the load's colour with each loaded region outlined, the load's
    arrow, and the backplate behind the last column."""
    columns, pitch = len(colours), layer_pitch(rows, depth)
    thickness = SLAB_THICKNESS * pitch
    y_span, z_span = (-0.5, rows - 0.5), (-0.5, depth - 0.5)
    last = layer_x(columns - 1, pitch) + thickness + BACKPLATE_GAP * pitch
    draw_slab(
        axis,
        (last, last + BACKPLATE_THICKNESS * pitch),
        (-1.0, rows - 0.5),
        (-1.0, depth - 0.5),
        BACKPLATE_COLOUR,
        BACKPLATE_GID,
    )
    for column in reversed(range(columns)):  # from the backplate to the load: the nearer slab drawn over
        x0 = layer_x(column, pitch)
        draw_slab(axis, (x0, x0 + thickness), y_span, z_span, colours[column], LAYER_GID.format(column + 1))
    front = layer_x(0, pitch)
    dotted = max(rows, depth) <= MAX_DOTS_SIDE
    if dotted:
        loaded = set().union(*(face.masses() for face in faces))
        i, k = np.meshgrid(np.arange(rows), np.arange(depth), indexing="ij")
        pushed = np.array([(a, b) in loaded for a, b in zip(i.ravel(), k.ravel())])
        dots = project(front, i.ravel(), k.ravel())
        size = float(np.clip(260.0 / max(rows, depth), 6.0, 40.0))
        axis.scatter(dots[~pushed, 0], dots[~pushed, 1], s=size, c="white", edgecolors="0.2", linewidths=0.3, zorder=3)
        axis.scatter(
            dots[pushed, 0], dots[pushed, 1], s=size, c=LOAD_COLOUR, edgecolors="0.2", linewidths=0.3, zorder=3
        )
    for face in sorted(faces, key=lambda f: -len(f.masses())):
        axis.add_patch(
            Polygon(
                face_outline(face, front),
                closed=True,
                edgecolor=LOAD_COLOUR,
                lw=1.6,
                zorder=4,
                facecolor="none" if dotted else (0.86, 0.08, 0.24, 0.35),
                gid=LOAD_GID,
            )
        )
    centre = ((rows - 1) / 2, (depth - 1) / 2)
    tip, tail = project(front - 0.1, *centre), project(front - ARROW_LENGTH * pitch, *centre)
    axis.annotate(
        "",
        xy=tip,
        xytext=tail,
        zorder=5,
        arrowprops=dict(arrowstyle="-|>", lw=2.2, color=LOAD_COLOUR, mutation_scale=14),
    )
    for column, name in enumerate(names):
        foot = project(layer_x(column, pitch) + thickness / 2, -0.5, -0.5)
        axis.text(
            foot[0],
            foot[1] - 0.35,
            name,
            rotation=60,
            ha="right",
            va="top",
            fontsize=label_size,
            rotation_mode="anchor",
        )
    for column in range(columns if numbered else 0):  # each layer's number over its far top edge
        top = project(layer_x(column, pitch) + thickness / 2, rows - 0.5, depth - 0.5)
        axis.text(
            top[0],
            top[1] + 0.25,
            f"layer {column + 1}" if column == 0 else str(column + 1),
            ha="right" if column == 0 else "center",
            va="bottom",
            fontsize=label_size - 0.5,
            color="0.3",
        )
    low, high = plate_bounds(rows, columns, depth)
    axis.set_xlim(low[0], high[0])
    axis.set_ylim(low[1], high[1])  # the names hang below, saved with the whole figure (charts.save's fit)
    axis.set_aspect("equal")
    axis.set_axis_off()


def where_loaded(faces: Sequence[LoadedFace]) -> str:
    """The loaded regions in words, for a title."""

    def one(face: LoadedFace) -> str:
        side = len(face.row_range)
        return "its whole face" if face.whole_face else f"a centred {side} x {side} patch"

    return " or ".join(one(face) for face in faces)


def draw_plate_answers(case, designs, colour_map, norm, path: Path) -> str:
    """The report's lattice picture of a plate: one panel per (title, order) in ``designs``, each layer coloured
    by its material's k."""
    from .charts import figure_title, save

    materials = case.materials
    faces = case.loaded_faces()
    low, high = plate_bounds(case.rows, case.columns, case.depth)
    height = 4.4  # inches of a panel's drawing; its width as the plate's
    width = height * (high[0] - low[0]) / (high[1] - low[1])
    figure, axes = plt.subplots(
        1,
        len(designs),
        figsize=(max(width, 2.6) * len(designs) + 1.4, height + 1.0),
        squeeze=False,
        layout="constrained",
    )
    for axis, (label, order) in zip(axes[0], designs):
        colours = [colour_map(norm(materials[m - 1]["k"])) for m in order]
        draw_plate(axis, case.rows, case.depth, colours, [materials[m - 1]["name"] for m in order], faces)
        axis.set_title(label, fontsize=9)
    from matplotlib.cm import ScalarMappable

    bar = figure.colorbar(ScalarMappable(norm=norm, cmap=colour_map), ax=axes[0].tolist(), shrink=0.8)
    bar.set_label("spring constant k of the layer's material, along y and z (N)")
    figure_title(
        figure,
        f"{case.rows} x {case.columns} x {case.depth} plate: {case.columns} layers along x, "
        f"each {case.rows} x {case.depth} masses (y x z); the load (arrow) on layer 1 over "
        f"{where_loaded(faces)} (red), the backplate (grey) behind layer {case.columns}",
    )
    return save(figure, path, tight=False, fit=True)


# ------------------------------------------------------------------------------------------ the model page's figure

SPRING_KINDS: tuple[tuple[str, str, LineStyleType], ...] = (  # (what joins a mass to a neighbour, colour, line style)
    ("along x, between columns: k0, α0, c0", "tab:blue", "-"),
    ("along y and z, inside the column: its material's k, α, c", "tab:green", "-"),
    (
        "face diagonals of the xy and xz planes, between columns: k_diag, α_diag by the diagonal rule",
        "tab:orange",
        "--",
    ),
    ("face diagonals of the yz plane, inside the column: its material's k_diag, α_diag", "tab:purple", "--"),
)


def spring_kind(offset: tuple[int, int, int]) -> int | None:
    """The kind (an index of SPRING_KINDS) of the spring to the neighbour at ``offset`` (dx, dy, dz), None for
    a body diagonal: no spring (docs/model.md section 10)."""
    moved = [axis for axis, step in zip("xyz", offset) if step]
    if len(moved) == 1:
        return 0 if moved == ["x"] else 1
    if len(moved) == 2:
        return 2 if "x" in moved else 3
    return None


def draw_springs(axis) -> None:
    """The springs of one mass (i, j, k) to its 26 neighbours: the 6 nearest and the 12 face diagonals, none to
    the 8 corners of the body diagonals; the planes of the columns j - 1, j, j + 1 outlined."""
    for dx, name in ((1, "j + 1"), (0, "j"), (-1, "j - 1")):  # each column's plane, faint: the springs show through
        plane = project([dx] * 4, [-1.4, 1.4, 1.4, -1.4], [-1.4, -1.4, 1.4, 1.4])
        axis.add_patch(
            Polygon(plane, closed=True, facecolor=(0.5, 0.5, 0.5, 0.08), edgecolor="0.6", lw=0.7, gid=f"column {name}")
        )
        foot = project(dx, -1.4, -1.4)
        axis.text(foot[0], foot[1] - 0.15, f"column {name}", ha="center", va="top", fontsize=8)
    offsets = [(dx, dy, dz) for dx in (-1, 0, 1) for dy in (-1, 0, 1) for dz in (-1, 0, 1) if (dx, dy, dz) != (0, 0, 0)]
    centre = project(0, 0, 0)
    for offset in sorted(offsets, key=lambda o: -o[0] + o[2]):  # the far ones first
        kind = spring_kind(offset)
        end = project(*offset)
        if kind is None:
            axis.scatter(*end, s=30, facecolors="white", edgecolors="0.45", linewidths=0.9, zorder=4)
            continue
        _, colour, style = SPRING_KINDS[kind]
        axis.plot([centre[0], end[0]], [centre[1], end[1]], color=colour, linestyle=style, lw=2.0, zorder=3)
        axis.scatter(*end, s=34, c="0.3", zorder=4)
    axis.scatter(*centre, s=90, c="black", zorder=5)
    axis.annotate(
        "mass (i, j, k)",
        xy=centre,
        xytext=(0.45, 2.2),
        fontsize=8,
        zorder=6,
        arrowprops=dict(arrowstyle="-", lw=0.6, color="0.3", shrinkB=5),
    )
    draw_axes_key(axis, (-2.7, -2.0, 0.0), length=0.7)
    handles = [
        Line2D([], [], color=colour, linestyle=style, lw=2.0, label=label) for label, colour, style in SPRING_KINDS
    ]
    handles.append(
        Line2D(
            [],
            [],
            linestyle="",
            marker="o",
            markerfacecolor="white",
            markeredgecolor="0.45",
            label="body diagonals (the cube's corners): no spring",
        )
    )
    axis.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.02), fontsize=7.5, frameon=False)
    corners = project([-1.6, 1.6] * 4, [-1.6, -1.6, 1.6, 1.6] * 2, [-1.6] * 4 + [1.6] * 4)
    low, high = corners.min(axis=0), corners.max(axis=0)
    axis.set_xlim(low[0] - 0.8, high[0])  # the axes' key on the left
    axis.set_ylim(low[1] - 0.3, high[1] + 0.5)  # the mass's name above
    axis.set_aspect("equal")
    axis.set_axis_off()


def draw_axes_key(axis, origin, length: float = 1.6) -> None:
    """Arrows along x, y and z from ``origin`` (model coordinates), named."""
    start = project(*origin)
    for step, name in (((1, 0, 0), "x"), ((0, 1, 0), "y"), ((0, 0, 1), "z")):
        end = project(*(np.array(origin) + length * np.array(step)))
        axis.annotate("", xy=end, xytext=start, arrowprops=dict(arrowstyle="-|>", lw=1.2, color="0.2"))
        axis.text(
            *(end + 0.25 * (end - start) / np.linalg.norm(end - start)),
            name,
            fontsize=9,
            ha="center",
            va="center",
            style="italic",
        )


MODEL_ROWS, MODEL_COLUMNS, MODEL_DEPTH, MODEL_PATCH = 5, 4, 5, 3  # the plate the figure draws


def draw_model_figure(path: Path) -> str:
    """docs/model.md section 10's figure: the plate's grid with the load patch and the backplate (left), the
    springs of one mass (right)."""
    from .charts import save

    figure, (left, right) = plt.subplots(1, 2, figsize=(12.0, 6.6), gridspec_kw={"width_ratios": [1.1, 1]})
    colours = [plt.get_cmap("Pastel1")(j) for j in range(MODEL_COLUMNS)]
    names = [f"column {j}" for j in range(1, MODEL_COLUMNS)] + ["column C"]
    face = loaded_face(MODEL_ROWS, MODEL_DEPTH, MODEL_PATCH)
    draw_plate(left, MODEL_ROWS, MODEL_DEPTH, colours, names, [face], label_size=8, numbered=False)
    pitch = layer_pitch(MODEL_ROWS, MODEL_DEPTH)
    draw_axes_key(left, (layer_x(0, pitch) - ARROW_LENGTH * pitch, -0.5, -0.5))
    tip = project(layer_x(0, pitch) - ARROW_LENGTH * pitch, (MODEL_ROWS - 1) / 2, (MODEL_DEPTH - 1) / 2)
    left.text(tip[0], tip[1] + 0.35, "load F_total", color=LOAD_COLOUR, fontsize=8.5, ha="left", va="bottom")
    corner = project(layer_x(0, pitch), MODEL_ROWS - 0.5, MODEL_DEPTH - 0.5)
    left.text(
        corner[0] - 0.2,
        corner[1] + 0.3,
        f"centred P x P patch (P = {MODEL_PATCH}) on column 1's face",
        color=LOAD_COLOUR,
        fontsize=8.5,
        ha="left",
        va="bottom",
    )
    back = project(layer_x(MODEL_COLUMNS - 1, pitch) + (SLAB_THICKNESS + BACKPLATE_GAP) * pitch, MODEL_ROWS - 0.5, -1.0)
    left.text(back[0] + 0.5, back[1] - 0.5, "backplate\nbehind\ncolumn C", fontsize=8.5, ha="left", va="top")
    left.set_title("The plate: an R x C x D grid, one material per column (a layer of R x D masses)", fontsize=9.5)
    left.set_xlim(left.get_xlim()[0], left.get_xlim()[1] + 2.2)
    figure.text(
        0.02,
        0.02,
        "x: columns j = 1..C, the load's direction, through the thickness\ny: rows i = 1..R        z: depth k = 1..D",
        fontsize=8.5,
        va="bottom",
    )
    draw_springs(right)
    right.set_title("The springs of one mass: 6 nearest neighbours and 12 face diagonals", fontsize=9.5)
    return save(figure, path, tight=True, fit=True)


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m orchestrator.plate_picture", description="Draws docs/model.md section 10's figure of the plate."
    )
    parser.add_argument(
        "--write", required=True, metavar="PNG", type=Path, help="the image to write, e.g. docs/images/plate-model.png"
    )
    args = parser.parse_args(argv)
    if not args.write.parent.is_dir():
        print(f"--write {args.write}: its folder {args.write.parent} does not exist", file=sys.stderr)
        return 2
    draw_model_figure(args.write)
    print(f"wrote {args.write}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
