"""The README is a user guide that stays inside the repository: every link and image it names exists here."""
from __future__ import annotations

import re
from pathlib import Path

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
