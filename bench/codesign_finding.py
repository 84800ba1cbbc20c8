"""The co-design finding: how far tailored layers bring the peak below the order search's answer at the same mass.

    python -m bench.codesign_finding            # the study's 11 x 11 lattice: both rules and the mean rule's front
    python -m bench.codesign_finding --quick    # smaller search budgets (a few minutes on two cores)

Each line is the study's command line, run as a user runs it (``python orchestrator/run.py ... --vary k,c,mass`` in
a fresh process, timed from start to exit): under each diagonal rule the order search at the table's values, then
CMA-ES over the order and every column's k, c and mass factors (0.5..2) within the order's own mass (121 kg), then
SLSQP on the epigraph of the sampled peak over the factors; under the mean rule, NSGA-II's front of the peak against
the stack's mass from the lightest stack the factors allow (60.5 kg) to ``--mass-budget 180`` kg, beside the order
search's answer, and the layers' properties that move the answer's peak most (the polish's sensitivities); pymoo's
mixed-variable GA (``--codesign-method mixed-ga``) in CMA-ES's place under the mean rule, at the same
``--vary-budget``; and the order search alone with every damper at exponent n = 0.5 and 2 beside the study's n = 1.
Each answer's start values are typed into FMPy's ``simulate_fmu`` and must give its peak (1e-6).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

from fmpy import simulate_fmu

from fmu_src.materials import MaterialTable, study_materials, write_materials_csv

from .common import add_fmu_option, lattice_fmu, order_text, percent
from .measurements import ROOT, Page, Run, Table, write_page

VARIED = "k,c,mass"
AGREEMENT = 1e-6  # FMPy's run of the answer's start values against its reported peak
DAMPING_EXPONENTS = (0.5, 2.0)  # beside the study's linear dampers (n = 1, the mean rule's run)
FRONT_MASS_BUDGET = 180.0  # kg: the front's upper end, about half again the study's stack
FRONT_ROWS_SHOWN = 14
SENSITIVITIES_SHOWN = 8  # the layers' properties that move the mean rule's peak most, at its answer


def run_study(fmu: Path | None, out: Path, options: list[str]) -> tuple[float, dict, str]:
    """``orchestrator/run.py`` with ``options`` in a fresh process: its wall seconds, results.json and console.
    Without ``fmu`` the run builds (or reuses) the FMU its options ask for, as a user's run does."""
    words = [sys.executable, str(ROOT / "orchestrator" / "run.py"), "--out", str(out), "--no-progress", *options]
    if fmu is not None:
        words[2:2] = ["--fmu", str(fmu)]
    start = time.perf_counter()
    done = subprocess.run(words, cwd=ROOT, capture_output=True, text=True, check=False, env=dict(os.environ))
    seconds = time.perf_counter() - start
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(words[1:])}: exit {done.returncode}: {done.stderr.strip()[-500:]}")
    return seconds, json.loads((out / "results.json").read_text()), done.stdout


def fmpy_peak(fmu: Path, parameters: dict, horizon: float) -> float:
    result = simulate_fmu(str(fmu), start_values=parameters, stop_time=horizon, output=["peak_backplate_force"])
    return float(result["peak_backplate_force"][-1])


def polish_text(polish: dict | None) -> str:
    if polish is None:
        return "none (a run of the polish failed)"
    tolerance = polish["tolerance"]
    met = "met" if polish["kkt_residual"] <= tolerance else "not met"
    return (
        f"minimax residual {polish['kkt_residual']:.2g} ({met}) over {len(polish['active_times'])} active samples "
        f"(the peak's sample alone: {polish['smooth_residual']:.2g}); tolerance {tolerance:g}"
    )


