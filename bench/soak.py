"""Soak: the FMU's life cycle repeated a million times, with the resident memory sampled along the way.

    python -m bench.soak                                        # the target: 10^6 FMU cycles per configuration
    python -m bench.soak --cycles 200000 --evaluations 10000 --refusals 20000   # shorter, same page
    python -m bench.soak --quick                                # a minute: 20,000 / 1,000 / 2,000
    python -m bench.soak --only dask                            # one row, printed: no page

Why: loops that evaluate an FMU many thousand times are known to leak or crash in the importers users run. A
lattice FMU meant to be evaluated a hundred million times shows here that its life cycle does not grow. One
cycle is what a search evaluation does: reset, set an order, initialise, advance over the horizon, read the
outputs. The lifecycle, not the physics, is what could leak, so the lattice is small (3 x 3) and the horizon
short (1 ms): a cycle is cheap enough for a million of them.

Measured configurations:
- a small C driver (orchestrator/soak_driver.c, compiled here) that loads the FMU's binary itself (dlopen, or
  LoadLibrary under Wine for the Windows DLL) and calls the FMI functions directly: FMI 2 and FMI 3,
  Co-Simulation (one doStep over the horizon) and Model Exchange (the driver steps explicit Euler over the
  horizon: the path through the interface, not the physics); it reports its own resident memory (Linux
  /proc/self/statm, Windows GetProcessMemoryInfo's working set);
- evaluations through the orchestrator's Evaluator (``orchestrator.loop.Evaluator``) on a process pool and on a
  local Dask cluster: the resident memory of this process and all its children;
- cycles through ``LatticeFMU.simulate``, the orchestrator's own FMI 2 Co-Simulation path (fmpy's loader,
  direct calls);
- bad inputs refused by ``LatticeFMU.simulate`` (a material out of range, a repeated material, too few columns,
  a parameter out of range): every one must be refused, and memory must not grow.

Criterion: the resident memory after the warm-up (the first fifth of the cycles) grows by less than 1 MB: the
median of the last quarter of the samples after the warm-up minus the median of the first quarter, so that the
allocator's noise does not count; the least-squares slope is shown beside it.
"""

from __future__ import annotations

import itertools
import os
import shutil
import tempfile
from pathlib import Path

from orchestrator.soak import (
    BATCH,
    COLS,
    HORIZON,
    ME_STEPS,
    ROWS,
    SAMPLES,
    WARM_UP,
    NotRun,
    SoakResult,
    compile_driver,
    evaluator_soak,
    refusal_soak,
    run_driver,
    simulate_soak,
    unpack,
)

from orchestrator.executors import LOCAL_MONITOR_SAMPLES

from .measurements import Page, Run, Table, write_page

PARTS = ("driver", "simulate", "process", "dask", "refusals")  # what --only chooses from

# ---------------------------------------------------------------- the page


