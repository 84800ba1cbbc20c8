"""The README is a user guide that stays inside the repository: every link and image it names exists here."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

pytestmark = pytest.mark.quick  # a first check: python -m pytest -m quick

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()


def test_every_link_and_image_is_a_file_of_the_repository():
    targets = re.findall(r"\]\(([^)\s]+)\)", README)
    assert targets, "the README links nothing"
    for target in targets:
        assert "://" not in target and not target.startswith(("/", "mailto:")), target
        assert (ROOT / target.split("#")[0]).is_file(), target


def test_the_readme_is_short_and_runs_the_test_command_ci_runs():
    assert len(README.splitlines()) <= 300
    ci = (ROOT / ".ci" / "run").read_text()
    assert "python -m pytest\n" in README
    commands = [line.strip() for line in ci.splitlines() if line.strip().startswith("python -m pytest")]
    assert commands == ["python -m pytest", "python -m pytest -m slurm"]  # the README's, then the SLURM group


def test_the_readme_quotes_the_run_times_as_their_page_measured_them():
    """The plate's, the quick tests' and the whole suite's run times in the README are the run times page's, not
    typed apart."""
    page = (ROOT / "docs" / "measurements" / "run_times.md").read_text()
    rows = {
        cells[0].strip("` "): cells[1:]
        for cells in (line.strip("|").split("|") for line in page.splitlines() if line.startswith("| `"))
    }
    plate_wall, plate_did = (
        cell.strip() for cell in rows["python orchestrator/run.py --scene plate_11x11x11 --budget 20 --repeats 1"]
    )
    quick_wall, quick_did = (cell.strip() for cell in rows["python -m pytest -m quick"])
    text = " ".join(README.split())
    plate_runs = plate_did.split(" FMU runs")[0]
    assert f"(`--budget 20 --repeats 1`: {plate_runs} FMU runs, {plate_wall} on two loaded cores" in text
    assert f"`python -m pytest -m quick` runs {quick_did.split()[0]} of its tests" in text
    assert f"in {quick_wall}, and the whole suite in {rows['python -m pytest'][0].strip()}, on two" in text
    assert f"at its defaults {rows['python orchestrator/run.py --scene plate_11x11x11'][0].strip()}" in text
