"""Search the material order that minimises the peak force on the backplate (a thin CLI over orchestrator/).

    python orchestrator/run.py                         # the default study: both diagonal rules, 11 x 11
    python orchestrator/run.py --method cmaes --budget 2000 --repeats 3
    python orchestrator/run.py --materials my_materials.csv --cols 5
    python orchestrator/run.py --case F_total=600,1200,2400 --aggregate worst
    python orchestrator/run.py --executor dask --scheduler tcp://10.0.0.5:8786
    python orchestrator/run.py --executor dask --cluster slurm --jobs 8 --walltime 02:00:00
    python orchestrator/run.py --resume                # continue an interrupted run
    python orchestrator/run.py --study results/study.toml --out again   # a study file, run again

Errors are one line on stderr with exit code 2 (a traceback only with --debug); a study without an answer
exits 3; an interrupted run exits 130 (Ctrl-C) or 143 (SIGTERM) and keeps every finished evaluation in
OUT.partial/journal.jsonl for --resume.
"""

from __future__ import annotations

import math
import os
import sys

if __name__ == "__main__":  # run as `python orchestrator/run.py`: import from the checkout's root, so that this
    # folder's modules (types.py) do not stand in for the standard library's of the same name
    sys.path[0] = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

import argparse  # noqa: E402
import dataclasses  # noqa: E402

from orchestrator.interruption import Interrupted, requested, terminate_on_sigterm  # noqa: E402

EXIT_OK, EXIT_USAGE, EXIT_NO_RESULT = 0, 2, 3


def build_parser() -> argparse.ArgumentParser:
    from orchestrator.cluster import ClusterConfig
    from orchestrator.options import Parser, add_options
    from orchestrator.runner import RunConfig
    from orchestrator.steps import STEPS
    from orchestrator.study import CaseConfig

    parser = Parser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    add_options(parser, CaseConfig, "the case")
    for step in STEPS:
        if dataclasses.fields(step.Config):
            add_options(parser, step.Config, step.title.lower())
    add_options(parser, RunConfig, "the run")
    add_options(
        parser,
        ClusterConfig,
        "the cluster",
        "Dask's workers as SLURM batch jobs (--executor dask "
        "--cluster slurm); every option also a key of a study file's [cluster] section",
    )
    parser.add_argument(
        "--study",
        metavar="FILE",
        help="run the study file FILE (every run writes one: OUT/study.toml); options given here override the file's",
    )
    return parser


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    from orchestrator.cluster import ClusterConfig
    from orchestrator.options import config_from
    from orchestrator.runner import NoResult, RunConfig, run_in_folder
    from orchestrator.steps import STEPS
    from orchestrator.study import CaseConfig

    debug = getattr(args, "RunConfig.debug", False)
    study_file = None
    if args.study is not None:
        from orchestrator.studyfile import StudyFileError, read_study_file

        try:
            study_file = read_study_file(args.study)
        except StudyFileError as exc:
            parser.error(str(exc))
        study_file.apply(args)
    try:
        run = config_from(RunConfig, args)
        case = config_from(CaseConfig, args)
        cluster = config_from(ClusterConfig, args)
        configs = {step: config_from(step.Config, args) for step in STEPS if dataclasses.fields(step.Config)}
    except ValueError as exc:
        parser.error(str(exc))
    interrupted = (
        f"interrupted: the finished evaluations are kept in {run.out}.partial/journal.jsonl; continue with "
        "the same options and --resume"
    )
    try:
        with terminate_on_sigterm():
            outcome = run_in_folder(run, case, configs, STEPS, study_file=study_file, cluster=cluster)
    except (KeyboardInterrupt, Interrupted) as exc:
        print(interrupted, file=sys.stderr)
        return 143 if isinstance(exc, Interrupted) else 130
    except NoResult as exc:
        print(f"{parser.prog}: no answer: {exc}; report: {run.out}/report.html", file=sys.stderr)
        return EXIT_NO_RESULT
    except Exception as exc:  # noqa: BLE001 - one line for users, the traceback with --debug
        if requested():  # a library turned the interruption into an error of its own
            print(interrupted, file=sys.stderr)
            return 143
        if debug:
            raise
        print(f"{parser.prog}: error: {one_line(exc)}", file=sys.stderr)
        return EXIT_USAGE
    print_answer(outcome)
    fmu_note = study_file.fmu_note(outcome.study.fmu_sha256) if study_file is not None else None
    if fmu_note:
        print(fmu_note, file=sys.stderr)
    return EXIT_OK