def main(argv=None) -> int:
    run = Run.start(__file__, argv)
    parser = run.parser(__doc__, quick="--vary-budget 400 --budget 60 --repeats 1 for the order search")
    add_fmu_option(parser)
    args = parser.parse_args(argv)
    searches = ["--budget", "60", "--repeats", "1"] if args.quick else []
    vary_budget = ["--vary-budget", "400"] if args.quick else []
    rows = []
    sensitivity_rows: list[tuple] = []
    starts: dict[str, tuple[list, float, float]] = {}  # by rule: the order search's answer, its peak and mass
    with lattice_fmu(args.fmu) as fmu, tempfile.TemporaryDirectory(prefix="bench_codesign_") as folder:
        for rule, method in (("mean", "cmaes"), ("receiver", "cmaes"), ("mean", "mixed-ga")):
            options = ["--vary", VARIED, "--diagonal-rule", rule, *searches, *vary_budget]
            options += ["--codesign-method", method] if method != "cmaes" else []
            seconds, record, _ = run_study(fmu, Path(folder) / f"{rule}_{method}", options)
            answer = record["answers"][0]
            codesign = record["steps"]["codesign"]["answers"][0]
            horizon = record["case"]["horizon"]
            again = fmpy_peak(fmu, answer["parameters"], horizon)
            if abs(again / answer["peak"] - 1.0) > AGREEMENT:
                raise SystemExit(f"{rule}: the answer reports {answer['peak']!r} N, FMPy gives {again!r} N")
            polish = codesign["polish"]
            starts.setdefault(rule, (codesign["start_order"], codesign["start_peak"], codesign["mass_budget"]))
            if rule == "mean" and method == "cmaes" and polish is not None:
                names = record["steps"]["codesign"]["names"]
                ranked = sorted(
                    (
                        (abs(value), column, name, value)
                        for column, row in enumerate(polish["sensitivities"], start=1)
                        for name, value in zip(names, row)
                    ),
                    reverse=True,
                )
                sensitivity_rows = [
                    (f"{column}", answer["columns"][column - 1]["material"], name, f"{value:+.1f}")
                    for _, column, name, value in ranked[:SENSITIVITIES_SHOWN]
                ]
            rows.append(
                (
                    f"`python orchestrator/run.py {' '.join(options)}`",
                    order_text(codesign["start_order"]),
                    f"{codesign['start_peak']:.2f}",
                    order_text(answer["order"]),
                    f"{answer['peak']:.2f}",
                    percent(answer["peak"], codesign["start_peak"]),
                    f"{answer['total_mass']:.2f} of {codesign['mass_budget']:.2f}",
                    f"{abs(again / answer['peak'] - 1.0):.1e}",
                    polish_text(polish),
                    f"{seconds:.0f}",
                )
            )
        options = ["--vary", VARIED, "--objective", "sampled,mass", "--mass-budget", f"{FRONT_MASS_BUDGET:g}"]
        options += ["--diagonal-rule", "mean", *searches, *vary_budget]
        seconds, record, _ = run_study(fmu, Path(folder) / "front", options)
        front = record["steps"]["codesign"]["fronts"][0]
        shown = [d for d in front["designs"] if d["full_values"] is not None]
        step = max(1, len(shown) // FRONT_ROWS_SHOWN)
        lightest, upper = front["mass_range"]
        heaviest_evaluated = front["evaluated_masses"][1]
        heaviest_on_front = max(d["full_values"][1] for d in shown)
        order, peak, mass = starts["mean"]
        dominating = [
            d
            for d in shown
            if d["full_values"][0] <= peak and d["full_values"][1] <= mass and d["full_values"] != [peak, mass]
        ]
        within = [d for d in shown if d["full_values"][1] <= mass * (1 + 1e-9)]
        at_study = min(within, key=lambda d: d["full_values"][0]) if within else None
        codesign_peak = float(rows[0][4])
        at_study_text = (
            f"; at or below the study's {mass:.0f} kg the front's best is {at_study['full_values'][0]:.2f} N, "
            f"against {codesign_peak:.2f} N for the CMA-ES co-design above"
            if at_study is not None
            else ""
        )
        front_table = Table(
            ("stack mass (kg)", "peak (N)", "order"),
            tuple(
                (f"{d['full_values'][1]:.2f}", f"{d['full_values'][0]:.2f}", order_text(d["point"]["order"]))
                for d in (shown[::step] + ([shown[-1]] if (len(shown) - 1) % step else []))
            )
            + ((f"{mass:.2f}", f"{peak:.2f}", f"{order_text(order)}: the order search's answer, the table's values"),),
            caption=(
                f"`python orchestrator/run.py {' '.join(options)}` ({seconds:.0f} s): {len(shown)} designs on the "
                f"front of {front['evaluations']:,} NSGA-II evaluated within {lightest:.1f}..{upper:.1f} kg (the "
                "lightest stack the factors allow, --mass-budget the upper end), every "
                f"{step}th shown and the lightest (full fidelity); NSGA-II evaluated designs up to "
                f"{heaviest_evaluated:.1f} kg and none heavier than the front's {heaviest_on_front:.1f} kg lowers "
                "the peak further; the last row is the order search's answer under the mean rule, which "
                f"{len(dominating)} of the front's "
                f"designs dominate (no heavier, no higher peak){at_study_text}"
            ),
        )
        damping_rows = [(1.0, order_text(order), f"{peak:.2f}", "the mean rule's run above")]
        for exponent in DAMPING_EXPONENTS:
            table = Path(folder) / f"damping_{exponent:g}.csv"
            write_materials_csv(
                MaterialTable(tuple(replace(m, damping_exponent=exponent) for m in study_materials().materials)),
                table,
            )
            options = ["--materials", str(table), "--diagonal-rule", "mean", "--no-sensitivity", *searches]
            seconds, record, _ = run_study(None, Path(folder) / f"n{exponent:g}", options)
            answer = record["answers"][0]
            damping_rows.append(
                (
                    exponent,
                    order_text(answer["order"]),
                    f"{answer['peak']:.2f}",
                    f"{answer['evidence']['status'].replace('_', ' ')}, {seconds:.0f} s",
                )
            )
        damping_table = Table(
            ("damping exponent n (every material)", "best order (mean rule)", "peak (N)", "how sure, wall s"),
            tuple((f"{n:g}", *rest) for n, *rest in sorted(damping_rows)),
            caption=(
                "The order search alone (no --vary) with the study's table and every material's dampers at exponent "
                "n (`python orchestrator/run.py --materials TABLE --diagonal-rule mean --no-sensitivity`, TABLE the "
                "study's with a damping_exponent column of n; its FMU built by the run)"
            ),
        )
    mean = rows[0]
    page = Page(
        name=run.name,
        title="Co-design: tailored layers at the study's mass",
        headline=(
            f"mean rule at the study's 121 kg: {mean[4]} N with tailored k, c and mass against {mean[2]} N for the "
            f"order search's answer at the table's values ({mean[5]} %), in {mean[9]} s"
        ),
        summary=(
            "Under each diagonal rule, the study's 11 x 11 lattice: the order search at the table's values, then "
            f"CMA-ES over the order and each column's {VARIED} factors in 0.5..2 within the order's own mass, "
            "then SLSQP on the epigraph of the sampled peak over the factors at the order CMA-ES ends at (the "
            "first-order residual of the minimax problem over the samples within its active tolerance of the peak, "
            "relative to the peak, per unit of the log-scaled factor, against its tolerance; beside it the residual "
            "with the peak's sample alone, the smooth measure a tie of samples keeps large). "
            "The last row searches with pymoo's mixed-variable GA (each column's material a choice, its "
            "factors reals) in CMA-ES's place, at the same --vary-budget. Each answer's start values, typed into "
            "FMPy's simulate_fmu, give its peak (the FMPy column: the relative difference)."
        ),
        tables=(
            Table(
                (
                    "command",
                    "order search's answer",
                    "its peak (N)",
                    "co-design's order",
                    "co-design's peak (N)",
                    "%",
                    "stack mass (kg)",
                    "FMPy",
                    "polish: first-order optimality",
                    "wall s",
                ),
                tuple(rows),
            ),
            front_table,
            damping_table,
            Table(
                ("column", "material", "property", "d peak / d ln(factor) (N)"),
                tuple(sensitivity_rows),
                caption=(
                    "The mean rule's answer: the peak's sensitivity to a relative change of each layer's property "
                    "(the polish's multiplier-weighted gradient of the active samples at its end), the largest first"
                ),
            ),
        ),
        notes=(
            "The sampled peak is a maximum over samples, not differentiable where two samples tie: the polish "
            "minimises it as the epigraph problem (each sample near the peak a smooth constraint) and measures "
            "first-order optimality with multipliers over every active sample.",
        ),
    )
    write_page(run, page)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
