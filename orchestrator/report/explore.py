"""explore.html: the study's results in one interactive page that opens from a file system with no network.

The page holds plotly.js (inlined: plotly is the FMI Python world's charting library, FMPy's GUI and web app use
it) and the study's results as JSON, and draws: the convergence of every run (methods and seeds toggled in the
legend), every evaluation as a sortable, filterable table, the Pareto front (two objectives) with each point's
order, objectives and design file, and the lattice of the design chosen in the table or on the front (of a plate,
its layers seen from the side beside layer 1's face and the masses the load pushes). The table, its sorting and
filtering are a few lines of plain JavaScript over the embedded JSON: a table library would add more to the page
than the code it replaces. The plate is drawn flat, not in plotly's 3-D view: that needs WebGL, which a browser
without a graphics driver does not have.

Every front point gets a design file (``front/``), so a point clicked on the front can be opened in an SSP tool
like the answers' design files.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import markupsafe

from builder.rendering import add_templates

from ..steps.answers import Answers
from ..charts import METHOD_NAMES, RULE_COLOURS, method_colour
from ..steps.finalists import Finalists
from ..steps.pareto import Pareto
from ..steps.searches import Searches
from ..study import StudyResult

EXPLORE_FILE = "explore.html"
FRONT_FOLDER = "front"
SEARCH, FULL = "search", "full"


def _number(value: Any) -> Any:
    return value if value is None or not isinstance(value, float) or math.isfinite(value) else None


def _row(rule: str, method: str, seed: int | None, index: int, evaluation, fidelity: str, materials) -> dict:
    return {
        "rule": rule,
        "method": method,
        "seed": seed,
        "index": index,
        "order": list(evaluation.order),
        "materials": [materials.name_of(m) for m in evaluation.order],
        "value": _number(evaluation.value),
        "values": [_number(v) for v in evaluation.values],
        "status": evaluation.status,
        "censored_above": _number(evaluation.limit) if evaluation.censored else None,
        "seconds": _number(evaluation.seconds),
        "fidelity": fidelity,
        "horizon": evaluation.outputs.horizon if evaluation.outputs is not None else None,
        "message": evaluation.message,
    }


def front_design_file(rule: str, rank: int) -> str:
    return f"{FRONT_FOLDER}/design_{rule.replace(' ', '_')}_{rank:03d}.ssp"


def explore_data(study: StudyResult, materials, refused: dict[str, str]) -> dict:
    """What the page shows, as JSON-ready data (every number from the typed results); ``refused``: the design
    files not written."""
    case = study.case
    searches = study.result(Searches)
    runs, rows = [], []
    for run in searches.runs if searches else ():
        runs.append(
            {"rule": run.label, "method": run.method, "seed": run.seed, "best": [_number(v) for v in run.best_so_far()]}
        )
        rows += [
            _row(run.label, run.method, run.seed, index, e, SEARCH, materials)
            for index, e in enumerate(run.evaluations, start=1)
        ]
    methods = list(dict.fromkeys(run["method"] for run in runs))
    finalists = study.result(Finalists)
    for rule in finalists.rules if finalists else ():
        rows += [
            _row(rule.diagonal_rule, "finalists", None, index, e, FULL, materials)
            for index, e in enumerate(rule.evaluations, start=1)
        ]
    fronts = []
    pareto = study.result(Pareto)
    for front in pareto.fronts if pareto else ():
        chosen = {c.order: c for c in front.chosen}
        points = []
        for rank, point in enumerate(front.points, start=1):
            name = (
                chosen[point.order].design_file
                if point.order in chosen
                else front_design_file(front.diagonal_rule, rank)
            )
            points.append(
                {
                    "order": list(point.order),
                    "materials": [materials.name_of(m) for m in point.order],
                    "values": [_number(v) for v in point.values],
                    "label": chosen[point.order].label if point.order in chosen else "",
                    "design_file": None if name in refused else name,
                }
            )
        fronts.append({"rule": front.diagonal_rule, "exact": front.exact, "points": points})
    answers = study.result(Answers)
    return {
        "case_line": case.line(),
        "outputs": list(case.objective.outputs),
        "units": list(case.objective.units),
        "rows": case.rows,
        "columns": case.columns,
        "depth": case.depth,
        "loaded_faces": [
            {
                "load_patch": len(f.row_range) if not f.whole_face else 0,
                "whole_face": f.whole_face,
                "rows": [f.row_range.start, f.row_range.stop - 1],
                "depth": [f.depth_range.start, f.depth_range.stop - 1],
            }
            for f in case.loaded_faces()
        ],
        "materials": [{"name": m["name"], "k": m["k"]} for m in case.materials],
        "runs": runs,
        "evaluations": rows,
        "fronts": fronts,
        "method_colours": {m: method_colour(m, methods) for m in methods},
        "method_names": {m: METHOD_NAMES.get(m, m) for m in methods},
        "rule_colours": list(RULE_COLOURS),
        "answers": [
            {
                "rule": a.diagonal_rule,
                "order": list(a.order),
                "value": a.peak,
                "design_file": None if a.design_file in refused else a.design_file,
            }
            for a in (answers.answers if answers else ())
        ],
    }


def write_front_design_files(study: StudyResult, out: Path, materials) -> dict[str, str]:
    """A design file for every point of each front that has none yet; {file: why not written} for refusals."""
    from . import write_design_file

    refused: dict[str, str] = {}
    pareto = study.result(Pareto)
    for front in pareto.fronts if pareto else ():
        chosen = {c.order for c in front.chosen}
        for rank, point in enumerate(front.points, start=1):
            if point.order not in chosen:
                write_design_file(
                    study,
                    out,
                    front_design_file(front.diagonal_rule, rank),
                    point.order,
                    front.diagonal_rule,
                    materials,
                    refused,
                )
    return refused


def _script_json(data: Any) -> markupsafe.Markup:
    """JSON safe inside a <script> element (no "</" can end it early)."""
    text = json.dumps(data, allow_nan=False, separators=(",", ":"))
    return markupsafe.Markup(text.replace("</", "<\\/").replace("<!--", "<\\!--"))


def plotly_js() -> str:
    from plotly.offline import get_plotlyjs

    return get_plotlyjs()


def explore_contents(study: StudyResult) -> str:
    """What explore.html holds for this study, in the words of the report's link to it: the convergence only when
    searches ran, the Pareto front only when the study has one."""
    searches = study.result(Searches)
    pareto = study.result(Pareto)
    parts = (["convergence by method and seed"] if searches is not None and searches.runs else []) + [
        "a sortable table of every evaluation"
    ]
    if pareto is not None and pareto.fronts:
        parts.append("the Pareto front")
    parts.append("each design's plate" if study.case.depth > 1 else "each design's lattice")
    return ", ".join(parts[:-1]) + " and " + parts[-1]


def write_explore(study: StudyResult, out: Path, materials, refused: dict[str, str]) -> Path:
    """``out/explore.html`` (and the front's design files); returns its path."""
    out = Path(out)
    refused = {**refused, **write_front_design_files(study, out, materials)}
    data = explore_data(study, _Names(study.case.materials), refused)
    page = (
        add_templates("orchestrator")
        .get_template("report/explore.html.j2")
        .render(
            case_line=study.case.line(),
            data=_script_json(data),
            has_front=len(data["outputs"]) == 2 and bool(data["fronts"]),  # the page draws a front of two objectives
            plotly=markupsafe.Markup(plotly_js().replace("</script", "<\\/script")),
        )
    )
    path = out / EXPLORE_FILE
    path.write_text(page, encoding="utf-8")
    return path


class _Names:
    """Material names by number from the case's material rows."""

    def __init__(self, rows) -> None:
        self.rows = rows

    def name_of(self, material: int) -> str:
        return self.rows[material - 1]["name"]


__all__ = ["EXPLORE_FILE", "explore_contents", "explore_data", "write_explore"]