def one_line(exc: BaseException) -> str:
    if isinstance(exc, MemoryError):
        return "out of memory (free memory, or run with fewer --workers)"
    if isinstance(exc, OSError) and exc.errno == 28:
        return (
            f"no space left on the device of {exc.filename or 'the report or temporary folder'} (free space, or "
            "set TMPDIR or --out elsewhere)"
        )
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__


def front_sureness_line(sureness) -> str:
    """How sure a front is, in a few words: exact, or how many runs reached it and what would settle it."""
    if sureness.exact:
        return "exact: every design of the space swept"
    ends = "".join(
        f"; the known optimum of {k.output} alone {'is' if k.on_front else 'is NOT'} on it" for k in sureness.known_ends
    )
    return f"best found{ends}; {sureness.settle}"


def parameters_line(answer, study) -> str:
    """The answer as the start values to type into any FMI tool, and what the FMU does without them."""
    from orchestrator.report import rule_default_note

    note = rule_default_note(study, answer)
    cases = study.case.cases
    each = (
        (
            f", with each load case of {', '.join(f'{name} = {values}' for name, values in cases.items())} "
            f"(the value is the {study.case.aggregate} of their runs)"
        )
        if cases
        else ""
    )
    return f"in any FMI tool: {answer.start_values_text()}{each}, stop time {study.case.horizon:g} s" + (
        f" ({note})" if note else ""
    )


def print_answer(outcome) -> None:
    """The answer in a few lines, as the report's first screen gives it."""
    from orchestrator.report import case_line
    from orchestrator.steps import Answers, OptunaExport, Pareto, Starts, StatisticalEstimate

    study = outcome.study
    print(case_line(study))
    answers = study.result(Answers)
    statistical = study.result(StatisticalEstimate)
    unit = study.case.objective.units[0]
    for answer in answers.answers if answers else ():
        other = "".join(
            f", {v:.2f} {unit} under the {r} rule"
            for r, v in answer.values_by_rule.items()
            if r != answer.diagonal_rule and v is not None
        )
        evidence = answer.evidence
        role = f" ({'; '.join(answer.roles)})" if answer.roles else ""
        status = evidence.status.replace("_", " ")
        if evidence.status != "best_found" and evidence.covers:
            status += f" for {evidence.covers}"
        print(
            f"{answer.diagonal_rule} rule{role}: build {list(answer.order)}: {answer.peak:.2f} {unit}{other}; "
            f"{status}, {evidence.origin()}, {evidence.local_text()}; {answer.design_file}"
        )
        print(f"  {parameters_line(answer, study)}")
        line = codesign_line(study, answer.diagonal_rule, unit)
        if line:
            print(f"  {line}")
        if evidence.settlement is not None:
            print(f"  {evidence.settlement.line()}")
        estimate = statistical.for_rule(answer.diagonal_rule) if statistical else None
        if estimate is not None:
            print(f"  {estimate.sentence}")
    for reason in statistical.unfitted if statistical else ():
        print(f"  statistical estimate: {reason}")
        same = answer.equivalence
        if same is not None and same.equivalent:
            print(
                f"  equivalent for practical purposes to the runner-up {list(answer.runner_up)} "
                f"({answer.runner_up_peak:.2f} {unit}): {same.reason(unit)}"
            )
    starts = study.result(Starts)
    if starts is not None:
        from orchestrator.steps.starts import comparison_line

        for comparison in starts.comparisons:
            print(comparison_line(comparison, unit))
    pareto = study.result(Pareto)
    for front in pareto.fronts if pareto else ():
        print(
            f"{front.diagonal_rule} rule: {len(front.points)} designs on the Pareto front "
            f"({front_sureness_line(front.sureness)}); "
            + "; ".join(f"{c.label} {list(c.order)} ({c.design_file})" for c in front.chosen)
        )
    from orchestrator.steps import CoDesign

    codesign = study.result(CoDesign)
    for front in codesign.fronts if codesign else ():
        ends = [d for d in front.designs if d.full_values is not None]
        span = (
            f": {ends[0].full_values[0]:.2f} {unit} at {ends[0].full_values[1]:.2f} kg to "
            f"{ends[-1].full_values[0]:.2f} {unit} at {ends[-1].full_values[1]:.2f} kg (full fidelity)"
            if ends
            else ""
        )
        print(
            f"{front.diagonal_rule} rule: {len(front.designs)} designs (order and factors) on the co-design front of "
            f"{front.evaluations:,} NSGA-II evaluated within {front.mass_range[0]:.2f}..{front.mass_range[1]:.2f} kg"
            f"{span}; each in results.json's steps.codesign.fronts"
        )
        if front.seeds:
            print(
                f"  seeded by CMA-ES (then the polish) within {len(front.seeds)} mass budgets, "
                f"{sum(s.evaluations for s in front.seeds):,} designs: "
                + "; ".join(
                    f"{s.budget:.2f} kg: "
                    + (f"{s.values[0]:.2f} {unit} at {s.values[1]:.2f} kg" if s.values else "none within it")
                    for s in front.seeds
                )
                + " (search fidelity)"
            )
        for choice in front.chosen:
            peak, mass = (choice.design.full_values or (math.nan, math.nan))[:2]
            print(
                f"  {choice.label}: {list(choice.design.point.order)} with tailored layers, "
                f"{peak:.2f} {unit} at {mass:.2f} kg ({choice.design_file})"
            )
    from orchestrator.steps.pareto import BEST_DESIGN_FILE, best_design

    best = best_design(study)
    if best is not None:
        among = " among the orders at the table's values" if codesign is not None and codesign.fronts else ""
        print(f"{BEST_DESIGN_FILE}: the knee of the {best.diagonal_rule} rule's front{among}, {list(best.order)}")
    exported = study.result(OptunaExport)
    if exported is not None and exported.error is None:
        print(
            f"optuna: {sum(s.trials for s in exported.studies)} trials in {exported.storage} (studies "
            + ", ".join(repr(s.name) for s in exported.studies)
            + f"): optuna-dashboard {exported.storage}"
        )
    for line in cost_lines(study):
        print(line)
    print(f"report: {outcome.report}")


