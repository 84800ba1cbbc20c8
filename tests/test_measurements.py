"""The measurement pages and the README's table of their headlines agree, and every page says how it was made.

The README quotes the pages' headlines in a block that bench/measurements.py writes when asked
(`python -m bench.measurements --write-readme`); a page regenerated without its README block, or a figure typed
into the block by hand, is caught here. Nothing is imported from bench/: the pages and the README are read as a
reader reads them.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PAGES = sorted(p for p in (ROOT / "docs" / "measurements").glob("*.md") if p.name != "index.md")
START = "<!-- measurements: written by bench/measurements.py from docs/measurements; never by hand -->"
END = "<!-- measurements: end -->"


def front_matter(path: Path) -> dict:
    lines = path.read_text().splitlines()
    assert lines[0] == "---", f"{path.name} has no front matter"
    meta = {}
    for line in lines[1 : lines.index("---", 1)]:
        key, _, value = line.partition(": ")
        meta[key] = json.loads(value)
    return meta


def readme_rows() -> dict[str, str]:
    readme = (ROOT / "README.md").read_text()
    assert START in readme and END in readme
    block = readme[readme.index(START) + len(START) : readme.index(END)]
    return {
        m.group(1): line
        for line in block.splitlines()
        for m in [re.search(r"\(docs/measurements/([\w.]+\.md)\)", line)]
        if m
    }


def cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def test_every_page_names_its_command_commit_and_date():
    assert PAGES, "no measurement pages"
    for page in PAGES:
        meta = front_matter(page)
        assert meta["benchmark"] == page.stem and meta["headline"] and meta["title"], page.name
        assert meta["command"].startswith(f"python -m bench.{page.stem}"), page.name
        assert re.fullmatch(r"[0-9a-f]{7}", meta["commit"]) and re.fullmatch(r"20\d\d-\d\d-\d\d", meta["date"])
        assert f"<!-- Written by `{meta['command']}`;" in page.read_text(), page.name


def test_the_readme_block_holds_each_pages_headline_as_written_and_nothing_else():
    rows = readme_rows()
    assert sorted(rows) == [p.name for p in PAGES]
    for page in PAGES:
        meta = front_matter(page)
        row = rows[page.name]
        assert f"| {cell(meta['headline'])} |" in row, page.name
        assert f"`{cell(meta['command'])}` at {meta['commit']}, {meta['date']}" in row, page.name
