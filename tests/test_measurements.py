"""The measurement pages and the README's table of their headlines agree, and every page says how it was made.

The README quotes the pages' headlines in a block that bench/measurements.py writes; a page regenerated without
its README block (or a figure typed into the block by hand) is caught here.
"""
from __future__ import annotations

import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
measurements = pytest.importorskip("bench.measurements")


def test_the_readme_block_is_the_pages_headlines_as_written():
    readme = measurements.README.read_text()
    assert readme == measurements.readme_with_headlines(readme, measurements.index_entries())


def test_every_page_names_its_command_commit_and_date():
    entries = measurements.index_entries()
    assert entries, "no measurement pages"
    for entry in entries:
        assert entry["command"].startswith(f"python -m bench.{Path(entry['file']).stem}"), entry
        assert len(entry["commit"]) == 7 and entry["date"][:2] == "20", entry
        assert entry["headline"], entry


def test_a_readme_without_its_markers_is_refused_in_one_line():
    with pytest.raises(ValueError, match="README.md has no block"):
        measurements.readme_with_headlines("# a README\n", measurements.index_entries())


def test_only_the_block_changes():
    readme = f"before\n{measurements.README_START}\nold figures\n{measurements.README_END}\nafter\n"
    entry = {"file": "x.md", "title": "X", "headline": "1 | 2", "command": "python -m bench.x", "commit": "abcdef0",
             "date": "2026-12-01"}
    written = measurements.readme_with_headlines(readme, [entry])
    assert written.startswith(f"before\n{measurements.README_START}\n") and written.endswith(
        f"{measurements.README_END}\nafter\n")
    assert "old figures" not in written and "1 \\| 2" in written and "abcdef0, 2026-12-01" in written