def main(argv=None) -> int:
    run = Run.start(__file__, argv)
    parser = run.parser(__doc__, quick="20,000 FMU cycles per configuration, 1,000 evaluations, 2,000 refusals")
    parser.add_argument("--cycles", type=int, default=1_000_000, help="FMU cycles per driver configuration")
    parser.add_argument("--evaluations", type=int, default=100_000, help="evaluations per executor")
    parser.add_argument("--refusals", type=int, default=100_000, help="bad inputs refused")
    parser.add_argument("--workers", type=int, default=2, help="workers of the process pool and the Dask cluster")
    parser.add_argument(
        "--only",
        nargs="+",
        choices=PARTS,
        help="run only these configurations and print their rows, without writing the page (it holds them all): "
        "driver (the C driver's eight), simulate (LatticeFMU.simulate), process and dask (the Evaluator on "
        "each), refusals",
    )
    args = parser.parse_args(argv)
    parts = frozenset(args.only or PARTS)
    if args.quick:
        args.cycles, args.evaluations, args.refusals = 20_000, 1_000, 2_000
    for option in ("cycles", "evaluations", "refusals", "workers"):
        if getattr(args, option) < (1 if option == "workers" else 100):
            parser.error(
                f"--{option}: a whole number >= {1 if option == 'workers' else 100}, got {getattr(args, option)}"
            )

    from builder.build import build_fmu

    results: list[SoakResult | NotRun] = []
    with tempfile.TemporaryDirectory(prefix="bench_soak_") as folder_text:
        folder = Path(folder_text)
        wine = shutil.which("wine") is not None and shutil.which("x86_64-w64-mingw32-gcc") is not None
        wine = wine and "driver" in parts
        platforms = "x86_64-linux,x86_64-windows" if wine else None
        fmus = {
            version: build_fmu(
                output=folder / f"Lattice3x3-fmi{version}.fmu",
                rows=ROWS,
                cols=COLS,
                fmi_version=version,
                platforms=platforms,
                reference_results=False,
            )
            for version in ((2, 3) if "driver" in parts else (2,))
        }
        unpacked = {version: unpack(path, folder / f"fmi{version}") for version, path in fmus.items()}
        environment = dict(os.environ, WINEDEBUG="-all", WINEPREFIX=str(folder / "wine"))
        for windows in (False, True) if "driver" in parts else ():
            driver = compile_driver(folder, windows) if (wine or not windows) else "wine or mingw-w64 not found"
            for version, model_exchange in itertools.product((2, 3), (False, True)):
                name = (
                    f"FMI {version} {'Model Exchange' if model_exchange else 'Co-Simulation'}, "
                    f"{'Windows DLL under Wine' if windows else 'Linux'}"
                )
                if isinstance(driver, str):
                    results.append(NotRun(name, driver))
                    continue
                if windows and version == 2 and not model_exchange:
                    run_driver(driver, unpacked[version], False, True, 100, environment)  # Wine sets up its prefix
                results.append(run_driver(driver, unpacked[version], model_exchange, windows, args.cycles, environment))
                print(results[-1])
        if "simulate" in parts:
            results.append(simulate_soak(fmus[2], args.cycles))
            print(results[-1])
        for kind in ("process", "dask"):
            if kind in parts:
                results.append(evaluator_soak(fmus[2], kind, args.evaluations, args.workers))
                print(results[-1])
        if "refusals" in parts:
            results.append(refusal_soak(fmus[2], args.refusals))
            print(results[-1])

    measured = [r for r in results if isinstance(r, SoakResult)]
    flat = all(r.growth.flat and not r.failures for r in measured)
    rows = tuple(
        (
            r.configuration,
            f"{r.cycles:,}",
            f"{r.per_second:,.0f}",
            f"{r.growth.warm_bytes / 2**20:.1f}",
            f"{r.growth.growth_bytes / 2**10:+.0f}",
            f"{r.growth.slope_bytes_per_million / 2**10:+.0f}",
            str(r.failures),
            "yes" if r.growth.flat and not r.failures else "NO",
        )
        if isinstance(r, SoakResult)
        else (r.configuration, "not run", r.reason, "", "", "", "", "")
        for r in results
    )
    if args.only:
        for row in rows:
            print(" | ".join(row))
        return 0 if flat else 1
    worst = max(measured, key=lambda r: r.growth.growth_bytes)
    page = Page(
        name=run.name,
        title="Soak: a million runs, flat",
        headline=(
            f"{'flat' if flat else 'NOT flat'}: resident growth after warm-up at most "
            f"{worst.growth.growth_bytes / 2**10:+.0f} KB over {args.cycles:,} FMU cycles per configuration "
            f"(criterion < 1 MB); {min(r.per_second for r in measured[:4]):,.0f}-"
            f"{max(r.per_second for r in measured[:4]):,.0f} cycles/s natively"
        ),
        summary=(
            f"Cycles of the FMU's life (reset, set an order, initialise, advance {HORIZON * 1e3:g} ms, read every "
            f"real output) on a {ROWS} x {COLS} lattice: the lifecycle, not the physics, is what could leak, so "
            f"the lattice is small and the horizon short. This run: {args.cycles:,} cycles per driver "
            f"configuration, {args.evaluations:,} evaluations per executor, {args.refusals:,} refused bad inputs "
            f"(the target is 10^6, 10^5 and 10^5: `--cycles 1000000 --evaluations 100000 --refusals 100000`, the "
            f"default). Resident memory sampled {SAMPLES} times along each; growth is the median of the last "
            f"quarter of the samples after the warm-up (the first {WARM_UP:.0%}) minus the median of the first "
            f"quarter; the slope is a least-squares fit over the same samples. Model Exchange cycles take "
            f"{ME_STEPS} explicit Euler steps over the horizon in the driver. Evaluator rows count the memory of "
            f"this process and all its workers, with a fresh Evaluator for each batch of {BATCH} orders "
            f"(so its cache does not answer them); runs per second include the executor's dispatch."
        ),
        tables=(
            Table(
                (
                    "configuration",
                    "cycles",
                    "per second",
                    "resident after warm-up (MB)",
                    "growth (KB)",
                    "slope (KB per 10^6)",
                    "failures",
                    "< 1 MB",
                ),
                rows,
            ),
        ),
        notes=(
            (
                "The driver (orchestrator/soak_driver.c) calls the FMI functions of the binary directly, so no "
                "importer library's own memory is counted; under Wine the working set is Wine's report for the "
                "process."
            ),
            (
                "Failures are FMI calls that returned an error (driver), evaluations that failed (Evaluator), or "
                "bad inputs that were not refused (refusals)."
            ),
            (
                "Dask: each of its processes (the scheduler beside this process's client, each worker) samples its "
                "own CPU, memory, disk and network use twice a second into a history for the dashboard, which Dask "
                "keeps for an hour (7,200 samples a quantity): it grows with time, not with the evaluations, and "
                "was what grew in Python's memory (tracemalloc in the client and in the workers, Python's "
                "allocated blocks and the histories' lengths compared along a soak: nothing else grew by more "
                "than a few KB). A local cluster here serves no dashboard and keeps "
                f"{LOCAL_MONITOR_SAMPLES} samples a quantity (orchestrator.executors.LOCAL_WORKER_CONFIG), so the "
                "history is full within the warm-up. The slope both Evaluator rows keep, the process pool's as "
                "the Dask cluster's, is not in Python's objects and is not explained here."
            ),
        ),
    )
    write_page(run, page)
    return 0 if flat else 1


if __name__ == "__main__":
    raise SystemExit(main())
