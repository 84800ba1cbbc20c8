"""Every search method against a known optimum (issue 11): success rate, ERT and a runtime ECDF.

    python bench/exhaustive_sweep.py --cols 8 --workers 2 --all-peaks      # the table, once
    python bench/known_optima.py --table bench/out/exhaustive_11x8/peaks_11x8.npz --seeds 20 \
        --out bench/out/known_optima_11x8

The objective is a lookup in the exhaustive sweep's table of every order's peak at the search fidelity
(``SampledPeak(...).tasks(SEARCH)`` of ``orchestrator.objective``: the FMU's own values, so no
simulation is needed and a run costs milliseconds).  The optimum is the table's minimum.  For each
method, budget and seed the search runs through the loop (``run_search``) exactly as on the FMU; a run
succeeds when it evaluates the optimum.

Figures (COCO's definitions): success rate = successful runs / runs; ERT = evaluations summed over all
runs, a successful run counted up to the evaluation that found the optimum, an unsuccessful one with all
its evaluations (at most its budget), divided by the number of successful runs (infinite with none);
the runtime ECDF is, per budget, the fraction of runs that found the optimum within k evaluations.
"""
from __future__ import annotations

import argparse
import csv
import json
import math
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

from orchestrator.exhaustive import order_from_rank, rank_of  # noqa: E402
from orchestrator.executors import make_executor  # noqa: E402
from orchestrator.loop import run_search  # noqa: E402
from orchestrator.search import make_search  # noqa: E402
from orchestrator.types import Evaluation, failed  # noqa: E402

METHODS = ("cmaes", "pso", "sa", "ga", "de", "random")
BUDGETS = (100, 300, 1000)


class LookupObjective:
    """An order's peak from an exhaustive sweep's table (by lexicographic rank); NaN is a failure."""

    def __init__(self, table: np.ndarray, columns: int) -> None:
        self.table, self.columns = np.asarray(table, dtype=float), int(columns)
        if len(self.table) != math.factorial(self.columns):
            raise ValueError(f"table has {len(self.table)} entries, not {self.columns}! = "
                             f"{math.factorial(self.columns)}")

    def __call__(self, order) -> Evaluation:
        value = float(self.table[rank_of(order)])
        if math.isnan(value):
            return failed(order, "failed in the exhaustive sweep")
        return Evaluation(tuple(order), value, "ok")


def one_run(args: tuple) -> dict:
    table_path, method, budget, seed = args
    data = np.load(table_path)
    columns = int(data["columns"])
    objective = LookupObjective(data["peaks"], columns)
    optimum = order_from_rank(int(np.nanargmin(data["peaks"])), columns)
    with make_executor("serial") as executor:
        run = run_search(make_search(method, columns, seed, budget=budget), objective, budget, executor,
                         method_name=method, seed=seed)
    hit = next((k for k, e in enumerate(run.evaluations, start=1) if e.order == optimum), None)
    return {"method": method, "budget": budget, "seed": seed, "evaluations": run.n_evaluations,
            "success": hit is not None, "found_at": hit, "best_peak": run.best_peak,
            "best_order": list(run.best_order) if run.best_order else None, "stop_reason": run.stop_reason}


def ert(runs: list[dict]) -> float:
    """COCO's expected running time: all evaluations spent (each run up to its success or budget) per success."""
    successes = sum(r["success"] for r in runs)
    spent = sum(r["found_at"] if r["success"] else min(r["evaluations"], r["budget"]) for r in runs)
    return spent / successes if successes else math.inf


def ecdf_chart(runs: list[dict], methods, budgets, path: Path, title: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(budgets), figsize=(5 * len(budgets), 4), sharey=True)
    for ax, budget in zip(np.atleast_1d(axes), budgets):
        for method in methods:
            mine = [r for r in runs if r["method"] == method and r["budget"] == budget]
            hits = sorted(r["found_at"] for r in mine if r["success"])
            x = np.unique(np.concatenate([[1], hits, [budget]]))
            y = [sum(h <= k for h in hits) / len(mine) for k in x]
            ax.step(x, y, where="post", label=method)
        ax.set_xscale("log")
        ax.set_xlim(10, budget)
        ax.set_xlabel("evaluations")
        ax.set_title(f"budget {budget}")
        ax.grid(True, alpha=0.3)
    np.atleast_1d(axes)[0].set_ylabel("fraction of runs that found the optimum")
    np.atleast_1d(axes)[-1].legend(loc="upper left")
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--table", required=True, help="peaks_11xC.npz from bench/exhaustive_sweep.py --all-peaks")
    parser.add_argument("--methods", nargs="+", default=list(METHODS))
    parser.add_argument("--budgets", nargs="+", type=int, default=list(BUDGETS))
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--workers", type=int, default=2, help="runs in parallel (processes)")
    parser.add_argument("--out", default=None)
    args = parser.parse_args(argv)
    if args.seeds < 1:
        parser.error("--seeds must be at least 1")
    data = np.load(args.table)
    columns, peaks = int(data["columns"]), data["peaks"]
    optimum_rank = int(np.nanargmin(peaks))
    optimum = order_from_rank(optimum_rank, columns)
    ties = int(np.sum(peaks == peaks[optimum_rank]))
    out = Path(args.out or ROOT / "bench" / "out" / f"known_optima_11x{columns}")
    out.mkdir(parents=True, exist_ok=True)
    print(f"11 x {columns}: {len(peaks):,} orders, {int(np.isnan(peaks).sum())} failed; optimum {list(optimum)} "
          f"at {peaks[optimum_rank]:.6f} N (screening fidelity; {ties} order(s) at that value); second best "
          f"{np.sort(peaks[np.isfinite(peaks)])[1]:.6f} N")
    jobs = [(args.table, m, b, s) for m in args.methods for b in args.budgets for s in range(args.seeds)]
    with make_executor("process", args.workers) as executor:
        runs = list(executor.map(one_run, jobs, chunksize=4))
    with open(out / "runs.csv", "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(runs[0]))
        writer.writeheader()
        writer.writerows(runs)
    rows = []
    for method in args.methods:
        for budget in args.budgets:
            mine = [r for r in runs if r["method"] == method and r["budget"] == budget]
            rows.append({"method": method, "budget": budget, "runs": len(mine),
                         "successes": sum(r["success"] for r in mine),
                         "success_rate": sum(r["success"] for r in mine) / len(mine), "ert": ert(mine),
                         "median_best": float(np.median([r["best_peak"] for r in mine]))})
    (out / "summary.json").write_text(json.dumps({"columns": columns, "optimum": list(optimum),
                                                  "optimum_peak": float(peaks[optimum_rank]), "seeds": args.seeds,
                                                  "rows": rows}, indent=1))
    print(f"{'method':8s} {'budget':>6s} {'success':>9s} {'ERT':>9s} {'median best':>12s}")
    for row in rows:
        ert_text = "inf" if math.isinf(row["ert"]) else f"{row['ert']:.0f}"
        print(f"{row['method']:8s} {row['budget']:6d} {row['successes']:4d}/{row['runs']:<4d} {ert_text:>9s} "
              f"{row['median_best']:12.4f}")
    ecdf_chart(runs, args.methods, args.budgets, out / "runtime_ecdf.png",
               f"11 x {columns}: runs that found the optimum ({args.seeds} seeds)")
    print(f"wrote {out}/runs.csv, summary.json, runtime_ecdf.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
