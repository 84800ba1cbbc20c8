"""The three bodies of docs/model.md section 11 drawn side by side along x: the projectile striking the lattice's
loaded face through the Hunt-Crossley contact, the lattice, and the hull the backplate moves with, on a spring
and a damper to the ground, with the ports that couple them. Written by

    python -m orchestrator.system_picture --write docs/images/system-model.png

A side view (x to the right, the rows up), drawn on flat axes as section 10's figure is
(orchestrator/plate_picture.py): the picture is a diagram, so its bodies are placed at fixed page positions, the
contact's overlap δ exaggerated so that it can be marked.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Sequence

import numpy as np
from matplotlib.patches import FancyBboxPatch, Rectangle, Wedge

from .charts import plt, save

ROWS, COLUMNS = 5, 4  # the lattice drawn: its last column stands for column C
FRONT_X = 4.0  # column 1's masses (the loaded face, x_front) on the page; one column a unit further each
OVERLAP = 0.45  # δ as drawn
NOSE_RADIUS = 0.8
BODY_LENGTH = 2.2  # of the projectile's cylinder, behind its nose
BACKPLATE_GAP, BACKPLATE_THICKNESS = 0.55, 0.3
HULL_WIDTH = 2.0
GROUND_X = 12.3  # the ground's face, where the spring and the damper end
HALF_HEIGHT = (ROWS - 1) / 2 + 0.6  # of the backplate and the hull
PROJECTILE_COLOUR, LATTICE_COLOUR, HULL_COLOUR, PORT_COLOUR = "crimson", "tab:blue", "0.55", "darkgreen"
FONT = 9.0
# The ports' names the figure must show (docs/model.md section 11; the lattice's and the hull's variables).
FRONT_PORT = ("F_front", "x_front", "v_front")
BACK_PORT = ("backplate_force", "F", "x_back", "v_back")


def column_x(column: int) -> float:
    """The page x of column ``column`` (0-based) of the lattice drawn."""
    return FRONT_X + column


def zigzag(x0: float, x1: float, y: float, turns: int = 6, amplitude: float = 0.22) -> tuple[np.ndarray, np.ndarray]:
    """A spring's line from (x0, y) to (x1, y): straight ends, ``turns`` zigzags between."""
    lead = 0.15 * (x1 - x0)
    xs = np.linspace(x0 + lead, x1 - lead, 2 * turns + 1)
    ys = y + amplitude * np.array([0.0] + [(-1) ** n for n in range(2 * turns - 1)] + [0.0])
    return np.concatenate([[x0], xs, [x1]]), np.concatenate([[y], ys, [y]])


def draw_damper(axis, x0: float, x1: float, y: float, colour: str = "0.2") -> None:
    """A dashpot from (x0, y) to (x1, y): a rod and its piston inside an open cylinder."""
    middle = (x0 + x1) / 2
    half = 0.22
    axis.plot([x0, middle + 0.15], [y, y], color=colour, lw=1.4)  # the rod
    axis.plot([middle + 0.15] * 2, [y - half * 0.8, y + half * 0.8], color=colour, lw=2.2)  # the piston
    axis.plot(
        [middle - 0.3, middle + 0.6, middle + 0.6, middle - 0.3],
        [y + half, y + half, y - half, y - half],
        color=colour,
        lw=1.4,
    )  # the cylinder, open towards the rod
    axis.plot([middle + 0.6, x1], [y, y], color=colour, lw=1.4)


def draw_lattice(axis) -> None:
    """The masses and springs of a small lattice: along x between columns, along y in a column, the diagonals
    faint; column 1 the loaded face, the last column C."""
    ys = np.arange(ROWS) - (ROWS - 1) / 2
    xs = np.array([column_x(j) for j in range(COLUMNS)])
    spring = dict(color=LATTICE_COLOUR, lw=1.0, zorder=2)
    for y in ys:
        axis.plot(xs, [y] * COLUMNS, **spring)
    for x in xs:
        axis.plot([x, x], [ys[0], ys[-1]], **spring)
    for j in range(COLUMNS - 1):
        for i in range(ROWS - 1):
            for start, end in (((j, i), (j + 1, i + 1)), ((j, i + 1), (j + 1, i))):
                axis.plot(
                    [xs[start[0]], xs[end[0]]],
                    [ys[start[1]], ys[end[1]]],
                    color=LATTICE_COLOUR,
                    lw=0.6,
                    ls=":",
                    alpha=0.7,
                    zorder=1,
                )
    x, y = np.meshgrid(xs, ys)
    axis.scatter(x.ravel(), y.ravel(), s=46, c="white", edgecolors="0.15", linewidths=0.9, zorder=4)
    axis.scatter([xs[0]] * ROWS, ys, s=46, c=PROJECTILE_COLOUR, edgecolors="0.15", linewidths=0.9, zorder=4)
    back = backplate_x()
    for y in ys:  # column C's contact with the backplate, across its gap
        axis.plot([xs[-1], back], [y, y], color="0.4", lw=0.8, ls=(0, (2, 2)), zorder=1)
    top = ys[-1] + 0.35
    axis.text(xs[0] - 0.25, top, "column 1\n(the loaded face)", ha="left", va="bottom", fontsize=FONT)
    axis.text(xs[-1], top, "column C", ha="center", va="bottom", fontsize=FONT)
    axis.text(
        (xs[0] + xs[-1]) / 2,
        ys[0] - 0.75,
        "the lattice",
        ha="center",
        va="top",
        fontsize=FONT + 0.5,
        color=LATTICE_COLOUR,
        weight="bold",
    )


