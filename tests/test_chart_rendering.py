"""The charts as a person sees them: the report's PNGs as report.html shows them and explore.html, in a browser
window 1280 px wide (Debian's chromium through Selenium, as tests/test_explore.py drives it).

No text of a chart may overlap another text, no legend may cover a label or the data (text bounding boxes from
matplotlib's renderer, ``get_window_extent``, once the figure is saved; in explore.html from the page's DOM), no
text may be shown smaller than ``MIN_TEXT_PX`` screen pixels, a legend must show whole without scrolling, a log
axis must read as numbers that grow, and report.html must hold its images (one file that can be mailed).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from test_explore import CHROMEDRIVER, CHROMIUM, browser, main  # noqa: F401 - browser: the fixture, used by name

from orchestrator import charts

WINDOW_WIDTH = 1280
SAVE_DPI = 110  # the report's charts are saved at this resolution
OVERLAP_PX = 1.0  # boxes overlapping by less than this (in each direction) touch, they do not cover


@dataclass(frozen=True)
class Box:
    x0: float
    y0: float
    x1: float
    y1: float

    def overlaps(self, other: Box) -> bool:
        return (
            min(self.x1, other.x1) - max(self.x0, other.x0) > OVERLAP_PX
            and min(self.y1, other.y1) - max(self.y0, other.y0) > OVERLAP_PX
        )

    def holds(self, x: float, y: float) -> bool:
        return self.x0 < x < self.x1 and self.y0 < y < self.y1


@dataclass(frozen=True)
class ChartText:
    text: str
    box: Box
    size_px: float  # its height in the saved image's pixels
    legend: int | None  # which legend of the figure it belongs to


@dataclass(frozen=True)
class ChartLayout:
    """What a saved figure shows, in one pixel space: each text, each legend's frame and the data it may cover."""

    file: str
    texts: tuple[ChartText, ...]
    legends: tuple[Box, ...]
    data_points: tuple[np.ndarray, ...]  # per axes: the drawn lines and bands, sampled every pixel or so

    def problems(self) -> list[str]:
        found = []
        for a, b in itertools.combinations(self.texts, 2):
            if a.box.overlaps(b.box):
                found.append(f"{self.file}: text {a.text!r} overlaps {b.text!r}")
        for index, legend in enumerate(self.legends):
            for text in self.texts:
                if text.legend != index and legend.overlaps(text.box):
                    found.append(f"{self.file}: a legend covers the text {text.text!r}")
            covered = sum(int(sum(legend.holds(x, y) for x, y in points)) for points in self.data_points)
            if covered:
                found.append(f"{self.file}: a legend covers the data ({covered} sampled points under it)")
        return found


def box_of(extent) -> Box:
    return Box(extent.x0, extent.y0, extent.x1, extent.y1)


