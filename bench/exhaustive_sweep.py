"""Every order of an 11 x C lattice (issue 11): screened at the search fidelity, verified at full fidelity.

    python bench/exhaustive_sweep.py --cols 8 --workers 2 --all-peaks --out bench/out/exhaustive_11x8
    python bench/exhaustive_sweep.py --cols 8 --workers 2 --out bench/out/exhaustive_11x8_kill --kill-after 30 \
        --expect tests/data/known_optimum_11x8.json

The FMU is built with ``build_fmu.py --cols C`` into OUT (or taken from --fmu).  Screening uses the
searches' fidelity (``SampledPeak(...).tasks(SEARCH)`` of ``orchestrator.objective``: 1 s horizon, rtol
1e-5, the full 8 s for an order still touching the plate near 1 s); every order within
``--screening-error`` (relative) of the best
and every screening failure is re-evaluated over the full 8 s at the FMU's default accuracy.

``--kill-after S`` runs the sweep as a child in its own process group, SIGKILLs the whole group after S
seconds (client and pool workers), then runs it again with the same checkpoint and prints what came from
the checkpoint; with ``--expect FILE`` (a known-optimum JSON) it checks the optimum found against it.
On a Dask cluster (workers started with ``--nthreads 1`` where the project is installed and the FMU is at
the same path), the 11-column sweep:

    python bench/exhaustive_sweep.py --cols 11 --executor dask --scheduler tcp://HOST:8786 --confirm-exhaustive \
        --chunk-size 20160 --fmu /shared/MassSpringLattice.fmu --out /shared/exhaustive_11x11

``--all-peaks`` also writes every order's screened peak by lexicographic rank to OUT/peaks_11xC.npz
(the lookup table of bench/known_optima.py).
"""
from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

from orchestrator.exhaustive import peak_table, run_exhaustive  # noqa: E402
from orchestrator.executors import make_executor  # noqa: E402
from orchestrator.objective import FULL, SEARCH, SEARCH_HORIZON, SEARCH_RTOL, SampledPeak  # noqa: E402

FULL_HORIZON = 8.0
# rtol 1e-5 at 1 s erred by at most 2.7e-5 (relative) over 257 orders (bench/horizon_study.py); the bound used
# to pick the orders to verify is four times that, and the sweep reports the largest error it then sees.
SCREENING_ERROR = 1e-4
# the FMU's default accuracy (rtol 1e-7) erred by at most 1.8e-7 over 5 orders (bench/work_precision.py).
FULL_ERROR = 1e-6


def build(cols: int, out: Path) -> Path:
    path = out / f"lattice_11x{cols}.fmu"
    if not path.exists():
        subprocess.run([sys.executable, str(ROOT / "build_fmu.py"), "--cols", str(cols), "-o", str(path)],
                       check=True, stdout=subprocess.DEVNULL)
    return path


def sweep(args, fmu: Path) -> dict:
    objective = SampledPeak(fmu, args.cols, FULL_HORIZON)
    (screening,), (full,) = objective.tasks(SEARCH), objective.tasks(FULL)  # one FMU run per order each
    with_limit = screening.with_limit if objective.supports_limits else None  # the FMU's peak_force_limit
    scene = {"scene": "armour_11x11", "cols": args.cols, "search_horizon": SEARCH_HORIZON,
             "search_rtol": SEARCH_RTOL}
    last = [time.perf_counter()]

    def progress(done, total):
        if time.perf_counter() - last[0] > 10 or done == total:
            last[0] = time.perf_counter()
            print(f"  {done}/{total} chunks", file=sys.stderr, flush=True)

    with make_executor(args.executor, args.workers, args.scheduler) as executor:
        return run_exhaustive(screening, args.cols, executor, args.checkpoint, args.chunk_size,
                              full_objective=full, screening_error=args.screening_error, full_error=FULL_ERROR,
                              scene=scene, executor_kind=args.executor, confirm=args.confirm_exhaustive,
                              all_peaks=args.all_peaks, progress=progress,
                              objective_with_limit=None if args.all_peaks else with_limit)


