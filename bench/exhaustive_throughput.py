"""Exhaustive throughput: designs per core-second of the sweep's chunks, and of whole sweeps started with and
without a short search's incumbent.

    python -m bench.exhaustive_throughput           # 2 workers: chunks of 11 x 8, 9, 11; 11 x 8 sweeps; the frontier
    python -m bench.exhaustive_throughput --quick   # chunks of 11 x 8; two 11 x 7 sweeps; the frontier's chunks smaller

Why: what an exhaustive sweep costs decides whether it runs here or on a cluster (the orchestrator refuses one
beyond its local limit with the projected core-hours), and the force limit is what makes it affordable: a
chunk simulates each design with ``peak_force_limit`` at the screening threshold of the best value known, so
a design worse than that stops early. Chunks: one chunk of designs from the middle of the ranks
(``orchestrator.exhaustive.ScreenChunk`` through the Evaluator, in this process) with no limit at all, with
no incumbent (the chunk lowers its limit as its own best improves, as a sweep's first chunks do) and with the
limit at the threshold of the known optimum's own search-fidelity value, CPU time inside the chunk. Sweeps:
the orchestrator's exhaustive step (``run_in_folder`` with the searches, the sweep, the verification of
finalists and the answers) on the armour scene narrowed to C columns, once alone (the first chunks run without
an incumbent) and once after a short annealing run that hands the sweep its best value.
"""

from __future__ import annotations

import math
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

from orchestrator.design import DesignSpace
from orchestrator.executors import make_executor
from orchestrator.exhaustive import ChunkResult, ScreenChunk, screening_threshold
from orchestrator.known_optima import known_optima
from orchestrator.loop import Evaluator, run_search
from orchestrator.objective import SEARCH, LatticeObjective, close_instances
from orchestrator.search import make_search
from orchestrator.runner import RunConfig, run_in_folder
from orchestrator.steps import Answers, Exhaustive, Finalists, Searches
from orchestrator.steps.exhaustive import SCREENING_ERROR
from orchestrator.steps.searches import SearchesConfig
from orchestrator.study import CaseConfig

from .common import (
    FULL_HORIZON,
    TWELVE_MATERIALS_TEXT,
    WithoutLimit,
    lattice_fmu,
    narrow_lattice,
    order_text,
    twelve_column_lattice,
)
from .measurements import Page, Run, Table, write_page

KNOWN = {k.columns: k.order for k in known_optima() if k.diagonal_rule == "receiver" and k.rows == 11}
PLATE_SCENE = "plate_11x11x11"
JOB_CORES = 32  # cores per SLURM job in the frontier's commands (one single-threaded Dask worker each)


@dataclass(frozen=True)
class Frontier:
    """A space beyond a sweep here, priced: its chunk's rate with the force limit at a short search's best."""

    label: str
    options: str  # run.py's options that select the case
    designs: int
    incumbent: float  # the annealing run's best, at the search fidelity
    threshold: float
    chunk: ChunkResult  # the fastest of the repeats

    @property
    def rate(self) -> float:
        return self.chunk.designs / self.chunk.cpu_seconds

    @property
    def core_hours(self) -> float:
        return self.designs / self.rate / 3600


def frontier(label: str, options: str, fmu, columns: int, budget: int, designs: int, repeats: int, workers: int):
    """The incumbent of an annealing run of ``budget`` designs (receiver rule), then a chunk of ``designs`` from
    the middle rank timed with the limit at its threshold (the fastest of ``repeats``, CPU time in the chunk)."""
    space = DesignSpace.permutations(columns)
    objective = LatticeObjective(str(fmu), space, FULL_HORIZON, parameters={"diagonal_rule": "receiver"})
    with make_executor("process", workers) as executor:
        searched = run_search(
            make_search("sa", space, 1, budget=budget), objective, budget, Evaluator(executor), method_name="sa", seed=1
        )
    close_instances()
    incumbent = searched.best_value
    if incumbent is None:
        raise SystemExit(f"{label}: the annealing run found no design with a value")
    (screening,) = objective.tasks(SEARCH)
    limit = screening_threshold(incumbent, SCREENING_ERROR)
    start = space.size // 2
    with make_executor("serial") as executor:
        Evaluator(executor).evaluate([(screening, space.unrank(start))])  # this process opens the FMU first
        fastest = fastest_chunk(executor, screening, space, start, designs, limit, repeats, label)
    close_instances()
    return Frontier(label, options, space.size, incumbent, limit, fastest)


