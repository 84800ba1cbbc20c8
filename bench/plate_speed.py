"""One evaluation of the 11 x 11 x 11 plate: CPU time, right-hand sides and accuracy, with and without symmetry.

    python -m bench.plate_speed            # both diagonal rules, 10 timing rounds (the page gives its run time)
    python -m bench.plate_speed --quick    # the receiver rule only, 3 timing rounds

Why: a search on the plate (docs/model.md section 10) evaluates thousands of designs, so what one evaluation
costs decides whether a search is practical, and a cost is worth only as much as the figure it buys. For the
scene ``plate_11x11x11`` under its centred 3 x 3 patch and under the whole face, both diagonal rules, and three
orders (the study's best, the sequential order, and the 11-column lattice's receiver-rule optimum), it times the
orchestrator's own tasks (``orchestrator.objective.FMURun`` from ``LatticeObjective.tasks``, what a worker of the
Evaluator calls): the search evaluation (the searches' solver, tolerance and horizon, re-run over the full
horizon when the plate is still touched near its end) and the 8 s evaluation at the FMU's default setting,
each with ``use_symmetry`` 1 (a quarter of the plate, x components only) and 0 (the whole plate). Times are CPU
seconds (``time.process_time``: the FMU runs on one thread, so one core's time) of the fastest of interleaved
rounds. Each peak is compared with a tight run (the FMU's DOP853 at rtol 1e-13, atol 1e-15, with symmetry, over
8 s); the energy balance of docs/model.md section 7 is read as tests/test_fmu.py reads it, from the outputs.
"""

from __future__ import annotations

import tempfile
import time
from dataclasses import dataclass

from fmpy import read_model_description

from builder.build import build_core_library
from fmu_src.core import Core
from fmu_src.variables import STATE_ORDER
from orchestrator.design import DesignSpace
from orchestrator.objective import FULL, SEARCH, LatticeObjective, close_instances
from orchestrator.simulation import LatticeFMU, declared_lattice_size
from orchestrator.types import Evaluation
from scenes import Scene

from .common import (
    BEST_KNOWN,
    FULL_HORIZON,
    SEQUENTIAL,
    STUDY_BEST,
    add_fmu_option,
    default_setting,
    lattice_fmu,
    order_text,
    relative,
    search_parameters,
    search_setting_text,
    setting_text,
    span,
)
from .measurements import Page, Run, Table, write_page

SCENE = "plate_11x11x11"
PATCHES = (3, 0)  # load_patch: the scene's centred 3 x 3 patch, and the whole face
RULES = ("receiver", "mean")
ORDERS = {"study's best": STUDY_BEST, "sequential": SEQUENTIAL, "2-D receiver optimum": BEST_KNOWN}
EVALUATIONS = (SEARCH, FULL)
SYMMETRIES = (1, 0)
TIGHT = {"rtol": 1e-13, "atol": 1e-15}  # at the FMU's default solver, DOP853
TIGHT_CHECK = {"rtol": 1e-12, "atol": 1e-14}  # how far the tight run itself moves from one decade looser
SEARCH_BUDGET_MS = 50.0  # CPU ms of one search evaluation on one core: the target the page answers
SYMMETRY_TARGET = 1e-9  # relative difference of the peaks with and without symmetry
BALANCE_TARGET = 1e-6  # of the external work
BALANCE_OUTPUTS = ("kinetic_energy", "potential_energy", "external_work", "dissipated_energy", "nonreciprocal_work")
PEAK = "peak_backplate_force"
ENERGY_INTEGRALS = tuple(name for name in STATE_ORDER if name[:2] not in ("ux", "uy", "uz", "vx", "vy", "vz"))


@dataclass(frozen=True)
class Case:
    """One load, rule and order of the plate."""

    patch: int
    rule: str
    label: str
    order: tuple[int, ...]

    @property
    def load(self) -> str:
        return f"{self.patch} x {self.patch} patch" if self.patch else "whole face"

    def parameters(self, symmetry: int) -> dict:
        return {"load_patch": self.patch, "diagonal_rule": self.rule, "use_symmetry": symmetry}


