"""The report's charts are readable: no legend over the data, no title cut off at the figure's edges, no label
printed over another. Each chart is drawn from results shaped like the study's (the force peaks of the default
study, its solver settings, a two-objective run's title) and its drawn geometry checked."""

from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from orchestrator.objective import Trajectory
from orchestrator import charts
from orchestrator.steps.pareto import Pareto, draw_pareto
from orchestrator.steps.searches import Searches, draw_convergence
from orchestrator.steps.trajectories import LabelledTrajectory, Trajectories, draw_force_and_energy
from orchestrator.steps.work_precision import SolverPoint, WorkPrecision, WorkPrecisionResult, draw_work_precision

DATA = Path(__file__).resolve().parent / "data"
TWO_OBJECTIVE_LINE = (
    "11 x 11 lattice, 11 materials (permutation: 39,916,800 designs), load 1200 N at 0 deg for "
    "0.15 s, minimising peak_backplate_force, max_compression over 8 s, diagonal rules receiver "
    "and mean"
)


def study_of(results: dict, **fields) -> SimpleNamespace:
    """A study as the chart functions read it: each step's result by the step's type."""
    return SimpleNamespace(result=results.get, **fields)


@pytest.fixture()
def drawn(monkeypatch, tmp_path):
    """Draws a chart and returns its figure, laid out as saved (the figure is not closed)."""
    monkeypatch.setattr(charts.plt, "close", lambda *args: None)

    def draw(function, *args):
        assert function(*args) is not None
        figure = charts.plt.gcf()
        figure.canvas.draw()
        return figure

    yield draw
    charts.plt.close("all")


def inside_figure(figure, box) -> bool:
    width, height = figure.canvas.get_width_height()
    return box.x0 >= -0.5 and box.y0 >= -0.5 and box.x1 <= width + 0.5 and box.y1 <= height + 0.5


def data_points_under_legend(figure) -> int:
    renderer = figure.canvas.get_renderer()
    count = 0
    for axis in figure.axes:
        legend = axis.get_legend()
        if legend is None:
            continue
        box = legend.get_window_extent(renderer)
        assert inside_figure(figure, box), "the legend is cut off"
        for line in axis.lines:
            xy = line.get_xydata()
            if len(xy):
                shown = axis.transData.transform(xy)
                count += int(
                    np.sum(
                        (shown[:, 0] > box.x0)
                        & (shown[:, 0] < box.x1)
                        & (shown[:, 1] > box.y0)
                        & (shown[:, 1] < box.y1)
                    )
                )
    return count


def title_fits(figure) -> bool:
    title = figure._suptitle
    return title is not None and inside_figure(figure, title.get_window_extent(figure.canvas.get_renderer()))


def crowded_labels(figure, clearance: float = 1.5) -> list[tuple[str, str]]:
    """Labels closer than ``clearance`` points to another label, or than half of it to a marker other than their
    own point's."""
    renderer = figure.canvas.get_renderer()
    pad = clearance / 2 * figure.dpi / 72.0  # half on each box: two labels keep ``clearance`` apart
    labels = [a for axis in figure.axes for a in axis.texts if a.get_text()]  # not the leaders' empty ones
    boxes = [a.get_window_extent(renderer).padded(pad) for a in labels]
    crowded = [
        (labels[i].get_text(), labels[j].get_text())
        for i in range(len(labels))
        for j in range(i)
        if boxes[i].overlaps(boxes[j])
    ]
    for label, box in zip(labels, boxes):
        crowded += [
            (label.get_text(), "a marker")
            for marker in charts.marker_boxes(label.axes, exclude=label.xy)
            if box.overlaps(marker)
        ]
    return crowded


def force_study():
    """The default study's four force curves: the mean rule's answer peaks highest (2619 N), near 0.3 s."""
    time = np.linspace(0.0, 1.0, 1001)
    curves = []
    for label, order, peak in (
        ("receiver rule's answer", (1, 10, 9, 6, 4, 5, 7, 8, 3, 2, 11), 1415.4),
        ("mean rule's answer", (3, 1, 2, 4, 8, 7, 6, 5, 9, 10, 11), 2619.4),
        ("sequential", tuple(range(1, 12)), 1750.1),
        ("study's best", (1, 7, 5, 9, 3, 6, 11, 8, 2, 4, 10), 1504.8),
    ):
        force = peak * np.exp(-(((time - 0.31) / 0.05) ** 2))
        curves.append(
            LabelledTrajectory(
                label, "receiver", Trajectory(order, "ok", "", tuple(time), {"backplate_force": tuple(force)}, 0.0)
            )
        )
    energy_time = tuple(np.linspace(0.0, 8.0, 801))
    energy = Trajectory(
        curves[0].trajectory.order,
        "ok",
        "",
        energy_time,
        {
            name: tuple(np.sin(np.array(energy_time)) * 50 + 50)
            for name in (
                "kinetic_energy",
                "potential_energy",
                "external_work",
                "dissipated_energy",
                "nonreciprocal_work",
                "energy_balance_error",
            )
        },
        0.0,
    )
    trajectories = SimpleNamespace(
        force=tuple(curves), energy=(LabelledTrajectory("receiver rule's answer", "receiver", energy),)
    )
    return study_of({Trajectories: trajectories})


