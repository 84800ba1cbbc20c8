"""How an evaluation's cost grows with the lattice: square lattices 5 x 5 to 31 x 31, and 11 rows by C columns.

    python bench/scaling.py --out bench/out/scaling            # the quick subset (default): ~2 min
    python bench/scaling.py --out bench/out/scaling --full     # every odd size 5..31, and 20: ~5 min
    python bench/scaling.py --out bench/out/scaling_whole --use-symmetry 0   # the whole lattice everywhere

With use_symmetry 1 (the FMU as it ships) every lattice drops uy and vy (the load is along x) and one with an
odd number of rows integrates only its upper half, so odd and even row counts lie on two different lines;
--use-symmetry 0 gives the cost law of the whole model.

For each lattice the FMU is built with `python build_fmu.py --rows R --cols C` (kept in DIR/fmus and
rebuilt when fmu_src/ or build_fmu.py is newer, or with --rebuild; the material table is SPEC 3's with C
materials) and run through fmpy (orchestrator.simulation.LatticeFMU) on two evaluations:
- the search evaluation: 1 s as the searches run it (orchestrator.objective.search_tolerances: their
  solver and rtol, atol = rtol / 100);
- the 8 s scene at the FMU's default (DOP853, rtol 1e-7, atol 1e-9);
for the sequential order 1..C and --random-orders random permutations of 1..C. It measures the CPU time
per evaluation (time.process_time; the minimum over --repeats rounds, the rounds interleaved over every
lattice, order and evaluation, since the machine is shared), the right-hand sides (the FMU's counter) and
so the microseconds per right-hand side, all solver and fmpy work included.

Growth law: a least-squares line through log(cost) against log(number of masses) per series (square,
11 x C) and evaluation, over the median over orders at each lattice: cost ~ N^p. The same for the
right-hand sides and the microseconds per right-hand side, whose exponents add up to p.

Writes DIR/scaling_runs.csv (every lattice, order, evaluation), DIR/scaling.csv (per lattice and
evaluation: medians and ranges over orders), DIR/scaling_fits.csv, DIR/scaling.txt and DIR/scaling.png
(log-log).
"""
from __future__ import annotations

import argparse
import math
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import ROOT, random_orders, write_csv  # noqa: E402

import build_fmu  # noqa: E402
from orchestrator.simulation import LatticeFMU, SimulationError  # noqa: E402
from orchestrator.objective import SEARCH_HORIZON, SEARCH_RTOL, search_tolerances  # noqa: E402

_SEARCH = search_tolerances(SEARCH_RTOL)  # what the searches run: their solver and rtol, atol rtol / 100
EVALUATIONS = {
    "search": (f"search evaluation (1 s, {_SEARCH['solver']} rtol {SEARCH_RTOL:g})", SEARCH_HORIZON, _SEARCH),
    "scene8s": ("8 s scene (dop853 rtol 1e-7)", 8.0, {}),
}
OUTPUTS = ("peak_backplate_force", "peak_time", "last_contact_time", "rhs_evaluations", "steps_accepted",
           "steps_rejected")
QUICK_SIZES = (5, 8, 11, 14, 20, 25, 31)
FULL_SIZES = tuple(sorted(set(range(5, 32, 2)) | {20}))
ROWS_BY_C = 11


def lattices(full: bool) -> list[tuple[str, int, int]]:
    """(series, rows, cols): square R x R, and 11 x C (11 x 11 is shared by both series)."""
    sizes = FULL_SIZES if full else QUICK_SIZES
    return [("square", n, n) for n in sizes] + [("11xC", ROWS_BY_C, c) for c in sizes]


def newest_source_time() -> float:
    paths = [ROOT / "build_fmu.py", *(p for p in (ROOT / "fmu_src").rglob("*") if p.is_file())]
    return max(p.stat().st_mtime for p in paths)


