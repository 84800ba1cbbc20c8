"""Horizon and fidelity: is a 1 s horizon enough, and which tolerance keeps the ranking of the best orders?

    python bench/horizon_study.py --out bench/out/horizon_study          # 200 random orders + 57 more, ~3 min
    python bench/horizon_study.py --out DIR --quick                     # 40 random orders
    python bench/horizon_study.py --out DIR --orders 1000 --workers 2

Orders: --orders random ones, the sequential order, the study's best, and the 55 single swaps of the
study's best (a neighbourhood: the close competitors a search has to tell apart).

Per order, one run of the C FMU to 8 s at rtol 1e-10 (the truth) is read at 0.5, 0.75, 1, 2 and 8 s (the
FMU's peak outputs are running maxima, so one run gives the peak of every shorter horizon) with
last_contact_time; then one run to 2 s at each tolerance of --rtols (atol = rtol * 1e-2), read at the same
horizons. A sample of orders is also run separately at exactly 1 s and rtol 1e-5 (the searches' objective)
to confirm that reading a long run at 1 s gives what a 1 s run gives.

Writes DIR/horizon_study.csv (one row per order, tolerance and horizon), DIR/horizon_study_summary.csv
(per tolerance and horizon: errors against the truth at 8 s, ranking kept or not), DIR/horizon_study.png,
and prints the conclusion.
"""
from __future__ import annotations

import argparse
import itertools
import math
import statistics
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import (IsolatedFMU, ROOT, SEQUENTIAL, STUDY_BEST, build_fmus, order_text,  # noqa: E402
                    random_orders, write_csv)

from orchestrator.objective import SEARCH_HORIZON, SEARCH_RTOL, search_tolerances  # noqa: E402

HORIZONS = (0.5, 0.75, 1.0, 2.0, 8.0)
TRUTH_RTOL = 1e-10
SEARCH = (SEARCH_HORIZON, SEARCH_RTOL)  # the orchestrator's search horizon and tolerance
DEFAULT_RTOL = 1e-7  # the FMU's default: what the full-scene verification uses
SAME = 1e-9  # relative difference below which two peaks count as the same number
RECORD = ("peak_backplate_force", "peak_backplate_force_continuous", "peak_time", "last_contact_time")


def swaps(order) -> list[tuple[int, ...]]:
    out = []
    for i, j in itertools.combinations(range(len(order)), 2):
        o = list(order)
        o[i], o[j] = o[j], o[i]
        out.append(tuple(o))
    return out


def read_at(result: dict, horizons) -> dict[float, dict]:
    """The recorded outputs at each horizon (communication points every 0.25 s from 0)."""
    trajectory = result["trajectory"]
    out = {}
    for h in horizons:
        i = int(round(h / 0.25))
        assert abs(trajectory.time[i] - h) < 1e-9, (trajectory.time[i], h)
        out[h] = {name: float(trajectory.values[name][i]) for name in RECORD}
    return out


