"""The exhaustive sweep's cost per chunk on each executor, with an objective that costs microseconds.

    python bench/exhaustive_overhead.py --table bench/out/exhaustive_11x8/peaks_11x8.npz --workers 2

The objective looks each order up in an exhaustive sweep's peak table (bench/known_optima.py), so the
chunks' own work is tiny and what the wall time shows is the executor's cost per chunk (submit, pickling,
scheduling, the result's transfer) plus the client's (checkpoint writes).  Per-chunk overhead =
(wall seconds x workers - the chunks' own seconds) / chunks; the machine is shared, so it is an upper bound.
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

import numpy as np  # noqa: E402

from known_optima import LookupObjective  # noqa: E402
from orchestrator.exhaustive import read_chunk, run_exhaustive  # noqa: E402
from orchestrator.executors import make_executor  # noqa: E402


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--table", required=True)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--chunk-sizes", nargs="+", type=int, default=[1008, 4032])
    parser.add_argument("--executors", nargs="+", default=["process", "dask"])
    args = parser.parse_args(argv)
    data = np.load(args.table)
    columns = int(data["columns"])
    objective = LookupObjective(data["peaks"], columns)
    for kind in args.executors:
        with make_executor(kind, args.workers) as executor:
            for chunk_size in args.chunk_sizes:
                with tempfile.TemporaryDirectory() as folder:
                    start = time.perf_counter()
                    result = run_exhaustive(objective, columns, executor, folder, chunk_size, screening_error=0.0,
                                            executor_kind=kind, in_flight=2 * args.workers)
                    wall = time.perf_counter() - start
                    own = sum(read_chunk(p)["seconds"] for p in Path(folder).glob("chunk_*.json"))
                overhead = (wall * args.workers - own) / result["chunks"]
                print(f"{kind:8s} chunks of {chunk_size:5d}: {result['chunks']:3d} chunks in {wall:6.2f} s wall; "
                      f"the chunks' own {own:6.2f} s; overhead {overhead * 1e3:7.1f} ms per chunk "
                      f"({result['orders_per_core_second']:,.0f} lookups per core-second)", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