def fmu_for(folder: Path, rows: int, cols: int, rebuild: bool, log) -> Path:
    path = folder / f"Lattice{rows}x{cols}.fmu"
    if rebuild or not path.is_file() or path.stat().st_mtime < newest_source_time():
        start = time.perf_counter()
        build_fmu.build_fmu(rows=rows, cols=cols, output=path)
        log(f"built {path.name} ({rows} x {cols}) in {time.perf_counter() - start:.1f} s "
            f"(python build_fmu.py --rows {rows} --cols {cols} -o {path})")
    return path


def fit(ns, values) -> tuple[float, float]:
    """(exponent p, factor a) of values ~ a * N^p, least squares in log-log."""
    p, log_a = np.polyfit(np.log(ns), np.log(values), 1)
    return float(p), float(math.exp(log_a))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", default=str(ROOT / "bench" / "out" / "scaling"), help="folder for CSVs and chart")
    size = parser.add_mutually_exclusive_group()
    size.add_argument("--quick", dest="full", action="store_false",
                      help=f"sizes {', '.join(map(str, QUICK_SIZES))} (default)")
    size.add_argument("--full", dest="full", action="store_true",
                      help=f"sizes {', '.join(map(str, FULL_SIZES))}")
    parser.set_defaults(full=False)
    parser.add_argument("--random-orders", type=int, default=None,
                        help="random orders beside the sequential one (default 2; --full 3)")
    parser.add_argument("--repeats", type=int, default=None, help="interleaved timing rounds (default 3; --full 5)")
    parser.add_argument("--evaluations", nargs="+", choices=sorted(EVALUATIONS), default=["search", "scene8s"])
    parser.add_argument("--rebuild", action="store_true", help="rebuild every FMU")
    parser.add_argument("--seed", type=int, default=2024, help="seed of the random orders")
    parser.add_argument("--use-symmetry", type=int, choices=(0, 1), default=1,
                        help="the FMU's use_symmetry: 1 (default, as it ships: ux and vx only, and the upper half "
                             "of a lattice with an odd number of rows) or 0 (the whole lattice at every size, the "
                             "cost law of the model itself)")
    args = parser.parse_args(argv)
    random_count = args.random_orders if args.random_orders is not None else (3 if args.full else 2)
    repeats = args.repeats or (5 if args.full else 3)
    if random_count < 0 or repeats < 1:
        parser.error("--random-orders must be >= 0 and --repeats >= 1")
    out = Path(args.out)
    (out / "fmus").mkdir(parents=True, exist_ok=True)
    log_lines = []

    def log(text):
        print(text, flush=True)
        log_lines.append(text)

    shapes = list(dict.fromkeys((r, c) for _, r, c in lattices(args.full)))
    fmus, orders = {}, {}
    for rows, cols in shapes:
        path = fmu_for(out / "fmus", rows, cols, args.rebuild, log)
        fmus[(rows, cols)] = LatticeFMU(path, instance_name=f"scaling{rows}x{cols}")
        orders[(rows, cols)] = {"sequential": tuple(range(1, cols + 1))}
        for k, order in enumerate(random_orders(random_count, args.seed + cols, n=cols)):
            orders[(rows, cols)][f"random{k + 1}"] = order

    runs: dict[tuple, dict] = {}
    started = time.perf_counter()
    try:
        for round_index in range(repeats):
            for shape in shapes:
                for label, order in orders[shape].items():
                    for evaluation in args.evaluations:
                        _, horizon, parameters = EVALUATIONS[evaluation]
                        key = (shape, label, evaluation)
                        run = runs.setdefault(key, {"times": [], "failure": ""})
                        start = time.process_time()
                        try:
                            result = fmus[shape].simulate(
                                order, horizon=horizon, parameters={**parameters, "use_symmetry": args.use_symmetry},
                                outputs=OUTPUTS)
                        except SimulationError as exc:
                            run["failure"] = str(exc)
                            continue
                        run["times"].append(time.process_time() - start)
                        run["result"] = result
            log(f"round {round_index + 1}/{repeats} done ({time.perf_counter() - started:.0f} s)")
    finally:
        for fmu in fmus.values():
            fmu.close()

    run_rows = []
    for (shape, label, evaluation), run in runs.items():
        rows, cols = shape
        row = {"rows": rows, "cols": cols, "masses": rows * cols, "evaluation": evaluation, "order": label,
               "materials": orders[shape][label], "repeats": len(run["times"]), "failure": run["failure"]}
        if run["times"] and not run["failure"]:
            result = run["result"]
            cpu = min(run["times"])
            row.update(cpu_ms=cpu * 1e3, cpu_ms_median=statistics.median(run["times"]) * 1e3,
                       rhs=int(result["rhs_evaluations"]), us_per_rhs=cpu / result["rhs_evaluations"] * 1e6,
                       steps_accepted=int(result["steps_accepted"]), steps_rejected=int(result["steps_rejected"]),
                       peak=result["peak_backplate_force"], peak_time=result["peak_time"],
                       last_contact_time=result["last_contact_time"])
        run_rows.append(row)

    table, fits = [], []
    for series in dict.fromkeys(s for s, _, _ in lattices(args.full)):
        members = [(r, c) for s, r, c in lattices(args.full) if s == series]
        for evaluation in args.evaluations:
            points = []
            for rows, cols in members:
                good = [r for r in run_rows if (r["rows"], r["cols"], r["evaluation"]) == (rows, cols, evaluation)
                        and "cpu_ms" in r]
                failed = [r for r in run_rows if (r["rows"], r["cols"], r["evaluation"]) == (rows, cols, evaluation)
                          and "cpu_ms" not in r]
                entry = {"series": series, "rows": rows, "cols": cols, "masses": rows * cols, "evaluation": evaluation,
                         "orders": len(good), "failed": len(failed)}
                if good:
                    entry.update({f"{q}_median": statistics.median(r[q] for r in good)
                                  for q in ("cpu_ms", "rhs", "us_per_rhs")})
                    entry.update({f"{q}_min": min(r[q] for r in good) for q in ("cpu_ms", "rhs", "us_per_rhs")})
                    entry.update({f"{q}_max": max(r[q] for r in good) for q in ("cpu_ms", "rhs", "us_per_rhs")})
                    entry["last_contact_max"] = max(r["last_contact_time"] for r in good)
                    entry["peak_time_max"] = max(r["peak_time"] for r in good)
                    points.append(entry)
                table.append(entry)
            if len(points) >= 2:
                ns = [p["masses"] for p in points]
                fit_row = {"series": series, "evaluation": evaluation, "lattices": len(points),
                           "masses_min": min(ns), "masses_max": max(ns)}
                for q in ("cpu_ms", "rhs", "us_per_rhs"):
                    p, a = fit(ns, [pt[f"{q}_median"] for pt in points])
                    fit_row[f"{q}_exponent"], fit_row[f"{q}_factor"] = p, a
                big = [pt for pt in points if pt["masses"] >= 100]
                if len(big) >= 2:
                    fit_row["cpu_ms_exponent_from_100"] = fit([p["masses"] for p in big],
                                                              [p["cpu_ms_median"] for p in big])[0]
                fits.append(fit_row)

    log(f"\nCPU per evaluation through fmpy, minimum of {repeats} interleaved rounds per order, median "
        f"[range] over the sequential order and {random_count} random ones; the machine was shared")
    log(f"{'lattice':>8s} {'masses':>6s} {'evaluation':10s} {'CPU ms':>24s} {'RHS':>20s} {'us/RHS':>8s} "
        f"{'last contact':>12s}")
    for e in table:
        name = f"{e['rows']}x{e['cols']}"
        if "cpu_ms_median" not in e:
            log(f"{name:>8s} {e['masses']:6d} {e['evaluation']:10s} all runs failed")
            continue
        log(f"{name:>8s} {e['masses']:6d} {e['evaluation']:10s} {e['cpu_ms_median']:8.2f} "
            f"[{e['cpu_ms_min']:6.2f}-{e['cpu_ms_max']:6.2f}] {e['rhs_median']:6.0f} [{e['rhs_min']:5d}-{e['rhs_max']:5d}]"
            f" {e['us_per_rhs_median']:8.2f} {e['last_contact_max']:10.2f} s")
    log("\ngrowth laws (least squares in log-log over the medians): cost ~ N^p, N = number of masses")
    for f in fits:
        label = EVALUATIONS[f["evaluation"]][0]
        tail = (f"; from N >= 100: CPU ~ N^{f['cpu_ms_exponent_from_100']:.2f}"
                if "cpu_ms_exponent_from_100" in f else "")
        log(f"{f['series']:6s} {label:36s} CPU ~ N^{f['cpu_ms_exponent']:.2f} = RHS count ~ N^{f['rhs_exponent']:.2f}"
            f" x us/RHS ~ N^{f['us_per_rhs_exponent']:.2f} (N {f['masses_min']}-{f['masses_max']}){tail}")
    twenty = next((e for e in table if (e["rows"], e["cols"], e["evaluation"]) == (20, 20, "search")
                   and "cpu_ms_median" in e), None)
    if twenty:
        log(f"20 x 20 search evaluation: {twenty['cpu_ms_median']:.1f} ms CPU "
            f"[{twenty['cpu_ms_min']:.1f}-{twenty['cpu_ms_max']:.1f}], {twenty['rhs_median']:.0f} right-hand sides "
            f"at {twenty['us_per_rhs_median']:.1f} us")
    failures = [r for r in run_rows if r["failure"]]
    for r in failures:
        log(f"FAILED {r['rows']}x{r['cols']} {r['evaluation']} {r['order']}: {r['failure']}")

    write_csv(out / "scaling_runs.csv", run_rows)
    write_csv(out / "scaling.csv", table)
    write_csv(out / "scaling_fits.csv", fits)
    (out / "scaling.txt").write_text("\n".join(log_lines) + "\n")
    chart(out / "scaling.png", table, fits)
    print(f"wrote {out}/scaling_runs.csv, scaling.csv, scaling_fits.csv, scaling.txt, scaling.png")
    return 1 if failures else 0


