"""A Pareto front that is a front: it starts from the known optima of each objective and never reports a point
that a design the study evaluated, or a known optimum, dominates; and it says how sure it is."""

from __future__ import annotations

import json

import numpy as np
import pytest

from orchestrator import run as cli
from orchestrator.known_optima import known_optima
from orchestrator.objective import FMURun
from orchestrator.search import make_search
from orchestrator.search.pareto import dominated_by
from orchestrator.steps.exhaustive import FrontPoint
from orchestrator.steps.pareto import undominated
from orchestrator.types import OK, Evaluation

from problems import TwoObjectives


def test_dominated_by_marks_exactly_the_points_another_design_beats():
    points = [(1.0, 5.0), (2.0, 4.0), (3.0, 3.0), (3.0, 3.0)]
    others = [(2.0, 3.5), (1.0, 5.0), (0.5, 9.0)]
    # (2, 3.5) beats (2, 4) and nothing else; an equal point (1, 5) beats nothing; (3, 3) stays twice
    assert list(dominated_by(points, others)) == [False, True, False, False]
    assert list(dominated_by(points, [])) == [False] * 4
    with pytest.raises(ValueError, match="2 objectives but others have 3"):
        dominated_by(points, [(1.0, 1.0, 1.0)])


def test_the_reported_set_never_holds_a_point_an_evaluated_design_dominates():
    def evaluation(order, values):
        return Evaluation(order, values[0], OK, values=values)

    found = [evaluation((1, 2, 3), (10.0, 1.0)), evaluation((2, 1, 3), (5.0, 2.0)), evaluation((3, 2, 1), (6.0, 2.5))]
    known = evaluation((1, 3, 2), (4.0, 1.5))  # a known optimum of the first objective: beats (2, 1, 3) and (3, 2, 1)
    front = undominated(found + [known])
    assert [p.order for p in front] == [(1, 3, 2), (1, 2, 3)]
    assert all(isinstance(p, FrontPoint) for p in front)
    assert not dominated_by([p.values for p in front], [e.values for e in found + [known]]).any()


def test_nsga2_starts_from_its_seeds():
    problem = TwoObjectives.random(7, 3)
    seeds = [(7, 6, 5, 4, 3, 2, 1), (2, 1, 3, 4, 5, 6, 7)]
    search = make_search("nsga2", 7, 0, seeds=seeds, pop_size=10)
    first = search.ask()
    assert first[:3] == [(1, 2, 3, 4, 5, 6, 7)] + seeds
    search.tell(first, [problem.value(d) for d in first])
    with pytest.raises(ValueError, match="nsga2 seeds"):
        make_search("nsga2", 7, 0, seeds=[(1, 1, 2, 3, 4, 5, 6)])


def test_the_studys_two_objective_front_is_not_dominated_by_the_certified_optimum(fmu_path, tmp_path, capfd):
    """The study's scene at the default budget, receiver rule, sampled peak and compression: no reported point
    is dominated by the certified optimum of the peak or by any design the run evaluated at full fidelity."""
    out = tmp_path / "front"
    code = cli.main(
        [
            "--fmu",
            str(fmu_path),
            "--out",
            str(out),
            "--objective",
            "sampled,max_compression",
            "--diagonal-rule",
            "receiver",
            "--no-progress",
            "--executor",
            "process",
            "--workers",
            "2",
        ]
    )
    console = capfd.readouterr().out
    assert code == 0, console
    certified = next(k for k in known_optima() if k.columns == 11 and k.diagonal_rule == "receiver" and k.certified)
    run = FMURun(str(fmu_path), 8.0, (), ("peak_backplate_force", "max_compression"))
    optimum = run(certified.order)
    assert optimum.ok and optimum.value == pytest.approx(certified.peak, rel=1e-6)
    results = json.loads((out / "results.json").read_text())
    front = results["steps"]["pareto"]["fronts"][0]
    values = [tuple(p["values"]) for p in front["points"]]
    assert values and not dominated_by(values, [optimum.values]).any(), (optimum.values, values)
    full = [json.loads(line) for line in (out / "journal.jsonl").read_text().splitlines()]
    evaluated = [
        tuple(r["result"]["values"])
        for r in full
        if isinstance(r.get("result"), dict)
        and r["result"].get("status") == OK
        and len(r["result"].get("values") or ()) == 2
        and "|8.0|None|" in r.get("key", "")
    ]
    assert evaluated and not dominated_by(values, evaluated).any()
    assert tuple(front["points"][0]["order"]) == certified.order  # the low-force end is the certified optimum
    sure = front["sureness"]
    assert not sure["exact"] and sure["runs"] == 3 and len(sure["coverage"]) == 3
    assert np.all(np.array(sure["coverage"]) <= 1 + 1e-12)
    assert sure["known_ends"][0]["on_front"] and sure["settle"]
    descended = {d["output"]: d for d in front["descended"]}
    assert set(descended) == {"peak_backplate_force", "max_compression"}
    assert all(d["evaluations"] > 0 for d in descended.values())
    assert "the known optimum of peak_backplate_force alone is on it" in console
