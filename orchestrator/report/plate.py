"""The plate of layers drawn in an oblique view (docs/model.md section 10): the report's lattice picture of a
plate, and the model page's figure of the plate and the springs of one mass, written by

    python -m orchestrator.report.plate --write docs/images/plate-model.png

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
from matplotlib.collections import LineCollection, PolyCollection
from matplotlib.colors import to_rgb
from matplotlib.lines import Line2D
from matplotlib.patches import Polygon

from fmu_src.variables import LoadedFace, loaded_face

from .charts import plt

X_SCREEN = np.array([1.0, 0.0])  # one unit along x on the page
Y_SCREEN = np.array([0.0, 1.0])
Z_SCREEN = np.array([-0.5, 0.3])  # along z: up and to the left, shortened as a depth is
SLAB_THICKNESS = 0.45  # of a layer drawn as a slab, in units of the spacing between columns
BACKPLATE_GAP = 0.45  # between column C's slab and the backplate
BACKPLATE_THICKNESS = 0.35
LOAD_COLOUR = "crimson"
BACKPLATE_COLOUR = "dimgray"
ARROW_LENGTH = 3.0  # of the load's arrow, in units of the spacing
LAYER_GID = "layer {}"  # each slab's gid: what the tests count
LOAD_GID, BACKPLATE_GID = "loaded region", "backplate"


def project(x, y, z) -> np.ndarray:
    """Page coordinates of model points (x, y, z): arrays broadcast, the last axis of the result is (page x,
    page y)."""
    x, y, z = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (x, y, z)))
    return x[..., None] * X_SCREEN + y[..., None] * Y_SCREEN + z[..., None] * Z_SCREEN


def layer_x(column: int) -> float:
    """The x of the struck face of column ``column`` (0-based) drawn as a slab: its masses' x, less half the
    slab."""
    return column - SLAB_THICKNESS / 2


def box_faces(x: tuple[float, float], y: tuple[float, float], z: tuple[float, float]) -> list[np.ndarray]:
    """The three faces of a box the view shows: the one facing the load (-x), the top (+y), the front (-z)."""
    (x0, x1), (y0, y1), (z0, z1) = x, y, z
    return [project([x0, x0, x0, x0], [y0, y1, y1, y0], [z0, z0, z1, z1]),
            project([x0, x1, x1, x0], [y1, y1, y1, y1], [z0, z0, z1, z1]),
            project([x0, x1, x1, x0], [y0, y0, y1, y1], [z0, z0, z0, z0])]


def shaded(colour, amount: float) -> tuple[float, float, float]:
    """``colour`` towards white (amount > 0) or black (amount < 0): the top lit, the front edge in shade."""
    rgb = np.array(to_rgb(colour))
    target = np.ones(3) if amount > 0 else np.zeros(3)
    return tuple(rgb + abs(amount) * (target - rgb))


def draw_slab(axis, x: tuple[float, float], y: tuple[float, float], z: tuple[float, float], colour,
              gid: str, alpha: float = 1.0) -> PolyCollection:
    faces = box_faces(x, y, z)
    slab = PolyCollection(faces, facecolors=[colour, shaded(colour, 0.35), shaded(colour, -0.3)],
                          edgecolors="0.15", linewidths=0.4, alpha=alpha, gid=gid)
    axis.add_collection(slab)
    return slab


def plate_bounds(rows: int, columns: int, depth: int, arrow_length: float) -> tuple[np.ndarray, np.ndarray]:
    """The page's lower left and upper right corners around what draw_plate draws (the names below aside): the
    slabs, the backplate, the arrow's tail and the layer numbers above, with a margin."""
    last = layer_x(columns - 1) + SLAB_THICKNESS + BACKPLATE_GAP + BACKPLATE_THICKNESS
    corners = project([layer_x(0), last] * 4, [-1.0, -1.0, rows, rows] * 2,
                      [-1.0, -1.0, -1.0, -1.0, depth, depth, depth, depth])
    tail = project(layer_x(0) - arrow_length, (rows - 1) / 2, (depth - 1) / 2)
    points = np.vstack([corners, tail])
    return points.min(axis=0) - 0.3, points.max(axis=0) + np.array([0.3, 1.2])


def face_outline(face: LoadedFace, x: float) -> np.ndarray:
    """The loaded region on the plane x, as a closed polygon around its masses (half a spacing out)."""
    y0, y1 = face.row_range.start - 0.5, face.row_range.stop - 0.5
    z0, z1 = face.depth_range.start - 0.5, face.depth_range.stop - 0.5
    return project([x] * 4, [y0, y1, y1, y0], [z0, z0, z1, z1])


