"""What peak_force_limit saves per search: each method's runs with the force limit (the polishing descent
asks each neighbour with the current value as its limit, the annealing each move with its Metropolis
threshold) against the same runs without it.

    python bench/force_limit_search.py                       # cmaes, pso, sa; 5 seeds; 100 evaluations
    python bench/force_limit_search.py --budget 300 --seeds 10

Per run: the CPU time spent in the FMU (the evaluations' own seconds, summed), the right-hand sides, the
evaluations censored, and the best order and its value (which the limit must not change: a censored
neighbour was going to be rejected anyway). Serial, one core, runs interleaved (with, without) so that
the machine's load hits both alike.
"""
from __future__ import annotations

import argparse
import statistics
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from orchestrator.executors import make_executor  # noqa: E402
from orchestrator.loop import Evaluator, run_search  # noqa: E402
from orchestrator.objective import SampledPeak  # noqa: E402
from orchestrator.search import make_search  # noqa: E402
from orchestrator.study import ensure_fmu  # noqa: E402


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--fmu", default=None)
    parser.add_argument("--methods", nargs="+", default=["cmaes", "pso", "sa"])
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--budget", type=int, default=100)
    args = parser.parse_args(argv)
    fmu = ensure_fmu("armour_11x11", args.fmu)
    variants = {"limit": SampledPeak(fmu, 11, 8.0), "no limit": SampledPeak(fmu, 11, 8.0, use_limits=False)}
    assert variants["limit"].supports_limits, "this FMU has no peak_force_limit"
    print(f"force limit per search: {', '.join(args.methods)} x {args.seeds} seeds x {args.budget} evaluations, "
          "serial", flush=True)
    totals = {name: {"cpu": 0.0, "rhs": 0, "censored": 0, "again": 0} for name in variants}
    same = True
    with make_executor("serial") as executor:
        for method in args.methods:
            per = {name: [] for name in variants}
            per_rhs = {name: [] for name in variants}
            for seed in range(args.seeds):
                runs = {}
                for name, objective in variants.items():
                    run = run_search(make_search(method, 11, seed, budget=args.budget), objective, args.budget,
                                     Evaluator(executor), method_name=method, seed=seed)
                    cpu = sum(e.seconds for e in run.evaluations)
                    rhs = sum(e.details.get("rhs_evaluations") or 0 for e in run.evaluations)
                    per[name].append(cpu)
                    per_rhs[name].append(rhs)
                    totals[name]["cpu"] += cpu
                    totals[name]["rhs"] += rhs
                    totals[name]["censored"] += run.n_censored
                    totals[name]["again"] += run.n_reevaluated
                    runs[name] = run
                agree = runs["limit"].best_order == runs["no limit"].best_order
                same &= agree
                print(f"  {method:6s} seed {seed}: {per['limit'][-1]:.3f} s with the limit "
                      f"({runs['limit'].n_censored} censored, {runs['limit'].n_reevaluated} evaluated again) against {per['no limit'][-1]:.3f} s; best "
                      f"{runs['limit'].best_peak:.3f} / {runs['no limit'].best_peak:.3f} N"
                      + ("" if agree else "  (different best order)"), flush=True)
            ratio = statistics.median(a / b for a, b in zip(per["limit"], per["no limit"]))
            rhs_ratio = sum(per_rhs["limit"]) / sum(per_rhs["no limit"])
            print(f"{method:6s} median FMU time with the limit / without: {ratio:.2f}; right-hand sides "
                  f"{sum(per_rhs['limit']):,} / {sum(per_rhs['no limit']):,} ({rhs_ratio:.2f})", flush=True)
    limit, free = totals["limit"], totals["no limit"]
    print(f"all runs: FMU time {limit['cpu']:.1f} s with the limit against {free['cpu']:.1f} s "
          f"({limit['cpu'] / free['cpu']:.2f}); right-hand sides {limit['rhs']:,} against {free['rhs']:,} "
          f"({limit['rhs'] / free['rhs']:.2f}); {limit['censored']:,} evaluations censored, {limit['again']:,} orders "
          f"evaluated again (censored below a later limit); the same best order "
          f"in every run: {same}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
