"""Every search method against a known optimum: success rate, expected running time and final quality.

    python -m bench.known_optima            # about 5 min, 2 workers: the 11 x 8 sweep, 6 methods x 20 seeds x 3 budgets
    python -m bench.known_optima --quick    # about 1.5 min: the 11 x 7 sweep, 6 methods x 5 seeds x 2 budgets
    python -m bench.known_optima --columns 11 --seeds 10    # 84,000 FMU evaluations: several minutes on 2 workers

Why: "several seeds agree" is not evidence that a search finds the optimum; where every design can be
evaluated, a search's success can be counted. The armour scene narrowed to C columns is swept once at the
search fidelity (``orchestrator.exhaustive.ScreenChunk`` with every value kept, through the Evaluator on a
process pool), which gives every design's value; then every method runs through ``orchestrator.loop.run_search``
on that table (a lookup, so a run costs milliseconds and exactly the values the FMU gives), and a run succeeds
when it evaluates the table's optimum. With more columns than a sweep here can afford (``--columns 11``), the
searches run on the FMU itself (the orchestrator's objective at its search fidelity, through a process pool)
against the optimum recorded in ``orchestrator/known_optima.json``. The expected running time (ERT) is COCO's:
evaluations summed over all runs, a successful run counted up to its success, divided by the number of successes.
"""

from __future__ import annotations

import math
import statistics
from dataclasses import dataclass

from orchestrator.design import DesignSpace
from orchestrator.executors import make_executor
from orchestrator.known_optima import known_optima
from orchestrator.loop import Evaluator, run_search
from orchestrator.objective import LatticeObjective, close_instances
from orchestrator.search import make_search
from orchestrator.types import Evaluation, OK, failed

from .common import FULL_HORIZON, lattice_fmu, narrow_lattice, order_text, screened_values
from .measurements import Page, Run, Table, write_page

METHODS = ("cmaes", "pso", "sa", "ga", "de", "random")
MAX_SWEPT = 9  # columns up to which the benchmark sweeps the table itself (9! designs: minutes on 2 cores)
RECORDED = {k.columns: k for k in known_optima() if k.rows == 11 and k.diagonal_rule == "receiver"}
BUDGETS = (100, 300, 1000)


@dataclass(frozen=True)
class Lookup:
    """A design's value from the sweep's table (by lexicographic rank); a design that failed stays failed."""

    space: DesignSpace
    values: tuple[float | None, ...]

    @property
    def key(self) -> str:
        """Its identity for the Evaluator's cache (one table per benchmark run; never its values' repr)."""
        return f"sweep table of {self.space.key}"

    def __call__(self, order) -> Evaluation:
        value = self.values[self.space.rank(order)]
        return failed(order, "failed in the sweep") if value is None else Evaluation(tuple(order), value, OK)


def sweep_values(columns: int, workers: int) -> tuple[DesignSpace, tuple]:
    space = DesignSpace.permutations(columns)
    with narrow_lattice(columns) as (_, fmu):
        return space, screened_values(fmu, space, workers)


def ert(runs: list[dict]) -> float:
    successes = sum(r["success"] for r in runs)
    spent = sum(r["found_at"] if r["success"] else r["evaluations"] for r in runs)
    return spent / successes if successes else math.inf


def search_table(methods, budgets, seeds: int, columns: int, objective, optimum, executor) -> tuple[list, dict]:
    """Per method, a cell per budget: successes, ERT and the median best value; and the successes per method."""
    rows, successes_by_method = [], {}
    for method in methods:
        cells = []
        for budget in budgets:
            runs = []
            for seed in range(seeds):
                result = run_search(
                    make_search(method, columns, seed, budget=budget),
                    objective,
                    budget,
                    Evaluator(executor),
                    method_name=method,
                    seed=seed,
                )
                hit = next((k for k, e in enumerate(result.evaluations, start=1) if e.order == optimum), None)
                runs.append(
                    {
                        "success": hit is not None,
                        "found_at": hit,
                        "evaluations": result.n_evaluations,
                        "best": result.best_value,
                    }
                )
            successes = sum(r["success"] for r in runs)
            successes_by_method.setdefault(method, []).append(successes)
            value = ert(runs)
            cells.append(
                f"{successes}/{len(runs)}, ERT {'inf' if math.isinf(value) else f'{value:.0f}'}, median "
                f"{statistics.median(r['best'] for r in runs):.2f}"
            )
        rows.append((method, *cells))
    return rows, successes_by_method


