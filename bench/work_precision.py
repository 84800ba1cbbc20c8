"""Work against precision of the FMU's solvers: what each setting costs, what it gets wrong, where it fails.

    python -m bench.work_precision            # about 3 min: 10 orders, both horizons, 2 timed passes
    python -m bench.work_precision --quick    # about 50 s: 5 orders, fewer settings, one pass

Why: the searches' solver and tolerance (``orchestrator.objective.SEARCH_SOLVER`` and ``SEARCH_RTOL``), the
FMU's default tolerance and the fixed-step solvers' limits are chosen from this. For every solver setting
(the adaptive DOP853, Tsit5, DOPRI5 and Fine's Runge-Kutta-Nystrom 5(4) pair over a grid of rtol, atol =
rtol / 100; fixed-step RK4 and semi-implicit Euler over a grid of steps up past their stability limits) and
every order (the sequential order, the study's best, the best known, the reversed order and random ones), on
the searches' horizon (1 s) and the study's scene (8 s), the sampled peak is compared with DOP853 at rtol
1e-13 on the same order and horizon. A setting's error is its worst relative error over the orders; its work
the mean count of right-hand sides per run (the FMU's own count) and the CPU time per run through fmpy
(``time.process_time``, the fastest of the passes, the settings interleaved within each pass). That tight
reference is itself checked against scipy over the numpy model (``reference/``) at rtol 1e-11.
"""

from __future__ import annotations

import math
import time

from orchestrator.objective import SEARCH_HORIZON
from orchestrator.simulation import LatticeFMU, SimulationError
from reference import Scene
from reference.simulate import simulate

from .common import (
    BEST_KNOWN,
    FULL_HORIZON,
    REVERSED,
    SEQUENTIAL,
    STUDY_BEST,
    add_fmu_option,
    default_setting,
    lattice_fmu,
    setting_text,
    random_orders,
    relative,
    search_parameters,
)
from .measurements import Page, Run, Table, write_page

SEARCH_TARGET = 3e-5  # worst relative error the search ranking tolerates (bench.horizon_study measures the gaps)
FULL_TARGET = 1e-6  # worst relative error of a reported number
TIGHT = {"solver": "dop853", "rtol": 1e-13, "atol": 1e-15}
OUTPUTS = ("peak_backplate_force", "peak_backplate_force_continuous", "rhs_evaluations")
ADAPTIVE = ("dop853", "tsit5", "dopri5", "rkn5")
RTOLS = (1e-3, 1e-4, 3e-5, 2e-5, 1e-5, 8e-6, 5e-6, 1e-6, 1e-7, 1e-8, 1e-9)
QUICK_RTOLS = (1e-4, 1e-5, 8e-6, 1e-6, 1e-7, 1e-8)
FIXED = {
    "rk4": (1e-4, 5e-4, 1e-3, 2.5e-3, 5e-3, 0.01, 0.02, 0.025, 0.03, 0.04),
    "semi_implicit_euler": (1e-4, 2e-4, 5e-4, 1e-3, 2e-3, 5e-3, 0.01, 0.015, 0.02, 0.03),
}
QUICK_FIXED = {"rk4": (1e-3, 5e-3, 0.02, 0.03), "semi_implicit_euler": (1e-4, 1e-3, 0.01, 0.02)}
HORIZONS = {"search evaluation": SEARCH_HORIZON, "scene": FULL_HORIZON}


def settings(quick: bool) -> list[tuple[str, str, dict]]:
    rtols, fixed = (QUICK_RTOLS, QUICK_FIXED) if quick else (RTOLS, FIXED)
    out = [
        (solver, f"rtol {r:g}", {"solver": solver, "rtol": r, "atol": r * 1e-2}) for solver in ADAPTIVE for r in rtols
    ]
    out += [
        (solver, f"h {h:g} s", {"solver": solver, "fixed_step": h}) for solver, steps in fixed.items() for h in steps
    ]
    return out


