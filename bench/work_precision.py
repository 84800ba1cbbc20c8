"""Work against precision: what each solver setting costs and what it gets wrong, and where it fails.

    python bench/work_precision.py --out bench/out/work_precision          # ~3 min on one core
    python bench/work_precision.py --out DIR --quick                       # ~1 min
    python bench/work_precision.py --out DIR --horizon 8 --no-reference-fmu   # the full published scene

For every order (sequential, the study's best, reversed, random ones) and every setting:
- the C FMU's adaptive DOP853 at rtol 1e-3 ... 1e-12 (atol = rtol * 1e-2),
- its fixed-step RK4 and semi-implicit Euler at steps from 1e-4 s up past their stability limits,
- the reference FMU (pythonfmu over the numpy/scipy model) at a few tolerances,
it measures seconds per evaluation (in the worker process, the best of --repeats), right-hand-side
evaluations, and the relative error of the sampled and of the continuous peak against a tight reference
(the C FMU at rtol 1e-13, cross-checked with the numpy/scipy route reference.simulate at rtol 1e-11).
Status: ok (both errors <= 1e-6), inaccurate (a number, but off by more), diverged (an FMI error saying
so), error (another FMI error), timeout (doStep did not return: the worker was killed).

Writes DIR/work_precision.csv (one row per solver and setting, over the orders: mean seconds, max error,
worst status), DIR/work_precision_runs.csv (one row per order too), DIR/reference_check.csv and
DIR/work_precision.png (error against time, log-log; failures marked on a band at the top).
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import (ALL_OUTPUTS, IsolatedFMU, ROOT, bench_orders, build_fmus, order_text,  # noqa: E402
                    write_csv)

ACCURATE = 1e-6
STATUS_RANK = {"ok": 0, "inaccurate": 1, "diverged": 2, "error": 3, "timeout": 4}
SOLVER_LABELS = {"adaptive": "C FMU, adaptive DOP853", "rk4": "C FMU, fixed-step RK4",
                 "semi_implicit_euler": "C FMU, semi-implicit Euler", "reference_fmu": "reference FMU (scipy DOP853)"}


def settings(quick: bool, with_reference: bool) -> list[tuple[str, str, dict, str]]:
    """(solver, setting label, FMU parameters, which FMU)."""
    rtols = [1e-3, 1e-5, 1e-7, 1e-9, 1e-11] if quick else [10.0 ** -k for k in range(3, 13)]
    rk4_steps = ([1e-4, 1e-3, 5e-3, 0.01, 0.02, 0.025, 0.03, 0.035, 0.05] if quick else
                 [1e-4, 2e-4, 5e-4, 1e-3, 2e-3, 5e-3, 0.01, 0.015, 0.02, 0.025, 0.03, 0.035, 0.04, 0.05])
    sie_steps = ([1e-4, 2e-4, 5e-4, 1e-3, 5e-3, 0.01, 0.02] if quick else
                 [1e-4, 2e-4, 5e-4, 7e-4, 1e-3, 2e-3, 5e-3, 0.01, 0.015, 0.02, 0.03])
    out = [("adaptive", f"rtol={r:.0e}", {"solver": 0, "rtol": r, "atol": r * 1e-2}, "c") for r in rtols]
    out += [("rk4", f"h={h:g}", {"solver": 1, "fixed_step": h}, "c") for h in rk4_steps]
    out += [("semi_implicit_euler", f"h={h:g}", {"solver": 2, "fixed_step": h}, "c") for h in sie_steps]
    if with_reference:
        ref_rtols = [1e-5, 1e-7] if quick else [1e-4, 1e-6, 1e-8]
        out += [("reference_fmu", f"rtol={r:.0e}", {"rtol": r, "atol": r * 1e-2}, "reference") for r in ref_rtols]
    return out


def classify(status: str, payload, truth: dict) -> tuple[str, float, float, str]:
    """(status, rel. error sampled, rel. error continuous, message)."""
    if status == "timeout":
        return "timeout", math.nan, math.nan, payload
    if status == "error":
        kind = "diverged" if ("diverged" in payload or "collapsed" in payload or "non-finite" in payload) else "error"
        return kind, math.nan, math.nan, payload
    sampled = abs(payload["peak_backplate_force"] / truth["peak_backplate_force"] - 1)
    continuous = abs(payload["peak_backplate_force_continuous"] / truth["peak_backplate_force_continuous"] - 1)
    if not (math.isfinite(sampled) and math.isfinite(continuous)):
        return "diverged", math.nan, math.nan, "a non-finite peak came back as a number"
    return ("ok" if max(sampled, continuous) <= ACCURATE else "inaccurate"), sampled, continuous, ""


def measure(fmu: IsolatedFMU, order, horizon: float, parameters: dict, repeats: int, timeout: float):
    """Best of `repeats` (runs over 1 s are not repeated); the last outcome's status and result."""
    best = math.inf
    status = payload = None
    for _ in range(max(1, repeats)):
        status, payload, seconds = fmu.run(order, horizon, parameters, ALL_OUTPUTS, timeout=timeout)
        best = min(best, seconds)
        if status != "ok" or seconds > 1.0:
            break
    return status, payload, best


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", default=str(ROOT / "bench" / "out" / "work_precision"), help="output folder")
    parser.add_argument("--horizon", type=float, default=1.0,
                        help="simulated seconds (default 1: the searches' horizon; the peak is over by then)")
    parser.add_argument("--random-orders", type=int, default=2, help="random orders besides the three fixed ones")
    parser.add_argument("--repeats", type=int, default=3, help="timed runs per C FMU setting (the best counts)")
    parser.add_argument("--timeout", type=float, default=15.0, help="seconds before a C FMU run counts as hung")
    parser.add_argument("--no-reference-fmu", action="store_true", help="skip the reference FMU (pythonfmu) route")
    parser.add_argument("--reference-orders", type=int, default=2,
                        help="orders the (slow) reference FMU runs (the first N: sequential, study's best, ...)")
    parser.add_argument("--quick", action="store_true", help="fewer settings, one cross-check, 1 random order")
    args = parser.parse_args(argv)
    if args.quick:
        args.random_orders, args.repeats, args.reference_orders = min(args.random_orders, 1), 1, 1
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    with_reference = not args.no_reference_fmu
    started = time.perf_counter()
    fmus = build_fmus(out, c=True, reference=with_reference)
    orders = bench_orders(args.random_orders)
    plan = settings(args.quick, with_reference)
    print(f"work-precision: {len(orders)} orders x {len(plan)} settings, horizon {args.horizon:g} s "
          f"(FMUs built into {out / 'fmus'})", flush=True)

    # the tight reference: the C FMU at rtol 1e-13, cross-checked with numpy/scipy (reference.simulate)
    from reference import Scene, simulate

    truths, checks = {}, []
    with IsolatedFMU(fmus["c"], timeout=300) as c_fmu:
        for k, (name, order) in enumerate(orders.items()):
            status, payload, _ = c_fmu.run(order, args.horizon, {"rtol": 1e-13, "atol": 1e-15})
            if status != "ok":
                raise SystemExit(f"the tight reference failed for {name}: {payload}")
            truths[name] = payload
            if args.quick and k > 0:
                continue
            rtol = 1e-10 if args.quick else 1e-11
            t0 = time.perf_counter()
            scipy_run = simulate(Scene(order=order), horizon=args.horizon, rtol=rtol, atol=rtol * 1e-2)
            row = {"order_name": name, "order": order, "c_fmu_rtol": 1e-13, "scipy_rtol": rtol,
                   "c_fmu_peak": payload["peak_backplate_force"], "scipy_peak": scipy_run.peak_backplate_force,
                   "c_fmu_peak_continuous": payload["peak_backplate_force_continuous"],
                   "scipy_peak_continuous": scipy_run.peak_backplate_force_continuous,
                   "scipy_seconds": time.perf_counter() - t0}
            row["rel_diff_sampled"] = abs(row["scipy_peak"] / row["c_fmu_peak"] - 1)
            row["rel_diff_continuous"] = abs(row["scipy_peak_continuous"] / row["c_fmu_peak_continuous"] - 1)
            checks.append(row)
            print(f"  reference {name:11s} {order_text(order):26s} peak {row['c_fmu_peak']:.10f} N "
                  f"(numpy/scipy: rel. diff {row['rel_diff_sampled']:.1e} sampled, "
                  f"{row['rel_diff_continuous']:.1e} continuous)", flush=True)
    write_csv(out / "reference_check.csv", checks)

    runs = []
    isolated = {which: IsolatedFMU(path, timeout=args.timeout) for which, path in fmus.items()}
    try:
        for solver, label, parameters, which in plan:
            names = list(orders)[:args.reference_orders] if which == "reference" else list(orders)
            for name in names:
                order = orders[name]
                timeout = args.timeout if which == "c" else max(600.0, args.timeout)
                repeats = args.repeats if which == "c" else 1
                status, payload, seconds = measure(isolated[which], order, args.horizon, parameters, repeats,
                                                   timeout)
                kind, err_s, err_c, message = classify(status, payload, truths[name])
                runs.append({
                    "solver": solver, "setting": label, "order_name": name, "order": order,
                    "seconds_per_eval": seconds, "status": kind,
                    "rel_error": max(err_s, err_c) if kind in ("ok", "inaccurate") else math.nan,
                    "rel_error_sampled": err_s, "rel_error_continuous": err_c,
                    "rhs_evaluations": payload["rhs_evaluations"] if status == "ok" else None,
                    "steps_accepted": payload["steps_accepted"] if status == "ok" else None,
                    "steps_rejected": payload["steps_rejected"] if status == "ok" else None,
                    "peak": payload["peak_backplate_force"] if status == "ok" else None,
                    "peak_continuous": payload["peak_backplate_force_continuous"] if status == "ok" else None,
                    "energy_balance_error": payload["energy_balance_error"] if status == "ok" else None,
                    "message": message.replace("\n", " ")[:300],
                    **{f"param_{k}": v for k, v in parameters.items()},
                })
            print(f"  {solver:20s} {label:12s} " + summary_line([r for r in runs if r["solver"] == solver
                                                                   and r["setting"] == label]), flush=True)
    finally:
        for fmu in isolated.values():
            fmu.close()

    table = aggregate(runs, plan)
    write_csv(out / "work_precision_runs.csv", runs)
    write_csv(out / "work_precision.csv", table)
    plot(table, out / "work_precision.png", args.horizon, len(orders))
    report(table, checks, args.horizon, orders)
    print(f"wrote {out / 'work_precision.csv'}, {out / 'work_precision_runs.csv'}, "
          f"{out / 'reference_check.csv'}, {out / 'work_precision.png'} in {time.perf_counter() - started:.0f} s")
    return 0


