"""Every search method against a known optimum (issue 11): success rate, ERT and a runtime ECDF.

    python bench/exhaustive_sweep.py --cols 8 --workers 2 --all-peaks      # the table, once
    python bench/known_optima.py --table bench/out/exhaustive_11x8/peaks_11x8.npz --seeds 20 \
        --out bench/out/known_optima_11x8
    python build_fmu.py -o /tmp/k11/MassSpringLattice.fmu                   # the FMU mode (11 x 11)
    python bench/known_optima.py --fmu /tmp/k11/MassSpringLattice.fmu --seeds 10 --out bench/out/known_optima_11x11

The objective is a lookup in the exhaustive sweep's table of every order's peak at the search fidelity
(``SampledPeak(...).tasks(SEARCH)`` of ``orchestrator.objective``: the FMU's own values, so no
simulation is needed and a run costs milliseconds).  The optimum is the table's minimum.  For each
method, budget and seed the search runs through the loop (``run_search``) exactly as on the FMU; a run
succeeds when it evaluates the optimum.

Figures (COCO's definitions): success rate = successful runs / runs; ERT = evaluations summed over all
runs, a successful run counted up to the evaluation that found the optimum, an unsuccessful one with all
its evaluations (at most its budget), divided by the number of successful runs (infinite with none);
the runtime ECDF is, per budget, the fraction of runs that found the optimum within k evaluations.

With ``--fmu`` there is no table (11! orders were never swept): each run evaluates on the FMU through
the orchestrator's own path (``SampledPeak(fmu, C, horizon)``, a fresh ``Evaluator`` per run on one process
pool, so runs share no cache), and the target is ``--target-order`` (default the best known 11-column
order): a run succeeds when it evaluates that order.  Each run's best order is also evaluated at full
fidelity (the horizon at the FMU's default accuracy), the value the study's figures are comparable with.
Finished runs are appended to runs.csv as they end; started again with the same --out, the runs already
there are kept, so --seeds can be raised afterwards (the summary is always of seeds 0..N-1).
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
from orchestrator.loop import Evaluator, run_search  # noqa: E402
from orchestrator.objective import FULL, SEARCH, SampledPeak  # noqa: E402
from orchestrator.search import make_search  # noqa: E402
from orchestrator.types import Evaluation, failed  # noqa: E402

METHODS = ("cmaes", "pso", "sa", "ga", "de", "random")
BUDGETS = (100, 300, 1000)
BEST_KNOWN_11 = (1, 10, 9, 6, 4, 5, 7, 8, 3, 2, 11)  # 1405.906 N over 8 s (README, "Results")
FIELDS = ("method", "budget", "seed", "evaluations", "success", "found_at", "best_peak", "best_order",
          "stop_reason")
FMU_FIELDS = FIELDS + ("best_peak_full", "n_censored", "n_failed", "cpu_seconds", "wall_seconds")


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


def one_fmu_run(objective: SampledPeak, executor, method: str, budget: int, seed: int, target: tuple) -> dict:
    """One search on the FMU through the orchestrator's loop, with its own Evaluator (no shared cache)."""
    import time

    cpu, wall = time.process_time(), time.perf_counter()
    run = run_search(make_search(method, objective.n_var, seed, budget=budget), objective, budget,
                     Evaluator(executor), method_name=method, seed=seed)
    hit = next((k for k, e in enumerate(run.evaluations, start=1) if e.order == target), None)
    full = None
    if run.best_order is not None:
        [evaluation] = objective.evaluate([run.best_order], Evaluator(executor), fidelity=FULL)
        full = evaluation.peak if evaluation.ok else None
    return {"method": method, "budget": budget, "seed": seed, "evaluations": run.n_evaluations,
            "success": hit is not None, "found_at": hit, "best_peak": run.best_peak,
            "best_order": list(run.best_order) if run.best_order else None, "stop_reason": run.stop_reason,
            "best_peak_full": full, "n_censored": run.n_censored, "n_failed": run.n_failed,
            "cpu_seconds": round(time.process_time() - cpu, 3), "wall_seconds": round(time.perf_counter() - wall, 3)}


def read_runs(path: Path) -> list[dict]:
    """runs.csv of an earlier (possibly interrupted) FMU-mode run, with its types back."""
    if not path.exists():
        return []
    runs = []
    with open(path, newline="") as handle:
        for row in csv.DictReader(handle):
            number = (lambda v: float(v) if v not in ("", "None") else None)
            runs.append({**row, "budget": int(row["budget"]), "seed": int(row["seed"]),
                         "evaluations": int(row["evaluations"]), "success": row["success"] == "True",
                         "found_at": int(row["found_at"]) if row["found_at"] not in ("", "None") else None,
                         "best_peak": number(row["best_peak"]), "best_peak_full": number(row["best_peak_full"]),
                         "best_order": json.loads(row["best_order"]) if row["best_order"] not in ("", "None")
                         else None})
    return runs


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


def summarise(runs: list[dict], methods, budgets) -> list[dict]:
    rows = []
    for method in methods:
        for budget in budgets:
            mine = [r for r in runs if r["method"] == method and r["budget"] == budget]
            if not mine:
                continue
            row = {"method": method, "budget": budget, "runs": len(mine),
                   "successes": sum(r["success"] for r in mine),
                   "success_rate": sum(r["success"] for r in mine) / len(mine), "ert": ert(mine),
                   "median_best": float(np.median([r["best_peak"] for r in mine if r["best_peak"] is not None]))}
            full = [r["best_peak_full"] for r in mine if r.get("best_peak_full") is not None]
            if full:
                row["median_best_full"] = float(np.median(full))
            rows.append(row)
    return rows


