"""Horizon and tolerance: is the searches' short horizon enough, and which tolerance keeps the ranking of the
best orders?

    python -m bench.horizon_study            # about 2 min on 2 workers: 200 random orders and 57 more
    python -m bench.horizon_study --quick    # about 30 s: 30 random orders and 57 more

Why: the searches rank designs over ``orchestrator.objective.SEARCH_HORIZON`` with ``SEARCH_SOLVER`` at
``SEARCH_RTOL``; that is safe only if no design still touches the plate by then and the error is far below the
gaps between good designs. Orders: random ones, the sequential order, the study's best and its 55 single swaps
(close competitors a search has to tell apart). Per order one run to 8 s with DOP853 at rtol 1e-10 (the truth)
is read at 0.5, 0.75, 1, 2 and 8 s (the FMU's peaks are running maxima, so one run gives every shorter
horizon's peak), and one run to 2 s with the searches' solver at each tolerance is read at the search horizon.
Every run is a recorded FMU run (``orchestrator.objective.RecordRun``) through the orchestrator's Evaluator on
a process pool. A sample of orders is also run exactly as the searches run it, to confirm that a run read at
the horizon equals a run that stops there.
"""

from __future__ import annotations

import itertools
import math
import statistics

from orchestrator.executors import make_executor
from orchestrator.loop import Evaluator
from orchestrator.objective import SEARCH_HORIZON, SEARCH_RTOL, SEARCH_SOLVER, RecordRun, close_instances
from orchestrator.simulation import LatticeFMU

from .common import (
    SEQUENTIAL,
    STUDY_BEST,
    add_fmu_option,
    lattice_fmu,
    order_text,
    random_orders,
    relative,
    search_parameters,
)
from .measurements import Page, Run, Table, write_page

HORIZONS = (0.5, 0.75, 1.0, 2.0, 8.0)
STEP = 0.25  # s between recorded points: every horizon above is one of them
TRUTH = {"solver": "dop853", "rtol": 1e-10, "atol": 1e-12}
RTOLS = (1e-3, 1e-4, 3e-5, 1e-5, 8e-6, 1e-6, 1e-7)
SAME = 1e-9  # relative difference below which two peaks are the same number
TOP = 10
RECORD = ("peak_backplate_force", "peak_backplate_force_continuous", "peak_time", "last_contact_time")


def swaps(order) -> list[tuple[int, ...]]:
    out = []
    for i, j in itertools.combinations(range(len(order)), 2):
        swapped = list(order)
        swapped[i], swapped[j] = swapped[j], swapped[i]
        out.append(tuple(swapped))
    return out


def kendall_tau(a: list[float], b: list[float]) -> float:
    pairs = list(itertools.combinations(range(len(a)), 2))
    concordance = sum(
        math.copysign(1, (a[i] - a[j]) * (b[i] - b[j])) for i, j in pairs if (a[i] - a[j]) * (b[i] - b[j]) != 0
    )
    return concordance / len(pairs)


def at(trajectory, horizon: float) -> dict:
    index = int(round(horizon / STEP))
    if abs(trajectory.time[index] - horizon) > 1e-9:
        raise RuntimeError(f"recorded point {index} is at {trajectory.time[index]} s, not {horizon} s")
    return {name: trajectory.values[name][index] for name in RECORD}


