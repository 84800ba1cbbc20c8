"""What peak_force_limit saves: random orders over the search evaluation, with the limit at the best known peak
against no limit.

    python bench/force_limit.py                      # 40 random orders, 5 interleaved repeats
    python bench/force_limit.py --orders 200 --repeats 3 --limit 1405.906

Each order is run over the search horizon (1 s) at the searches' tolerances (orchestrator.objective) with and
without the limit, the two interleaved so that the machine's load hits both alike; CPU time
(time.process_time) per pass over all orders, the minimum over repeats. The right-hand sides (the FMU's own
count, not noisy) are reported too. Every run that stays below the limit is checked to give the same peak
bit for bit as the run without it. Then the sequential order with a limit of 1500 N: where it stops.
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
from bench.common import SEQUENTIAL, random_orders  # noqa: E402
from orchestrator.simulation import SOLVERS, LatticeFMU  # noqa: E402
from orchestrator.objective import SEARCH_HORIZON, SEARCH_RTOL, search_tolerances  # noqa: E402

BEST_KNOWN = (1, 10, 9, 6, 4, 5, 7, 8, 3, 2, 11)  # README: every search's best with 2000 evaluations
BEST_KNOWN_PEAK = 1405.906  # N, its peak over 8 s (0.01 s samples)
OUTPUTS = ("peak_backplate_force", "rhs_evaluations")


def one_pass(fmu: LatticeFMU, orders, parameters, limit) -> tuple[float, list[dict]]:
    start = time.process_time()
    results = [fmu.simulate(order, horizon=SEARCH_HORIZON, parameters=parameters, outputs=OUTPUTS,
                            peak_force_limit=limit) for order in orders]
    return time.process_time() - start, results


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--fmu", help="FMU to measure (default: build one from fmu_src/ into a temporary folder)")
    parser.add_argument("--orders", type=int, default=40, help="random orders")
    parser.add_argument("--seed", type=int, default=12, help="seed of the random orders")
    parser.add_argument("--repeats", type=int, default=5, help="interleaved passes with and without the limit")
    parser.add_argument("--limit", type=float, default=BEST_KNOWN_PEAK, help="peak_force_limit (N)")
    parser.add_argument("--rtol", type=float, default=SEARCH_RTOL, help="the FMU's rtol (atol = rtol / 100)")
    parser.add_argument("--solver", choices=sorted(SOLVERS), default="dop853", help="the FMU's solver")
    args = parser.parse_args(argv)
    fmu_path = Path(args.fmu) if args.fmu else build_fmu.build_fmu(
        output=Path(tempfile.mkdtemp(prefix="force_limit_")) / "MassSpringLattice.fmu")
    parameters = {**search_tolerances(args.rtol), "solver": SOLVERS[args.solver]}
    orders = random_orders(args.orders, args.seed)
    with LatticeFMU(fmu_path) as fmu:
        one_pass(fmu, orders[:3], parameters, None)  # warm up
        free_times, limited_times = [], []
        for _ in range(args.repeats):
            seconds, free = one_pass(fmu, orders, parameters, None)
            free_times.append(seconds)
            seconds, limited = one_pass(fmu, orders, parameters, args.limit)
            limited_times.append(seconds)
        sequential = fmu.simulate(SEQUENTIAL, horizon=SEARCH_HORIZON, parameters=parameters, outputs=OUTPUTS,
                                  peak_force_limit=1500.0)

    censored = [r for r in limited if r["censored"]]
    below = [(f, r) for f, r in zip(free, limited) if not r["censored"]]
    assert all(f["peak_backplate_force"] == r["peak_backplate_force"] for f, r in below), "not bit-identical"
    assert all(f["peak_backplate_force"] > args.limit for f, r in zip(free, limited) if r["censored"])
    free_rhs = sum(r["rhs_evaluations"] for r in free)
    limited_rhs = sum(r["rhs_evaluations"] for r in limited)
    reached = sorted(r["censored_at"] for r in censored)
    print(f"{args.orders} random orders (seed {args.seed}), {SEARCH_HORIZON:g} s horizon, {args.solver}, "
          f"rtol {parameters['rtol']:g}, "
          f"atol {parameters['atol']:g}, limit {args.limit:g} N: {len(censored)} censored "
          f"(stopped at {reached[0]:.2f}-{reached[-1]:.2f} s, median {reached[len(reached) // 2]:.2f} s)"
          if censored else f"{args.orders} random orders: none censored")
    print(f"  CPU per pass (min of {args.repeats}): without {1e3 * min(free_times):.1f} ms "
          f"({1e3 * min(free_times) / args.orders:.2f} ms/order), with {1e3 * min(limited_times):.1f} ms "
          f"({1e3 * min(limited_times) / args.orders:.2f} ms/order): 1/{min(free_times) / min(limited_times):.2f}")
    print(f"  right-hand sides: without {free_rhs} ({free_rhs / args.orders:.0f}/order), with {limited_rhs} "
          f"({limited_rhs / args.orders:.0f}/order): 1/{free_rhs / limited_rhs:.2f}")
    print(f"  below the limit: {len(below)} orders, each bit-identical to its run without the limit")
    print(f"sequential order, limit 1500 N: censored={sequential['censored']}, stopped at t = "
          f"{sequential['censored_at']} s with peak {sequential['peak_backplate_force']:.3f} N, "
          f"{sequential['rhs_evaluations']} right-hand sides")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