def backplate_x() -> float:
    """The page x of the backplate's face towards column C."""
    return column_x(COLUMNS - 1) + BACKPLATE_GAP


def draw_projectile(axis) -> None:
    """The rigid body, its nose overlapping the face by δ, its speed arrow above it."""
    tip = FRONT_X + OVERLAP
    centre = tip - NOSE_RADIUS
    body = Rectangle(
        (centre - BODY_LENGTH, -NOSE_RADIUS),
        BODY_LENGTH,
        2 * NOSE_RADIUS,
        facecolor=PROJECTILE_COLOUR,
        edgecolor="0.15",
        alpha=0.85,
        zorder=3,
    )
    nose = Wedge(
        (centre, 0.0), NOSE_RADIUS, -90, 90, facecolor=PROJECTILE_COLOUR, edgecolor="0.15", alpha=0.85, zorder=3
    )
    axis.add_patch(body)
    axis.add_patch(nose)
    axis.text(
        centre - BODY_LENGTH / 2,
        0.0,
        "projectile_mass",
        ha="center",
        va="center",
        fontsize=FONT,
        color="white",
        weight="bold",
        zorder=5,
    )
    arrow_y = NOSE_RADIUS + 0.45
    axis.annotate(
        "",
        xy=(centre, arrow_y),
        xytext=(centre - BODY_LENGTH, arrow_y),
        arrowprops=dict(arrowstyle="-|>", lw=1.8, color=PROJECTILE_COLOUR, mutation_scale=14),
    )
    axis.text(
        centre - BODY_LENGTH / 2,
        arrow_y + 0.15,
        "v_p\n(at t = 0: projectile_speed)",
        ha="center",
        va="bottom",
        fontsize=FONT,
    )
    axis.text(
        centre - BODY_LENGTH / 2 - 0.5,
        arrow_y + 1.05,
        "the projectile\n(a rigid body along +x)",
        ha="center",
        va="bottom",
        fontsize=FONT + 0.5,
        color=PROJECTILE_COLOUR,
        weight="bold",
    )
    draw_overlap(axis, tip)


def draw_overlap(axis, tip: float) -> None:
    """δ = x_p - x_front measured between the nose's tip and the face, below the lattice."""
    low = -(ROWS - 1) / 2 - 1.55
    for x in (FRONT_X, tip):
        axis.plot(
            [x, x], [-NOSE_RADIUS if x == tip else -(ROWS - 1) / 2, low - 0.15], color="0.3", lw=0.7, ls="--", zorder=2
        )
    axis.annotate(
        "",
        xy=(tip, low),
        xytext=(FRONT_X, low),
        arrowprops=dict(arrowstyle="<|-|>", lw=0.9, color="0.2", mutation_scale=8, shrinkA=0, shrinkB=0),
    )
    axis.text(FRONT_X - 0.1, low, "x_front", ha="right", va="center", fontsize=FONT - 0.5)
    axis.text(tip + 0.1, low, "x_p", ha="left", va="center", fontsize=FONT - 0.5)
    axis.text(
        (FRONT_X + tip) / 2,
        low - 0.3,
        "δ = x_p − x_front (overlap, exaggerated)",
        ha="center",
        va="top",
        fontsize=FONT - 0.5,
    )
    axis.annotate(
        "Hunt-Crossley contact: F_c = k_c δ^n (1 + λ δ')\nfor δ > 0, else 0",
        xy=(tip - 0.2, -0.5),
        xytext=(FRONT_X - 2.55, -(ROWS - 1) / 2 - 0.15),
        ha="center",
        va="top",
        fontsize=FONT - 0.5,
        arrowprops=dict(arrowstyle="-", lw=0.6, color="0.3", shrinkB=2),
    )