def main(argv=None) -> int:
    run = Run.start(__file__, argv)
    parser = run.parser(__doc__, quick="30 random orders, four tolerances")
    add_fmu_option(parser)
    parser.add_argument("--orders", type=int, default=200, help="random orders (besides the 57 fixed ones)")
    parser.add_argument("--seed", type=int, default=7, help="seed of the random orders")
    parser.add_argument("--workers", type=int, default=2, help="worker processes")
    args = parser.parse_args(argv)
    rtols = RTOLS
    if args.quick:
        args.orders = min(args.orders, 30)
        rtols = (1e-4, 1e-5, SEARCH_RTOL, 1e-6)
    kinds: dict[tuple, str] = {}
    for order in random_orders(args.orders, args.seed):
        kinds.setdefault(order, "random")
    kinds.setdefault(SEQUENTIAL, "random")  # the baseline belongs to the random set's ranking
    kinds[STUDY_BEST] = "neighbourhood"
    for order in swaps(STUDY_BEST):
        kinds.setdefault(order, "neighbourhood")
    orders = list(kinds)

    with lattice_fmu(args.fmu) as path:
        search = search_parameters(path)
        fmu_path = str(path)

        def recorded(order, horizon, parameters):
            return RecordRun(fmu_path, order, horizon, STEP, tuple(sorted(parameters.items())), RECORD)

        tasks = [recorded(o, 8.0, TRUTH) for o in orders]
        tasks += [recorded(o, 2.0, {**search, "rtol": r, "atol": r * 1e-2}) for r in rtols for o in orders]
        direct_orders = orders[:: max(1, len(orders) // 12)]
        with make_executor("process", args.workers) as executor:
            results = Evaluator(executor).run(tasks)
        with LatticeFMU(path) as fmu:
            direct = {
                o: fmu.simulate(o, horizon=SEARCH_HORIZON, parameters=search, outputs=RECORD) for o in direct_orders
            }
        close_instances()
    failed = [t for t in results if not t.ok]
    if failed:
        raise SystemExit(f"{len(failed)} runs failed, first {list(failed[0].order)}: {failed[0].message}")
    truth = {o: t for o, t in zip(orders, results[: len(orders)])}
    by_rtol = {
        r: dict(zip(orders, results[len(orders) * (k + 1) : len(orders) * (k + 2)])) for k, r in enumerate(rtols)
    }
    final = {o: at(truth[o], 8.0) for o in orders}

    horizon_rows = []
    for h in HORIZONS[:-1]:
        values = {o: at(truth[o], h) for o in orders}
        diffs = [
            max(
                relative(values[o]["peak_backplate_force"], final[o]["peak_backplate_force"]),
                relative(values[o]["peak_backplate_force_continuous"], final[o]["peak_backplate_force_continuous"]),
            )
            for o in orders
        ]
        guard = sum(1 for o in orders if values[o]["last_contact_time"] >= 0.9 * h)
        horizon_rows.append((f"{h:g} s", sum(d > SAME for d in diffs), f"{max(diffs):.1e}", guard))

    groups = {name: [o for o in orders if kinds[o] == name] for name in ("random", "neighbourhood")}
    true_peak = {o: final[o]["peak_backplate_force"] for o in orders}
    gaps = {}
    for name, members in groups.items():
        best = sorted(members, key=true_peak.get)[:TOP]
        gaps[name] = min(relative(true_peak[b], true_peak[a]) for a, b in zip(best, best[1:]))
    smallest_gap = min(gaps.values())
    tolerance_rows = []
    errors_at = {}
    for rtol in rtols:
        peaks = {o: at(by_rtol[rtol][o], SEARCH_HORIZON) for o in orders}
        errors = [relative(peaks[o]["peak_backplate_force"], true_peak[o]) for o in orders]
        errors_at[rtol] = max(errors)
        kept, taus = [], []
        for name, members in groups.items():
            by_truth = sorted(members, key=true_peak.get)[:TOP]
            by_tolerance = sorted(members, key=lambda o: peaks[o]["peak_backplate_force"])[:TOP]
            kept.append("yes" if by_truth == by_tolerance else "no")
            taus.append(
                kendall_tau([true_peak[o] for o in members], [peaks[o]["peak_backplate_force"] for o in members])
            )
        tolerance_rows.append(
            (
                f"{rtol:g}" + (" (the searches')" if rtol == SEARCH_RTOL else ""),
                f"{max(errors):.1e}",
                f"{statistics.median(errors):.1e}",
                f"{max(errors) / smallest_gap:.2f}",
                *kept,
                *(f"{t:.4f}" for t in taus),
            )
        )
    direct_difference = max(
        max(
            relative(
                direct[o]["peak_backplate_force"], at(by_rtol[SEARCH_RTOL][o], SEARCH_HORIZON)["peak_backplate_force"]
            )
            for o in direct_orders
        )
        if SEARCH_RTOL in by_rtol
        else 0.0,
        0.0,
    )
    contact = [final[o]["last_contact_time"] for o in orders]
    peak_times = [final[o]["peak_time"] for o in orders]
    latest = max(orders, key=lambda o: final[o]["last_contact_time"])
    safe = [r for r in rtols if errors_at[r] < smallest_gap / 10]
    one_second = next(row for row in horizon_rows if row[0] == f"{SEARCH_HORIZON:g} s")
    notes = [
        f"The continuous peak comes at {min(peak_times):.3f}-{max(peak_times):.3f} s; the last contact with the "
        f"plate ends at {min(contact):.3f}-{max(contact):.3f} s (median {statistics.median(contact):.3f} s; the "
        f"latest: {order_text(latest)} at {final[latest]['last_contact_time']:.3f} s).",
        f"The smallest relative gap between neighbours among the best {TOP} orders by the truth: {gaps['random']:.1e} "
        f"in the random set, {gaps['neighbourhood']:.1e} among the study's best and its swaps. The loosest "
        f"tolerance whose worst error is below a tenth of the smallest gap (so that the ranking is kept by accuracy, "
        f"not by errors that happen to be alike): " + (f"rtol {max(safe):g}." if safe else "none of those tried."),
    ]
    if SEARCH_RTOL in by_rtol:
        notes.append(
            f"A run stopped at {SEARCH_HORIZON:g} s with the searches' setting against the 2 s run read at "
            f"{SEARCH_HORIZON:g} s: largest relative difference {direct_difference:.1e} over "
            f"{len(direct_orders)} orders."
        )
    headline = (
        f"at {SEARCH_HORIZON:g} s the peak equals the 8 s peak for {len(orders) - one_second[1]} of "
        f"{len(orders)} orders; the last contact ends by {max(contact):.2f} s; the searches' "
        f"{SEARCH_SOLVER} at rtol {SEARCH_RTOL:g} errs by at most "
        + (f"{errors_at[SEARCH_RTOL]:.1e}" if SEARCH_RTOL in errors_at else "(not run)")
        + f" against a smallest top-{TOP} gap of {smallest_gap:.1e}"
    )
    page = Page(
        name=run.name,
        title="Horizon and tolerance of the search evaluation",
        headline=headline,
        summary=(
            f"{len(orders)} orders: {args.orders} random ones (seed {args.seed}), the sequential order, the study's "
            f"best and its 55 single swaps. The truth is each order's run to 8 s with DOP853 at rtol 1e-10, atol "
            f"1e-12, read at every horizon; the tolerances are runs to 2 s with the searches' solver "
            f"({SEARCH_SOLVER}, atol = rtol / 100) read at {SEARCH_HORIZON:g} s and compared with the truth at 8 s. "
            f"All runs through the orchestrator's Evaluator on {args.workers} worker process(es)."
        ),
        tables=(
            Table(
                (
                    "horizon",
                    "orders whose peak differs from the 8 s peak",
                    "largest relative difference",
                    "orders still touching the plate in its last tenth (re-run over the full horizon)",
                ),
                tuple(horizon_rows),
                caption="**Shorter horizons against 8 s** (the truth's tolerance):",
            ),
            Table(
                (
                    "rtol",
                    "worst error",
                    "median error",
                    "worst error / smallest top-10 gap",
                    "top 10 kept, random set",
                    "top 10 kept, neighbourhood",
                    "Kendall tau, random set",
                    "Kendall tau, neighbourhood",
                ),
                tuple(tolerance_rows),
                caption=f"**Tolerances** ({SEARCH_HORIZON:g} s peak against the truth at 8 s):",
            ),
        ),
        notes=tuple(notes),
    )
    write_page(run, page)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
