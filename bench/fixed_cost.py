"""Fixed cost per run through orchestrator.simulation: CPU time of a run that simulates (almost) nothing.

    python bench/fixed_cost.py                  # 2000 runs of 1 ms of simulated time, 5 batches
    python bench/fixed_cost.py --runs 500 --horizon 1e-4

Each run is what a search evaluation costs apart from the integration: reset, setup, the order and the
search tolerances set, initialisation, one doStep, the evaluation's 13 outputs read (as
orchestrator.objective's FMU runs ask for them). The horizon is so short that the solver takes one or two
steps; CPU time (time.process_time) per run, the minimum over batches (the machine is shared).
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import build_fmu  # noqa: E402
from orchestrator.simulation import COUNTER_OUTPUTS, ENERGY_OUTPUTS, PEAK_OUTPUTS, LatticeFMU  # noqa: E402
from orchestrator.objective import SEARCH_RTOL, search_tolerances  # noqa: E402

OUTPUTS = PEAK_OUTPUTS + ENERGY_OUTPUTS + COUNTER_OUTPUTS + ("last_contact_time",)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--fmu", help="FMU to measure (default: build one from fmu_src/ into a temporary folder)")
    parser.add_argument("--runs", type=int, default=2000, help="runs per batch")
    parser.add_argument("--batches", type=int, default=5, help="batches (the fastest is reported)")
    parser.add_argument("--horizon", type=float, default=1e-3, help="simulated time per run (s)")
    args = parser.parse_args(argv)
    fmu_path = Path(args.fmu) if args.fmu else build_fmu.build_fmu(
        output=Path(tempfile.mkdtemp(prefix="fixed_cost_")) / "MassSpringLattice.fmu")
    parameters = search_tolerances(SEARCH_RTOL)
    order = (1, 10, 9, 6, 4, 5, 7, 8, 3, 2, 11)
    with LatticeFMU(fmu_path) as fmu:
        fmu.simulate(order, horizon=args.horizon, parameters=parameters, outputs=OUTPUTS)  # warm up
        per_run = []
        for _ in range(args.batches):
            start = time.process_time()
            for _ in range(args.runs):
                fmu.simulate(order, horizon=args.horizon, parameters=parameters, outputs=OUTPUTS)
            per_run.append((time.process_time() - start) / args.runs)
        result = fmu.simulate(order, horizon=args.horizon, parameters=parameters, outputs=OUTPUTS)
    print(f"fixed cost per run ({args.horizon:g} s simulated, {result['rhs_evaluations']} right-hand sides, "
          f"{len(OUTPUTS)} outputs read): min {1e3 * min(per_run):.4f} ms CPU, "
          f"median {1e3 * sorted(per_run)[len(per_run) // 2]:.4f} ms over {args.batches} batches of {args.runs}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