def codesign_line(study, rule: str, unit: str) -> str:
    """A rule's co-design in one line: each layer's factors, the stack's mass against the budget, the order
    search's answer it started from, and the polish's first-order optimality; "" without --vary."""
    from orchestrator.steps import CoDesign

    result = study.result(CoDesign)
    found = result.for_rule(rule) if result else None
    if found is None:
        return ""
    layers = "; ".join(
        f"{c.column}: {c.material} " + " ".join(f"{name} x{factor:.3f}" for name, factor in c.factors.items())
        for c in found.columns
    )
    polish = found.polish
    optimality = (
        ""
        if polish is None
        else f"; polish: minimax first-order residual {polish.kkt_residual:.2g} over {len(polish.active_times)} "
        f"active samples (tolerance {polish.tolerance:g}: {'met' if polish.converged else 'NOT met'}) after "
        f"{polish.iterations} SLSQP iterations"
    )
    return (
        f"co-design: {found.total_mass:.2f} kg of {found.mass_budget:.2f} kg; from {list(found.start_order)} at "
        f"{found.start_peak:.2f} {unit} (the table's values){optimality}; layers {layers}"
    )


def cost_lines(study) -> list[str]:
    """What the run simulated, step by step, and each step that simulated more than the searches (what --budget
    bounds) with why and the option that bounds it; nothing when no search ran."""
    from orchestrator.steps import Exhaustive, Searches

    searches = next((cost for cost in study.costs if cost.step == Searches.name), None)
    if searches is None:
        return []
    total = sum(cost.simulated for cost in study.costs)
    swept = any(cost.step == Exhaustive.name and cost.simulated for cost in study.costs)
    unit = "tasks (an FMU run each, a sweep's chunk one)" if swept else "FMU runs"
    lines = [
        f"simulated: {total:,} {unit}: "
        + ", ".join(f"{cost.step.replace('_', ' ')} {cost.simulated:,}" for cost in study.costs if cost.simulated)
    ]
    lines += [
        f"  {cost.step.replace('_', ' ')}: {cost.simulated:,} {'tasks' if swept else 'FMU runs'}, more than "
        f"the searches' {searches.simulated:,} (--budget): {cost.note}"
        for cost in study.costs
        if cost is not searches and cost.simulated > searches.simulated and cost.note
    ]
    return lines


if __name__ == "__main__":
    sys.exit(main())
