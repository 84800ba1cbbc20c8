"""The orchestrator's targets (issue 3): search quality at 100 and 2000 evaluations, and throughput.

    python bench/search_targets.py --quality 100 --seeds 5       # median best of each search over 5 seeds
    python bench/search_targets.py --quality 2000 --seeds 3      # does every seed find the best known order?
    python bench/search_targets.py --throughput 100 100000       # seconds for N evaluations on all cores

Searches use the study's search objective (orchestrator.objective.SampledPeak at its search fidelity: 1 s horizon, rtol 1e-5,
sampled peak, 8 s for an order still touching the plate near 1 s); every best order is then
re-evaluated over the full 8 s scene at the FMU's default accuracy, which is the number printed.
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from orchestrator.executors import make_executor  # noqa: E402
from orchestrator.loop import Evaluator, run_search  # noqa: E402
from orchestrator.objective import SampledPeak  # noqa: E402
from orchestrator.search import make_search  # noqa: E402
from orchestrator.study import ensure_fmu, final_descent, verify  # noqa: E402

SEARCHES = ("cmaes", "pso", "sa")


def objective_of(fmu: Path) -> SampledPeak:
    """The study's objective: searches at its search fidelity (1 s, rtol 1e-5), results at full (8 s)."""
    return SampledPeak(fmu, 11, 8.0)


def quality(fmu: Path, budget: int, seeds: int, executor_kind: str, workers: int | None) -> None:
    objective = objective_of(fmu)
    bests = {}
    with make_executor(executor_kind, workers) as executor:
        for method in SEARCHES:
            values = []
            for seed in range(seeds):
                # a fresh evaluator (no cache shared between seeds): each run pays for its own evaluations
                run = run_search(make_search(method, 11, seed, budget=budget), objective, budget, Evaluator(executor),
                                 method_name=method, seed=seed)
                checked = verify(objective, Evaluator(executor), [run.best_order])[run.best_order]
                values.append((checked.peak, run.best_order, run.best_index, run.wall_seconds))
                print(f"{method:6s} seed {seed}: {checked.peak:9.3f} N  {list(run.best_order)}  found at "
                      f"evaluation {run.best_index}, {run.wall_seconds:.1f} s", flush=True)
            median = statistics.median(v[0] for v in values)
            bests[method] = values
            print(f"{method:6s} median best over {seeds} seeds at {budget} evaluations: {median:.3f} N", flush=True)
        best_value, best_order = min((v[0], v[1]) for values in bests.values() for v in values)
        print(f"\nbest order found: {list(best_order)} at {best_value:.4f} N (8 s, sampled, default accuracy)")
        # is it a local optimum? (single swaps and insertions, on the search objective, confirmed on 8 s)
        evaluator = Evaluator(executor)
        start = verify(objective, evaluator, [best_order])
        local = final_descent(objective, evaluator, start[best_order], start)
        final = min((v for v in start.values() if v.ok), key=lambda v: v.peak)
        print(f"after the local descent: {list(final.order)} at {final.peak:.4f} N; locally optimal: "
              f"{local['locally_optimal']} ({local['swaps_checked']} swaps, {local['insertions_checked']} insertions)")
        for method, values in bests.items():
            hits = sum(1 for v in values if v[1] == final.order)
            print(f"{method:6s} found that order in {hits} of {len(values)} seeds")


def throughput(fmu: Path, counts: list[int], executor_kind: str, workers: int | None) -> None:
    objective = objective_of(fmu)
    for count in counts:
        with make_executor(executor_kind, workers) as executor:
            start = time.perf_counter()
            run = run_search(make_search("random", 11, 0, batch=64), objective, count, executor,
                             method_name="random", seed=0)
            seconds = time.perf_counter() - start
        where = ("1 core (serial)" if executor_kind == "serial"
                 else f"{workers or os.cpu_count()} {executor_kind} workers")
        good = [e for e in run.evaluations if e.ok]
        inside = sum(e.seconds for e in good) / max(len(good), 1)
        fallbacks = sum(1 for e in good if e.details["horizon"] > objective.search_horizon)
        print(f"{run.n_evaluations} evaluations ({run.n_failed} failed) on {where}: "
              f"{seconds:.1f} s, {seconds / run.n_evaluations * 1e3:.2f} ms per evaluation (each {inside * 1e3:.2f} ms "
              f"inside its worker; {fallbacks} fell back to the full horizon)", flush=True)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--fmu", default=None)
    parser.add_argument("--quality", type=int, default=None, help="budget per search run")
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--throughput", type=int, nargs="*", default=None, help="evaluation counts to time")
    parser.add_argument("--executor", default="process")
    parser.add_argument("--workers", type=int, default=None)
    args = parser.parse_args(argv)
    fmu = ensure_fmu("armour_11x11", args.fmu)
    if args.quality:
        quality(fmu, args.quality, args.seeds, args.executor, args.workers)
    if args.throughput:
        throughput(fmu, args.throughput, args.executor, args.workers)
    if not args.quality and not args.throughput:
        parser.error("give --quality BUDGET and/or --throughput N [N ...]")
    return 0


if __name__ == "__main__":
    sys.exit(main())