@dataclass(frozen=True)
class Timing:
    """The fastest CPU time of one evaluation over the rounds, and the evaluation (the same in every round)."""

    seconds: float
    evaluation: Evaluation

    @property
    def rhs(self) -> int:
        return int(self.evaluation.work)

    @property
    def us_per_rhs(self) -> float:
        return self.seconds * 1e6 / self.rhs

    @property
    def peak(self) -> float:
        return float(self.evaluation.value)

    @property
    def horizon(self) -> float:
        return float(self.evaluation.outputs.horizon)

    def output(self, name: str) -> float:
        return float(self.evaluation.outputs[name])


@dataclass(frozen=True)
class Accuracy:
    """The tight run of a case and the energy balance of its 8 s run at the default setting, sampled."""

    tight_peak: float
    tight_rhs: int
    tight_moved: float  # relative change of the tight peak from TIGHT_CHECK to TIGHT
    worst_sampled_balance: dict[int, float]  # use_symmetry -> max over every 0.01 s of |balance| / W_ext(end)


def integrated_states(
    core, shape: tuple[int, int, int], declared: int, patch: int, symmetry: int, load_angle: float
) -> int:
    """The continuous states the Co-Simulation solver integrates, as cosimulation.c's solver_layout chooses them
    from the core's own rules (asked of the compiled core, ``fmu_src.core.Core``): every state the FMU declares;
    under use_symmetry and a load along x only ux and vx and the energy integrals, of the part that carries a
    mirror-symmetric plate's solution."""
    import reference
    from fmu_src.core import params_from_scene

    rows, cols, depth = shape
    params = params_from_scene(reference.Scene(rows=rows, cols=cols, load_angle=load_angle), depth, patch)
    if not (symmetry and core.along_x(params)):
        return declared
    part_rows, part_depth = core.mirrored_extent(params)
    return 2 * part_rows * cols * part_depth + len(ENERGY_INTEGRALS)


def time_cases(path, cases, rounds: int) -> dict[tuple, Timing]:
    """Every case's search and 8 s evaluation with and without symmetry, the fastest of ``rounds`` interleaved
    rounds (after one round that opens the instance and is not counted)."""
    tasks = {}
    for case in cases:
        for symmetry in SYMMETRIES:
            objective = LatticeObjective(
                str(path), DesignSpace.permutations(len(case.order)), FULL_HORIZON, parameters=case.parameters(symmetry)
            )
            for evaluation in EVALUATIONS:
                tasks[(case, evaluation, symmetry)] = objective.tasks(evaluation)[0]
    best: dict[tuple, Timing] = {}
    try:
        for round_ in range(rounds + 1):
            for key, task in tasks.items():
                start = time.process_time()
                result = task(key[0].order)
                seconds = time.process_time() - start
                if not result.ok:
                    raise SystemExit(
                        f"{key[0].load}, {key[0].rule}, {order_text(key[0].order)}, {key[1]} "
                        f"evaluation, use_symmetry {key[2]}: failed: {result.message}"
                    )
                if round_ and (key not in best or seconds < best[key].seconds):
                    best[key] = Timing(seconds, result)
    finally:
        close_instances()
    return best


def accuracy(path, cases) -> dict[Case, Accuracy]:
    out = {}
    with LatticeFMU(path, instance_name="tight") as fmu:
        for case in cases:
            tight = fmu.simulate(
                case.order,
                horizon=FULL_HORIZON,
                parameters={**case.parameters(1), **TIGHT},
                outputs=(PEAK, "rhs_evaluations"),
            )
            check = fmu.simulate(
                case.order, horizon=FULL_HORIZON, parameters={**case.parameters(1), **TIGHT_CHECK}, outputs=(PEAK,)
            )
            worst = {}
            for symmetry in SYMMETRIES:  # tests/test_fmu.py's balance of the outputs, every 0.01 s
                result = fmu.simulate(
                    case.order,
                    horizon=FULL_HORIZON,
                    parameters=case.parameters(symmetry),
                    communication_step=0.01,
                    record=BALANCE_OUTPUTS,
                    outputs=BALANCE_OUTPUTS,
                )
                v = result.trajectory.values
                balance = (
                    v["external_work"]
                    + v["nonreciprocal_work"]
                    - v["kinetic_energy"]
                    - v["potential_energy"]
                    - v["dissipated_energy"]
                )
                worst[symmetry] = float(max(abs(balance)) / v["external_work"][-1])
            out[case] = Accuracy(tight[PEAK], int(tight["rhs_evaluations"]), relative(check[PEAK], tight[PEAK]), worst)
    return out