def summary_line(rows: list[dict]) -> str:
    worst = max(rows, key=lambda r: STATUS_RANK[r["status"]])["status"]
    good = [r for r in rows if r["status"] in ("ok", "inaccurate")]
    if not good:
        return f"{worst:10s} {rows[0]['message'][:110]}"
    seconds = sum(r["seconds_per_eval"] for r in good) / len(good)
    error = max(r["rel_error"] for r in good)
    return f"{worst:10s} {seconds * 1e3:9.2f} ms/eval  max rel. error {error:.1e}"


def aggregate(runs: list[dict], plan) -> list[dict]:
    table = []
    for solver, label, parameters, which in plan:
        rows = [r for r in runs if r["solver"] == solver and r["setting"] == label]
        good = [r for r in rows if r["status"] in ("ok", "inaccurate")]
        worst = max(rows, key=lambda r: STATUS_RANK[r["status"]])
        mean = lambda key: sum(r[key] for r in good) / len(good) if good else math.nan  # noqa: E731
        table.append({
            "solver": solver, "setting": label, "fmu": which,
            "rtol": parameters.get("rtol"), "fixed_step": parameters.get("fixed_step"),
            "orders": len(rows), "orders_failed": len(rows) - len(good),
            "seconds_per_eval": mean("seconds_per_eval") if good else
            sum(r["seconds_per_eval"] for r in rows) / len(rows),
            "rhs_evaluations": mean("rhs_evaluations"),
            "rel_error": max((r["rel_error"] for r in good), default=math.nan),
            "rel_error_sampled": max((r["rel_error_sampled"] for r in good), default=math.nan),
            "rel_error_continuous": max((r["rel_error_continuous"] for r in good), default=math.nan),
            "status": worst["status"],
            "failed_orders": " ".join(r["order_name"] for r in rows if r not in good),
            "message": worst["message"] if worst not in good else "",
        })
    return table