def sampled(path_points: np.ndarray, step: float = 1.0) -> np.ndarray:
    """The points of a polyline in display space, with points added along each segment every ``step`` px."""
    points = [path_points[:1]]
    for start, end in itertools.pairwise(path_points):
        count = int(np.hypot(*(end - start)) // step) + 1
        points.append(np.linspace(start, end, count + 1)[1:])
    return np.concatenate(points) if len(path_points) else path_points


def drawn_texts(figure) -> list:
    """The Text artists a draw of the figure renders (the renderer is told each one's text), in drawing order."""
    renderer = figure.canvas.get_renderer()
    drawn: dict[int, object] = {}
    draw_text = renderer.draw_text

    def recording(gc, x, y, s, prop, angle, ismath=False, mtext=None):
        if mtext is not None and s.strip():
            drawn[id(mtext)] = mtext
        return draw_text(gc, x, y, s, prop, angle, ismath=ismath, mtext=mtext)

    renderer.draw_text = recording
    try:
        figure.draw(renderer)
    finally:
        del renderer.draw_text
    return list(drawn.values())


def layout_of(figure, file: str) -> ChartLayout:
    """The layout of a figure as it was saved."""
    from matplotlib.collections import PolyCollection
    from matplotlib.legend import Legend
    from matplotlib.text import Text

    texts = drawn_texts(figure)
    renderer = figure.canvas.get_renderer()
    legends = [artist for artist in figure.findobj(Legend) if artist.get_visible()]
    owner = {id(text): index for index, legend in enumerate(legends) for text in legend.findobj(Text)}
    shown = tuple(
        ChartText(
            text.get_text(),
            box_of(text.get_window_extent(renderer)),
            text.get_fontsize() * SAVE_DPI / 72.0,
            owner.get(id(text)),
        )
        for text in texts
    )
    data = []
    for axis in figure.axes:
        frame = axis.bbox
        paths = [axis.transData.transform(line.get_xydata()) for line in axis.lines if line.get_visible()]
        paths += [
            axis.transData.transform(path.vertices)
            for collection in axis.collections
            if isinstance(collection, PolyCollection) and collection.get_visible()
            for path in collection.get_paths()
        ]
        for points in paths:
            points = sampled(points[np.isfinite(points).all(axis=1)])
            data.append(points[[frame.contains(x, y) for x, y in points]] if len(points) else points)
    return ChartLayout(
        file, shown, tuple(box_of(legend.get_window_extent(renderer)) for legend in legends), tuple(data)
    )


@pytest.fixture(scope="module")
def study(fmu_path, tmp_path_factory):
    """The default study's steps and charts, small: the default methods with two seeds, each chart's layout
    recorded as it is saved (``Figure.savefig``, whichever module draws it)."""
    from matplotlib.figure import Figure

    layouts: dict[str, ChartLayout] = {}
    original = Figure.savefig

    def recording_savefig(figure, path, *args, **kwargs):
        original(figure, path, *args, **kwargs)
        layouts[Path(path).name] = layout_of(figure, Path(path).name)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(Figure, "savefig", recording_savefig)
        out = tmp_path_factory.mktemp("charts") / "results"
        assert (
            main(
                "--fmu",
                fmu_path,
                "--out",
                out,
                "--budget",
                "30",
                "--repeats",
                "2",
                "--no-sensitivity",
                "--no-progress",
                "--executor",
                "serial",
            )
            == 0
        )
    return out, layouts


def test_no_chart_has_overlapping_text_or_a_legend_over_labels_or_data(study):
    _, layouts = study
    assert {"convergence.png", "force_energy.png", "work_precision.png", "lattice.png"} <= set(layouts)
    problems = [problem for layout in layouts.values() for problem in layout.problems()]
    assert problems == []


needs_browser = pytest.mark.skipif(
    CHROMIUM is None or CHROMEDRIVER is None,
    reason="needs Debian's chromium and chromium-driver (apt-get install chromium chromium-driver)",
)


@needs_browser
def test_report_html_holds_its_charts_and_shows_their_text_readable_at_1280_px(study, request):
    out, layouts = study
    driver = request.getfixturevalue("browser")
    driver.set_window_size(WINDOW_WIDTH, 1800)
    driver.get((out / "report.html").resolve().as_uri())
    images = driver.execute_script(
        "return [...document.images].map(i => [i.getAttribute('src').slice(0, 22), i.dataset.chart || '', "
        "i.naturalWidth, i.clientWidth])"
    )
    assert images and all(source == "data:image/png;base64," for source, *_ in images), images
    shown = {chart: (natural, client) for _, chart, natural, client in images}
    assert set(shown) == set(layouts)
    small = []
    for chart, (natural, client) in shown.items():
        assert natural > 0, chart
        smallest = min(text.size_px for text in layouts[chart].texts) * client / natural
        if smallest < charts.MIN_TEXT_PX:
            small.append(f"{chart}: text shown {smallest:.1f} px high")
    assert small == []


PLOT_TEXTS = """
const boxes = [];
for (const plot of document.querySelectorAll('.js-plotly-plot')) {
  if (!plot.offsetParent) continue;
  for (const text of plot.querySelectorAll('text')) {
    const r = text.getBoundingClientRect();
    const style = getComputedStyle(text);
    if (!text.textContent.trim() || r.width === 0 || style.display === 'none' || style.visibility === 'hidden'
        || text.closest('.hovertext') || style.opacity === '0') continue;
    boxes.push([plot.id, text.textContent, r.left, r.top, r.right, r.bottom]);
  }
}
return boxes;
"""


@needs_browser
def test_explore_html_at_1280_px_shows_whole_legends_growing_log_axes_and_no_overlapping_text(study, request):
    out, _ = study
    driver = request.getfixturevalue("browser")
    driver.set_window_size(WINDOW_WIDTH, 1800)
    driver.get((out / "explore.html").resolve().as_uri())
    driver.execute_script("window.dispatchEvent(new Event('resize'))")
    scrollbars = driver.execute_script(
        "return [...document.querySelectorAll('.legend .scrollbar')].map(s => s.getBBox().height)"
        ".filter(h => h > 0).length"
    )
    assert scrollbars == 0, "a legend needs scrolling"
    ticks = driver.execute_script(
        "return [...document.querySelectorAll('#convergence .js-plotly-plot')].map(p => "
        "[...p.querySelectorAll('.xtick text')].map(t => t.textContent))"
    )
    assert ticks and all(ticks)
    for labels in ticks:
        values = [float(label.replace("\u2212", "-").replace(",", "")) for label in labels]
        assert values == sorted(values) and len(set(values)) == len(values), labels
    boxes = driver.execute_script(PLOT_TEXTS)
    overlapping = [
        (a[1], b[1]) for a, b in itertools.combinations(boxes, 2) if a[0] == b[0] and Box(*a[2:]).overlaps(Box(*b[2:]))
    ]
    assert overlapping == []
