"""The FMU's speed and accuracy on the study's 8 s scene, against the study's own way of computing it.

    python -m bench.fmu_speed            # about 1.5 min: 20 FMU runs and 2 scipy runs per order
    python -m bench.fmu_speed --quick    # about 40 s: 5 FMU runs and 1 scipy run per order

Why: the FMU exists to make an evaluation cheap without making it wrong, so every speed figure comes with its
accuracy. For the two published orders it times the FMU through fmpy (``orchestrator.simulation.LatticeFMU``:
reset, parameters, one doStep, outputs) at its defaults, and scipy's ``solve_ivp(DOP853)`` over the numpy
reference model (``reference/``, the study's route) at the route's own setting (rtol 1e-8, atol 1e-6) and at the
loosest rtol of a 1-2-5 grid from 1e-8 to 1e-10 (atol rtol / 100) whose error is at most the FMU's: a grid of
decades would hand scipy up to ten times the FMU's accuracy, and its cost with it. Each peak is compared with
the FMU at rtol 1e-13 and with the study's published number.
"""

from __future__ import annotations

import time

from fmu_src.published import PUBLISHED_PEAKS
from orchestrator.simulation import LatticeFMU
from reference import Scene
from reference.simulate import simulate

from .common import (
    FULL_HORIZON,
    SEQUENTIAL,
    STUDY_BEST,
    add_fmu_option,
    default_setting,
    lattice_fmu,
    order_text,
    relative,
    setting_text,
    span,
)
from .measurements import Page, Run, Table, write_page

MATCHING_RTOLS = (1e-8, 5e-9, 2e-9, 1e-9, 5e-10, 2e-10, 1e-10)
ORDERS = {"sequential": SEQUENTIAL, "study's best": STUDY_BEST}
TIGHT = {"rtol": 1e-13, "atol": 1e-15}
OUTPUTS = ("peak_backplate_force", "rhs_evaluations")


def time_fmu(fmu: LatticeFMU, order, repeats: int) -> tuple[float, dict]:
    """The fastest of ``repeats`` runs at the FMU's defaults, and its outputs."""
    best, result = float("inf"), None
    for _ in range(repeats):
        start = time.perf_counter()
        result = fmu.simulate(order, horizon=FULL_HORIZON, outputs=OUTPUTS)
        best = min(best, time.perf_counter() - start)
    return best, result


def time_scipy(order, rtol: float, atol: float, repeats: int):
    best, result = float("inf"), None
    for _ in range(repeats):
        start = time.perf_counter()
        result = simulate(
            Scene(order=order), horizon=FULL_HORIZON, rtol=rtol, atol=atol, method="DOP853", continuous_peak=False
        )
        best = min(best, time.perf_counter() - start)
    return best, result


def main(argv=None) -> int:
    run = Run.start(__file__, argv)
    parser = run.parser(__doc__, quick="5 FMU runs and 1 scipy run per order")
    add_fmu_option(parser)
    parser.add_argument("--repeats", type=int, default=20, help="FMU runs per order (the fastest counts)")
    parser.add_argument("--scipy-repeats", type=int, default=2, help="scipy runs per order and setting")
    args = parser.parse_args(argv)
    if args.quick:
        args.repeats, args.scipy_repeats = 5, 1

    rows, speedups, equal_speedups, fmu_errors, published_errors = [], [], [], [], []
    with lattice_fmu(args.fmu) as path, LatticeFMU(path) as fmu:
        for label, order in ORDERS.items():
            truth = fmu.simulate(order, horizon=FULL_HORIZON, parameters=TIGHT, outputs=OUTPUTS)["peak_backplate_force"]
            seconds, result = time_fmu(fmu, order, args.repeats)
            peak = result["peak_backplate_force"]
            error = relative(peak, truth)
            fmu_errors.append(error)
            published_errors.append(relative(peak, PUBLISHED_PEAKS[order]))
            rows.append(
                (
                    label,
                    f"FMU through fmpy, defaults ({setting_text(default_setting(path))})",
                    f"{seconds * 1e3:.2f}",
                    result["rhs_evaluations"],
                    f"{peak:.6f}",
                    f"{error:.1e}",
                    "",
                )
            )
            scipy_seconds, scipy = time_scipy(order, 1e-8, 1e-6, args.scipy_repeats)
            scipy_error = relative(scipy.peak_backplate_force, truth)
            speedups.append(scipy_seconds / seconds)
            rows.append(
                (
                    "",
                    "scipy DOP853 over numpy, rtol 1e-8, atol 1e-6",
                    f"{scipy_seconds * 1e3:.1f}",
                    scipy.n_rhs,
                    f"{scipy.peak_backplate_force:.6f}",
                    f"{scipy_error:.1e}",
                    f"{speedups[-1]:.0f}x",
                )
            )
            for rtol in MATCHING_RTOLS:
                matched_seconds, matched = time_scipy(order, rtol, rtol * 1e-2, args.scipy_repeats)
                matched_error = relative(matched.peak_backplate_force, truth)
                if matched_error <= error:
                    break
            reached = matched_error <= error
            if reached:
                equal_speedups.append(matched_seconds / seconds)
            rows.append(
                (
                    "",
                    f"scipy at the FMU's accuracy (rtol {rtol:g}, atol {rtol * 1e-2:g})"
                    + ("" if reached else ": not reached"),
                    f"{matched_seconds * 1e3:.1f}",
                    matched.n_rhs,
                    f"{matched.peak_backplate_force:.6f}",
                    f"{matched_error:.1e}",
                    f"{matched_seconds / seconds:.0f}x" if reached else "",
                )
            )

    equal = (
        f"{span(equal_speedups, '{:.0f}')}x faster than scipy at the FMU's accuracy or better"
        if equal_speedups
        else f"scipy did not reach the FMU's accuracy by rtol {MATCHING_RTOLS[-1]:g}"
    )
    headline = (
        f"one 8 s evaluation: the FMU is {span(speedups, '{:.0f}')}x faster than the study's scipy route "
        f"and {equal}; the FMU's error {span(fmu_errors, '{:.1e}')}"
    )
    page = Page(
        name=run.name,
        title="FMU speed and accuracy against scipy",
        headline=headline,
        summary=(
            f"One evaluation of the study's scene ({FULL_HORIZON:g} s, peak over the 0.01 s samples, receiver rule) "
            f"for the two published orders, {', '.join(order_text(o) for o in ORDERS.values())}. Times are wall "
            f"seconds of the fastest of {args.repeats} FMU runs and of {args.scipy_repeats} scipy run(s) per "
            "setting, through `orchestrator.simulation.LatticeFMU` (reset, parameters, one doStep, outputs) and "
            "`reference.simulate` (scipy's `solve_ivp` over the vectorised numpy model of `reference/`). The "
            "error is relative to the FMU at rtol 1e-13, atol 1e-15 on the same order. At its defaults the FMU "
            f"gives the published peaks to {span(published_errors, '{:.1e}')} (relative)."
        ),
        tables=(
            Table(
                ("order", "route", "ms per evaluation", "right-hand sides", "peak (N)", "error", "scipy / FMU"),
                tuple(rows),
            ),
        ),
    )
    write_page(run, page)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