def test_the_force_legend_hides_no_curve(drawn, tmp_path):
    figure = drawn(draw_force_and_energy, force_study(), tmp_path / "force.png", TWO_OBJECTIVE_LINE)
    assert data_points_under_legend(figure) == 0
    assert title_fits(figure)


def test_the_chosen_designs_force_curve_is_drawn_over_the_others_and_the_legend_keeps_their_order(drawn, tmp_path):
    study = force_study()
    figure = drawn(draw_force_and_energy, study, tmp_path / "force.png", TWO_OBJECTIVE_LINE)
    force_axis = figure.axes[0]
    chosen = study.result(Trajectories).force[0].label
    lines = {line.get_label().split(" [")[0]: line for line in force_axis.lines}
    assert max(lines.values(), key=lambda line: (line.get_zorder(), force_axis.lines.index(line))) is lines[chosen]
    assert lines[chosen].get_linewidth() > max(line.get_linewidth() for label, line in lines.items() if label != chosen)
    legend = [text.get_text().split(" [")[0] for text in force_axis.get_legend().get_texts()]
    assert legend == [labelled.label for labelled in study.result(Trajectories).force]


def test_a_two_objective_convergence_title_is_not_cut_off(drawn, tmp_path):
    def run(label, method, seed):
        curve = list(np.minimum.accumulate(np.random.default_rng(seed).uniform(1400, 4000, 200)))
        return SimpleNamespace(label=label, method=method, n_evaluations=200, best_so_far=lambda: curve)

    runs = [
        run(label, method, seed)
        for label in ("receiver", "mean")
        for method in ("nsga2", "random")
        for seed in range(3)
    ]
    study = study_of(
        {Searches: SimpleNamespace(runs=runs)},
        case=SimpleNamespace(
            objective=SimpleNamespace(units=("N", "m"), outputs=("peak_backplate_force", "max_compression"))
        ),
    )
    figure = drawn(
        draw_convergence,
        study,
        tmp_path / "convergence.png",
        f"Convergence over seeds: median and quartiles. {TWO_OBJECTIVE_LINE}",
        {},
    )
    assert title_fits(figure)


def test_the_solver_chart_prints_no_label_over_another_and_no_legend_over_the_data(drawn, tmp_path):
    recorded = json.loads((DATA / "work_precision_points.json").read_text())
    result = WorkPrecisionResult(
        recorded["diagonal_rule"],
        recorded["target"],
        SolverPoint(**recorded["default"]),
        tuple(SolverPoint(**p) for p in recorded["points"]),
    )
    figure = drawn(draw_work_precision, study_of({WorkPrecision: result}), tmp_path / "wp.png")
    assert crowded_labels(figure) == []
    assert data_points_under_legend(figure) == 0


def test_the_front_chart_prints_no_label_over_another(drawn, tmp_path):
    def point(values):
        return SimpleNamespace(values=values)

    ends = (SimpleNamespace(output="peak_backplate_force", values=(1405.9, 0.2616), certified=True),)
    front = SimpleNamespace(
        diagonal_rule="receiver",
        points=[point((1405.9, 0.2616)), point((1480.0, 0.2595)), point((1931.0, 0.2560))],
        chosen=[
            SimpleNamespace(label="lowest peak_backplate_force", values=(1405.9, 0.2616)),
            SimpleNamespace(label="knee", values=(1480.0, 0.2595)),
            SimpleNamespace(label="lowest max_compression", values=(1931.0, 0.2560)),
        ],
        sureness=SimpleNamespace(known_ends=ends),
    )
    study = study_of(
        {Pareto: SimpleNamespace(fronts=(front,))},
        case=SimpleNamespace(
            objective=SimpleNamespace(units=("N", "m"), outputs=("peak_backplate_force", "max_compression"))
        ),
    )
    figure = drawn(draw_pareto, study, tmp_path / "pareto.png")
    assert crowded_labels(figure) == []
    renderer = figure.canvas.get_renderer()
    frame = figure.axes[0].get_window_extent(renderer)
    assert all(charts.inside(t.get_window_extent(renderer), frame) for t in figure.axes[0].texts if t.get_text())
    assert data_points_under_legend(figure) == 0


def test_labels_crowded_on_one_point_are_spread_with_leaders(drawn, tmp_path):
    def crowd(study, path):
        figure, axis = charts.plt.subplots(figsize=(4, 3))
        axis.plot([1.0, 2.0, 3.0], [1.0, 1.0, 1.0], "o-")
        labels = [
            axis.annotate(f"setting {k}", (2.0, 1.0), fontsize=6, textcoords="offset points", xytext=(3, 3))
            for k in range(8)
        ]
        return charts.save(figure, path, labels=labels)

    figure = drawn(crowd, None, tmp_path / "crowd.png")
    texts = [t for t in figure.axes[0].texts if t.get_text()]
    assert len(texts) == 8
    renderer = figure.canvas.get_renderer()
    boxes = [t.get_window_extent(renderer) for t in texts]
    assert not any(boxes[i].overlaps(boxes[j]) for i in range(len(boxes)) for j in range(i))
    assert any(t.arrow_patch is not None for t in figure.axes[0].texts if not t.get_text())  # leaders drawn
