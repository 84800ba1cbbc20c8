"""The writer of the measurement pages: a benchmark writes its page and the index, and README.md only when asked.

Run as a user runs it, on a copy of the repository's bench/, README.md and pages (tests import nothing from
bench/): a benchmark's writer called with and without --write-readme, and the separate command."""

from __future__ import annotations

import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

pytestmark = pytest.mark.quick  # a first check: python -m pytest -m quick

ROOT = Path(__file__).resolve().parents[1]
BENCHMARK = textwrap.dedent("""
    import sys
    from bench.measurements import Page, Run, write_page
    run = Run("speed", sys.argv[1:])
    run.parser("Speed.", quick="less").parse_args(sys.argv[1:])
    write_page(run, Page("speed", "A figure", "42 designs per second", "what was measured"))
""")


@pytest.fixture()
def copy(tmp_path):
    shutil.copytree(ROOT / "bench", tmp_path / "bench", ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copytree(ROOT / "docs" / "measurements", tmp_path / "docs" / "measurements")
    shutil.copy(ROOT / "README.md", tmp_path / "README.md")
    return tmp_path


def run(copy: Path, *argv: str) -> str:
    done = subprocess.run([sys.executable, *argv], cwd=copy, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    return done.stdout


def test_a_benchmark_leaves_the_readme_alone_unless_asked(copy):
    before = (copy / "README.md").read_text()
    out = run(copy, "-c", BENCHMARK, "--quick")
    assert (copy / "README.md").read_text() == before
    assert (copy / "docs" / "measurements" / "speed.md").is_file()
    assert "speed.md" in (copy / "docs" / "measurements" / "index.md").read_text()
    assert "python -m bench.measurements --write-readme" in out
    run(copy, "-c", BENCHMARK, "--quick", "--write-readme")
    readme = (copy / "README.md").read_text()
    assert "42 designs per second" in readme and "`python -m bench.speed --quick`" in readme


def test_the_separate_command_rebuilds_the_readme_from_the_pages(copy):
    run(copy, "-c", BENCHMARK)
    assert "42 designs per second" not in (copy / "README.md").read_text()
    run(copy, "-m", "bench.measurements", "--write-readme")
    assert "42 designs per second" in (copy / "README.md").read_text()