def chart(path: Path, table: list[dict], fits: list[dict]) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    quantities = (("cpu_ms", "CPU ms per evaluation"), ("rhs", "right-hand sides per evaluation"),
                  ("us_per_rhs", "CPU us per right-hand side"))
    styles = {("square", "search"): ("C0", "o", "-"), ("square", "scene8s"): ("C1", "o", "-"),
              ("11xC", "search"): ("C0", "s", "--"), ("11xC", "scene8s"): ("C1", "s", "--")}
    fig, axes = plt.subplots(1, 3, figsize=(16, 4.8))
    for ax, (q, title) in zip(axes, quantities):
        for (series, evaluation), (colour, marker, line) in styles.items():
            points = [e for e in table if e["series"] == series and e["evaluation"] == evaluation and f"{q}_median" in e]
            if not points:
                continue
            ns = np.array([p["masses"] for p in points])
            med = np.array([p[f"{q}_median"] for p in points])
            lo = med - np.array([p[f"{q}_min"] for p in points])
            hi = np.array([p[f"{q}_max"] for p in points]) - med
            f = next((f for f in fits if f["series"] == series and f["evaluation"] == evaluation), None)
            label = f"{'R x R' if series == 'square' else '11 x C'}, {EVALUATIONS[evaluation][0]}"
            if f:
                label += f": N^{f[f'{q}_exponent']:.2f}"
                grid = np.geomspace(ns.min(), ns.max(), 50)
                ax.plot(grid, f[f"{q}_factor"] * grid ** f[f"{q}_exponent"], line, color=colour, lw=0.8, alpha=0.6)
            ax.errorbar(ns, med, yerr=[lo, hi], fmt=marker, color=colour, ms=4, capsize=2, label=label,
                        mfc="none" if series == "11xC" else colour)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("number of masses N")
        ax.set_title(title)
        ax.legend(fontsize=7)
    fig.suptitle("cost of one evaluation through fmpy against lattice size (median over orders, bars: range)",
                 fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    sys.exit(main())