def plot(table: list[dict], path: Path, horizon: float, n_orders: int) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(10.5, 6.8))
    colours = {"adaptive": "tab:blue", "rk4": "tab:orange", "semi_implicit_euler": "tab:green",
               "reference_fmu": "tab:purple"}
    good_errors = [r["rel_error"] for r in table if r["orders_failed"] == 0 and r["rel_error"] > 0]
    floor = min(good_errors + [1e-13]) / 3
    fail_band, band_top = 3.0, 3e3
    for solver, colour in colours.items():
        rows = [r for r in table if r["solver"] == solver]
        if not rows:
            continue
        good = [r for r in rows if r["orders_failed"] == 0]
        ax.plot([r["seconds_per_eval"] for r in good], [max(r["rel_error"], floor) for r in good], "o-",
                color=colour, label=SOLVER_LABELS[solver], ms=5)
        for r in good:
            ax.annotate(r["setting"].replace("rtol=", ""), (r["seconds_per_eval"], max(r["rel_error"], floor)),
                        fontsize=6.5, color=colour, xytext=(3, 3), textcoords="offset points")
        for r in (r for r in rows if r["orders_failed"] > 0):
            marker = {"timeout": "v", "diverged": "x", "error": "X"}.get(r["status"], "s")
            ax.plot(r["seconds_per_eval"], fail_band, marker, color=colour, ms=8, mew=2)
            ax.annotate(f"{r['setting'].replace('rtol=', '')} {r['orders_failed']}/{r['orders']}",
                        (r["seconds_per_eval"], fail_band), fontsize=6, color=colour, rotation=90,
                        xytext=(-3, 7), textcoords="offset points", va="bottom")
    default = next((r for r in table if r["solver"] == "adaptive" and r["setting"] == "rtol=1e-07"), None)
    within = [r for r in table if r["orders_failed"] == 0 and r["rel_error"] <= ACCURATE]
    fastest = min(within, key=lambda r: r["seconds_per_eval"]) if within else None
    if default and default["orders_failed"] == 0:
        ax.plot(default["seconds_per_eval"], max(default["rel_error"], floor), "*", ms=18, mfc="none",
                mec="black", label=f"FMU default (rtol 1e-7): {default['rel_error']:.1e}, "
                                   f"{default['seconds_per_eval'] * 1e3:.1f} ms")
    if fastest:
        ax.plot(fastest["seconds_per_eval"], max(fastest["rel_error"], floor), "o", ms=14, mfc="none",
                mec="red", mew=1.5, label=f"fastest within {ACCURATE:.0e}: {SOLVER_LABELS[fastest['solver']]} "
                                          f"{fastest['setting']}, {fastest['seconds_per_eval'] * 1e3:.1f} ms")
    ax.axhline(ACCURATE, color="grey", ls="--", lw=1)
    ax.annotate(f"{ACCURATE:.0e}", xy=(0.005, ACCURATE * 1.3), xycoords=("axes fraction", "data"), color="grey",
                fontsize=8)
    ax.axhspan(1.0, band_top, color="red", alpha=0.06)
    ax.text(0.99, 0.985, "failed on k/n orders: x diverged (FMI error), v doStep never returned, X other error",
            transform=ax.transAxes, fontsize=8, color="darkred", va="top", ha="right")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_ylim(floor / 2, band_top)
    ax.set_xlabel("seconds per evaluation (mean over the orders; one core)")
    ax.set_ylabel("relative error of the peak (max over orders of sampled and continuous)")
    ax.set_title(f"Work against precision, {horizon:g} s horizon, {n_orders} orders; reference: C FMU at rtol 1e-13")
    ax.grid(True, which="both", alpha=0.25)
    ax.legend(fontsize=8, loc="lower left")
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)