def draw_hull(axis) -> None:
    """The backplate fixed to the hull, a mass M on a spring k and a damper c to the hatched ground."""
    back = backplate_x()
    axis.add_patch(
        Rectangle(
            (back, -HALF_HEIGHT), BACKPLATE_THICKNESS, 2 * HALF_HEIGHT, facecolor="dimgray", edgecolor="0.15", zorder=3
        )
    )
    hull_x = back + BACKPLATE_THICKNESS
    axis.add_patch(
        FancyBboxPatch(
            (hull_x, -HALF_HEIGHT),
            HULL_WIDTH,
            2 * HALF_HEIGHT,
            boxstyle="square,pad=0",
            facecolor=HULL_COLOUR,
            edgecolor="0.15",
            alpha=0.5,
            zorder=2,
        )
    )
    centre = hull_x + HULL_WIDTH / 2
    axis.text(centre, 0.0, "the hull\nmass M\nx, v", ha="center", va="center", fontsize=FONT + 0.5, weight="bold")
    axis.text(
        back + BACKPLATE_THICKNESS / 2,
        HALF_HEIGHT + 0.15,
        "backplate\n(moves with the hull)",
        ha="center",
        va="bottom",
        fontsize=FONT,
    )
    right = hull_x + HULL_WIDTH
    axis.plot(*zigzag(right, GROUND_X, 1.1), color="0.2", lw=1.3)
    axis.text((right + GROUND_X) / 2, 1.5, "spring k", ha="center", va="bottom", fontsize=FONT)
    draw_damper(axis, right, GROUND_X, -1.1)
    axis.text((right + GROUND_X) / 2, -1.5, "damper c", ha="center", va="top", fontsize=FONT)
    axis.add_patch(
        Rectangle(
            (GROUND_X, -HALF_HEIGHT), 0.4, 2 * HALF_HEIGHT, facecolor="white", edgecolor="0.2", hatch="///", zorder=2
        )
    )
    axis.text(GROUND_X + 0.2, -HALF_HEIGHT - 0.15, "ground", ha="center", va="top", fontsize=FONT)


def draw_ports(axis) -> None:
    """What crosses each port, below the bodies: the front port's on the left, the back port's on the right."""
    top = -(ROWS - 1) / 2 - 2.6
    front = (
        "front port (column 1's face)\n"
        "F_front ← the projectile's contact_force\n"
        "x_front, v_front → the projectile's inputs"
    )
    back = "back port (the backplate)\nbackplate_force → F, the hull's input\nx_back, v_back ← x, v, the hull's outputs"
    box = dict(boxstyle="round,pad=0.4", facecolor="white", edgecolor=PORT_COLOUR, lw=1.0)
    axis.text(
        FRONT_X - 1.2, top, front, ha="center", va="top", fontsize=FONT, color=PORT_COLOUR, bbox=box, linespacing=1.5
    )
    axis.text(
        backplate_x() + 1.3,
        top,
        back,
        ha="center",
        va="top",
        fontsize=FONT,
        color=PORT_COLOUR,
        bbox=box,
        linespacing=1.5,
    )


def system_figure():
    """The figure of the projectile, the lattice and the hull with their ports (not saved)."""
    figure, axis = plt.subplots(figsize=(11.5, 7.0))
    draw_lattice(axis)
    draw_projectile(axis)
    draw_hull(axis)
    draw_ports(axis)
    axis.set_xlim(FRONT_X - BODY_LENGTH - NOSE_RADIUS - 1.6, GROUND_X + 0.8)
    axis.set_ylim(-(ROWS - 1) / 2 - 3.9, HALF_HEIGHT + 1.4)
    axis.set_aspect("equal")
    axis.set_axis_off()
    axis.set_title(
        "Section 11's system along x: projectile → lattice → hull, and what crosses each port", fontsize=FONT + 1.5
    )
    return figure


def draw_system_figure(path: Path) -> str:
    """docs/model.md section 11's figure, written to ``path``."""
    return save(system_figure(), path, tight=True, fit=True)


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m orchestrator.system_picture",
        description="Draws docs/model.md section 11's figure of the projectile, the lattice and the hull.",
    )
    parser.add_argument(
        "--write", required=True, metavar="PNG", type=Path, help="the image to write, e.g. docs/images/system-model.png"
    )
    args = parser.parse_args(argv)
    if not args.write.parent.is_dir():
        print(f"--write {args.write}: its folder {args.write.parent} does not exist", file=sys.stderr)
        return 2
    draw_system_figure(args.write)
    print(f"wrote {args.write}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
