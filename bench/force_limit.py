"""What the force limit (the FMU's ``peak_force_limit``) saves: per run, and per search.

    python -m bench.force_limit            # about 1.5 min: 40 orders x 5 passes; 3 searches x 3 seeds x 100 designs
    python -m bench.force_limit --quick    # about 40 s: 20 orders x 2 passes; 3 searches x 1 seed x 60 designs

Why: a search only needs to know that a design is worse than a threshold it already has (the descent's current
value, the annealing's Metropolis threshold, the exhaustive sweep's incumbent), so the FMU may stop such a run
as soon as its sampled peak passes the threshold. Per run: random orders over the search evaluation (the
searches' solver, tolerance and horizon), with the limit at the best known order's own peak at that fidelity
against no limit, the two interleaved pass by pass so that the machine's load hits both alike; CPU time per pass
through ``orchestrator.simulation.LatticeFMU`` (the fastest pass) and right-hand sides; every run that stays
below the limit must give the same peak bit for bit. Per search: each method's runs through
``orchestrator.loop.run_search`` on the orchestrator's objective with and without limits (the same seeds, a
fresh Evaluator per run), their CPU time, the evaluations censored and whether the best design is the same.
"""

from __future__ import annotations

import statistics
import time

from orchestrator.design import DesignSpace
from orchestrator.executors import make_executor
from orchestrator.loop import Evaluator, run_search
from orchestrator.objective import SEARCH, SEARCH_HORIZON, LatticeObjective, close_instances
from orchestrator.search import make_search
from orchestrator.simulation import LatticeFMU

from .common import (
    BEST_KNOWN,
    FULL_HORIZON,
    SEQUENTIAL,
    add_fmu_option,
    lattice_fmu,
    random_orders,
    search_parameters,
    search_setting_text,
    span,
)
from .measurements import Page, Run, Table, write_page

OUTPUTS = ("peak_backplate_force", "rhs_evaluations")
METHODS = ("cmaes", "pso", "sa")


def one_pass(fmu: LatticeFMU, orders, parameters, limit) -> tuple[float, list[dict]]:
    start = time.process_time()
    results = [
        fmu.simulate(order, horizon=SEARCH_HORIZON, parameters=parameters, outputs=OUTPUTS, peak_force_limit=limit)
        for order in orders
    ]
    return time.process_time() - start, results


def per_run(path, orders, passes: int):
    parameters = search_parameters(path)
    with LatticeFMU(path) as fmu:
        limit = fmu.simulate(BEST_KNOWN, horizon=SEARCH_HORIZON, parameters=parameters, outputs=OUTPUTS)[
            "peak_backplate_force"
        ]
        one_pass(fmu, orders[:3], parameters, None)  # warm caches before timing
        free_times, limited_times = [], []
        for _ in range(passes):
            seconds, free = one_pass(fmu, orders, parameters, None)
            free_times.append(seconds)
            seconds, limited = one_pass(fmu, orders, parameters, limit)
            limited_times.append(seconds)
    censored = [r for r in limited if r.stopped_early]
    below = [(f, r) for f, r in zip(free, limited) if not r.stopped_early]
    if any(f["peak_backplate_force"] != r["peak_backplate_force"] for f, r in below):
        raise SystemExit("a run below the limit did not give the same peak bit for bit as without the limit")
    if any(f["peak_backplate_force"] <= limit for f, r in zip(free, limited) if r.stopped_early):
        raise SystemExit("a run was stopped although its peak stays below the limit")
    return {
        "parameters": parameters,
        "limit": limit,
        "free_ms": min(free_times) * 1e3 / len(orders),
        "limited_ms": min(limited_times) * 1e3 / len(orders),
        "free_rhs": sum(r["rhs_evaluations"] for r in free) / len(orders),
        "limited_rhs": sum(r["rhs_evaluations"] for r in limited) / len(orders),
        "censored": len(censored),
        "below": len(below),
        "stopped": [r.stop_time for r in censored],
    }


