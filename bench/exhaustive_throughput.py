"""Orders per core-second of the exhaustive sweep's chunk task, without and with the force limit.

    python bench/exhaustive_throughput.py --cols 9 11 --incumbent 9=1493.546 11=1405.906

For each lattice (built with ``build_fmu.py --cols C``), one chunk of ``--orders`` orders from the middle
of the ranks runs through ``orchestrator.exhaustive.evaluate_chunk`` at the searches' fidelity, in this
process, ``--repeats`` times; the best CPU-time rate is printed (the machine is shared: CPU time, best of
repeats).  With an incumbent (a peak the sweep has already found, e.g. the 11 x 9 best of a partial sweep
or the best known 11-column order), the chunk runs as in a sweep that has it: every order is simulated
with ``peak_force_limit`` at the incumbent's screening threshold and stops once its peak passes it.
"""
from __future__ import annotations

import argparse
import math
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from orchestrator.exhaustive import evaluate_chunk, screening_threshold  # noqa: E402
from orchestrator.objective import SEARCH, SampledPeak  # noqa: E402

SCREENING_ERROR = 1e-4


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cols", nargs="+", type=int, default=[9, 11])
    parser.add_argument("--incumbent", nargs="*", default=[], help="COLS=PEAK pairs")
    parser.add_argument("--orders", type=int, default=600)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args(argv)
    incumbents = {int(k): float(v) for k, v in (item.split("=") for item in args.incumbent)}
    with tempfile.TemporaryDirectory() as folder:
        for cols in args.cols:
            fmu = Path(folder) / f"lattice_11x{cols}.fmu"
            subprocess.run([sys.executable, str(ROOT / "build_fmu.py"), "--cols", str(cols), "-o", str(fmu)],
                           check=True, stdout=subprocess.DEVNULL)
            task = SampledPeak(fmu, cols, 8.0).tasks(SEARCH)[0]
            start = math.factorial(cols) // 2
            limits = [None] + ([screening_threshold(incumbents[cols], SCREENING_ERROR)] if cols in incumbents else [])
            for limit in limits:
                rates, chunk = [], None
                for _ in range(args.repeats):
                    chunk = evaluate_chunk(task, cols, start, start + args.orders, screening_error=SCREENING_ERROR,
                                           objective_with_limit=task.with_limit if limit else None, limit=limit)
                    rates.append(chunk["orders"] / chunk["cpu_seconds"])
                what = "no limit" if limit is None else f"limit {limit:.3f} N"
                print(f"11 x {cols}, {what}: {max(rates):.0f} orders per core-second (best of {args.repeats} x "
                      f"{args.orders}); censored {chunk['n_censored']}, failed {chunk['n_failed']}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