def write_outputs(out: Path, runs: list[dict], methods, budgets, header: dict, title: str) -> None:
    rows = summarise(runs, methods, budgets)
    (out / "summary.json").write_text(json.dumps({**header, "rows": rows}, indent=1))
    has_full = any("median_best_full" in row for row in rows)
    print(f"{'method':8s} {'budget':>6s} {'success':>9s} {'ERT':>9s} {'median best':>12s}"
          + (f" {'(full fid.)':>12s}" if has_full else ""))
    for row in rows:
        ert_text = "inf" if math.isinf(row["ert"]) else f"{row['ert']:.0f}"
        print(f"{row['method']:8s} {row['budget']:6d} {row['successes']:4d}/{row['runs']:<4d} {ert_text:>9s} "
              f"{row['median_best']:12.4f}" + (f" {row.get('median_best_full', math.nan):12.4f}" if has_full else ""))
    ecdf_chart(runs, [m for m in methods if any(r["method"] == m for r in runs)], budgets,
               out / "runtime_ecdf.png", title)
    print(f"wrote {out}/runs.csv, summary.json, runtime_ecdf.png")


def parse_order(text: str) -> tuple:
    try:
        order = tuple(int(v) for v in text.split(","))
    except ValueError:
        order = ()
    if not order or sorted(order) != list(range(1, len(order) + 1)):
        raise argparse.ArgumentTypeError(f"--target-order must be a permutation of 1..C separated by commas, "
                                         f"got {text!r}")
    return order


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    source = parser.add_mutually_exclusive_group(required=True)
    source.add_argument("--table", help="peaks_11xC.npz from bench/exhaustive_sweep.py --all-peaks")
    source.add_argument("--fmu", help="the lattice FMU: run the searches on it against --target-order")
    parser.add_argument("--target-order", type=parse_order, default=BEST_KNOWN_11,
                        help="with --fmu: the order a run must evaluate to succeed (default: the best known "
                             "11-column order, " + ",".join(map(str, BEST_KNOWN_11)) + ")")
    parser.add_argument("--horizon", type=float, default=8.0, help="with --fmu: the full horizon, s")
    parser.add_argument("--methods", nargs="+", default=list(METHODS))
    parser.add_argument("--budgets", nargs="+", type=int, default=list(BUDGETS))
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--workers", type=int, default=2,
                        help="processes: runs in parallel (--table) or evaluations in parallel (--fmu)")
    parser.add_argument("--out", default=None)
    args = parser.parse_args(argv)
    if args.seeds < 1:
        parser.error("--seeds must be at least 1")
    if args.fmu is not None:
        return fmu_main(args)
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
    write_outputs(out, runs, args.methods, args.budgets,
                  {"columns": columns, "optimum": list(optimum), "optimum_peak": float(peaks[optimum_rank]),
                   "seeds": args.seeds}, f"11 x {columns}: runs that found the optimum ({args.seeds} seeds)")
    return 0


def fmu_main(args) -> int:
    """The searches on the FMU itself against a target order (no table): seeds outermost, so an
    interrupted run leaves whole seeds; runs already in --out/runs.csv are kept and not run again."""
    target = tuple(args.target_order)
    columns = len(target)
    if not Path(args.fmu).is_file():
        raise SystemExit(f"--fmu: no such file {args.fmu!r}")
    objective = SampledPeak(args.fmu, columns, args.horizon)
    out = Path(args.out or ROOT / "bench" / "out" / f"known_optima_11x{columns}")
    out.mkdir(parents=True, exist_ok=True)
    runs_path = out / "runs.csv"
    runs = [r for r in read_runs(runs_path) if r["seed"] < args.seeds]  # the summary is of seeds 0..N-1
    done = {(r["method"], r["budget"], r["seed"]) for r in runs}
    with make_executor("process", args.workers) as executor:
        search_value, full_value = (objective.evaluate([target], Evaluator(executor), fidelity=f)[0]
                                    for f in (SEARCH, FULL))
        print(f"11 x {columns} on {args.fmu}: target {list(target)} at {search_value.peak} N (search fidelity), "
              f"{full_value.peak} N (full, {args.horizon} s); {len(runs)} runs from {runs_path}")
        new_file = not runs_path.exists()
        with open(runs_path, "a", newline="") as handle:
            writer = csv.DictWriter(handle, fieldnames=list(FMU_FIELDS))
            if new_file:
                writer.writeheader()
            for seed in range(args.seeds):
                for method in args.methods:
                    for budget in args.budgets:
                        if (method, budget, seed) in done:
                            continue
                        run = one_fmu_run(objective, executor, method, budget, seed, target)
                        writer.writerow(run)
                        handle.flush()
                        runs.append(run)
                        found = f"found at {run['found_at']}" if run["success"] else "not found"
                        print(f"seed {seed} {method:6s} {budget:5d}: {found:14s} best {run['best_peak']} N "
                              f"({run['best_peak_full']} N full) {run['wall_seconds']:.1f} s wall", flush=True)
    beaten = [r for r in runs if r["best_peak_full"] is not None and r["best_peak_full"] < full_value.peak - 1e-6]
    for r in beaten:
        print(f"BETTER than the target: {r['method']} budget {r['budget']} seed {r['seed']}: {r['best_order']} "
              f"at {r['best_peak_full']} N (full fidelity)")
    seeds = sorted({r["seed"] for r in runs})
    write_outputs(out, runs, args.methods, args.budgets,
                  {"columns": columns, "fmu": str(args.fmu), "target": list(target),
                   "target_peak_search": search_value.peak, "target_peak_full": full_value.peak,
                   "horizon": args.horizon, "seeds": seeds, "better_than_target": len(beaten)},
                  f"11 x {columns} on the FMU: runs that evaluated {list(target)} ({len(seeds)} seeds)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
