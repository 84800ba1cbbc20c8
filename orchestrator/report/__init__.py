"""The report folder of a study: results.json, evaluations.csv, the design files, the charts and report.html.

The report only renders: every number comes from the study's typed results (``StudyResult``); nothing here
simulates. HTML and the design files are rendered from templates (jinja2, autoescaped), one template per step
under ``orchestrator/templates/report/``.
"""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path
from typing import Any

import jinja2
import markupsafe

from builder.rendering import add_templates

from ..records import to_record
from ..steps.answers import Answers
from ..steps.codesign import CoDesign
from ..steps.exhaustive import Exhaustive
from ..steps.pareto import BEST_DESIGN_FILE, Pareto, best_design
from ..steps.searches import Searches, draw_convergence
from ..steps.starts import Starts
from ..steps.trajectories import IMPACT_CHART, draw_impact
from ..study import PROJECTILE, PULSE, StudyResult, search_fidelity

RESULTS_FORMAT = "lattice-results/1"
TERMS = {
    "sampled peak": "the largest backplate force among the samples every 0.01 s (peak_sample_interval): what "
    "the study computed and published",
    "continuous peak": "the largest backplate force over the continuous solution (between the samples too); "
    "at least the sampled peak",
    "search fidelity": "the cheaper evaluation the searches rank by: a short horizon (the scene's: "
    f"{search_fidelity(PULSE).horizon:g} s under the study's pulse, "
    f"{search_fidelity(PROJECTILE).horizon:g} s under a projectile, whose contact lasts longer; "
    "extended while the lattice still touches the backplate) at a looser tolerance; every reported "
    "number is at full fidelity, the whole scene at the FMU's default accuracy",
    "censored": "an evaluation the FMU stopped as soon as its peak passed a force limit the search gave "
    "(it could no longer win): its value is only known to be above that limit, and it is never "
    "reported as a value",
    "regret": "what keeping the chosen design costs under a variation of the case: its value there minus the "
    "best value this study knows for that variation",
    "screening error": "how far the search fidelity's value of a design is from its full-fidelity value "
    "(relative); an answer is safe when it is far smaller than the gap to the runner-up",
    "receiver rule": "each diagonal spring takes its constants from the column of the mass it pushes (as the "
    "study computed): between columns of different materials the two ends feel different "
    "forces, so Newton's third law does not hold there",
    "mean rule": "each diagonal spring uses the mean of its two columns' constants: reciprocal, physically consistent",
}


def inline_png(folder: Path):
    """The jinja2 filter that gives a chart file of ``folder`` as a data URI: report.html holds its images, so the
    one file can be mailed or moved (the PNGs stay beside it for other uses)."""
    import base64

    def inline(name: str) -> str:
        return "data:image/png;base64," + base64.b64encode((folder / name).read_bytes()).decode("ascii")

    return inline


def _env() -> jinja2.Environment:
    """The one environment (builder.rendering) with the orchestrator's templates and the report's filters."""
    env = add_templates("orchestrator")
    env.filters["n"] = _number
    env.filters["g2"] = lambda v: "n/a" if v is None else f"{v:,.2g}"
    env.filters["order"] = lambda order: "[" + ", ".join(str(m) for m in order) + "]" if order else "none"
    env.filters["sci"] = lambda v, digits=1: (
        "n/a" if v is None or (isinstance(v, float) and math.isnan(v)) else f"{v:.{digits}e}"
    )
    return env


def _number(value: Any, digits: int = 2) -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "n/a"
    return f"{value:,.{digits}f}"


def rule_default_note(study: StudyResult, answer) -> str:
    """What the FMU runs when a user leaves diagonal_rule out, after the answer's parameters: its default rule,
    the receiver rule of the published table (docs/model.md section 2), and whether this answer needs the rule
    set."""
    case = study.case
    default = case.rule_default
    if not default or "diagonal_rule" not in answer.parameters:
        return ""
    code = case.rule_codes.get(default)
    if answer.diagonal_rule == default:
        return f"diagonal_rule {code} = {default} is also the FMU's default: it reproduces the study's published table"
    return (
        f"diagonal_rule {answer.parameters['diagonal_rule']} = {answer.diagonal_rule}: without it the FMU runs "
        f"its default, {code} = {default}, which reproduces the study's published table, and gives another "
        "number"
    )


def case_line(study: StudyResult) -> str:
    return study.case.line()


def results_record(study: StudyResult) -> dict:
    """results.json: the answers first, then the case and every step's result, as the typed results hold them."""
    steps = {name: to_record(result) for name, result in study.results_by_name().items()}
    answers = study.result(Answers)
    return {
        "format": RESULTS_FORMAT,
        "answers": to_record(answers.answers) if answers else [],
        "pareto": _pareto_points(study),
        "case": to_record(study.case),
        "case_line": case_line(study),
        "fmu": {"path": study.fmu_path, "sha256": study.fmu_sha256},
        "steps": steps,
        "evaluator": to_record(study.evaluator),
        "costs": to_record(study.costs),
        "wall_seconds": study.wall_seconds,
        "run": study.run_id,
        "terms": TERMS,
    }


def _pareto_points(study: StudyResult) -> list:
    pareto = study.result(Pareto)
    if pareto is None:
        return []
    outputs = study.case.objective.outputs
    return [
        {
            "diagonal_rule": front.diagonal_rule,
            "order": list(point.order),
            "objectives": dict(zip(outputs, point.values)),
        }
        for front in pareto.fronts
        for point in front.points
    ]