def main(argv=None) -> int:
    run = Run.start(__file__, argv)
    parser = run.parser(__doc__, quick="11 x 7, 5 seeds, budgets 100 and 300")
    parser.add_argument(
        "--columns",
        type=int,
        default=8,
        help=f"the lattice 11 x C: swept when C <= {MAX_SWEPT}; beyond, the searches run on the FMU "
        "against the optimum orchestrator/known_optima.json records for C",
    )
    parser.add_argument("--methods", nargs="+", default=list(METHODS), choices=METHODS)
    parser.add_argument("--budgets", nargs="+", type=int, default=list(BUDGETS))
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--workers", type=int, default=2, help="worker processes of the sweep (or of the FMU runs)")
    args = parser.parse_args(argv)
    if args.quick:
        args.columns, args.seeds, args.budgets = 7, min(args.seeds, 5), [b for b in args.budgets if b <= 300]
    optimiser_methods = [m for m in args.methods if m != "random"]
    space = DesignSpace.permutations(args.columns)
    if args.columns <= MAX_SWEPT:
        space, values = sweep_values(args.columns, args.workers)
        known = sorted((v, r) for r, v in enumerate(values) if v is not None)
        optimum = space.unrank(known[0][1])
        with make_executor("serial") as executor:
            rows, successes = search_table(
                args.methods, args.budgets, args.seeds, args.columns, Lookup(space, values), optimum, executor
            )
        what = (
            f"swept at the search fidelity: optimum {order_text(optimum)} at {known[0][0]:.6f} N, the second "
            f"best at {known[1][0]:.6f} N ({known[1][0] / known[0][0] - 1:.1e} above)"
        )
    else:
        recorded = RECORDED.get(args.columns)
        if recorded is None:
            parser.error(
                f"--columns {args.columns}: beyond {MAX_SWEPT} a recorded optimum is needed; "
                f"orchestrator/known_optima.json has one for {sorted(RECORDED)}"
            )
        optimum = recorded.order
        with lattice_fmu(None, cols=args.columns) as fmu, make_executor("process", args.workers) as executor:
            objective = LatticeObjective(fmu, space, FULL_HORIZON)
            rows, successes = search_table(
                args.methods, args.budgets, args.seeds, args.columns, objective, optimum, executor
            )
            close_instances()
        what = (
            f"not swept here: the optimum recorded in orchestrator/known_optima.json "
            f"({'certified' if recorded.certified else 'not certified'}), {order_text(optimum)} at "
            f"{recorded.peak:.6f} N over the full horizon; every run simulates on the FMU through a process pool "
            f"of {args.workers}"
        )
    largest = args.budgets[-1]
    everyone = [m for m in optimiser_methods if successes[m][-1] == args.seeds]
    headline = f"11 x {args.columns}: at {largest} designs " + (
        f"every optimiser found the optimum in all {args.seeds} seeds"
        if everyone == optimiser_methods
        else f"{', '.join(everyone) or 'no optimiser'} found the optimum in all {args.seeds} seeds"
    )
    page = Page(
        name=run.name,
        title="Search methods against a known optimum",
        headline=headline,
        summary=(
            f"The armour scene with {args.columns} columns (receiver rule; {space.size:,} designs), {what}. Each "
            f"cell: runs that evaluated the optimum of {args.seeds} seeds (0-{args.seeds - 1}), COCO's expected "
            "running time in evaluations, and the median best value (N, search fidelity)."
        ),
        tables=(Table(("method", *(f"budget {b}" for b in args.budgets)), tuple(rows)),),
    )
    write_page(run, page)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