def kendall_tau(a: list[float], b: list[float]) -> float:
    n, s = len(a), 0
    for i in range(n):
        for j in range(i + 1, n):
            s += math.copysign(1, (a[i] - a[j]) * (b[i] - b[j])) if (a[i] - a[j]) * (b[i] - b[j]) != 0 else 0
    return s / (n * (n - 1) / 2)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", default=str(ROOT / "bench" / "out" / "horizon_study"), help="output folder")
    parser.add_argument("--orders", type=int, default=200, help="random orders (besides the 57 fixed ones)")
    parser.add_argument("--seed", type=int, default=7, help="seed of the random orders")
    parser.add_argument("--rtols", type=float, nargs="+", default=[1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8])
    parser.add_argument("--top", type=int, default=10, help="size of the 'best orders' whose ranking must be kept")
    parser.add_argument("--workers", type=int, default=1, help="FMU worker processes (default 1: one core)")
    parser.add_argument("--timeout", type=float, default=60.0, help="seconds before a run counts as hung")
    parser.add_argument("--fmu", help="use this FMU instead of building one from fmu_src/ into DIR/fmus")
    parser.add_argument("--quick", action="store_true", help="40 random orders, 4 tolerances")
    args = parser.parse_args(argv)
    if args.quick:
        args.orders = min(args.orders, 40)
        args.rtols = [r for r in args.rtols if r in (1e-3, 1e-5, 1e-6, 1e-7)] or args.rtols
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    fmu_path = Path(args.fmu) if args.fmu else build_fmus(out)["c"]

    orders: dict[tuple, str] = {}
    for o in random_orders(args.orders, args.seed):
        orders.setdefault(o, "random")
    orders.setdefault(SEQUENTIAL, "sequential")
    orders[STUDY_BEST] = "study_best"
    for o in swaps(STUDY_BEST):
        orders.setdefault(o, "swap_of_study_best")
    order_list = list(orders)
    rtols = sorted(set(args.rtols), reverse=True)
    print(f"horizon study: {len(order_list)} orders ({args.orders} random, the sequential, the study's best and "
          f"its {len(swaps(STUDY_BEST))} swaps) x (truth at rtol {TRUTH_RTOL:g} to 8 s + {len(rtols)} tolerances to "
          f"2 s), {args.workers} worker(s)", flush=True)

    started = time.perf_counter()
    workers = [IsolatedFMU(fmu_path, timeout=args.timeout) for _ in range(max(1, args.workers))]
    rows, failures = [], []

    def study(index_order):
        index, order = index_order
        fmu = workers[index % len(workers)]
        found = []
        for rtol, horizon in [(TRUTH_RTOL, 8.0)] + [(r, 2.0) for r in rtols]:
            # the truth by DOP853 (the FMU's default); the tolerances under study with the searches' solver
            settings = ({**search_tolerances(rtol), "solver": "dop853"} if rtol == TRUTH_RTOL
                        else search_tolerances(rtol))
            status, result, seconds = fmu.run(order, horizon, settings, RECORD,
                                              communication_step=0.25, record=RECORD)
            if status != "ok":
                failures.append({"order": order, "rtol": rtol, "status": status, "message": result})
                continue
            for h, values in read_at(result, [h for h in HORIZONS if h <= horizon]).items():
                found.append({"order": order, "set": orders[order], "rtol": rtol, "horizon": h,
                              "peak_sampled": values["peak_backplate_force"],
                              "peak_continuous": values["peak_backplate_force_continuous"],
                              "peak_time": values["peak_time"], "last_contact_time": values["last_contact_time"],
                              "run_seconds": seconds, "run_horizon": horizon})
        return found

    try:
        with ThreadPoolExecutor(len(workers)) as pool:
            for k, found in enumerate(pool.map(study, list(enumerate(order_list))), start=1):
                rows += found
                if k % 25 == 0 or k == len(order_list):
                    print(f"  {k}/{len(order_list)} orders, {time.perf_counter() - started:.0f} s", flush=True)
        # does a run read at 1 s equal a run that stops at 1 s? (the searches' own setting)
        direct = []
        horizon, rtol = SEARCH
        for order in order_list[:: max(1, len(order_list) // 12)]:
            status, result, _ = workers[0].run(order, horizon, search_tolerances(rtol), RECORD)
            if status == "ok":
                direct.append((order, result))
    finally:
        for fmu in workers:
            fmu.close()

    write_csv(out / "horizon_study.csv", rows,
              ["order", "set", "rtol", "horizon", "peak_sampled", "peak_continuous", "peak_time",
               "last_contact_time", "run_seconds", "run_horizon"])
    if failures:
        write_csv(out / "horizon_study_failures.csv", failures)
    summary, conclusion = analyse(rows, rtols, order_list, orders, args.top, direct, failures)
    write_csv(out / "horizon_study_summary.csv", summary)
    plot(rows, summary, rtols, out / "horizon_study.png", len(order_list))
    print()
    print("\n".join(conclusion))
    print(f"wrote {out / 'horizon_study.csv'}, {out / 'horizon_study_summary.csv'}, {out / 'horizon_study.png'} in "
          f"{time.perf_counter() - started:.0f} s")
    return 0


def analyse(rows, rtols, order_list, orders, top, direct, failures):
    table = {(r["order"], r["rtol"], r["horizon"]): r for r in rows}
    truth = {o: table[(o, TRUTH_RTOL, 8.0)] for o in order_list if (o, TRUTH_RTOL, 8.0) in table}
    complete = [o for o in order_list if o in truth]
    rel = lambda a, b: abs(a / b - 1) if b else abs(a - b)  # noqa: E731
    summary, lines = [], []

    # 1. horizons, at the truth's tolerance
    contact = [truth[o]["last_contact_time"] for o in complete]
    peak_times = [truth[o]["peak_time"] for o in complete]
    latest = max(complete, key=lambda o: truth[o]["last_contact_time"])
    lines.append(f"HORIZON ({len(complete)} orders, rtol {TRUTH_RTOL:g}): the continuous peak comes at "
                 f"{min(peak_times):.3f}-{max(peak_times):.3f} s; the last contact with the plate ends at "
                 f"{min(contact):.3f}-{max(contact):.3f} s (median {statistics.median(contact):.3f} s; latest: "
                 f"{order_text(latest)} ({orders[latest]}) at {truth[latest]['last_contact_time']:.3f} s)")
    for h in HORIZONS[:-1]:
        diffs_s = [rel(table[(o, TRUTH_RTOL, h)]["peak_sampled"], truth[o]["peak_sampled"]) for o in complete]
        diffs_c = [rel(table[(o, TRUTH_RTOL, h)]["peak_continuous"], truth[o]["peak_continuous"]) for o in complete]
        differ = sum(1 for a, b in zip(diffs_s, diffs_c) if max(a, b) > SAME)
        guard = sum(1 for o in complete if table[(o, TRUTH_RTOL, h)]["last_contact_time"] >= 0.9 * h)
        summary.append({"kind": "horizon", "rtol": TRUTH_RTOL, "horizon": h, "orders": len(complete),
                        "orders_differing_from_8s": differ, "max_rel_diff_sampled": max(diffs_s),
                        "max_rel_diff_continuous": max(diffs_c), "orders_in_contact_in_last_10pct": guard})
        lines.append(f"  {h:4g} s: the peak differs from the 8 s peak (> {SAME:g}) for {differ} of {len(complete)} "
                     f"orders (max rel. diff sampled {max(diffs_s):.1e}, continuous {max(diffs_c):.1e}); "
                     f"{guard} would trigger the 8 s fallback (contact in the last 10%)")

    # 2. tolerances: the 1 s peak at each tolerance against the truth at 8 s; the ranking of the best orders
    def ranking(values: dict) -> list:
        return sorted(values, key=lambda o: values[o])

    groups = {"random": [o for o in complete if orders[o] in ("random", "sequential", "study_best")],
              "neighbourhood": [o for o in complete if orders[o] in ("study_best", "swap_of_study_best")]}
    true_peak = {o: truth[o]["peak_sampled"] for o in complete}
    gaps = {}
    for name, members in groups.items():
        best = ranking({o: true_peak[o] for o in members})[:top]
        gaps[name] = min(rel(true_peak[b], true_peak[a]) for a, b in zip(best, best[1:])) if len(best) > 1 else math.nan
    lines.append(f"TOLERANCE (the 1 s, sampled peak at each rtol against the truth at 8 s; 'top {top}' = the best "
                 f"{top} orders by the truth; smallest relative gap between neighbours in the top {top}: random "
                 f"set {gaps['random']:.1e}, study-best neighbourhood {gaps['neighbourhood']:.1e})")
    kept_all = {}
    for rtol in rtols:
        at = {o: table.get((o, rtol, SEARCH[0])) for o in complete}
        have = [o for o in complete if at[o] is not None]
        err_s = [rel(at[o]["peak_sampled"], truth[o]["peak_sampled"]) for o in have]
        err_c = [rel(at[o]["peak_continuous"], truth[o]["peak_continuous"]) for o in have]
        seconds = statistics.mean(at[o]["run_seconds"] for o in have) if have else math.nan
        row = {"kind": "tolerance", "rtol": rtol, "horizon": SEARCH[0], "orders": len(have),
               "max_rel_err_sampled": max(err_s, default=math.nan),
               "median_rel_err_sampled": statistics.median(err_s) if err_s else math.nan,
               "max_rel_err_continuous": max(err_c, default=math.nan),
               "seconds_per_2s_run": seconds}
        kept = True
        for name, members in groups.items():
            members = [o for o in members if at.get(o) is not None]
            by_truth = ranking({o: true_peak[o] for o in members})
            by_tol = ranking({o: at[o]["peak_sampled"] for o in members})
            same_top = by_truth[:top] == by_tol[:top]
            row[f"top{top}_kept_{name}"] = same_top
            row[f"kendall_tau_{name}"] = kendall_tau([true_peak[o] for o in members],
                                                      [at[o]["peak_sampled"] for o in members])
            row[f"best_kept_{name}"] = by_truth[:1] == by_tol[:1]
            kept = kept and same_top
        kept_all[rtol] = kept
        summary.append(row)
        lines.append(f"  rtol {rtol:7.0e}: max rel. error {row['max_rel_err_sampled']:.1e} sampled, "
                     f"{row['max_rel_err_continuous']:.1e} continuous; top {top} ranking kept: random set "
                     f"{row[f'top{top}_kept_random']}, neighbourhood {row[f'top{top}_kept_neighbourhood']} "
                     f"(Kendall tau {row['kendall_tau_random']:.4f} / {row['kendall_tau_neighbourhood']:.4f}); "
                     f"{seconds * 1e3:.1f} ms per 2 s run")
    loosest = None
    for rtol in rtols:  # loosest first: the loosest such that it and every tighter one keep the ranking
        if all(kept_all[r] for r in rtols if r <= rtol):
            loosest = rtol
            break
    if direct:
        key = lambda o: (o, SEARCH[1], SEARCH[0])  # noqa: E731
        worst = max(max(rel(r["peak_backplate_force"], table[key(o)]["peak_sampled"]),
                        rel(r["peak_backplate_force_continuous"], table[key(o)]["peak_continuous"]))
                    for o, r in direct if key(o) in table)
        lines.append(f"a run stopped at {SEARCH[0]:g} s (rtol {SEARCH[1]:g}) against the 2 s run read at 1 s: "
                     f"max rel. diff {worst:.1e} over {len(direct)} orders")
    if failures:
        lines.append(f"FAILED runs: {len(failures)} (see horizon_study_failures.csv): "
                     + "; ".join(f"{order_text(f['order'])} rtol {f['rtol']:g}: {f['status']}" for f in failures[:5]))

    one_s = next(s for s in summary if s["kind"] == "horizon" and s["horizon"] == 1.0)
    search_row = next((s for s in summary if s["kind"] == "tolerance" and s["rtol"] == SEARCH[1]), None)
    lines.append("CONCLUSION")
    lines.append(f"  1 s horizon: {'the same peak as 8 s for every order' if one_s['orders_differing_from_8s'] == 0 else 'DIFFERS from 8 s for ' + str(one_s['orders_differing_from_8s']) + ' orders'} "
                 f"(max rel. diff {max(one_s['max_rel_diff_sampled'], one_s['max_rel_diff_continuous']):.1e}); "
                 f"the latest contact ends at {max(contact):.3f} s")
    lines.append(f"  loosest tolerance that keeps the top-{top} ranking (random set and the neighbourhood, and every "
                 f"tighter one does too): {'none of those tried' if loosest is None else f'rtol {loosest:g}'}")
    smallest_gap = min(g for g in gaps.values() if not math.isnan(g))
    safe = [s["rtol"] for s in summary if s["kind"] == "tolerance"
            and max(s["max_rel_err_sampled"], s["max_rel_err_continuous"]) < smallest_gap / 10]
    lines.append(f"  loosest tolerance whose error is below a tenth of the smallest top-{top} gap ({smallest_gap:.1e}), "
                 f"so that the ranking is kept by accuracy and not by errors that happen to be alike: "
                 f"{'none' if not safe else f'rtol {max(safe):g}'}")
    if search_row:
        lines.append(f"  the searches' setting ({SEARCH[0]:g} s, rtol {SEARCH[1]:g}): max rel. error "
                     f"{search_row['max_rel_err_sampled']:.1e} against the 8 s truth; ranking kept: {kept_all.get(SEARCH[1])}")
    return summary, lines


def plot(rows, summary, rtols, path: Path, n_orders: int) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    fig, axes = plt.subplots(1, 3, figsize=(17, 5.6))
    truth = [r for r in rows if r["rtol"] == TRUTH_RTOL and r["horizon"] == 8.0]
    ax = axes[0]
    ax.hist([r["last_contact_time"] for r in truth], bins=30, color="tab:blue", alpha=0.7, label="last contact ends")
    ax.hist([r["peak_time"] for r in truth], bins=30, color="tab:red", alpha=0.6, label="continuous peak")
    for h in HORIZONS[:-1]:
        ax.axvline(h, color="black", ls=":", lw=1)
        ax.text(h, ax.get_ylim()[1] * 0.95, f" {h:g} s", fontsize=8, va="top")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("orders")
    ax.set_title(f"When the peak comes and contact ends ({n_orders} orders, 8 s runs)")
    ax.legend(fontsize=8)

    ax = axes[1]
    rows_h = [x for x in summary if x["kind"] == "horizon"]
    positions = np.arange(len(rows_h))
    differ = [x["orders_differing_from_8s"] for x in rows_h]
    touching = [x["orders_in_contact_in_last_10pct"] for x in rows_h]
    ax.bar(positions - 0.2, differ, 0.4, color="tab:red", label=f"peak differs from the 8 s peak (> {SAME:g})")
    ax.bar(positions + 0.2, touching, 0.4, color="tab:blue",
           label="still touching the plate in the last 10% (the search fidelity re-runs these over 8 s)")
    for x, row in zip(positions, rows_h):
        worst = max(row["max_rel_diff_sampled"], row["max_rel_diff_continuous"])
        ax.text(x - 0.2, 0.5, f"max diff\n{worst:.0e}", ha="center", va="bottom", fontsize=7, rotation=90)
    ax.set_xticks(positions, [f"{x['horizon']:g} s" for x in rows_h])
    ax.set_ylim(0, n_orders * 1.15)
    ax.set_ylabel(f"orders (of {n_orders})")
    ax.set_title(f"Shorter horizons against 8 s (rtol {TRUTH_RTOL:g})")
    ax.legend(fontsize=8, loc="upper right")

    ax = axes[2]
    tol = [s for s in summary if s["kind"] == "tolerance"]
    x = [s["rtol"] for s in tol]
    ax.plot(x, [s["max_rel_err_sampled"] for s in tol], "o-", label="max error, sampled peak")
    ax.plot(x, [s["median_rel_err_sampled"] for s in tol], "s--", label="median error, sampled peak")
    ax.plot(x, [s["max_rel_err_continuous"] for s in tol], "^-", label="max error, continuous peak")
    for s in tol:
        kept = all(v for k, v in s.items() if k.startswith("top") and k.endswith(("random", "neighbourhood")))
        ax.annotate("ranking kept" if kept else "ranking CHANGED", (s["rtol"], s["max_rel_err_sampled"]),
                    fontsize=7, rotation=30, xytext=(4, 4), textcoords="offset points",
                    color="darkgreen" if kept else "darkred")
    ax.plot(x, x, color="grey", lw=0.8, ls=":", label="error = rtol")
    ax.axvline(SEARCH[1], color="tab:purple", lw=1, ls="--", label=f"searches' rtol ({SEARCH[1]:g})")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.invert_xaxis()
    ax.set_xlabel("rtol (atol = rtol * 1e-2)")
    ax.set_ylabel("relative error of the 1 s peak against the 8 s truth")
    ax.set_title("Tolerance: error and ranking of the best orders")
    ax.legend(fontsize=8, loc="lower left")
    for a in axes[1:]:
        a.grid(True, which="both", alpha=0.25)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    sys.exit(main())