def draw_plate(axis, rows: int, depth: int, colours: Sequence, names: Sequence[str],
               faces: Sequence[LoadedFace], label_size: float = 7, arrow_length: float = ARROW_LENGTH) -> None:
    """The plate on ``axis``: a slab per column (layer), coloured ``colours[j]`` and labelled ``names[j]`` under
    it, the masses of column 1's face as dots, those the load pushes (the union of ``faces``) in the load's
    colour with each loaded region outlined, the load's arrow, and the backplate behind the last column."""
    columns = len(colours)
    y_span, z_span = (-0.5, rows - 0.5), (-0.5, depth - 0.5)
    last = layer_x(columns - 1) + SLAB_THICKNESS + BACKPLATE_GAP
    draw_slab(axis, (last, last + BACKPLATE_THICKNESS), (-1.0, rows - 0.5), (-1.0, depth - 0.5), BACKPLATE_COLOUR,
              BACKPLATE_GID)
    for column in reversed(range(columns)):  # from the backplate to the load: the nearer slab drawn over
        x0 = layer_x(column)
        draw_slab(axis, (x0, x0 + SLAB_THICKNESS), y_span, z_span, colours[column], LAYER_GID.format(column + 1))
    front = layer_x(0)
    loaded = set().union(*(face.masses() for face in faces))
    i, k = np.meshgrid(np.arange(rows), np.arange(depth), indexing="ij")
    pushed = np.array([(a, b) in loaded for a, b in zip(i.ravel(), k.ravel())])
    dots = project(front, i.ravel(), k.ravel())
    size = float(np.clip(260.0 / max(rows, depth), 3.0, 40.0))
    axis.scatter(dots[~pushed, 0], dots[~pushed, 1], s=size, c="white", edgecolors="0.2", linewidths=0.3,
                 zorder=3)
    axis.scatter(dots[pushed, 0], dots[pushed, 1], s=size, c=LOAD_COLOUR, edgecolors="0.2", linewidths=0.3,
                 zorder=3)
    for face in sorted(faces, key=lambda f: -len(f.masses())):
        axis.add_patch(Polygon(face_outline(face, front), closed=True, fill=False, edgecolor=LOAD_COLOUR, lw=1.6,
                               zorder=4, gid=LOAD_GID))
    centre = ((rows - 1) / 2, (depth - 1) / 2)
    tip, tail = project(front - 0.1, *centre), project(front - arrow_length, *centre)
    axis.annotate("", xy=tip, xytext=tail, zorder=5,
                  arrowprops=dict(arrowstyle="-|>", lw=2.2, color=LOAD_COLOUR, mutation_scale=14))
    for column, name in enumerate(names):
        foot = project(layer_x(column) + SLAB_THICKNESS / 2, -0.5, -0.5)
        axis.text(foot[0], foot[1] - 0.35, name, rotation=60, ha="right", va="top", fontsize=label_size,
                  rotation_mode="anchor")
    for column in range(columns):  # each layer's number over its far top edge
        top = project(layer_x(column) + SLAB_THICKNESS / 2, rows - 0.5, depth - 0.5)
        axis.text(top[0], top[1] + 0.25, f"layer {column + 1}" if column == 0 else str(column + 1),
                  ha="right" if column == 0 else "center", va="bottom", fontsize=label_size - 0.5, color="0.3")
    low, high = plate_bounds(rows, columns, depth, arrow_length)
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
    low, high = plate_bounds(case.rows, case.columns, case.depth, ARROW_LENGTH)
    height = 4.4  # inches of a panel's drawing; its width as the plate's
    width = height * (high[0] - low[0]) / (high[1] - low[1])
    figure, axes = plt.subplots(1, len(designs), figsize=(max(width, 2.6) * len(designs) + 1.4, height + 1.0),
                                squeeze=False, layout="constrained")
    for axis, (label, order) in zip(axes[0], designs):
        colours = [colour_map(norm(materials[m - 1]["k"])) for m in order]
        draw_plate(axis, case.rows, case.depth, colours, [materials[m - 1]["name"] for m in order], faces,
                   arrow_length=ARROW_LENGTH)
        axis.set_title(label, fontsize=9)
    from matplotlib.cm import ScalarMappable

    bar = figure.colorbar(ScalarMappable(norm=norm, cmap=colour_map), ax=axes[0].tolist(), shrink=0.8)
    bar.set_label("spring constant k of the layer's material, along y and z (N)")
    figure_title(figure, f"{case.rows} x {case.columns} x {case.depth} plate: {case.columns} layers along x, "
                         f"each {case.rows} x {case.depth} masses (y x z); the load (arrow) on layer 1 over "
                         f"{where_loaded(faces)} (red), the backplate (grey) behind layer {case.columns}")
    return save(figure, path, tight=False, fit=True)
