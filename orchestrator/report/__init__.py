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

from ..records import to_record
from ..study import StudyResult
from . import charts

RESULTS_FORMAT = "lattice-results/1"
TERMS = {
    "sampled peak": "the largest backplate force among the samples every 0.01 s (peak_sample_interval): what "
                    "the study computed and published",
    "continuous peak": "the largest backplate force over the continuous solution (between the samples too); "
                       "at least the sampled peak",
    "search fidelity": "the cheaper evaluation the searches rank by: a 1 s horizon (extended while the lattice "
                       "still touches the plate) at a looser tolerance; every reported number is at full "
                       "fidelity, the whole scene at the FMU's default accuracy",
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
    "mean rule": "each diagonal spring uses the mean of its two columns' constants: reciprocal, physically "
                 "consistent",
}


def _env() -> jinja2.Environment:
    env = jinja2.Environment(loader=jinja2.PackageLoader("orchestrator", "templates"),
                             autoescape=jinja2.select_autoescape(["html", "j2"]), undefined=jinja2.StrictUndefined,
                             trim_blocks=True, lstrip_blocks=True)
    env.filters["n"] = _number
    env.filters["order"] = lambda order: "[" + ", ".join(str(m) for m in order) + "]" if order else "none"
    env.filters["sci"] = lambda v, digits=1: "n/a" if v is None or (isinstance(v, float) and math.isnan(v)) \
        else f"{v:.{digits}e}"
    return env


def _number(value: Any, digits: int = 2) -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "n/a"
    return f"{value:,.{digits}f}"


def case_line(study: StudyResult) -> str:
    """The case in one line: what every chart and the first screen state."""
    case = study.case
    load = case.load
    parts = [f"{case.rows} x {case.columns} lattice",
             f"{len(case.materials)} materials ({case.design_kind}: {case.design_count:,} designs)"]
    if "F_total" in load:
        parts.append(f"load {load['F_total']:g} N at {load.get('load_angle', 0):g} deg for {load.get('t_active', 0):g} s")
    parts.append(f"minimising {', '.join(case.objective.outputs)} over {case.horizon:g} s")
    if case.rules:
        parts.append(f"diagonal rule{'s' if len(case.rules) > 1 else ''} {' and '.join(case.rules)}")
    if case.cases:
        parts.append(f"{case.aggregate} of load cases {case.cases}")
    return ", ".join(parts)


def results_record(study: StudyResult) -> dict:
    """results.json: the answers first, then the case and every step's result, as the typed results hold them."""
    steps = {name: to_record(result) for name, result in study.steps.items()}
    answers = steps.get("answers", {}).get("answers", [])
    return {"format": RESULTS_FORMAT, "answers": answers, "pareto": _pareto_points(study),
            "case": to_record(study.case), "case_line": case_line(study),
            "fmu": {"path": study.fmu_path, "sha256": study.fmu_sha256},
            "steps": steps, "evaluator": to_record(study.evaluator), "wall_seconds": study.wall_seconds,
            "run": study.run_id, "terms": TERMS}


def _pareto_points(study: StudyResult) -> list:
    pareto = study.steps.get("pareto")
    if pareto is None:
        return []
    outputs = study.case.objective.outputs
    return [{"diagonal_rule": front.diagonal_rule, "order": list(point.order),
             "objectives": dict(zip(outputs, point.values))} for front in pareto.fronts for point in front.points]


def write_evaluations_csv(study: StudyResult, path: Path) -> None:
    """Every evaluation of the searches (journal.jsonl has every task of the run)."""
    fields = ["diagonal_rule", "method", "seed", "index", "order", "value", "status", "censored_above", "seconds",
              "horizon", "message"]
    searches = study.steps.get("searches")
    with path.open("w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(fields)
        for run in (searches.runs if searches else ()):
            for index, e in enumerate(run.evaluations, start=1):
                writer.writerow([run.label, run.method, run.seed, index, " ".join(map(str, e.order)),
                                 "" if e.value is None else repr(e.value), e.status,
                                 "" if e.limit is None else repr(e.limit), f"{e.seconds:.6f}",
                                 "" if e.outputs is None else e.outputs.horizon, e.message])


def write_design_files(study: StudyResult, out: Path, materials) -> dict[str, str]:
    """Each answer's design file (and each chosen Pareto point's); {file: why it was not written} for those
    the writer refused (a design a named tool would run differently)."""
    from ..ssp import write_best_design_ssp

    refused = {}
    designs = []
    answers = study.steps.get("answers")
    for answer in (answers.answers if answers else ()):
        designs.append((answer.design_file, answer.order, answer.diagonal_rule))
    pareto = study.steps.get("pareto")
    for front in (pareto.fronts if pareto else ()):
        designs += [(c.design_file, c.order, front.diagonal_rule) for c in front.chosen]
    for name, order, rule in designs:
        parameters = {"material": list(order), **study.case.parameters}
        if rule in study.case.rules:
            parameters["diagonal_rule"] = rule
        try:
            write_best_design_ssp(study.fmu_path, parameters, out / name, stop_time=study.case.horizon,
                                  materials=materials)
        except (ValueError, OSError) as exc:
            refused[name] = str(exc).splitlines()[0]
    return refused


def write_certificates(study: StudyResult, out: Path) -> list[str]:
    exhaustive = study.steps.get("exhaustive")
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


def write_report(study: StudyResult, out: str | Path, steps, materials=None) -> Path:
    """Everything a study gives, into ``out``; returns the path of report.html."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    line = case_line(study)
    answers = study.steps.get("answers")
    known = answers.known_optima if answers else {}
    made = {
        "convergence": charts.convergence(study, out / "convergence.png", line, known),
        "force_energy": charts.force_and_energy(study, out / "force_energy.png", line),
        "lattice": charts.lattice(study, out / "lattice.png"),
        "work_precision": charts.work_precision(study, out / "work_precision.png"),
        "exhaustive": charts.exhaustive(study, out / "exhaustive.png"),
        "pareto": charts.pareto(study, out / "pareto.png"),
    }
    figures = {k: v for k, v in made.items() if v}
    refused = write_design_files(study, out, materials)
    certificates = write_certificates(study, out)
    record = results_record(study)
    record["design_files_refused"] = refused
    (out / "results.json").write_text(json.dumps(record, indent=1, allow_nan=False))
    write_evaluations_csv(study, out / "evaluations.csv")
    env = _env()
    sections = []
    for step in steps:
        result = study.steps.get(step.name)
        if result is None or not step.template or step.name == "answers":
            continue
        sections.append(markupsafe.Markup(env.get_template(f"report/{step.template}").render(
            result=result, study=study, charts=figures, title=step.title, terms=TERMS)))
    page = env.get_template("report/report.html.j2").render(
        study=study, case_line=line, answers=answers, charts=figures, sections=sections, terms=TERMS,
        refused=refused, certificates=certificates, known=known)
    (out / "report.html").write_text(page)
    return out / "report.html"


__all__ = ["TERMS", "case_line", "results_record", "write_report"]
