"""The designer's own problem end to end: their materials, a catalogue larger than the stack, repetition and a
second objective, each answer checked against a brute force over the whole (small) space."""

from __future__ import annotations

import itertools
import json

import pytest

from fmu_src.materials import load_materials
from orchestrator import run as cli
from orchestrator.search.pareto import non_dominated
from orchestrator.simulation import LatticeFMU

TABLE = """name,k,k_diag,c,alpha,alpha_diag
steel,100,50,5,10,10
ceramic,62,31,2.5,11,12
aramid,35,20,3.5,9,9
rubber,12,5,6,8,7.5
foam,4,2,4,6.5,6.5
"""
COMMON = ["--cols", "3", "--no-progress", "--executor", "serial", "--no-sensitivity", "--diagonal-rule", "receiver"]


@pytest.fixture(scope="module")
def workspace(tmp_path_factory):
    """A folder with the table; the CLI builds the FMU for it into models/ there (once for the module)."""
    folder = tmp_path_factory.mktemp("designer")
    (folder / "materials.csv").write_text(TABLE)
    return folder


def run(workspace, monkeypatch, out, *argv):
    monkeypatch.chdir(workspace)
    return cli.main(["--materials", "materials.csv", "--out", str(out), *COMMON, *argv])


def brute_force(fmu, designs, parameters=None):
    with LatticeFMU(fmu) as lattice:
        return {d: lattice.simulate(d, 8.0, dict(parameters or {}))["peak_backplate_force"] for d in designs}


def test_a_catalogue_sweep_equals_the_brute_force_and_names_the_materials(workspace, monkeypatch, capfd):
    assert run(workspace, monkeypatch, "catalogue", "--method", "exhaustive", "random", "--budget", "10") == 0, (
        capfd.readouterr().err
    )
    results = json.loads((workspace / "catalogue" / "results.json").read_text())
    (answer,) = results["answers"]
    values = brute_force(results["fmu"]["path"], list(itertools.permutations(range(1, 6), 3)))
    best = min(values, key=values.get)
    assert tuple(answer["order"]) == best and answer["peak"] == pytest.approx(values[best], rel=1e-6)
    assert answer["evidence"]["status"] == "certified"
    table = load_materials(workspace / "materials.csv")
    assert answer["materials"] == [table.name_of(m) for m in best]
    html = (workspace / "catalogue" / "report.html").read_text()
    assert all(name in html for name in table.names)
    assert [m["name"] for m in results["case"]["materials"]] == list(table.names)
    assert results["case"]["design_count"] == 60


def test_repetition_searches_every_assignment(workspace, monkeypatch, capfd):
    assert (
        run(workspace, monkeypatch, "repeat", "--repeat", "--method", "exhaustive", "random", "--budget", "10") == 0
    ), capfd.readouterr().err
    results = json.loads((workspace / "repeat" / "results.json").read_text())
    (answer,) = results["answers"]
    designs = list(itertools.product(range(1, 6), repeat=3))
    values = brute_force(results["fmu"]["path"], designs, {"repeat_materials": 1})
    best = min(values, key=values.get)
    assert results["case"]["design_count"] == 125 and tuple(answer["order"]) == best
    assert answer["peak"] == pytest.approx(values[best], rel=1e-6)


def test_two_objectives_give_the_exact_front(workspace, monkeypatch, capfd):
    assert (
        run(
            workspace,
            monkeypatch,
            "front",
            "--objective",
            "sampled,max_compression",
            "--method",
            "exhaustive",
            "nsga2",
            "--budget",
            "40",
        )
        == 0
    ), capfd.readouterr().err
    results = json.loads((workspace / "front" / "results.json").read_text())
    fmu = results["fmu"]["path"]
    designs = list(itertools.permutations(range(1, 6), 3))
    with LatticeFMU(fmu) as lattice:
        points = {}
        for d in designs:
            out = lattice.simulate(d, 8.0, {}, outputs=("peak_backplate_force", "max_compression"))
            points[d] = (out["peak_backplate_force"], out["max_compression"])
    mask = non_dominated([points[d] for d in designs])
    exact = {d for d, keep in zip(designs, mask) if keep}
    found = {tuple(p["order"]) for p in results["pareto"]}
    assert found == exact
    front = results["steps"]["pareto"]["fronts"][0]
    assert front["exact"] and {c["label"] for c in front["chosen"]} >= {"lowest peak_backplate_force"}
    for chosen in front["chosen"]:
        assert (workspace / "front" / chosen["design_file"]).is_file()
