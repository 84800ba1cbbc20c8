"""The charts every step draws from a study's typed results (nothing here simulates): matplotlib set up once,
the methods' names and colours, the figure title and the PNG writer."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.transforms import Bbox  # noqa: E402


METHOD_NAMES = {
    "cmaes": "CMA-ES",
    "pso": "particle swarm",
    "sa": "simulated annealing",
    "ga": "genetic algorithm",
    "de": "differential evolution",
    "random": "random search",
    "local": "iterated local search",
    "sequential": "baseline order",
    "nsga2": "NSGA-II",
}
# The one palette of every chart and page (the PNGs and explore.html): a method has one colour everywhere,
# and no two methods share one. Hex, so that the browser and matplotlib read the same value.
COLOURS = {
    "cmaes": "#1f77b4",
    "pso": "#ff7f0e",
    "sa": "#2ca02c",
    "ga": "#9467bd",
    "de": "#8c564b",
    "random": "#7f7f7f",
    "local": "#bcbd22",
    "sequential": "#000000",
    "nsga2": "#17becf",
    "finalists": "#e377c2",
}
OTHER_COLOURS = ("#d62728", "#e377c2", "#17becf", "#8c564b")  # methods the palette does not name, in turn
RULE_COLOURS = ("#1f77b4", "#d62728", "#2ca02c", "#9467bd")  # the diagonal rules' answers and fronts, in turn
MIN_TEXT_PX = 8.0  # the smallest text a chart may show, in screen pixels, as report.html displays it at 1280 px


def method_colour(method: str, methods=()) -> str:
    """The colour of ``method`` on every chart and page; a method the palette does not name takes the next
    colour of ``OTHER_COLOURS`` by its place in ``methods``."""
    if method in COLOURS:
        return COLOURS[method]
    others = [m for m in dict.fromkeys(methods) if m not in COLOURS]
    return OTHER_COLOURS[(others.index(method) if method in others else 0) % len(OTHER_COLOURS)]


def save(figure, path: Path, tight: bool = True, labels=(), fit: bool = False) -> str:
    """Writes the figure. ``labels``: annotations beside their points, moved apart where they would overlap
    (once the layout is final, so that what is checked is what is drawn); ``fit``: the image grown or cropped to
    everything drawn (text outside the axes included)."""
    if tight:
        figure.tight_layout()
    spread_labels(figure, labels)
    figure.savefig(path, dpi=110, **({"bbox_inches": "tight", "pad_inches": 0.1} if fit else {}))
    plt.close(figure)
    return path.name


LABEL_RINGS = (3, 7, 12, 18, 26, 36, 48)  # points from its point at which a label is tried, nearest first


def spread_labels(figure, labels, clearance: float = 2.0) -> None:
    """Places each annotation (made with ``textcoords="offset points"``) at the nearest spot around its point,
    right, left, above or below, inside its axes, that keeps ``clearance`` points from every label placed before
    it and from every marker of its axes but its own point's (a faint background cloud excepted), and off every
    line where there is room; a label placed away from its point gets a thin leader line.
    Why by hand: matplotlib puts a label where it is told and has no collision avoidance, and a crowded chart
    (solver settings of similar cost and error, the ends of a front) would print labels on top of each other."""
    if not labels:
        return
    renderer = figure.canvas.get_renderer()
    pad = clearance * figure.dpi / 72.0
    to_points = 72.0 / figure.dpi
    placed: list[Bbox] = []
    for label in labels:
        obstacles = placed + marker_boxes(label.axes, exclude=label.xy)
        lines = line_points(label.axes)
        frame = label.axes.get_window_extent(renderer)
        extent = label.get_window_extent(renderer)
        width, height = extent.width * to_points, extent.height * to_points
        first = label.xyann
        chosen = None
        for avoid_lines in (True, False):  # off every line where there is room, else off the markers alone
            for ring in LABEL_RINGS:
                for dx, dy in (
                    (ring, 0.4 * ring),
                    (ring, -ring - 0.6 * height),
                    (-ring - width, 0.4 * ring),
                    (-ring - width, -ring - 0.6 * height),
                    (-width / 2, ring + 2),
                    (-width / 2, -ring - height - 2),
                ):
                    label.xyann = (dx, dy)
                    box = label.get_window_extent(renderer).padded(pad)
                    if (
                        inside(box, frame)
                        and not any(box.overlaps(other) for other in obstacles)
                        and not (avoid_lines and crosses(box, lines))
                    ):
                        chosen = (ring, dx, dy)
                        break
                if chosen:
                    break
            if chosen:
                break
        if chosen is None:
            label.xyann = first  # nowhere clear: where it was asked
        elif chosen[0] > LABEL_RINGS[1]:  # a leader from the label's corner to its point
            label.axes.annotate(
                "",
                xy=label.xy,
                xytext=label.xyann,
                textcoords="offset points",
                arrowprops=dict(arrowstyle="-", lw=0.4, color="0.45", shrinkA=0, shrinkB=2),
            )
        placed.append(label.get_window_extent(renderer))


def line_points(axis, step: float = 2.0) -> np.ndarray:
    """Points every ``step`` pixels along each drawn line of the axis (faint ones excepted), in display space:
    a label placed on them would hide the line, or read as another point's."""
    points = [np.empty((0, 2))]
    for line in axis.lines:
        if line.get_linestyle() in ("None", "", " ") or (line.get_alpha() or 1.0) < 0.5 or not line.get_visible():
            continue
        vertices = axis.transData.transform(line.get_xydata())
        vertices = vertices[np.isfinite(vertices).all(axis=1)]
        for start, end in zip(vertices[:-1], vertices[1:]):
            count = int(np.hypot(*(end - start)) // step) + 2
            points.append(np.linspace(start, end, min(count, 2000)))
    return np.concatenate(points)


def crosses(box, points: np.ndarray) -> bool:
    return bool(
        ((points[:, 0] > box.x0) & (points[:, 0] < box.x1) & (points[:, 1] > box.y0) & (points[:, 1] < box.y1)).any()
    )


def inside(box, frame) -> bool:
    return box.x0 >= frame.x0 and box.x1 <= frame.x1 and box.y0 >= frame.y0 and box.y1 <= frame.y1


def marker_boxes(axis, exclude=None) -> list:
    """The drawn extent of every marker of the axis's lines (the point ``exclude``, a label's own, left out)."""
    from matplotlib.transforms import Bbox

    boxes = []
    for line in axis.lines:
        if line.get_marker() in (None, "None", "", " ") or (line.get_alpha() or 1.0) < 0.5:
            continue  # no markers, or a faint background cloud a label may be printed over
        radius = line.get_markersize() / 2 * axis.figure.dpi / 72.0
        for point in line.get_xydata():
            if exclude is not None and np.allclose(point, exclude):
                continue
            x, y = axis.transData.transform(point)
            boxes.append(Bbox.from_extents(x - radius, y - radius, x + radius, y + radius))
    return boxes


def legend_below(axis, fontsize: float = 7, columns: int = 1):
    """The axis's legend under its x label, where it hides no data (a legend inside the axes covers whatever
    lies under it, and long labels cover most of the width)."""
    return axis.legend(fontsize=fontsize, loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=columns, frameon=False)


def figure_title(figure, text: str, fontsize: float = 9) -> None:
    """A title over the whole figure, wrapped to the figure's width (a line wider than the figure is cut off
    at both ends)."""
    width_points = figure.get_figwidth() * 72.0
    characters = max(40, int(0.9 * width_points / (0.55 * fontsize)))  # 0.55 em: a generous average glyph width
    figure.suptitle(wrapped(text, characters), fontsize=fontsize)


def best_so_far_matrix(runs) -> np.ndarray:
    """Rows: seeds; columns: evaluations; NaN before the first value and the last value after a run ended."""
    length = max(run.n_evaluations for run in runs)
    matrix = np.full((len(runs), length), np.nan)
    for row, run in enumerate(runs):
        curve = [np.nan if v is None else v for v in run.best_so_far()]
        matrix[row, : len(curve)] = curve
        if curve:
            matrix[row, len(curve) :] = curve[-1]
    return matrix


def wrapped(text: str, width: int = 150) -> str:
    """A chart title over several lines."""
    import textwrap

    return "\n".join(textwrap.wrap(text, width))


__all__ = [
    "COLOURS",
    "METHOD_NAMES",
    "MIN_TEXT_PX",
    "RULE_COLOURS",
    "best_so_far_matrix",
    "figure_title",
    "legend_below",
    "marker_boxes",
    "method_colour",
    "plt",
    "save",
    "spread_labels",
    "wrapped",
]