def measure(fmu: LatticeFMU, orders, horizon: float, plan, passes: int) -> dict:
    """Per setting: the results of the last pass (a failure as its message) and the fastest pass's CPU time."""
    measured = {}
    for _ in range(passes):
        for solver, label, parameters in plan:
            results = []
            start = time.process_time()
            for order in orders:
                try:
                    results.append(fmu.simulate(order, horizon=horizon, parameters=parameters, outputs=OUTPUTS))
                except SimulationError as exc:
                    results.append(str(exc))
            seconds = (time.process_time() - start) / len(orders)
            entry = measured.setdefault((solver, label), {"results": results, "seconds": seconds})
            entry["seconds"] = min(entry["seconds"], seconds)
    return measured


def failure_kind(message: str) -> str:
    return "diverged" if any(w in message for w in ("diverged", "collapsed", "non-finite")) else "FMI error"


def main(argv=None) -> int:
    run = Run.start(__file__, argv)
    parser = run.parser(__doc__, quick="1 random order, fewer settings, one pass")
    add_fmu_option(parser)
    parser.add_argument("--random-orders", type=int, default=6, help="random orders besides the four named ones")
    parser.add_argument("--seed", type=int, default=7, help="seed of the random orders")
    parser.add_argument("--passes", type=int, default=2, help="timed passes per setting (the fastest counts)")
    args = parser.parse_args(argv)
    if args.quick:
        args.random_orders, args.passes = min(args.random_orders, 1), 1
    orders = [SEQUENTIAL, STUDY_BEST, BEST_KNOWN, REVERSED] + random_orders(args.random_orders, args.seed)
    plan = settings(args.quick)

    tables, best_rows, check_rows, notes = [], [], [], []
    findings: dict[str, dict] = {}
    with lattice_fmu(args.fmu) as path, LatticeFMU(path) as fmu:
        search = search_parameters(path)
        default = default_setting(path)
        label = f"rtol {default['rtol']:g}"
        if (default["solver"], label) not in {(solver, text) for solver, text, _ in plan}:  # the default is measured
            plan.append(
                (
                    default["solver"],
                    label,
                    {"solver": default["solver"], "rtol": default["rtol"], "atol": default["atol"]},
                )
            )
        for horizon_name, horizon in HORIZONS.items():
            truths = [fmu.simulate(order, horizon=horizon, parameters=TIGHT, outputs=OUTPUTS) for order in orders]
            checked = orders[:1] if args.quick else orders[:2]
            for order, truth in zip(checked, truths):
                scipy = simulate(Scene(order=order), horizon=horizon, rtol=1e-11, atol=1e-13)
                sampled = relative(scipy.peak_backplate_force, truth["peak_backplate_force"])
                continuous = relative(scipy.peak_backplate_force_continuous, truth["peak_backplate_force_continuous"])
                check_rows.append(
                    (
                        horizon_name,
                        str(list(order)),
                        f"{truth['peak_backplate_force']:.9f}",
                        f"{sampled:.1e}",
                        f"{continuous:.1e}",
                    )
                )
            measured = measure(fmu, orders, horizon, plan, args.passes)
            rows = []
            summary = {}
            for (solver, label), entry in measured.items():
                results = entry["results"]
                failures = [r for r in results if isinstance(r, str)]
                good = [(r, t) for r, t in zip(results, truths) if not isinstance(r, str)]
                worst = max(
                    (
                        max(
                            relative(r["peak_backplate_force"], t["peak_backplate_force"]),
                            relative(r["peak_backplate_force_continuous"], t["peak_backplate_force_continuous"]),
                        )
                        for r, t in good
                    ),
                    default=math.nan,
                )
                sampled = max(
                    (relative(r["peak_backplate_force"], t["peak_backplate_force"]) for r, t in good), default=math.nan
                )
                rhs = sum(r["rhs_evaluations"] for r, _ in good) / len(good) if good else math.nan
                status = f"{len(failures)} of {len(orders)} failed: {failure_kind(failures[0])}" if failures else "ok"
                summary[(solver, label)] = {
                    "sampled": sampled,
                    "worst": worst,
                    "rhs": rhs,
                    "failed": len(failures),
                    "ms": entry["seconds"] * 1e3,
                }
                rows.append(
                    (
                        solver,
                        label,
                        "" if failures else f"{sampled:.1e}",
                        "" if failures else f"{worst:.1e}",
                        "" if failures else f"{rhs:.0f}",
                        f"{entry['seconds'] * 1e3:.2f}",
                        status,
                    )
                )
            tables.append(
                Table(
                    (
                        "solver",
                        "setting",
                        "worst error, sampled peak",
                        "worst error, sampled and continuous",
                        "mean right-hand sides",
                        "CPU ms per run",
                        "status",
                    ),
                    tuple(rows),
                    caption=f"**{horizon_name.capitalize()} ({horizon:g} s)**, {len(orders)} orders:",
                )
            )
            target = SEARCH_TARGET if horizon == SEARCH_HORIZON else FULL_TARGET
            for solver in ADAPTIVE + tuple(FIXED):
                good = [
                    (label, s)
                    for (name, label), s in summary.items()
                    if name == solver and s["failed"] == 0 and s["sampled"] <= target
                ]
                if good:
                    label, s = min(good, key=lambda item: item[1]["rhs"])
                    best_rows.append(
                        (
                            horizon_name,
                            f"{target:g}",
                            solver,
                            label,
                            f"{s['sampled']:.1e}",
                            f"{s['rhs']:.0f}",
                            f"{s['ms']:.2f}",
                        )
                    )
                else:
                    best_rows.append((horizon_name, f"{target:g}", solver, "none of the grid", "", "", ""))
            for solver in FIXED:
                stable = [
                    float(label.split()[1])
                    for (name, label), s in summary.items()
                    if name == solver and s["failed"] == 0
                ]
                failed = [
                    float(label.split()[1])
                    for (name, label), s in summary.items()
                    if name == solver and s["failed"] > 0
                ]
                notes.append(
                    f"{solver}, {horizon_name}: the largest step that ran on every order is "
                    f"{max(stable):g} s"
                    + (
                        f"; from {min(failed):g} s on a run ends with an FMI error naming the divergence"
                        if failed
                        else ""
                    )
                    if stable
                    else f"{solver}, {horizon_name}: no step of the grid ran on every order"
                )
            findings[horizon_name] = summary
    search_key = (search["solver"], f"rtol {search['rtol']:g}")
    default_key = (default["solver"], f"rtol {default['rtol']:g}")
    searched = findings["search evaluation"].get(search_key)
    default_found = findings["scene"].get(default_key)
    headline = []
    if searched:
        headline.append(
            f"the searches' setting ({search['solver']}, rtol {search['rtol']:g}, 1 s) errs by at most "
            f"{searched['sampled']:.1e} with {searched['rhs']:.0f} right-hand sides"
        )
    if default_found:
        headline.append(f"the FMU's default ({setting_text(default)}) by {default_found['worst']:.1e} over 8 s")
    agreement = max(max(float(r[3]), float(r[4])) for r in check_rows)
    page = Page(
        name=run.name,
        title="Work against precision of the FMU's solvers",
        headline="; ".join(headline),
        summary=(
            f"Every solver setting on {len(orders)} orders (the sequential order, the study's best, the best known "
            f"{list(BEST_KNOWN)}, the reversed order and {args.random_orders} random ones), over the searches' "
            f"horizon and the study's {FULL_HORIZON:g} s scene, through fmpy (`orchestrator.simulation.LatticeFMU`). "
            "Error: the largest relative error over the orders against DOP853 at rtol 1e-13, atol 1e-15 on the "
            "same order and horizon. Work: the mean count of right-hand sides per run (the FMU's counter) and "
            f"the CPU time per run (the fastest of {args.passes} pass(es)). The tight reference agrees with scipy "
            f"over the numpy model at rtol 1e-11 to {agreement:.1e} (table at the end). Adaptive settings use atol "
            "= rtol / 100."
        ),
        tables=(
            Table(
                (
                    "evaluation",
                    "target",
                    "solver",
                    "cheapest setting within it",
                    "worst error",
                    "mean right-hand sides",
                    "CPU ms per run",
                ),
                tuple(best_rows),
                caption="**The cheapest setting of each solver** (fewest right-hand sides) whose worst "
                "sampled-peak error is within the target:",
            ),
            *tables,
            Table(
                (
                    "evaluation",
                    "order",
                    "FMU at rtol 1e-13: peak (N)",
                    "scipy over numpy, rtol 1e-11: sampled peak, rel. difference",
                    "continuous peak, rel. difference",
                ),
                tuple(check_rows),
                caption="**The tight reference against scipy over the numpy model:**",
            ),
        ),
        notes=tuple(notes),
    )
    write_page(run, page)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