def report(table: list[dict], checks: list[dict], horizon: float, orders: dict) -> None:
    print()
    if checks:
        worst = max(max(c["rel_diff_sampled"], c["rel_diff_continuous"]) for c in checks)
        print(f"tight reference: the C FMU at rtol 1e-13 and numpy/scipy (rtol {checks[0]['scipy_rtol']:.0e}) agree "
              f"to {worst:.1e} (max over {len(checks)} order(s), sampled and continuous peaks)")
    default = next((r for r in table if r["solver"] == "adaptive" and r["setting"] == "rtol=1e-07"), None)
    if default:
        print(f"default solver (adaptive DOP853, rtol 1e-7, atol 1e-9): max rel. error {default['rel_error']:.1e} "
              f"(sampled {default['rel_error_sampled']:.1e}, continuous {default['rel_error_continuous']:.1e}), "
              f"{default['seconds_per_eval'] * 1e3:.2f} ms per {horizon:g} s evaluation, "
              f"{default['rhs_evaluations']:.0f} rhs evaluations; status {default['status']}")
    within = [r for r in table if r["orders_failed"] == 0 and r["rel_error"] <= ACCURATE]
    if within:
        fastest = min(within, key=lambda r: r["seconds_per_eval"])
        print(f"fastest setting within {ACCURATE:.0e} on all {len(orders)} orders: {SOLVER_LABELS[fastest['solver']]} "
              f"{fastest['setting']}: {fastest['seconds_per_eval'] * 1e3:.2f} ms, max rel. error "
              f"{fastest['rel_error']:.1e}")
        cheapest = min(within, key=lambda r: r["rhs_evaluations"])
        print(f"cheapest in right-hand-side evaluations within {ACCURATE:.0e} (timings on a shared machine are noisy): "
              f"{SOLVER_LABELS[cheapest['solver']]} {cheapest['setting']}: {cheapest['rhs_evaluations']:.0f} rhs "
              f"evaluations, {cheapest['seconds_per_eval'] * 1e3:.2f} ms, max rel. error {cheapest['rel_error']:.1e}")
    for solver in ("rk4", "semi_implicit_euler"):
        rows = [r for r in table if r["solver"] == solver]
        ok = [r for r in rows if r["orders_failed"] == 0]
        bad = [r for r in rows if r["orders_failed"] > 0]
        if ok:
            print(f"{solver}: largest step that worked on every order {max(r['fixed_step'] for r in ok):g} s; "
                  + ("failures: " + ", ".join(f"{r['setting']} {r['status']} ({r['failed_orders']})" for r in bad)
                     if bad else "no failures"))
    refs = [r for r in table if r["solver"] == "reference_fmu"]
    for r in refs:
        twin = next((t for t in table if t["solver"] == "adaptive" and t["rtol"] == r["rtol"]), None)
        ratio = f", {r['seconds_per_eval'] / twin['seconds_per_eval']:.0f}x the C FMU at the same rtol" if twin else ""
        print(f"reference FMU {r['setting']}: {r['seconds_per_eval']:.2f} s per evaluation{ratio}, "
              f"max rel. error {r['rel_error']:.1e}, status {r['status']}")


if __name__ == "__main__":
    sys.exit(main())