def ms(seconds: float) -> str:
    return f"{seconds * 1e3:.1f}"


def main(argv=None) -> int:
    run = Run.start(__file__, argv)
    parser = run.parser(__doc__, quick="the receiver rule only and 3 timing rounds")
    add_fmu_option(parser)
    parser.add_argument(
        "--rounds",
        type=int,
        default=None,
        help="interleaved timing rounds, the fastest counts (default 10, with --quick 3)",
    )
    args = parser.parse_args(argv)
    rules = ("receiver",) if args.quick else RULES
    if args.rounds is None:
        args.rounds = 3 if args.quick else 10
    if args.rounds < 1:
        parser.error(f"--rounds {args.rounds}: allowed values are whole numbers >= 1")

    scene = Scene.load(SCENE)
    load_angle = float(scene.parameter_values()["load_angle"])
    cases = [Case(patch, rule, label, order) for patch in PATCHES for rule in rules for label, order in ORDERS.items()]
    with lattice_fmu(args.fmu, scene=SCENE) as path:
        description = read_model_description(str(path))
        shape, whole_states = declared_lattice_size(path), len(description.derivatives)
        if shape != (scene.rows, scene.cols, scene.depth):
            raise SystemExit(
                f"--fmu {args.fmu}: its lattice is {' x '.join(map(str, shape or ()))}, the scene "
                f"{SCENE}'s {scene.rows} x {scene.cols} x {scene.depth} (rows x columns x depth): give "
                f"the FMU of the scene {SCENE}"
            )
        search_text = search_setting_text(search_parameters(path))
        default_text = setting_text(default_setting(path))
        timings = time_cases(path, cases, args.rounds)
        accuracies = accuracy(path, cases)

    with tempfile.TemporaryDirectory(prefix="plate_speed_core_", ignore_cleanup_errors=True) as folder:
        core = Core(build_core_library(folder))
        states = {
            (patch, symmetry): integrated_states(core, shape, whole_states, patch, symmetry, load_angle)
            for patch in PATCHES
            for symmetry in SYMMETRIES
        }
    cost_rows, accuracy_rows, balance_rows = [], [], []
    errors = {evaluation: [] for evaluation in EVALUATIONS}
    against_full, symmetry_differences, balances = [], [], []
    for case in cases:
        tight = accuracies[case]
        for evaluation in EVALUATIONS:
            with_, without = timings[(case, evaluation, 1)], timings[(case, evaluation, 0)]
            rhs = str(with_.rhs) if with_.rhs == without.rhs else f"{with_.rhs} / {without.rhs}"
            cost_rows.append(
                (
                    case.load,
                    case.rule,
                    case.label,
                    evaluation,
                    ms(with_.seconds),
                    ms(without.seconds),
                    rhs,
                    f"{with_.us_per_rhs:.1f}",
                    f"{without.us_per_rhs:.1f}",
                    f"{without.seconds / with_.seconds:.1f}x",
                )
            )
            error = relative(with_.peak, tight.tight_peak)
            errors[evaluation].append(error)
            full = timings[(case, FULL, 1)].peak
            if evaluation == SEARCH:
                against_full.append(relative(with_.peak, full))
            difference = relative(with_.peak, without.peak)
            symmetry_differences.append(difference)
            accuracy_rows.append(
                (
                    case.load,
                    case.rule,
                    case.label,
                    evaluation,
                    f"{with_.horizon:g}",
                    f"{with_.peak:.6f}",
                    f"{error:.1e}",
                    f"{relative(with_.peak, full):.1e}" if evaluation == SEARCH else "",
                    f"{difference:.1e}",
                )
            )
        full_with, full_without = timings[(case, FULL, 1)], timings[(case, FULL, 0)]
        ends = [abs(t.output("energy_balance_error")) / t.output("external_work") for t in (full_with, full_without)]
        sampled = [tight.worst_sampled_balance[s] for s in SYMMETRIES]
        balances.extend(ends + sampled)
        balance_rows.append(
            (
                case.load,
                case.rule,
                case.label,
                f"{full_with.output('external_work'):.4f}",
                f"{ends[0]:.1e}",
                f"{ends[1]:.1e}",
                f"{sampled[0]:.1e}",
                f"{sampled[1]:.1e}",
            )
        )
        accuracy_rows.append(
            (
                case.load,
                case.rule,
                case.label,
                "tight run",
                f"{FULL_HORIZON:g}",
                f"{tight.tight_peak:.6f}",
                f"{tight.tight_moved:.1e} (from rtol {TIGHT_CHECK['rtol']:g})",
                "",
                "",
            )
        )

    def seconds_of(evaluation, symmetry):
        return [timings[(c, evaluation, symmetry)].seconds for c in cases]

    search_with, search_without = seconds_of(SEARCH, 1), seconds_of(SEARCH, 0)
    full_with, full_without = seconds_of(FULL, 1), seconds_of(FULL, 0)
    budget = SEARCH_BUDGET_MS / 1e3

    def verdict(symmetry: int, what: str) -> str:
        worst_case = max(cases, key=lambda c: timings[(c, SEARCH, symmetry)].seconds)
        worst = timings[(worst_case, SEARCH, symmetry)]
        if worst.seconds < budget:
            return (
                f"{what}: **yes**, every search evaluation measured takes under {SEARCH_BUDGET_MS:g} ms of CPU "
                f"(the most {ms(worst.seconds)} ms: {worst_case.load}, {worst_case.rule} rule, "
                f"{worst_case.label})."
            )
        over = [c for c in cases if timings[(c, SEARCH, symmetry)].seconds >= budget]
        return (
            f"{what}: **no**, {len(over)} of {len(cases)} search evaluations take {SEARCH_BUDGET_MS:g} ms or more. "
            f"What stands in the way is the cost of a right-hand side over the states integrated "
            f"({states[(worst_case.patch, symmetry)]}): the most expensive ({worst_case.load}, {worst_case.rule} "
            f"rule, {worst_case.label}) takes {worst.rhs} right-hand sides at {worst.us_per_rhs:.1f} us each, "
            f"{ms(worst.seconds)} ms; at that many right-hand sides {SEARCH_BUDGET_MS:g} ms allows "
            f"{SEARCH_BUDGET_MS * 1e3 / worst.rhs:.1f} us each."
        )

    under = max(search_with) < budget
    headline = (
        f"11 x 11 x 11 plate: one search evaluation {span([s * 1e3 for s in search_with], '{:.1f}')} ms CPU with "
        f"symmetry ({'under' if under else 'not under'} {SEARCH_BUDGET_MS:g} ms), "
        f"{span([s * 1e3 for s in search_without], '{:.0f}')} ms on the whole plate; one 8 s evaluation "
        f"{span(full_with, '{:.3f}')} s, {span(full_without, '{:.2f}')} s; peak error at most "
        f"{max(errors[SEARCH]):.1e} (search), {max(errors[FULL]):.1e} (8 s); energy balance within "
        f"{max(balances):.1e} of the external work"
    )
    summary = (
        f"The scene `{SCENE}` ({scene.rows} rows x {scene.cols} columns x {scene.depth} masses deep: its "
        f"{scene.cols} layers are its columns, one material each), under the centred 3 x 3 patch (`load_patch` 3, "
        "the scene's) and the whole face (`load_patch` 0), "
        f"the {' and '.join(rules)} rule{'s' if len(rules) > 1 else ''}, and the orders "
        + ", ".join(f"{label} {order_text(order)}" for label, order in ORDERS.items())
        + f". **search**: the orchestrator's search evaluation ({search_text}; re-run over {FULL_HORIZON:g} s when "
        f"the last contact falls in the horizon's last tenth: the horizon column says which ran). **full**: the "
        f"{FULL_HORIZON:g} s evaluation at the FMU's default ({default_text}). Each was run through the task the "
        "Evaluator hands its workers (`FMURun`: reset, parameters, one doStep, every output read), with "
        f"`use_symmetry` 1 and 0, the fastest CPU time of {args.rounds} interleaved "
        f"round{'s' if args.rounds > 1 else ''}. States integrated: with "
        f"symmetry {span([states[(p, 1)] for p in PATCHES], '{:d}')} (ux and vx of the quarter up to the middle row "
        f"and the middle slice in depth, and the {len(ENERGY_INTEGRALS)} energy integrals), without it "
        f"{whole_states} (every state the FMU declares), as the FMU's solver lays them out. The right-hand "
        "sides are the FMU's counter (`rhs_evaluations`, both runs when the search re-ran); microseconds per "
        "right-hand side are the run's CPU time over that count, so they include everything else the run does.\n\n"
        f"**One search evaluation under {SEARCH_BUDGET_MS:g} ms of CPU on one core?** "
        + verdict(1, "With symmetry (a centred load along x, what the scene is)")
        + " "
        + verdict(0, "Without it (every state of the whole plate, what a load at an angle integrates)")
    )
    notes = (
        f"Accuracy: *error* is the relative error of the sampled peak (`{PEAK}`) against the tight run, the FMU's "
        f"DOP853 at rtol {TIGHT['rtol']:g}, atol {TIGHT['atol']:g}, with symmetry, over {FULL_HORIZON:g} s (its own "
        f"right-hand sides: {span([a.tight_rhs for a in accuracies.values()], '{:d}')}; its row gives how far it "
        f"moved from rtol {TIGHT_CHECK['rtol']:g}). A search ranks designs by the search evaluation's peak, which "
        f"stands for the {FULL_HORIZON:g} s peak of docs/model.md section 6 (`orchestrator/objective.py`: the short "
        f"horizon is trusted only when the plate was left before its last tenth, else the design is re-run over "
        f"{FULL_HORIZON:g} s), and the designs it finishes with are evaluated and reported at "
        f"the full fidelity: so the search figure's error is given against the tight {FULL_HORIZON:g} s peak and "
        f"against the {FULL_HORIZON:g} s evaluation's peak (at most {max(against_full):.1e}). *use_symmetry 1 "
        f"against 0* is the relative difference of the two peaks (target {SYMMETRY_TARGET:g}; at most "
        f"{max(symmetry_differences):.1e}).",
        f"Energy balance (docs/model.md section 7): |external_work + nonreciprocal_work - kinetic_energy - "
        f"potential_energy - dissipated_energy| over the external work of the {FULL_HORIZON:g} s run at the FMU's "
        "default: at its end (the FMU's `energy_balance_error`, from the timed runs) and the largest over the "
        f"outputs every 0.01 s (a run recording them, as tests/test_fmu.py checks it); target {BALANCE_TARGET:g}, "
        f"at most {max(balances):.1e}.",
    )
    page = Page(
        name=run.name,
        title="One evaluation of the 11 x 11 x 11 plate: cost and accuracy",
        headline=headline,
        summary=summary,
        tables=(
            Table(
                (
                    "load",
                    "rule",
                    "order",
                    "evaluation",
                    "CPU ms, symmetry",
                    "CPU ms, whole plate",
                    "right-hand sides",
                    "us per right-hand side, symmetry",
                    "us per right-hand side, whole plate",
                    "whole / symmetry",
                ),
                tuple(cost_rows),
                caption="**Cost of one evaluation:**",
            ),
            Table(
                (
                    "load",
                    "rule",
                    "order",
                    "evaluation",
                    "horizon run (s)",
                    "peak (N), symmetry",
                    "error against the tight run",
                    f"error against the {FULL_HORIZON:g} s evaluation",
                    "use_symmetry 1 against 0",
                ),
                tuple(accuracy_rows),
                caption="**Accuracy of its peak:**",
            ),
            Table(
                (
                    "load",
                    "rule",
                    "order",
                    "external work (J)",
                    "balance at the end, symmetry",
                    "at the end, whole plate",
                    "worst every 0.01 s, symmetry",
                    "worst every 0.01 s, whole plate",
                ),
                tuple(balance_rows),
                caption=f"**Energy balance of the {FULL_HORIZON:g} s evaluation** (relative to the external work):",
            ),
        ),
        notes=notes,
    )
    write_page(run, page)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
