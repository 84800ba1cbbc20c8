"""Scaling: how an evaluation's cost grows with the lattice, and how a search's throughput grows with workers.

    python -m bench.scaling            # about 5 min: 13 lattices built and timed; 1 and 2 workers
    python -m bench.scaling --quick    # about 2.5 min: 5 lattices; 1 and 2 workers

Why: a user's lattice is not the study's, and a user's machine has more cores. Lattice size: for square
lattices R x R and for 11 rows by C columns the FMU is built (``builder.build.build_fmu``, the study's material
law with C materials) and timed through fmpy (``orchestrator.simulation.LatticeFMU``) on the search evaluation
(the searches' solver, tolerance and horizon) and on the 8 s scene at the FMU's default, for the sequential
order and random ones: CPU time per evaluation (the fastest of the interleaved rounds), right-hand sides (the
FMU's counter) and so microseconds per right-hand side; a least-squares line in log-log gives the growth law
cost ~ N^p over the number of masses N. Workers: random designs evaluated at the search fidelity through the
orchestrator's Evaluator on a process pool of 1 .. W workers, designs per wall second.
"""

from __future__ import annotations

import os
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from builder.build import build_fmu
from orchestrator.design import DesignSpace
from orchestrator.executors import make_executor
from orchestrator.loop import Evaluator
from orchestrator.tasks import EvaluateDesign
from orchestrator.objective import SEARCH, SEARCH_HORIZON, LatticeObjective, close_instances
from orchestrator.simulation import LatticeFMU, SimulationError

from .common import (
    FULL_HORIZON,
    default_setting,
    lattice_fmu,
    random_orders,
    search_parameters,
    search_setting_text,
    setting_text,
)
from .measurements import Page, Run, Table, write_page

SIZES = (5, 8, 11, 14, 20, 25, 31)
QUICK_SIZES = (5, 11, 20)
OUTPUTS = ("peak_backplate_force", "rhs_evaluations", "last_contact_time")


def fit(ns, values) -> float:
    """The exponent p of values ~ a N^p (least squares in log-log)."""
    p, _ = np.polyfit(np.log(ns), np.log(values), 1)
    return float(p)


def lattice_costs(sizes, random_count: int, rounds: int, seed: int) -> tuple[list[dict], dict]:
    shapes = list(dict.fromkeys([(n, n) for n in sizes] + [(11, n) for n in sizes]))
    results: dict[tuple, dict] = {}
    with tempfile.TemporaryDirectory(prefix="bench_scaling_") as folder:
        fmus, orders, settings = {}, {}, {}
        try:
            for rows, cols in shapes:
                path = build_fmu(output=Path(folder) / f"Lattice{rows}x{cols}.fmu", rows=rows, cols=cols)
                fmus[(rows, cols)] = LatticeFMU(path, instance_name=f"scaling{rows}x{cols}")
                orders[(rows, cols)] = [tuple(range(1, cols + 1))] + random_orders(random_count, seed + cols, cols)
                settings[(rows, cols)] = {
                    "search": (SEARCH_HORIZON, search_parameters(path, cols)),
                    "scene": (FULL_HORIZON, {}),
                }
            for _ in range(rounds):
                for shape in shapes:
                    for index, order in enumerate(orders[shape]):
                        for evaluation, (horizon, parameters) in settings[shape].items():
                            entry = results.setdefault((shape, evaluation, index), {"times": []})
                            start = time.process_time()
                            try:
                                entry["result"] = fmus[shape].simulate(
                                    order, horizon=horizon, parameters=parameters, outputs=OUTPUTS
                                )
                            except SimulationError as exc:
                                entry["failure"] = str(exc)
                                continue
                            entry["times"].append(time.process_time() - start)
        finally:
            for fmu in fmus.values():
                fmu.close()
    table = []
    for shape in shapes:
        for evaluation in ("search", "scene"):
            good = [
                e
                for (s, ev, _), e in results.items()
                if s == shape and ev == evaluation and e["times"] and "failure" not in e
            ]
            if not good:
                table.append({"rows": shape[0], "cols": shape[1], "evaluation": evaluation, "failed": True})
                continue
            ms = [min(e["times"]) * 1e3 for e in good]
            rhs = [e["result"]["rhs_evaluations"] for e in good]
            table.append(
                {
                    "rows": shape[0],
                    "cols": shape[1],
                    "masses": shape[0] * shape[1],
                    "evaluation": evaluation,
                    "ms": statistics.median(ms),
                    "ms_range": (min(ms), max(ms)),
                    "rhs": statistics.median(rhs),
                    "us_per_rhs": statistics.median(m * 1e3 / r for m, r in zip(ms, rhs)),
                    "last_contact": max(e["result"]["last_contact_time"] for e in good),
                    "failed": False,
                }
            )
    fits = {}
    for series, members in (("R x R", [(n, n) for n in sizes]), ("11 x C", [(11, n) for n in sizes])):
        for evaluation in ("search", "scene"):
            points = [
                t
                for t in table
                if (t["rows"], t["cols"]) in members and t["evaluation"] == evaluation and not t["failed"]
            ]
            if len(points) >= 2:
                ns = [p["masses"] for p in points]
                fits[(series, evaluation)] = tuple(fit(ns, [p[q] for p in points]) for q in ("ms", "rhs", "us_per_rhs"))
    return table, fits


