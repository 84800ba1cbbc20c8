"""The README's recipes run as written: the route to a design file in FMPy and the `fmpy simulate` command (here),
and the Dask recipe with a worker in another folder (tests/test_cluster.py); its figures of the certified answers
are the report's, rounded as the report rounds them."""

from __future__ import annotations

import csv
import json
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from fmu_src.published import STUDY_BEST_ORDER
from orchestrator.simulation import LatticeFMU
from orchestrator.ssp import write_best_design_ssp

pytestmark = pytest.mark.quick  # a first check: python -m pytest -m quick

ROOT = Path(__file__).resolve().parents[1]


def python_blocks(text: str) -> list[str]:
    return re.findall(r"```python\n(.*?)```", text, flags=re.S)


def fmpy_design_snippet(text: str) -> str:
    (snippet,) = [block for block in python_blocks(text) if "simulate_ssp" in block]
    return snippet


def test_the_readme_runs_a_design_file_in_fmpy_as_written(fmu_path, tmp_path):
    snippet = fmpy_design_snippet((ROOT / "README.md").read_text())
    assert snippet == fmpy_design_snippet((ROOT / "docs" / "other-tools.md").read_text())
    write_best_design_ssp(
        fmu_path, {"material": list(STUDY_BEST_ORDER), "F_total": 1100.0}, tmp_path / "best_design.ssp", stop_time=8.0
    )
    (tmp_path / "tmp").mkdir()  # fmpy extracts into TMPDIR: the test's own, so nothing is left in the real one
    done = subprocess.run(
        [sys.executable, "-c", snippet],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=600,
        env={**os.environ, "TMPDIR": str(tmp_path / "tmp")},
    )
    assert done.returncode == 0, done.stderr
    peak = float(done.stdout.split()[-1])
    with LatticeFMU(fmu_path) as lattice:
        design = lattice.simulate(STUDY_BEST_ORDER, 8.0, {"F_total": 1100.0})["peak_backplate_force"]
        default = lattice.simulate(None, 8.0)["peak_backplate_force"]
    assert peak == pytest.approx(design, rel=1e-9)
    assert abs(peak - default) > 1.0  # the design's order and load, not the FMU's defaults


def known_optima_of_the_study() -> dict[str, dict]:
    """The certified 11 x 11 entries of orchestrator/known_optima.json, by diagonal rule."""
    entries = json.loads((ROOT / "orchestrator" / "known_optima.json").read_text())["optima"]
    return {e["diagonal_rule"]: e for e in entries if e["rows"] == e["columns"] == 11 and e["certified"]}


def fmpy_simulate_command(text: str) -> list[str]:
    (block,) = [b for b in re.findall(r"```\n(.*?)```", text, flags=re.DOTALL) if b.startswith("fmpy simulate")]
    return shlex.split(block.replace("\\\n", " "))


def test_the_readmes_fmpy_command_sets_the_rule_and_gives_the_mean_rules_answer(fmu_path, tmp_path):
    """The command as written (the FMU's path aside) sets the mean rule's certified order and diagonal_rule by
    its code, and prints the number the README and the report give for it."""
    readme = (ROOT / "README.md").read_text()
    words = fmpy_simulate_command(readme)
    assert words == fmpy_simulate_command((ROOT / "docs" / "other-tools.md").read_text())
    assert words[:3] == ["fmpy", "simulate", "models/MassSpringLattice.fmu"]
    given = words[words.index("--start-values") + 1 : words.index("--output-variables")]
    start_values = dict(zip(given[::2], given[1::2]))
    mean = known_optima_of_the_study()["mean"]
    assert [int(start_values[f"material[{j}]"]) for j in range(1, 12)] == mean["order"]
    assert start_values["diagonal_rule"] == "1"  # the mean rule's code
    reference = (ROOT / "docs" / "fmu-reference.md").read_text()
    (example,) = re.findall(r"```\n(material\[1\]=.*?)```", reference, flags=re.DOTALL)
    assert dict(word.split("=") for word in example.split()) == start_values  # the FMU reference's example too
    (tmp_path / "tmp").mkdir()
    done = subprocess.run(
        [sys.executable, "-m", "fmpy", "simulate", str(fmu_path), *words[3:]],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
        env={**os.environ, "TMPDIR": str(tmp_path / "tmp")},
    )
    assert done.returncode == 0, done.stderr
    with (tmp_path / "out.csv").open() as handle:
        peak = float(list(csv.DictReader(handle))[-1]["peak_backplate_force"])
    with LatticeFMU(fmu_path) as lattice:
        expected = lattice.simulate(mean["order"], 8.0, {"diagonal_rule": "mean"})["peak_backplate_force"]
    assert peak == pytest.approx(expected, rel=1e-9)
    assert f"certified answer, {peak:.2f} N)" in readme


def test_the_readmes_figures_of_the_certified_answers_are_the_reports(fmu_path):
    """Each certified answer's peak and its runner-up's, computed at full fidelity as the report computes them
    and rounded as it rounds them (peaks to 0.01 N, a runner-up's gap to 0.0001 N), are the README's."""
    readme = " ".join((ROOT / "README.md").read_text().split())
    optima = known_optima_of_the_study()
    with LatticeFMU(fmu_path) as lattice:
        peaks = {
            rule: [
                lattice.simulate(order, 8.0, {"diagonal_rule": rule})["peak_backplate_force"]
                for order in (entry["order"], entry["runner_up"]["order"])
            ]
            for rule, entry in optima.items()
        }
    best, runner = peaks["receiver"]
    assert f"{optima['receiver']['order']} at {best:.2f} N" in readme
    assert f"is {runner:.2f} N too ({runner - best:.4f} N higher)" in readme
    best, runner = peaks["mean"]
    assert (
        f"{optima['mean']['order']} at {best:.2f} N; its runner-up swaps the last two materials "
        f"({runner:.2f} N)" in readme
    )