def fastest_chunk(executor, function, space, start: int, designs: int, limit, repeats: int, label: str):
    """The fastest (least CPU) of ``repeats`` runs of one chunk of ``designs`` from rank ``start``."""
    fastest = None
    for _ in range(repeats):
        chunk = Evaluator(executor).run(
            [ScreenChunk(function, space, start, start + designs, 20, SCREENING_ERROR, limit)]
        )[0]
        if not chunk.ok:
            raise SystemExit(f"{label}: the chunk failed: {chunk.message}")
        if fastest is None or chunk.cpu_seconds < fastest.cpu_seconds:
            fastest = chunk
    assert fastest is not None
    return fastest


def clock(hours: float) -> str:
    """HH:MM:SS, rounded up to the minute."""
    minutes = max(1, math.ceil(hours * 60))
    return f"{minutes // 60:02d}:{minutes % 60:02d}:00"


def slurm_command(priced: Frontier, cores: int) -> str:
    """The command that sweeps ``priced`` on ``cores`` cores of a SLURM cluster: jobs of JOB_CORES cores, each
    job's walltime the expected wall time plus a quarter (a job that ends is replaced; nothing is lost)."""
    jobs = max(1, cores // JOB_CORES)
    walltime = clock(1.25 * priced.core_hours / (jobs * JOB_CORES))
    return (
        f"python orchestrator/run.py {priced.options} --method exhaustive --diagonal-rule receiver --executor dask "
        f"--cluster slurm --jobs {jobs} --job-cores {JOB_CORES} --walltime {walltime} --confirm-cost"
    )


def chunk_rates(columns: int, designs: int, repeats: int) -> dict:
    """Designs per core-second of one chunk, without and with the limit at the known optimum's threshold."""
    with narrow_lattice(columns) as (_, fmu):
        space = DesignSpace.permutations(columns)
        (screening,) = LatticeObjective(fmu, space, FULL_HORIZON).tasks(SEARCH)
        incumbent = screening(KNOWN[columns]).value
        limit = screening_threshold(incumbent, SCREENING_ERROR)
        start = space.size // 2
        with make_executor("serial") as executor:
            Evaluator(executor).evaluate([(screening, KNOWN[columns])])  # this process opens the FMU first
            out = {"incumbent": incumbent, "threshold": limit}
            variants = (
                ("no limit", WithoutLimit(screening), None),
                ("no incumbent", screening, None),
                ("limit", screening, limit),
            )
            for name, function, chunk_limit in variants:
                out[name] = fastest_chunk(
                    executor, function, space, start, designs, chunk_limit, repeats, f"11 x {columns}"
                )
        close_instances()
    return out


def sweep(scene: Path, fmu: Path, folder: Path, methods: tuple[str, ...], budget: int, workers: int):
    started = time.perf_counter()
    outcome = run_in_folder(
        RunConfig(out=str(folder), workers=workers, progress=False),
        CaseConfig(scene=str(scene), fmu=str(fmu), diagonal_rules=("receiver",)),
        {Searches: SearchesConfig(methods=methods, budget=budget, repeats=1)},
        (Searches, Exhaustive, Finalists, Answers),
    )
    wall = time.perf_counter() - started
    return outcome.study.result(Exhaustive).sweeps[0], wall


def main(argv=None) -> int:
    run = Run.start(__file__, argv)
    parser = run.parser(__doc__, quick="chunks of 11 x 8 only (300 designs, once); 11 x 7 swept")
    parser.add_argument(
        "--chunk-columns",
        nargs="+",
        type=int,
        default=[8, 9, 11],
        choices=sorted(KNOWN),
        help="lattices 11 x C whose chunk is timed (those with a known optimum)",
    )
    parser.add_argument("--chunk-designs", type=int, default=600, help="designs in the timed chunk")
    parser.add_argument("--repeats", type=int, default=3, help="timed runs of each chunk (the fastest counts)")
    parser.add_argument("--sweep-columns", type=int, default=8, help="the lattice 11 x C swept twice")
    parser.add_argument("--search-budget", type=int, default=100, help="designs of the short search before a sweep")
    parser.add_argument("--workers", type=int, default=2, help="worker processes of the sweeps")
    parser.add_argument(
        "--frontier-budget", type=int, default=500, help="designs of the annealing run giving the frontier's incumbent"
    )
    parser.add_argument(
        "--cluster-cores", default="256,1024", help="cores of the SLURM clusters the frontier is priced on, comma list"
    )
    args = parser.parse_args(argv)
    if args.quick:
        args.chunk_columns, args.chunk_designs, args.repeats, args.sweep_columns = [8], 300, 1, 7
        args.frontier_budget = 100
    try:
        cluster_cores = tuple(int(c) for c in args.cluster_cores.split(","))
    except ValueError:
        parser.error(f"--cluster-cores: a comma list of whole numbers >= {JOB_CORES}, got {args.cluster_cores!r}")
    if min(cluster_cores) < JOB_CORES or args.frontier_budget < 10:
        parser.error(f"--cluster-cores: each >= {JOB_CORES}; --frontier-budget >= 10")

    chunk_rows, rates = [], {}
    for columns in args.chunk_columns:
        measured = chunk_rates(columns, args.chunk_designs, args.repeats)
        for name, what in (
            ("no limit", "none: every design to its value"),
            ("no incumbent", "from the chunk's own best on"),
            ("limit", f"the incumbent's threshold, {measured['threshold']:.3f} N"),
        ):
            chunk = measured[name]
            rate = chunk.designs / chunk.cpu_seconds
            rates[(columns, name)] = rate
            chunk_rows.append(
                (
                    f"11 x {columns}",
                    f"{math.factorial(columns):,}",
                    what,
                    f"{rate:.0f}",
                    f"{chunk.censored} of {chunk.designs}",
                )
            )
    with narrow_lattice(args.sweep_columns) as (scene, fmu), tempfile.TemporaryDirectory(prefix="bench_sweep_") as out:
        alone, alone_wall = sweep(scene, fmu, Path(out) / "alone", ("exhaustive",), args.search_budget, args.workers)
        searched, searched_wall = sweep(
            scene, fmu, Path(out) / "searched", ("exhaustive", "sa"), args.search_budget, args.workers
        )
    priced = []
    with twelve_column_lattice() as fmu:
        priced.append(
            frontier(
                "11 x 12 lattice, 12 materials",
                "--materials twelve_materials.csv --cols 12",
                fmu,
                12,
                args.frontier_budget,
                args.chunk_designs,
                args.repeats,
                args.workers,
            )
        )
    with lattice_fmu(scene=PLATE_SCENE) as fmu:
        priced.append(
            frontier(
                "11 x 11 x 11 plate",
                f"--scene {PLATE_SCENE}",
                fmu,
                11,
                args.frontier_budget,
                args.chunk_designs // 4,
                args.repeats,
                args.workers,
            )
        )
    frontier_rows = tuple(
        (
            p.label,
            f"{p.designs:,}",
            f"{p.incumbent:.3f} N",
            f"{p.rate:.0f}",
            f"{p.chunk.censored} of {p.chunk.designs}",
            f"{p.core_hours:.1f}",
            *(f"{p.core_hours / cores * 60:.0f} min" for cores in cluster_cores),
        )
        for p in priced
    )
    command_rows = tuple(
        (p.label, f"{cores:,}", f"{p.core_hours / cores * 60:.0f} min", f"`{slurm_command(p, cores)}`")
        for p in priced
        for cores in cluster_cores
    )
    sweep_rows = []
    for label, result, wall in (
        ("alone", alone, alone_wall),
        (f"after an annealing run of {args.search_budget} designs", searched, searched_wall),
    ):
        certificate = result.certificate
        optimum = certificate.optimum
        sweep_rows.append(
            (
                label,
                "none" if result.initial_limit is None else f"{result.initial_limit:.3f} N",
                f"{certificate.designs:,}",
                f"{certificate.censored:,}",
                f"{result.designs_per_core_second:.0f}",
                f"{result.cpu_seconds:.1f}",
                f"{wall:.0f}",
                f"{order_text(optimum.order)} {optimum.full:.6f} N" if optimum else "none",
                "yes" if certificate.certified else "no: " + "; ".join(certificate.reasons),
            )
        )
    same = (
        alone.certificate.optimum
        and searched.certificate.optimum
        and alone.certificate.optimum.order == searched.certificate.optimum.order
    )
    notes = []
    if (11, "limit") in rates:
        hours = math.factorial(11) / rates[(11, "limit")] / 3600
        free_hours = math.factorial(11) / rates[(11, "no limit")] / 3600
        notes.append(
            f"At the 11 x 11 chunk rates, a sweep of all {math.factorial(11):,} orders costs about "
            f"{hours:.1f} core-hours with the limit ({free_hours:.1f} without): {hours / 16:.2f} hours on 16 "
            f"cores, {hours * 60 / 100:.0f} minutes on 100."
        )
    notes.append(f"Both sweeps found the same optimum: {'yes' if same else 'NO'}.")
    first = args.chunk_columns[0]
    headline = (
        f"11 x {first} chunk: {rates[(first, 'no limit')]:.0f} designs per core-second without the limit, "
        f"{rates[(first, 'limit')]:.0f} with it; an 11 x {args.sweep_columns} sweep "
        f"{alone.designs_per_core_second:.0f} alone, {searched.designs_per_core_second:.0f} after a short "
        "search"
    )
    page = Page(
        name=run.name,
        title="Exhaustive sweep throughput",
        headline=headline,
        summary=(
            f"Screening at the search fidelity; the screening error bound is {SCREENING_ERROR:.0e} (relative), and the "
            "limit is the largest screened value that can still be the optimum given the incumbent "
            "(`screening_threshold`). Chunks: "
            f"{args.chunk_designs} designs from the middle rank, the fastest of {args.repeats} run(s), CPU time "
            "inside the chunk; the incumbent is the known optimum's value at the search fidelity. Sweeps: "
            f"11 x {args.sweep_columns}, receiver rule, {args.workers} worker process(es), designs per core-second "
            "over the chunks' CPU time, wall time of the whole run (the sweep, the verification of every candidate "
            "at full fidelity, the second integrator on the optimum and runner-up, the report)."
        ),
        tables=(
            Table(
                ("lattice", "designs of the lattice", "limit", "designs per core-second", "censored"),
                tuple(chunk_rows),
                caption="**One chunk:**",
            ),
            Table(
                (
                    "sweep",
                    "first chunks' limit",
                    "designs",
                    "censored",
                    "designs per core-second",
                    "CPU s",
                    "wall s",
                    "optimum (full fidelity)",
                    "certified",
                ),
                tuple(sweep_rows),
                caption="**A whole sweep, with and without a short search's incumbent:**",
            ),
            Table(
                (
                    "space",
                    "designs",
                    "incumbent (search fidelity)",
                    "designs per core-second, limit at its threshold",
                    "censored",
                    "projected core-hours",
                    *(f"wall on {cores:,} cores" for cores in cluster_cores),
                ),
                frontier_rows,
                caption=(
                    f"**The frontier, priced** (receiver rule; incumbent: the best of an annealing run of "
                    f"{args.frontier_budget} designs; the chunk: {args.chunk_designs} designs of the 12-column "
                    f"lattice, {args.chunk_designs // 4} of the plate, from the middle rank, the fastest of "
                    f"{args.repeats} run(s); wall time: core-hours over the cores, the sweep's verification and "
                    "the jobs' queue not counted):"
                ),
            ),
            Table(
                ("space", "cores", "expected wall time", "command"),
                command_rows,
                caption=(
                    f"**On a SLURM cluster** (jobs of {JOB_CORES} cores; each job's walltime a quarter above the "
                    "expected wall time: a job that ends is replaced, nothing is lost or simulated twice; "
                    f"twelve_materials.csv: {TWELVE_MATERIALS_TEXT}):"
                ),
            ),
        ),
        notes=tuple(notes),
    )
    write_page(run, page)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
