"""Work against precision of the FMU's solvers on the search evaluation (1 s) and the 8 s scene.

    python bench/solver_work_precision.py --out bench/out/solver_work_precision
    python bench/solver_work_precision.py --out /tmp/wp --orders 4 --repeats 1     # quick look

For every solver setting (DOP853, Tsit5 and DOPRI5 over a grid of rtol with atol = rtol / 100, fixed-step RK4
over a grid of steps) and every order (random ones, the sequential order, the study's best and the best known),
the sampled peak (0.01 s samples, the searches' objective) is compared with DOP853 at rtol 1e-12,
atol 1e-14 on the same order and horizon. A setting's error is its worst relative error over the orders;
its work is the mean count of right-hand sides per run (the FMU's own count) and the CPU time per run
(time.process_time over all orders through orchestrator.simulation, the minimum over repeats, the
settings interleaved within each repeat; the machine is shared, so counts are the steadier measure).

Writes work_precision.csv and work_precision.png (error against right-hand sides and against CPU time,
one panel per horizon) to --out, and prints for each solver the setting that reaches a worst error of
--target (3e-5 by default, what the search ranking needs) with the fewest right-hand sides.
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
from bench.common import SEQUENTIAL, STUDY_BEST, random_orders, write_csv  # noqa: E402
from orchestrator.simulation import SOLVERS, LatticeFMU, SimulationError  # noqa: E402

BEST_KNOWN = (1, 10, 9, 6, 4, 5, 7, 8, 3, 2, 11)
HORIZONS = {"search evaluation (1 s)": 1.0, "scene (8 s)": 8.0}
REFERENCE = {"solver": SOLVERS["dop853"], "rtol": 1e-12, "atol": 1e-14}
OUTPUTS = ("peak_backplate_force", "rhs_evaluations")
ADAPTIVE_RTOLS = {
    "dop853": (1e-3, 1e-4, 3e-5, 1e-5, 3e-6, 1e-6, 1e-7, 1e-8, 1e-9),
    "tsit5": (1e-3, 3e-4, 1e-4, 6e-5, 4e-5, 3e-5, 2e-5, 1e-5, 5e-6, 1e-6, 1e-7, 1e-8, 1e-9),
    "dopri5": (1e-3, 1e-4, 3e-5, 2e-5, 1e-5, 5e-6, 1e-6, 1e-7, 1e-8, 1e-9),
    "rkn5": (1e-3, 3e-4, 1e-4, 6e-5, 4e-5, 3e-5, 2e-5, 1e-5, 8e-6, 6e-6, 5e-6, 1e-6, 1e-7, 1e-8, 1e-9),
}
RK4_STEPS = (1e-2, 5e-3, 2.5e-3, 1e-3, 5e-4)


def settings() -> list[tuple[str, str, dict]]:
    out = []
    for solver, rtols in ADAPTIVE_RTOLS.items():
        out += [(solver, f"rtol={r:.0e}", {"solver": SOLVERS[solver], "rtol": r, "atol": r * 1e-2}) for r in rtols]
    out += [("rk4", f"h={h:g}", {"solver": SOLVERS["rk4"], "fixed_step": h}) for h in RK4_STEPS]
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", default="bench/out/solver_work_precision", help="folder for the CSV and the chart")
    parser.add_argument("--fmu", help="FMU to measure (default: build one from fmu_src/ into a temporary folder)")
    parser.add_argument("--orders", type=int, default=12, help="random orders (besides the three named ones)")
    parser.add_argument("--seed", type=int, default=7, help="seed of the random orders")
    parser.add_argument("--repeats", type=int, default=3, help="timed passes per setting (the fastest is kept)")
    parser.add_argument("--target", type=float, default=3e-5, help="worst relative peak error a search needs")
    parser.add_argument("--horizons", nargs="*", choices=sorted(HORIZONS), default=list(HORIZONS),
                        help="which horizons to run")
    args = parser.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    fmu_path = Path(args.fmu) if args.fmu else build_fmu.build_fmu(
        output=Path(tempfile.mkdtemp(prefix="solver_wp_")) / "MassSpringLattice.fmu")
    orders = [SEQUENTIAL, STUDY_BEST, BEST_KNOWN] + random_orders(args.orders, args.seed)
    rows = []
    with LatticeFMU(fmu_path) as fmu:
        for horizon_name in args.horizons:
            horizon = HORIZONS[horizon_name]
            reference = [fmu.simulate(order, horizon=horizon, parameters=REFERENCE, outputs=OUTPUTS)
                         ["peak_backplate_force"] for order in orders]
            measured = {}
            for _ in range(args.repeats):
                for solver, label, parameters in settings():
                    start = time.process_time()
                    results = []
                    for order in orders:
                        try:
                            results.append(fmu.simulate(order, horizon=horizon, parameters=parameters,
                                                        outputs=OUTPUTS))
                        except SimulationError as exc:
                            results.append({"error": str(exc)})
                    seconds = (time.process_time() - start) / len(orders)
                    entry = measured.setdefault((solver, label), {"results": results, "seconds": seconds})
                    entry["seconds"] = min(entry["seconds"], seconds)
            for (solver, label), entry in measured.items():
                results = entry["results"]
                failed = [r for r in results if "error" in r]
                errors = [abs(r["peak_backplate_force"] / ref - 1.0) for r, ref in zip(results, reference)
                          if "error" not in r]
                rows.append({
                    "horizon": horizon_name, "solver": solver, "setting": label,
                    "worst_error": max(errors) if errors and not failed else float("nan"),
                    "median_error": sorted(errors)[len(errors) // 2] if errors else float("nan"),
                    "mean_rhs": sum(r["rhs_evaluations"] for r in results if "error" not in r) / max(1, len(errors)),
                    "cpu_ms_per_run": 1e3 * entry["seconds"], "failed": len(failed),
                })
    write_csv(out / "work_precision.csv", rows)
    chart(rows, out / "work_precision.png", args.target)
    print(f"{len(orders)} orders, reference DOP853 rtol 1e-12; worst relative error of the sampled peak, mean "
          f"right-hand sides, CPU ms per run (min of {args.repeats}); machine shared")
    for horizon_name in args.horizons:
        print(f"\n{horizon_name}")
        for row in rows:
            if row["horizon"] != horizon_name:
                continue
            failed = f"  {row['failed']} failed" if row["failed"] else ""
            print(f"  {row['solver']:7s} {row['setting']:12s} worst {row['worst_error']:9.2e}  median "
                  f"{row['median_error']:9.2e}  {row['mean_rhs']:8.0f} rhs  {row['cpu_ms_per_run']:7.2f} ms{failed}")
        print(f"  fewest right-hand sides with worst error <= {args.target:g}:")
        for solver in dict.fromkeys(r["solver"] for r in rows):
            good = [r for r in rows if r["horizon"] == horizon_name and r["solver"] == solver
                    and r["worst_error"] <= args.target]
            if good:
                best = min(good, key=lambda r: r["mean_rhs"])
                print(f"    {solver:7s} {best['setting']:12s} {best['mean_rhs']:6.0f} rhs, "
                      f"{best['cpu_ms_per_run']:.2f} ms, worst error {best['worst_error']:.2e}")
            else:
                print(f"    {solver:7s} no setting reaches it")
    print(f"\nwrote {out / 'work_precision.csv'} and {out / 'work_precision.png'}")
    return 0


def chart(rows: list[dict], path: Path, target: float) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    horizons = list(dict.fromkeys(r["horizon"] for r in rows))
    figure, axes = plt.subplots(len(horizons), 2, figsize=(12, 4.5 * len(horizons)), squeeze=False)
    for line, horizon_name in enumerate(horizons):
        for column, (key, label) in enumerate((("mean_rhs", "right-hand sides per run"),
                                               ("cpu_ms_per_run", "CPU ms per run (through fmpy)"))):
            axis = axes[line][column]
            for solver in dict.fromkeys(r["solver"] for r in rows):
                points = [r for r in rows if r["horizon"] == horizon_name and r["solver"] == solver
                          and r["worst_error"] == r["worst_error"] and r["worst_error"] > 0]
                if not points:
                    continue
                axis.loglog([p[key] for p in points], [p["worst_error"] for p in points], "o-", label=solver)
                for p in points:
                    axis.annotate(p["setting"].split("=")[1], (p[key], p["worst_error"]), fontsize=6,
                                  textcoords="offset points", xytext=(3, 3))
            axis.axhline(target, color="grey", linestyle="--", linewidth=0.8, label=f"search needs {target:g}")
            axis.set_xlabel(label)
            axis.set_ylabel("worst relative error of the sampled peak")
            axis.set_title(horizon_name)
            axis.grid(True, which="both", alpha=0.3)
            axis.legend(fontsize=8)
    figure.tight_layout()
    figure.savefig(path, dpi=120)
    plt.close(figure)


if __name__ == "__main__":
    raise SystemExit(main())
