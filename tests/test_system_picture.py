"""docs/model.md section 11's figure of the projectile, the lattice and the hull: written by the command its page
states, naming every port, its labels apart."""

from __future__ import annotations

import re
from itertools import combinations
from pathlib import Path

import pytest

from orchestrator import charts
from orchestrator import system_picture as system

PAGE = Path(__file__).resolve().parents[1] / "docs" / "model.md"


@pytest.fixture()
def figure():
    figure = system.system_figure()
    figure.tight_layout()  # laid out as charts.save lays it out before writing it
    figure.canvas.draw()
    yield figure
    charts.plt.close(figure)


def texts(figure) -> list:
    """Every non-empty text of the figure: the axes' labels and annotations, its title."""
    found = [text for axis in figure.axes for text in (*axis.texts, axis.title)]
    return [text for text in found + list(figure.texts) if text.get_text().strip()]


def test_the_figure_names_every_port_of_the_front_and_the_back(figure):
    words = set(re.findall(r"[A-Za-z_]+", " ".join(text.get_text() for text in texts(figure))))
    ports = system.FRONT_PORT + system.BACK_PORT
    assert set(ports) == {"F_front", "x_front", "v_front", "backplate_force", "F", "x_back", "v_back"}
    assert not set(ports) - words, f"the figure does not name {sorted(set(ports) - words)}"
    for body in ("projectile", "lattice", "hull", "backplate", "column C", "δ = x_p − x_front"):
        assert any(body in text.get_text() for text in texts(figure)), body


def test_no_two_labels_of_the_figure_overlap(figure):
    renderer = figure.canvas.get_renderer()
    boxes = [(text.get_text(), text.get_window_extent(renderer)) for text in texts(figure)]
    overlapping = [(a, b) for (a, box_a), (b, box_b) in combinations(boxes, 2) if box_a.overlaps(box_b)]
    assert not overlapping, overlapping


def test_the_system_figure_is_written_by_the_command_its_page_states(tmp_path, capsys):
    page = PAGE.read_text()
    section = page[page.index("## 11. ") : page.index("## 12. ")]
    assert "`python -m orchestrator.system_picture --write docs/images/system-model.png`" in section
    assert "(images/system-model.png)" in section
    assert system.main(["--write", str(tmp_path / "system-model.png")]) == 0
    assert (tmp_path / "system-model.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    capsys.readouterr()
    assert system.main(["--write", str(tmp_path / "missing" / "system-model.png")]) == 2
    error = capsys.readouterr().err.strip()
    assert error.startswith("--write") and "does not exist" in error and "\n" not in error