def summary(result: dict, workers: int) -> list[str]:
    optimum = result["optimum"]
    wall = result["screening_seconds"]
    lines = [
        f"orders {result['orders']:,} in {result['chunks']} chunks of {result['chunk_size']}; "
        f"from checkpoint {result['from_checkpoint']}; chunks rerun {result['chunks_rerun']}; "
        f"failed {result['failed']}",
        f"screening: {wall:.1f} s wall on {workers} workers; {result['cpu_seconds']:.1f} CPU s in the workers "
        f"over all chunks: {result['orders_per_core_second']:.0f} orders per core-second; per-chunk overhead "
        f"inside the worker {result['chunk_overhead_seconds'] * 1e3:.1f} ms",
        f"screened best {result['screened_best']['order']} at {result['screened_best']['peak']:.6f} N; "
        f"{len(result['candidates'])} orders within {result['screening_error']:g} of it "
        f"(threshold {result['screening_threshold']:.6f} N)",
        f"full fidelity ({FULL_HORIZON:g} s, default accuracy): {result['full_fidelity_checks']} checks; largest "
        f"screening error seen {result['max_screening_error_seen']:.2e} (bound held: "
        f"{result['screening_bound_held']})",
    ]
    if optimum:
        lines.append(f"optimum {optimum['order']} at {optimum['peak']:.6f} N (+- {optimum['tolerance']:.1e} N); "
                     f"runner-up {optimum['runner_up_peak']} N; distinct: {optimum['distinct_from_runner_up']}")
    lines.append(f"total {result['seconds']:.1f} s")
    return lines


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cols", type=int, default=8)
    parser.add_argument("--fmu", help="an 11 x COLS FMU (default: built into OUT)")
    parser.add_argument("--out", default=None, help="default bench/out/exhaustive_11xCOLS")
    parser.add_argument("--checkpoint", default=None, help="default OUT/checkpoint")
    parser.add_argument("--chunk-size", type=int, default=1008)
    parser.add_argument("--executor", choices=["serial", "process", "dask"], default="process")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--scheduler", default=None, help="a Dask scheduler's address (tcp://HOST:8786)")
    parser.add_argument("--screening-error", type=float, default=SCREENING_ERROR)
    parser.add_argument("--confirm-exhaustive", action="store_true",
                        help="confirm a sweep beyond the local limit (dask)")
    parser.add_argument("--all-peaks", action="store_true", help="keep every peak and write OUT/peaks_11xC.npz")
    parser.add_argument("--kill-after", type=float, default=None)
    parser.add_argument("--expect", default=None, help="a known-optimum JSON to compare the optimum with")
    args = parser.parse_args(argv)
    out = Path(args.out or ROOT / "bench" / "out" / f"exhaustive_11x{args.cols}")
    out.mkdir(parents=True, exist_ok=True)
    args.checkpoint = args.checkpoint or str(out / "checkpoint")
    fmu = Path(args.fmu) if args.fmu else build(args.cols, out)

    if args.kill_after is not None:
        child_args = [a for a in (argv if argv is not None else sys.argv[1:])]
        k = child_args.index("--kill-after")
        del child_args[k:k + 2]
        child = subprocess.Popen([sys.executable, __file__, *child_args, "--fmu", str(fmu)], start_new_session=True)
        time.sleep(args.kill_after)
        if child.poll() is None:
            os.killpg(child.pid, signal.SIGKILL)
            child.wait()
            print(f"killed the sweep's process group (SIGKILL) after {args.kill_after:g} s: "
                  f"{len(list(Path(args.checkpoint).glob('chunk_*.json')))} chunks checkpointed", flush=True)
        else:
            print(f"the sweep finished before {args.kill_after:g} s: nothing to kill", flush=True)

    try:
        result = sweep(args, fmu)
    except ValueError as exc:  # a refused sweep: one line
        print(exc, file=sys.stderr)
        return 2
    lines = summary(result, args.workers)
    print("\n".join(lines))
    (out / "result.json").write_text(json.dumps(result, indent=1))
    if args.all_peaks:
        table = peak_table(args.checkpoint, args.cols)
        fingerprint = json.loads((Path(args.checkpoint) / "fingerprint.json").read_text())
        np.savez_compressed(out / f"peaks_11x{args.cols}.npz", peaks=table, columns=args.cols,
                            fmu_sha256=fingerprint["fmu_sha256"])
        print(f"wrote {out / f'peaks_11x{args.cols}.npz'} ({np.isfinite(table).sum()} peaks)")
    if args.expect:
        expected = json.loads(Path(args.expect).read_text())
        same = result["optimum"] and result["optimum"]["order"] == expected["order"]
        print(f"optimum {'EQUALS' if same else 'DIFFERS FROM'} {args.expect}: {expected['order']}; "
              f"from_checkpoint {result['from_checkpoint']}")
        return 0 if same else 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