def per_search(path, methods, seeds: int, budget: int):
    space = DesignSpace.permutations(11)
    variants = {
        "with": LatticeObjective(path, space, FULL_HORIZON),
        "without": LatticeObjective(path, space, FULL_HORIZON, use_limits=False),
    }
    rows, ratios, same = [], [], True
    variants["with"].tasks(SEARCH)[0](SEQUENTIAL)  # this process opens the FMU before anything is timed
    with make_executor("serial") as executor:
        for method in methods:
            cpu = {name: [] for name in variants}
            censored = reevaluated = 0
            agree = 0
            for seed in range(seeds):
                bests = {}
                for name, objective in variants.items():
                    start = time.process_time()
                    result = run_search(
                        make_search(method, 11, seed, budget=budget),
                        objective,
                        budget,
                        Evaluator(executor),
                        method_name=method,
                        seed=seed,
                    )
                    cpu[name].append(time.process_time() - start)
                    bests[name] = result.best_order
                    if name == "with":
                        censored += result.censored
                        reevaluated += result.reevaluated
                agree += bests["with"] == bests["without"]
            same &= agree == seeds
            ratio = statistics.median(a / b for a, b in zip(cpu["with"], cpu["without"]))
            ratios.append(ratio)
            rows.append(
                (
                    method,
                    seeds,
                    budget,
                    f"{statistics.median(cpu['with']):.2f}",
                    f"{statistics.median(cpu['without']):.2f}",
                    f"{ratio:.2f}",
                    f"{censored} of {seeds * budget}",
                    reevaluated,
                    f"{agree} of {seeds}",
                )
            )
    close_instances()
    return rows, ratios, same


def main(argv=None) -> int:
    run = Run.start(__file__, argv)
    parser = run.parser(__doc__, quick="20 orders x 2 passes; 1 seed of 60 designs")
    add_fmu_option(parser)
    parser.add_argument("--orders", type=int, default=40, help="random orders of the per-run measurement")
    parser.add_argument("--seed", type=int, default=12, help="seed of the random orders")
    parser.add_argument("--passes", type=int, default=5, help="interleaved passes with and without the limit")
    parser.add_argument("--methods", nargs="+", default=list(METHODS), help="searches of the per-search measurement")
    parser.add_argument("--seeds", type=int, default=3, help="seeds per search")
    parser.add_argument("--budget", type=int, default=100, help="designs per search run")
    args = parser.parse_args(argv)
    if args.quick:
        args.orders, args.passes, args.seeds, args.budget = min(args.orders, 20), 2, 1, min(args.budget, 60)
    with lattice_fmu(args.fmu) as path:
        runs = per_run(path, random_orders(args.orders, args.seed), args.passes)
        search_rows, ratios, same = per_search(path, args.methods, args.seeds, args.budget)
    stopped = runs["stopped"]
    run_rows = (
        ("without the limit", f"{runs['free_ms']:.3f}", f"{runs['free_rhs']:.0f}", ""),
        (
            f"limit {runs['limit']:.3f} N",
            f"{runs['limited_ms']:.3f}",
            f"{runs['limited_rhs']:.0f}",
            f"{runs['censored']} of {args.orders}"
            + (f", stopped at {min(stopped):.2f}-{max(stopped):.2f} s" if stopped else ""),
        ),
    )
    saving = runs["free_ms"] / runs["limited_ms"]
    page = Page(
        name=run.name,
        title="What the force limit saves",
        headline=(
            f"with the limit at the best known peak a random design's run costs 1/{saving:.1f} of its CPU "
            f"time; a search with limits {span(ratios)} of its CPU time without them"
            + (", the same best design in every run" if same else ", NOT always the same best design")
        ),
        summary=(
            f"Per run: {args.orders} random orders (seed {args.seed}) over the search evaluation "
            f"({search_setting_text(runs['parameters'])}), the limit at the peak of the best known order "
            f"{list(BEST_KNOWN)} at that fidelity; CPU ms per order of the fastest of {args.passes} interleaved "
            f"passes, right-hand sides per order. "
            + (
                f"The {runs['below']} orders that stay below the limit gave the same peak bit for bit as without it "
                "(checked). "
                if runs["below"]
                else "No order stays below the limit. "
            )
            + "Per search: CPU seconds of a whole search run through "
            "`run_search` on a serial executor (median over seeds), with the orchestrator's objective with limits "
            "(the descent asks each neighbour with the current value, the annealing each move with its "
            "Metropolis threshold) and without."
        ),
        tables=(
            Table(
                ("run", "CPU ms per order", "right-hand sides per order", "censored"), run_rows, caption="**Per run:**"
            ),
            Table(
                (
                    "search",
                    "seeds",
                    "budget",
                    "CPU s with limits",
                    "CPU s without",
                    "ratio (median)",
                    "evaluations censored",
                    "designs evaluated again",
                    "same best design",
                ),
                tuple(search_rows),
                caption="**Per search:**",
            ),
        ),
    )
    write_page(run, page)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