def write_evaluations_csv(study: StudyResult, path: Path) -> None:
    """Every evaluation of the searches (journal.jsonl has every task of the run)."""
    fields = [
        "diagonal_rule",
        "method",
        "seed",
        "index",
        "order",
        "value",
        "status",
        "censored_above",
        "seconds",
        "horizon",
        "message",
    ]
    searches = study.result(Searches)
    with path.open("w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(fields)
        for run in searches.runs if searches else ():
            for index, e in enumerate(run.evaluations, start=1):
                writer.writerow(
                    [
                        run.label,
                        run.method,
                        run.seed,
                        index,
                        " ".join(map(str, e.order)),
                        "" if e.value is None else repr(e.value),
                        e.status,
                        "" if e.limit is None else repr(e.limit),
                        f"{e.seconds:.6f}",
                        "" if e.outputs is None else e.outputs.horizon,
                        e.message,
                    ]
                )


def write_design_files(study: StudyResult, out: Path, steps, materials) -> dict[str, str]:
    """Each step's design files; {file: why it was not written} for those the writer refused (a design a named
    tool would run differently)."""
    refused: dict[str, str] = {}
    answers = study.result(Answers)
    varied = {a.design_file: varied_of(a.parameters) for a in answers.answers} if answers else {}
    for step in steps:
        if study.result(type(step)) is None:
            continue
        for name, order, rule in step.design_files(study):
            own = varied.get(name, {}) if isinstance(step, Answers) else step.design_parameters(study).get(name, {})
            write_design_file(study, out, name, order, rule, materials, refused, own)
    return refused


def varied_of(parameters: dict) -> dict:
    """The material properties a co-design answer sets away from the table (``k[3]``, ``mass[1]`` ...)."""
    return {name: value for name, value in parameters.items() if "[" in name and not name.startswith("material[")}


def write_design_file(
    study: StudyResult,
    out: Path,
    name: str,
    order,
    rule: str,
    materials,
    refused: dict[str, str],
    varied: dict | None = None,
) -> None:
    """One design file: the FMU with the order, the run's parameters and the rule where the study chose it, and a
    co-design's ``varied`` material properties (the table then no longer names every value, so it is not
    checked against them); a design the writer refuses (one a named tool would run differently) goes into
    ``refused`` with why."""
    from ..ssp import write_best_design_ssp

    parameters = {"material": list(order), **study.case.parameters, **(varied or {})}
    if rule in study.case.rules:
        parameters["diagonal_rule"] = rule
    table = None if varied else materials
    try:
        write_best_design_ssp(study.fmu_path, parameters, out / name, stop_time=study.case.horizon, materials=table)
    except (ValueError, OSError) as exc:
        refused[name] = str(exc).splitlines()[0]


def write_certificates(study: StudyResult, out: Path) -> list[str]:
    exhaustive = study.result(Exhaustive)
    if exhaustive is None:
        return []
    folder = out / "exhaustive"
    folder.mkdir(exist_ok=True)
    written = []
    for index, sweep in enumerate(exhaustive.sweeps):
        name = "certificate.json" if index == 0 else f"certificate_{sweep.diagonal_rule}.json"
        (folder / name).write_text(json.dumps(to_record(sweep.certificate), indent=1))
        written.append(f"exhaustive/{name}")
    return written


def step_chart(step, study: StudyResult, path: Path, known: dict) -> str | None:
    """A step's chart. The searches' convergence carries each rule's known optimum, which the later answers
    step finds: the report, which reads both, composes it; every other chart is its step's own."""
    if isinstance(step, Searches):
        return draw_convergence(study, path, study.case.line(), known)
    return step.chart(study, path)


def write_report(study: StudyResult, out: str | Path, steps, materials=None) -> Path:
    """Everything a study gives, into ``out``; returns the path of report.html."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    answers = study.result(Answers)
    known = answers.known_optima if answers else {}
    figures = {}
    for step in steps:
        if study.result(type(step)) is not None and step.chart_file:
            made = step_chart(step, study, out / step.chart_file, known)
            if made:
                figures[type(step)] = made
    impact_chart = draw_impact(study, out / IMPACT_CHART)
    refused = write_design_files(study, out, steps, materials)
    certificates = write_certificates(study, out)
    record = results_record(study)
    record["design_files_refused"] = refused
    (out / "results.json").write_text(json.dumps(record, indent=1, allow_nan=False))
    write_evaluations_csv(study, out / "evaluations.csv")
    from .explore import explore_contents, write_explore

    write_explore(study, out, materials, refused)
    env = _env()
    env.filters["inline_png"] = inline_png(out)
    sections = []
    for step in steps:
        result = study.result(type(step))
        if result is None or not step.template or isinstance(step, Answers):
            continue
        sections.append(
            markupsafe.Markup(
                env.get_template(f"report/{step.template}").render(
                    result=result,
                    study=study,
                    chart=figures.get(type(step)),
                    title=step.title,
                    terms=TERMS,
                    refused=refused,
                )
            )
        )
    page = env.get_template("report/report.html.j2").render(
        study=study,
        case_line=study.case.line(),
        answers=answers,
        answers_chart=figures.get(Answers),
        rule_default_note=rule_default_note,
        impact_chart=impact_chart,
        sections=sections,
        terms=TERMS,
        refused=refused,
        certificates=certificates,
        known=known,
        pareto=study.result(Pareto),
        codesign=study.result(CoDesign),
        starts=study.result(Starts),
        best_design=best_design(study),
        best_design_file=BEST_DESIGN_FILE,
        explore_contents=explore_contents(study),
    )
    (out / "report.html").write_text(page)
    return out / "report.html"


__all__ = ["TERMS", "case_line", "results_record", "rule_default_note", "write_report"]
