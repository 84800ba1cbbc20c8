"""The writer of the measurement pages: a benchmark writes its page and the index, and README.md only when asked."""
from __future__ import annotations

import pytest

from bench import measurements


@pytest.fixture()
def pages(tmp_path, monkeypatch):
    """The writer pointed at a copy of README.md and an empty pages folder."""
    readme = tmp_path / "README.md"
    readme.write_text((measurements.README).read_text())
    monkeypatch.setattr(measurements, "PAGES", tmp_path / "measurements")
    monkeypatch.setattr(measurements, "README", readme)
    monkeypatch.setattr(measurements, "ROOT", tmp_path)
    return tmp_path


def page(name: str) -> measurements.Page:
    return measurements.Page(name, "A figure", "42 designs per second", "what was measured")


def test_a_benchmark_leaves_the_readme_alone_unless_asked(pages, capsys):
    before = (pages / "README.md").read_text()
    run = measurements.Run("speed", ["--quick"])
    run.parser("Speed.", quick="less").parse_args(["--quick"])
    measurements.write_page(run, page("speed"))
    assert (pages / "README.md").read_text() == before
    assert (pages / "measurements" / "speed.md").is_file() and (pages / "measurements" / "index.md").is_file()
    assert "python -m bench.measurements --write-readme" in capsys.readouterr().out


def test_write_readme_rebuilds_the_table_from_the_pages(pages):
    run = measurements.Run("speed", ["--quick", "--write-readme"])
    args = run.parser("Speed.", quick="less").parse_args(["--quick", "--write-readme"])
    assert args.quick and run.write_readme
    measurements.write_page(run, page("speed"))
    readme = (pages / "README.md").read_text()
    block = readme[readme.index(measurements.README_START):readme.index(measurements.README_END)]
    assert "42 designs per second" in block and "`python -m bench.speed --quick`" in block


def test_the_separate_command_rebuilds_the_readme(pages):
    measurements.write_page(measurements.Run("speed", []), page("speed"))
    assert "42 designs per second" not in (pages / "README.md").read_text()
    assert measurements.main(["--write-readme"]) == 0
    assert "42 designs per second" in (pages / "README.md").read_text()
