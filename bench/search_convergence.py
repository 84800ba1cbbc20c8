"""Search quality and convergence over seeds: how good each search's answer is at a budget, and how fast it
gets there.

    python -m bench.search_convergence            # about 2 min on 2 workers: 6 methods x 10 seeds x 100 designs
    python -m bench.search_convergence --quick    # about 45 s: 6 methods x 3 seeds x 50 designs

Why: one run of a stochastic search is an anecdote; the claims about the searches (each beats the study's
best within the study's budget, and which to use) are about the spread over seeds. Each method runs through
``orchestrator.loop.run_search`` on the orchestrator's objective (``LatticeObjective`` at its search
fidelity, force limits on) with a fresh Evaluator per run on one process pool, so runs share no cache; each
run's best design is then evaluated at full fidelity (the 8 s scene at the FMU's default accuracy), the value
that is compared with the study's published results.
"""

from __future__ import annotations

import statistics

from fmu_src.published import STUDY_BEST, STUDY_PARTICLE_SWARM, STUDY_SEQUENTIAL, STUDY_SIMULATED_ANNEALING
from orchestrator.design import DesignSpace
from orchestrator.executors import make_executor
from orchestrator.loop import Evaluator, run_search
from orchestrator.objective import FULL, LatticeObjective
from orchestrator.search import make_search

from .common import BEST_KNOWN, FULL_HORIZON, add_fmu_option, lattice_fmu, search_parameters, search_setting_text
from .measurements import Page, Run, Table, write_page

METHODS = ("cmaes", "pso", "sa", "ga", "de", "random")


def quartiles(values: list[float]) -> tuple[float, float, float]:
    if len(values) == 1:
        return values[0], values[0], values[0]
    q = statistics.quantiles(values, n=4, method="inclusive")
    return q[0], statistics.median(values), q[2]


def main(argv=None) -> int:
    run = Run.start(__file__, argv)
    parser = run.parser(__doc__, quick="3 seeds, 50 designs")
    add_fmu_option(parser)
    parser.add_argument("--methods", nargs="+", default=list(METHODS), choices=METHODS)
    parser.add_argument("--seeds", type=int, default=10, help="seeds per method (0 .. N-1)")
    parser.add_argument("--budget", type=int, default=100, help="distinct designs per run")
    parser.add_argument("--workers", type=int, default=2, help="worker processes")
    args = parser.parse_args(argv)
    if args.quick:
        args.seeds, args.budget = min(args.seeds, 3), min(args.budget, 50)
    checkpoints = [k for k in (10, 25, 50, 100, 200, 500, 1000) if k <= args.budget]
    rows, all_bests = [], []
    with lattice_fmu(args.fmu) as path:
        setting = search_setting_text(search_parameters(path))
        objective = LatticeObjective(path, DesignSpace.permutations(11), FULL_HORIZON)
        with make_executor("process", args.workers) as executor:
            for method in args.methods:
                bests, curves, found, walls, reached = [], [], [], [], 0
                for seed in range(args.seeds):
                    result = run_search(
                        make_search(method, 11, seed, budget=args.budget),
                        objective,
                        args.budget,
                        Evaluator(executor),
                        method_name=method,
                        seed=seed,
                    )
                    full = objective.evaluate([result.best_order], Evaluator(executor), FULL)[0]
                    if not full.ok:
                        raise SystemExit(
                            f"{method} seed {seed}: its best design failed at full fidelity: {full.message}"
                        )
                    bests.append(full.value)
                    curves.append(result.best_so_far())
                    found.append(result.best_index)
                    walls.append(result.wall_seconds)
                    reached += any(e.order == BEST_KNOWN for e in result.evaluations)
                    print(
                        f"{method:7s} seed {seed}: {full.value:.3f} N {list(result.best_order)} "
                        f"(found at {result.best_index}, {result.wall_seconds:.2f} s)",
                        flush=True,
                    )
                all_bests += [(value, method) for value in bests]
                q1, median, q3 = quartiles(bests)
                at = [
                    statistics.median(c[k - 1] for c in curves if len(c) >= k and c[k - 1] is not None)
                    for k in checkpoints
                ]
                rows.append(
                    (
                        method,
                        f"{median:.1f}",
                        f"{q1:.1f}-{q3:.1f}",
                        f"{min(bests):.1f}-{max(bests):.1f}",
                        f"{sum(b < STUDY_BEST.peak for b in bests)} of {len(bests)}",
                        f"{sum(b < STUDY_PARTICLE_SWARM.peak for b in bests)} of {len(bests)}",
                        f"{reached} of {len(bests)}",
                        f"{statistics.median(found):.0f}",
                        *(f"{v:.1f}" for v in at),
                        f"{statistics.median(walls):.2f}",
                    )
                )
    optimisers = [(v, m) for v, m in all_bests if m != "random"]
    medians = {row[0]: float(row[1]) for row in rows}
    best_method = min((m for m in medians if m != "random"), key=medians.get, default=None)
    headline = (
        f"at {args.budget} designs every one of the {len(optimisers)} optimiser runs ends below the study's "
        f"best ({STUDY_BEST.peak:.2f} N)"
        if optimisers and all(v < STUDY_BEST.peak for v, _ in optimisers)
        else f"at {args.budget} designs {sum(v < STUDY_BEST.peak for v, _ in optimisers)} of "
        f"{len(optimisers)} optimiser runs end below the study's best ({STUDY_BEST.peak:.2f} N)"
    )
    if best_method:
        headline += f"; the lowest median is {best_method}'s, {medians[best_method]:.1f} N"
    page = Page(
        name=run.name,
        title="Search quality and convergence over seeds",
        headline=headline,
        summary=(
            f"{len(args.methods)} methods x {args.seeds} seeds (0-{args.seeds - 1}) x {args.budget} distinct designs "
            f"on the study's 11 x 11 scene (receiver rule), searching at the search fidelity ({setting}, the full "
            f"{FULL_HORIZON:g} s for a design still touching the plate near its end, force limits on), "
            f"{args.workers} worker process(es). Best: each run's best design at full fidelity. The study "
            f"reported {STUDY_BEST.peak:.2f} N as its best (found at evaluation {STUDY_BEST.evaluation}), "
            f"{STUDY_PARTICLE_SWARM.peak:.2f} N for its particle swarm and {STUDY_SIMULATED_ANNEALING.peak:.2f} N "
            f"for its simulated annealing after about 100 evaluations each; the sequential order gives "
            f"{STUDY_SEQUENTIAL.peak:.2f} N. Best so far: the median over seeds of the best search-fidelity value "
            f"after k evaluations. The best known order is {list(BEST_KNOWN)}."
        ),
        tables=(
            Table(
                (
                    "method",
                    "median best (N)",
                    "quartiles",
                    "range",
                    f"below {STUDY_BEST.peak:.2f} N",
                    f"below {STUDY_PARTICLE_SWARM.peak:.2f} N",
                    "evaluated the best known order",
                    "found at evaluation (median)",
                    *(f"best so far at {k}" for k in checkpoints),
                    "wall s per run (median)",
                ),
                tuple(rows),
            ),
        ),
    )
    write_page(run, page)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