def worker_throughput(path, worker_counts, designs: int) -> list[tuple[int, float, float]]:
    objective = LatticeObjective(path, DesignSpace.permutations(11), FULL_HORIZON)
    (task,) = objective.tasks(SEARCH)
    out = []
    for workers in worker_counts:
        orders = random_orders(designs, 1000 + workers)
        with make_executor("process", workers) as executor:
            evaluator = Evaluator(executor)
            evaluator.run([EvaluateDesign(task, o) for o in random_orders(2 * workers, 7)])  # each worker opens its FMU
            start = time.perf_counter()
            results = evaluator.run([EvaluateDesign(task, o) for o in orders])
            wall = time.perf_counter() - start
        inside = statistics.mean(e.seconds for e in results if e.ok)
        out.append((workers, designs / wall, inside * 1e3))
    close_instances()
    return out


def main(argv=None) -> int:
    run = Run.start(__file__, argv)
    parser = run.parser(__doc__, quick="sizes 5, 11, 20; 1 random order; 2 rounds; 600 designs")
    parser.add_argument("--fmu", help="the 11 x 11 FMU of the worker measurement (default: built from fmu_src/)")
    parser.add_argument("--sizes", nargs="+", type=int, default=list(SIZES), help="R of R x R and C of 11 x C")
    parser.add_argument("--random-orders", type=int, default=2, help="random orders beside the sequential one")
    parser.add_argument("--rounds", type=int, default=3, help="interleaved timing rounds (the fastest counts)")
    parser.add_argument("--seed", type=int, default=2024, help="seed of the random orders")
    parser.add_argument(
        "--workers",
        nargs="+",
        type=int,
        default=None,
        help=f"worker counts of the throughput measurement (default 1 .. {os.cpu_count()})",
    )
    parser.add_argument("--designs", type=int, default=2000, help="designs per worker count")
    args = parser.parse_args(argv)
    if args.quick:
        args.sizes, args.random_orders, args.rounds, args.designs = list(QUICK_SIZES), 1, 2, min(args.designs, 600)
    worker_counts = args.workers or list(range(1, (os.cpu_count() or 1) + 1))

    table, fits = lattice_costs(args.sizes, args.random_orders, args.rounds, args.seed)
    with lattice_fmu(args.fmu) as path:
        setting = search_setting_text(search_parameters(path))
        default = setting_text(default_setting(path))
        throughput = worker_throughput(path, worker_counts, args.designs)

    size_rows = tuple(
        (f"{t['rows']} x {t['cols']}", t["rows"] * t["cols"], t["evaluation"], "failed", "", "", "", "")
        if t["failed"]
        else (
            f"{t['rows']} x {t['cols']}",
            t["masses"],
            t["evaluation"],
            f"{t['ms']:.2f}",
            f"{t['ms_range'][0]:.2f}-{t['ms_range'][1]:.2f}",
            f"{t['rhs']:.0f}",
            f"{t['us_per_rhs']:.2f}",
            f"{t['last_contact']:.2f}",
        )
        for t in table
    )
    fit_rows = tuple(
        (series, evaluation, f"N^{p:.2f}", f"N^{r:.2f}", f"N^{u:.2f}")
        for (series, evaluation), (p, r, u) in fits.items()
    )
    base = throughput[0][1]
    worker_rows = tuple((w, f"{rate:.0f}", f"{rate / base:.2f}", f"{inside:.2f}") for w, rate, inside in throughput)
    square = fits.get(("R x R", "search"))
    headline = (f"a search evaluation's CPU grows as N^{square[0]:.2f} over square lattices; " if square else "") + (
        f"{throughput[-1][0]} workers evaluate {throughput[-1][1]:.0f} designs per "
        f"second, {throughput[-1][1] / base:.2f}x one worker"
    )
    page = Page(
        name=run.name,
        title="Scaling with the lattice and with workers",
        headline=headline,
        summary=(
            f"Lattice size: square lattices and 11 x C for sizes {', '.join(map(str, args.sizes))}, the sequential "
            f"order and {args.random_orders} random order(s) each, the fastest of {args.rounds} interleaved rounds; "
            f"search: the searches' setting ({setting}); scene: {FULL_HORIZON:g} s at the FMU's default ({default}). "
            "The FMU as it ships (`use_symmetry` 1: under a load along x it leaves out uy and vy, and "
            "with an odd number of rows it integrates the upper half), so odd and even row counts lie on two lines. "
            f"From the size at which the last contact comes after {SEARCH_HORIZON:g} s the searches re-run a design "
            f"over the full horizon. Workers: {args.designs} random designs at the search fidelity through the "
            "Evaluator on a process pool, wall time after each worker opened its FMU; the machine has "
            f"{os.cpu_count()} cores and is shared."
        ),
        tables=(
            Table(
                (
                    "lattice",
                    "masses N",
                    "evaluation",
                    "CPU ms (median)",
                    "range over orders",
                    "right-hand sides",
                    "us per right-hand side",
                    "last contact (s)",
                ),
                size_rows,
                caption="**Cost per evaluation against the lattice:**",
            ),
            Table(
                ("series", "evaluation", "CPU", "right-hand sides", "us per right-hand side"),
                fit_rows,
                caption="**Growth laws** (least squares in log-log over the medians):",
            ),
            Table(
                ("workers", "designs per second", "against 1 worker", "ms per design inside its worker"),
                worker_rows,
                caption="**Search throughput against workers:**",
            ),
        ),
    )
    write_page(run, page)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
