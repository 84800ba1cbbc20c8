"""Fixed cost per run: what an evaluation costs apart from its integration, level by level.

    python -m bench.fixed_cost            # about 1 min: 5 batches of 1000 runs per level
    python -m bench.fixed_cost --quick    # about 20 s: 3 batches of 300

Why: a search evaluation integrates for about a millisecond, so what each run costs around the integration
(fmi2Reset, setting the order and the parameters, initialisation, one doStep, reading the outputs, and the
orchestrator's own bookkeeping) must stay small beside it. The horizon is so short (1 ms simulated) that the
solver takes a step or two. Each batch runs distinct random orders, timed with ``time.process_time``: through
``orchestrator.simulation.LatticeFMU.simulate`` with the outputs an evaluation reads, through the objective's
FMU run (``orchestrator.objective.FMURun``, which makes the Evaluation), and through the Evaluator on a serial
executor (cache, keys, the task protocol). The fastest batch counts.
"""

from __future__ import annotations

import time
from orchestrator.executors import make_executor
from orchestrator.loop import Evaluator
from orchestrator.objective import FMURun, close_instances
from orchestrator.simulation import LatticeFMU

from .common import add_fmu_option, lattice_fmu, random_orders, search_parameters
from .measurements import Page, Run, Table, write_page

HORIZON = 1e-3  # s simulated per run: a step or two


def fastest(batches, run_batch) -> float:
    """CPU seconds per run of the fastest batch."""
    best = float("inf")
    for orders in batches:
        start = time.process_time()
        run_batch(orders)
        best = min(best, (time.process_time() - start) / len(orders))
    return best


def main(argv=None) -> int:
    run = Run.start(__file__, argv)
    parser = run.parser(__doc__, quick="3 batches of 300 runs")
    add_fmu_option(parser)
    parser.add_argument("--runs", type=int, default=1000, help="runs per batch")
    parser.add_argument("--batches", type=int, default=5, help="batches per level (the fastest counts)")
    args = parser.parse_args(argv)
    if args.quick:
        args.runs, args.batches = 300, 3
    with lattice_fmu(args.fmu) as path:
        parameters = search_parameters(path)
        task = FMURun(str(path), HORIZON, tuple(sorted(parameters.items())))
        levels = {}
        with LatticeFMU(path) as fmu:
            first = fmu.simulate(random_orders(1, 0)[0], horizon=HORIZON, parameters=parameters)
            rhs, outputs = first["rhs_evaluations"], len(first.names)

            def direct(orders):
                for order in orders:
                    fmu.simulate(order, horizon=HORIZON, parameters=parameters)

            levels["LatticeFMU.simulate"] = fastest(
                [random_orders(args.runs, seed) for seed in range(args.batches)], direct
            )
        task(random_orders(1, 0)[0])  # opens this process's instance once

        def objective_run(orders):
            for order in orders:
                task(order)

        levels["FMURun (an Evaluation made)"] = fastest(
            [random_orders(args.runs, 100 + seed) for seed in range(args.batches)], objective_run
        )
        with make_executor("serial") as executor:

            def evaluator_run(orders):
                Evaluator(executor).evaluate([(task, order) for order in orders])

            levels["Evaluator, serial executor"] = fastest(
                [random_orders(args.runs, 200 + seed) for seed in range(args.batches)], evaluator_run
            )
        close_instances()
    rows = tuple((level, f"{seconds * 1e3:.4f}") for level, seconds in levels.items())
    page = Page(
        name=run.name,
        title="Fixed cost per run",
        headline=(
            f"{levels['LatticeFMU.simulate'] * 1e3:.3f} ms CPU per FMU run around the integration, "
            f"{levels['Evaluator, serial executor'] * 1e3:.3f} ms through the Evaluator"
        ),
        summary=(
            f"Runs of {HORIZON * 1e3:g} ms of simulated time ({rhs} right-hand sides) with the searches' parameters "
            f"({', '.join(f'{k} {v:g}' if isinstance(v, float) else f'{k} {v}' for k, v in parameters.items())}), "
            f"reading the {outputs} outputs an evaluation reads; the fastest of {args.batches} batches of "
            f"{args.runs} distinct random orders, CPU time per run."
        ),
        tables=(Table(("level", "CPU ms per run"), rows),),
    )
    write_page(run, page)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
