"""The projectile's finding (docs/model.md section 11): does the pulse's best order survive a body that answers back?

    python -m bench.projectile_finding            # about 6 min on 2 cores
    python -m bench.projectile_finding --quick    # about 4 min: fewer orders and a smaller settling budget

Why: the study loads the armour with a prescribed pulse (1200 N for 0.15 s, 180 N s); a real threat is a body
whose force depends on the armour it hits. The FMU's projectile mode (``load_mode`` projectile: a rigid body in
Hunt-Crossley contact with column 1's face, its default momentum the pulse's) is searched with the orchestrator's
own studies (``run_in_folder``, the steps ``python orchestrator/run.py`` runs), under both diagonal rules:

- *the search horizon*: the horizon study's check (``bench.horizon_study``'s logic) under the projectile: per
  order one run to 8 s with DOP853 at rtol 1e-10 (the truth) read every 0.25 s, and one run with the searches'
  solver and tolerance, on random orders, the sequential order and each rule's certified pulse optimum with its
  55 single swaps. The projectile scene's search horizon (``scenes/projectile_11x11.json``) must give every
  order's 8 s peak with no order still touching the plate in its last tenth, or the benchmark stops;
- *11 x 7, certified*: the 11 x 7 lattice (the study's first 7 materials, 5,040 orders) swept and certified under
  the projectile (``--load-mode projectile --cols 7 --method exhaustive``), against the pulse's certified 11 x 7
  optimum (the same sweep under the pulse) evaluated under the projectile: its peak, its excess over the
  projectile's optimum and its rank among the 5,040 orders at the search fidelity (every order screened with
  its value kept). The other way round too: the projectile's optimum under the pulse;
- *11 x 11, searched*: ``python orchestrator/run.py --load-mode projectile`` as it is (its wall time is the
  run time the README states), and its searches again at the budget its report gives to settle an answer few
  runs reached (ten times the default), against the pulse's certified 11 x 11 optima
  (``orchestrator/known_optima.json``) evaluated under the projectile: their peak, their excess over the best
  order found, and how many of the designs the searches evaluated lie below them.

Every peak in the tables is the sampled peak over 8 s at the FMU's default setting (the answers' full fidelity),
computed here through ``FMURun`` and the Evaluator; each answer's own reported peak must agree with it to 1e-9 or
the benchmark stops.
"""

from __future__ import annotations

import math
import statistics
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

from orchestrator.design import DesignSpace
from orchestrator.executors import make_executor
from orchestrator.known_optima import known_optima
from orchestrator.loop import Evaluator
from orchestrator.fmu import prepare_fmu
from orchestrator.objective import (
    SEARCH,
    SEARCH_HORIZON,
    SEARCH_RTOL,
    SEARCH_SOLVER,
    FMURun,
    LatticeObjective,
    RecordRun,
    close_instances,
)
from orchestrator.runner import RunConfig, run_in_folder
from orchestrator.steps import STEPS, Answers, Exhaustive, Searches
from orchestrator.steps.answers import BUDGET_FACTOR
from orchestrator.steps.searches import SearchesConfig
from orchestrator.steps.sensitivity import Sensitivity, SensitivityConfig
from orchestrator.study import PROJECTILE, CaseConfig, SearchFidelity, search_fidelity
from scenes import DEFAULT_SCENE, PROJECTILE_SCENE, Scene

from .common import (
    FULL_HORIZON,
    check_agrees,
    order_text,
    percent,
    random_orders,
    rank_of,
    relative,
    screened_values,
    search_parameters,
)
from .horizon_study import RECORD, SAME, STEP, TOP, TRUTH, at, kendall_tau, swaps
from .measurements import Page, Run, Table, write_page

RULES = ("mean", "receiver")
SWEPT_COLUMNS = 7
HORIZONS = (0.5, 0.75, 1.0, 1.25, 1.5, 2.0, 3.0, 4.0)  # s: each a multiple of STEP, compared with 8 s
RTOLS = (SEARCH_RTOL, 3e-6, 1e-6, 3e-7)  # the searches' solver at these tolerances against the truth
GUARD = 0.9  # an order touching the plate after this fraction of a horizon is re-run by the searches (CONTACT_GUARD)
PROJECTILE_PARAMETERS = {"load_mode": PROJECTILE}

COSTS: list[tuple] = []  # (study, methods, wall seconds) of every study this run made


@dataclass(frozen=True)
class Setting:
    random_orders: int
    workers: int
    sensitivity: bool
    settle_budget: int  # the 11 x 11 searches' budget that settles an answer (the report's suggestion)


def study(
    folder: Path, case: CaseConfig, setting: Setting, methods: tuple[str, ...] | None = None, budget: int | None = None
):
    """The orchestrator's own study of ``case``: with neither ``methods`` nor ``budget``, every step at its default
    (what ``python orchestrator/run.py`` runs with the case's options); else those methods (a sweep) or the
    default searches at that budget, sensitivity off."""
    configs = {}
    if methods is not None:
        configs[Searches] = SearchesConfig(methods=methods, budget=1)
    elif budget is not None:
        configs[Searches] = SearchesConfig(budget=budget)
    if methods is not None or budget is not None or not setting.sensitivity:
        configs[Sensitivity] = SensitivityConfig(enabled=False)
    start = time.perf_counter()
    outcome = run_in_folder(RunConfig(out=str(folder), workers=setting.workers, progress=False), case, configs, STEPS)
    seconds = time.perf_counter() - start
    searches = outcome.study.result(Searches)
    COSTS.append(
        (
            outcome.study.case.line(),
            " ".join(methods) if methods else f"{' '.join(searches.methods)}, budget {searches.budget}",
            f"{seconds:.0f}",
        )
    )
    return outcome, seconds


def evaluator_run(tasks, workers: int) -> list:
    with make_executor("process", workers=workers) as executor:
        results = Evaluator(executor).run(tasks)
    close_instances()
    return results


def full_peaks(fmu_path, parameters: dict, orders, workers: int) -> dict:
    """The sampled 8 s peak of each order at the FMU's default setting, through the Evaluator."""
    run = FMURun(str(fmu_path), FULL_HORIZON, tuple(sorted(parameters.items())))
    orders = list(dict.fromkeys(tuple(order) for order in orders))
    with make_executor("process", workers=workers) as executor:
        evaluations = Evaluator(executor).evaluate([(run, order) for order in orders])
    close_instances()
    bad = [e for e in evaluations if not e.ok]
    if bad:
        raise SystemExit(f"{len(bad)} full evaluations failed, first {order_text(bad[0].order)}: {bad[0].message}")
    return {e.order: e.value for e in evaluations}


def pulse_optima_11x11() -> dict:
    return {k.diagonal_rule: k for k in known_optima() if k.rows == 11 and k.columns == 11 and k.depth == 1}


@dataclass(frozen=True)
class HorizonCheck:
    rows: tuple[tuple, ...]  # one per rule and horizon
    tolerance_rows: tuple[tuple, ...]  # one per rule and tolerance
    needed: float  # the shortest horizon of HORIZONS that every rule's orders pass
    loosest_rtol: float | None  # the loosest of RTOLS whose worst error is below a tenth of the smallest gap
    latest_contact: float
    latest_peak: float
    smallest_gap: float
    orders: int


def horizon_check(fmu_path, search_horizon: float, search_rtol: float, setting: Setting) -> HorizonCheck:
    """bench.horizon_study's check under the projectile, for both rules: peaks at each horizon against 8 s (the
    truth), the last contact with the plate, and the searches' solver at each tolerance against the truth."""
    search = {**search_parameters(fmu_path), **PROJECTILE_PARAMETERS}
    optima = pulse_optima_11x11()
    kinds: dict[tuple, str] = {}
    for order in random_orders(setting.random_orders, 7):
        kinds.setdefault(order, "random")
    for rule in RULES:
        kinds[optima[rule].order] = "neighbourhood"
        for order in swaps(optima[rule].order):
            kinds.setdefault(order, "neighbourhood")
    orders = list(kinds)
    horizons = sorted(set(HORIZONS + (search_horizon,)))
    rtols = sorted(set(RTOLS + (search_rtol,)), reverse=True)

    def recorded(order, horizon, parameters):
        return RecordRun(str(fmu_path), order, horizon, STEP, tuple(sorted(parameters.items())), RECORD)

    rows, by_rule, needed, contacts, peaks, gaps = [], {}, [], [], [], []
    for rule in RULES:
        truth_parameters = {**TRUTH, **PROJECTILE_PARAMETERS, "diagonal_rule": rule}
        tasks = [recorded(o, FULL_HORIZON, truth_parameters) for o in orders]
        for rtol in rtols:
            searched = {**search, "diagonal_rule": rule, "rtol": rtol, "atol": rtol * 1e-2}
            tasks += [recorded(o, search_horizon, searched) for o in orders]
        results = evaluator_run(tasks, setting.workers)
        failed = [t for t in results if not t.ok]
        if failed:
            raise SystemExit(f"{len(failed)} runs failed, first {order_text(failed[0].order)}: {failed[0].message}")
        truth = dict(zip(orders, results[: len(orders)]))
        final = {o: at(truth[o], FULL_HORIZON) for o in orders}
        passing = []
        for h in horizons:
            values = {o: at(truth[o], h) for o in orders}
            diffs = [
                max(
                    relative(values[o]["peak_backplate_force"], final[o]["peak_backplate_force"]),
                    relative(values[o]["peak_backplate_force_continuous"], final[o]["peak_backplate_force_continuous"]),
                )
                for o in orders
            ]
            differ = sum(d > SAME for d in diffs)
            guard = sum(1 for o in orders if values[o]["last_contact_time"] >= GUARD * h)
            if not differ and not guard:
                passing.append(h)
            rows.append(
                (
                    rule,
                    f"{h:g} s" + (" (the projectile's search horizon)" if h == search_horizon else ""),
                    differ,
                    f"{max(diffs):.1e}",
                    guard,
                )
            )
        needed.append(min(passing) if passing else math.inf)
        contacts += [final[o]["last_contact_time"] for o in orders]
        peaks += [final[o]["peak_time"] for o in orders]
        true_peak = {o: final[o]["peak_backplate_force"] for o in orders}
        rule_gaps = []
        for name in ("random", "neighbourhood"):
            best = sorted([o for o in orders if kinds[o] == name], key=true_peak.get)[:TOP]
            rule_gaps.append(min(relative(true_peak[b], true_peak[a]) for a, b in zip(best, best[1:])))
        gaps.append(min(rule_gaps))
        for k, rtol in enumerate(rtols):
            part = results[len(orders) * (k + 1) : len(orders) * (k + 2)]
            at_search = {o: at(t, search_horizon)["peak_backplate_force"] for o, t in zip(orders, part)}
            errors = [relative(at_search[o], true_peak[o]) for o in orders]
            kept, taus = [], []
            for name in ("random", "neighbourhood"):
                members = [o for o in orders if kinds[o] == name]
                best = sorted(members, key=true_peak.get)[:TOP]
                kept.append("yes" if best == sorted(members, key=at_search.get)[:TOP] else "no")
                taus.append(f"{kendall_tau([true_peak[o] for o in members], [at_search[o] for o in members]):.4f}")
            by_rule[(rule, rtol)] = (
                max(errors),
                (
                    rule,
                    f"{rtol:g}" + (" (the projectile's searches')" if rtol == search_rtol else ""),
                    f"{max(errors):.1e}",
                    f"{statistics.median(errors):.1e}",
                    f"{min(rule_gaps):.1e}",
                    f"{max(errors) / min(rule_gaps):.2f}",
                    *kept,
                    *taus,
                ),
            )
    smallest_gap = min(gaps)
    safe = [r for r in rtols if all(by_rule[(rule, r)][0] < smallest_gap / 10 for rule in RULES)]
    return HorizonCheck(
        tuple(rows),
        tuple(by_rule[(rule, r)][1] for rule in RULES for r in rtols),
        max(needed),
        max(safe) if safe else None,
        max(contacts),
        max(peaks),
        smallest_gap,
        len(orders),
    )


def seven_columns(root: Path, setting: Setting, fidelity: SearchFidelity, log) -> tuple[list, list]:
    """The 11 x 7 lattice swept under the pulse and under the projectile: rows of the table, and findings."""
    pulse, seconds = study(
        root / "pulse_11x7", CaseConfig(cols=SWEPT_COLUMNS, diagonal_rules=RULES), setting, ("exhaustive",)
    )
    log(f"{pulse.study.case.line()}: swept in {seconds:.0f} s")
    struck, seconds = study(
        root / "projectile_11x7",
        CaseConfig(cols=SWEPT_COLUMNS, load_mode=PROJECTILE, diagonal_rules=RULES),
        setting,
        ("exhaustive",),
    )
    log(f"{struck.study.case.line()}: swept in {seconds:.0f} s")
    fmu = struck.study.fmu_path
    if fmu != pulse.study.fmu_path:
        raise SystemExit(f"the pulse and the projectile ran two FMUs ({pulse.study.fmu_path}, {fmu})")
    space = DesignSpace.permutations(SWEPT_COLUMNS)
    rows, findings = [], []
    for rule in RULES:
        certificate = struck.study.result(Exhaustive).for_rule(rule).certificate
        pulse_certificate = pulse.study.result(Exhaustive).for_rule(rule).certificate
        if certificate.optimum is None or pulse_certificate.optimum is None:
            raise SystemExit(f"{rule} rule: a sweep has no optimum ({'; '.join(certificate.reasons)})")
        optimum, pulse_optimum = certificate.optimum.order, pulse_certificate.optimum.order
        struck_peaks = full_peaks(
            fmu, {"diagonal_rule": rule, **PROJECTILE_PARAMETERS}, [optimum, pulse_optimum], setting.workers
        )
        pulse_peaks = full_peaks(fmu, {"diagonal_rule": rule}, [optimum, pulse_optimum], setting.workers)
        check_agrees(f"{rule}: the projectile's optimum", certificate.optimum.full, struck_peaks[optimum])
        check_agrees(f"{rule}: the pulse's optimum", pulse_certificate.optimum.full, pulse_peaks[pulse_optimum])
        values = screened_values(
            fmu,
            space,
            setting.workers,
            {"diagonal_rule": rule, **PROJECTILE_PARAMETERS},
            search_horizon=fidelity.horizon,
            search_rtol=fidelity.rtol,
        )
        rank, screened = rank_of(pulse_optimum, space, values)
        rows.append(
            (
                rule,
                order_text(optimum),
                f"{struck_peaks[optimum]:.2f}",
                f"{certificate.gap:.3f}" if certificate.gap is not None else "n/a",
                "yes" if certificate.certified else "no: " + "; ".join(certificate.reasons),
                order_text(pulse_optimum),
                f"{struck_peaks[pulse_optimum]:.2f}",
                percent(struck_peaks[pulse_optimum], struck_peaks[optimum]),
                f"{rank:,} of {screened:,}",
                percent(pulse_peaks[optimum], pulse_peaks[pulse_optimum]),
            )
        )
        findings.append(
            (
                rule,
                optimum == pulse_optimum,
                struck_peaks[pulse_optimum] / struck_peaks[optimum] - 1.0,
                rank,
                certificate.certified,
            )
        )
    return rows, findings


def eleven_columns(root: Path, setting: Setting, fidelity: SearchFidelity, log) -> tuple[list, list, float]:
    """``python orchestrator/run.py --load-mode projectile``, and its searches at the budget its report gives to
    settle an answer few runs reached, against the pulse's certified 11 x 11 optima."""
    outcome, seconds = study(root / "projectile_11x11", CaseConfig(load_mode=PROJECTILE), setting)
    log(f"{outcome.study.case.line()}: the default study in {seconds:.0f} s")
    settled, settled_seconds = study(
        root / "projectile_11x11_settled", CaseConfig(load_mode=PROJECTILE), setting, budget=setting.settle_budget
    )
    log(f"the same at budget {setting.settle_budget} in {settled_seconds:.0f} s")
    fmu = outcome.study.fmu_path
    optima = pulse_optima_11x11()
    rows, findings = [], []
    for rule in RULES:
        answers = {
            name: o.study.result(Answers).for_rule(rule) for name, o in (("default", outcome), ("settled", settled))
        }
        pulse = optima[rule]
        parameters = {"diagonal_rule": rule, **PROJECTILE_PARAMETERS}
        peaks = full_peaks(fmu, parameters, [a.order for a in answers.values()] + [pulse.order], setting.workers)
        for name, answer in answers.items():
            check_agrees(f"{rule}: the projectile's answer ({name})", answer.peak, peaks[answer.order])
        best = min((a.order for a in answers.values()), key=peaks.get)
        objective = LatticeObjective(
            fmu,
            DesignSpace.permutations(11),
            FULL_HORIZON,
            parameters=parameters,
            search_horizon=fidelity.horizon,
            search_rtol=fidelity.rtol,
        )
        with make_executor("process", workers=setting.workers) as executor:
            (screened,) = objective.evaluate([pulse.order], Evaluator(executor), SEARCH)
        close_instances()
        if not screened.ok:
            raise SystemExit(f"{rule}: the pulse's optimum failed at the search fidelity: {screened.message}")
        evaluated = {
            e.order: e
            for o in (outcome, settled)
            for run in o.study.result(Searches).runs_for(rule)
            for e in run.evaluations
        }
        below = sum(1 for e in evaluated.values() if e.ok and e.order != pulse.order and e.value < screened.value)

        def answered(answer) -> tuple[str, str, str]:
            evidence = answer.evidence
            return (
                order_text(answer.order),
                f"{peaks[answer.order]:.2f}",
                f"{evidence.status.replace('_', ' ')}; {evidence.runs_reaching} of {evidence.runs} search runs",
            )

        rows.append(
            (
                rule,
                *answered(answers["default"]),
                *answered(answers["settled"]),
                order_text(pulse.order),
                f"{pulse.peak:.2f}",
                f"{peaks[pulse.order]:.2f}",
                percent(peaks[pulse.order], peaks[best]),
                f"{below:,} of {len(evaluated):,}",
            )
        )
        findings.append(
            (
                rule,
                best == pulse.order,
                peaks[pulse.order] / peaks[best] - 1.0,
                below,
                answers["default"].order == answers["settled"].order,
            )
        )
    return rows, findings, seconds


def main(argv=None) -> int:
    run = Run.start(__file__, argv)
    parser = run.parser(
        __doc__,
        quick="40 random orders in the horizon check, the 11 x 11 study without "
        "sensitivity, its settling searches at twice the default budget",
    )
    parser.add_argument("--workers", type=int, default=2, help="worker processes of every study and check")
    parser.add_argument(
        "--orders",
        type=int,
        default=100,
        help="random orders of the horizon check (besides the pulse optima and their swaps)",
    )
    args = parser.parse_args(argv)
    default_budget = SearchesConfig().budget
    setting = Setting(
        random_orders=min(args.orders, 40) if args.quick else args.orders,
        workers=args.workers,
        sensitivity=not args.quick,
        settle_budget=default_budget * (2 if args.quick else BUDGET_FACTOR),
    )
    fidelity = search_fidelity(PROJECTILE)

    def log(text: str) -> None:
        print(text, flush=True)

    fmu = prepare_fmu(Scene.load(DEFAULT_SCENE)).path  # the armour FMU the 11 x 11 study runs
    check = horizon_check(fmu, fidelity.horizon, fidelity.rtol, setting)
    log(
        f"horizon check: {check.orders} orders per rule, every peak by {check.needed:g} s, rtol "
        f"{check.loosest_rtol} keeps the errors below a tenth of the smallest gap"
    )
    if check.needed > fidelity.horizon:
        raise SystemExit(
            f"under the projectile the peaks need a search horizon of {check.needed:g} s, "
            f"scenes/{PROJECTILE_SCENE}.json gives {fidelity.horizon:g} s: set its search_horizon"
        )
    if check.loosest_rtol is None or fidelity.rtol > check.loosest_rtol:
        raise SystemExit(
            f"under the projectile the searches' errors at rtol {fidelity.rtol:g} are not below a tenth "
            f"of the smallest gap ({check.smallest_gap:.1e}): set search_rtol in "
            f"scenes/{PROJECTILE_SCENE}.json to {check.loosest_rtol} or tighter"
        )
    with tempfile.TemporaryDirectory(prefix="projectile_finding_") as folder:
        seven_rows, seven = seven_columns(Path(folder), setting, fidelity, log)
        eleven_rows, eleven, seconds = eleven_columns(Path(folder), setting, fidelity, log)

    survived = [f for f in seven if f[1]]
    worst = max(seven, key=lambda f: f[2])
    above = [100 * f[2] for f in eleven]
    headline = (
        f"11 x 7, certified under the projectile: the pulse's optimum is the projectile's in {len(survived)} "
        f"of {len(seven)} rules, at worst {100 * worst[2]:.1f}% above it ({worst[0]} rule: rank {worst[3]:,} "
        f"of 5,040); 11 x 11, searched: the pulse's certified optimum is {min(above):.2f}-{max(above):.2f}% "
        f"above the best order found under the projectile; searched over {fidelity.horizon:g} s at rtol "
        f"{fidelity.rtol:g} (the contact ends by {check.latest_contact:.2f} s); `run.py --load-mode "
        f"projectile` took {seconds:.0f} s"
    )
    horizon_table = Table(
        (
            "rule",
            "horizon",
            "orders whose peak differs from the 8 s peak",
            "largest relative difference",
            f"orders still touching the plate after {GUARD:g} of it (re-run over the full horizon)",
        ),
        check.rows,
        caption=f"**Shorter horizons against 8 s under the projectile** ({check.orders} orders per rule):",
    )
    tolerance_table = Table(
        (
            "rule",
            "rtol",
            "worst error",
            "median error",
            "smallest top-10 gap",
            "worst error / gap",
            "top 10 kept, random set",
            "top 10 kept, neighbourhood",
            "Kendall tau, random set",
            "Kendall tau, neighbourhood",
        ),
        check.tolerance_rows,
        caption=(
            f"**The searches' solver** ({SEARCH_SOLVER}, atol = rtol / 100, read at {fidelity.horizon:g} s) at "
            "each tolerance against the truth at 8 s:"
        ),
    )
    seven_table = Table(
        (
            "rule",
            "projectile: certified optimum",
            "its peak (N)",
            "runner-up gap (N)",
            "certified",
            "pulse's certified optimum",
            "its peak under the projectile (N)",
            "above the projectile's optimum (%)",
            "its rank under the projectile (search fidelity)",
            "the projectile's optimum under the pulse, above the pulse's optimum (%)",
        ),
        tuple(seven_rows),
        caption=f"**11 x {SWEPT_COLUMNS}** (the study's materials 1-{SWEPT_COLUMNS}, 5,040 orders), "
        "swept under the projectile and under the pulse",
    )
    eleven_table = Table(
        (
            "rule",
            "projectile, default study: best found",
            "its peak (N)",
            "evidence",
            f"projectile, budget {setting.settle_budget}: best found",
            "its peak (N)",
            "evidence",
            "pulse's certified optimum",
            "its peak under the pulse (N)",
            "its peak under the projectile (N)",
            "above the best found under the projectile (%)",
            "designs the searches evaluated below it (search fidelity)",
        ),
        tuple(eleven_rows),
        caption=(
            "**11 x 11** (11! orders): `python orchestrator/run.py --load-mode projectile`, and the same "
            f"searches at `--budget {setting.settle_budget}` (the budget its report gives to settle an answer "
            "fewer than half the runs reached), sensitivity off"
        ),
    )
    projectile = Scene.load(PROJECTILE_SCENE).parameter_values()
    page = Page(
        name=run.name,
        title="The projectile's finding: the pulse's optimum under a body that answers back",
        headline=headline,
        summary=(
            f"The study's 11-row armour lattice struck by the default projectile (docs/model.md section 11): "
            f"{projectile['projectile_mass']:g} kg at {projectile['projectile_speed']:g} m/s, Hunt-Crossley "
            f"contact k_c {projectile['contact_stiffness']:g}, n {projectile['contact_exponent']:g}, lambda "
            f"{projectile['contact_damping']:g} s/m, against the pulse of 1200 N for 0.15 s it replaces; both "
            "diagonal rules. Peaks: the sampled peak over 8 s at the FMU's default setting, through the "
            f"Evaluator. The search fidelity under the projectile: {SEARCH_SOLVER} at rtol {fidelity.rtol:g} over "
            f"{fidelity.horizon:g} s (scenes/{PROJECTILE_SCENE}.json; the pulse's: rtol {SEARCH_RTOL:g} over "
            f"{SEARCH_HORIZON:g} s), checked first. The studies are the "
            f"orchestrator's own (`run_in_folder`), each on {setting.workers} worker processes."
        ),
        tables=(
            horizon_table,
            tolerance_table,
            seven_table,
            eleven_table,
            Table(("study", "methods", "wall s"), tuple(COSTS), caption="What each study cost"),
        ),
        notes=(
            f"The horizon check: {check.orders} orders per rule ({setting.random_orders} random ones, seed 7, and "
            "each rule's certified pulse optimum with its 55 single swaps). The continuous peak comes by "
            f"{check.latest_peak:.3f} s and the last contact with the plate ends by {check.latest_contact:.3f} s; "
            f"the shortest horizon tried that gives every order's 8 s peak with no order touching the plate in its "
            f"last tenth is {check.needed:g} s. The smallest relative gap between neighbours among the best 10 "
            f"orders (random set or neighbourhood, either rule) is {check.smallest_gap:.1e}; the loosest tolerance "
            "whose worst error is below a tenth of it (the pulse's criterion, bench.horizon_study): rtol "
            + (f"{check.loosest_rtol:g}." if check.loosest_rtol else "none of those tried."),
            "A certified optimum is the sweep's (every order screened, the best re-run at full fidelity and by a "
            "second integrator, the screening bound held); a best found is the searches' answer and says nothing "
            "of orders they did not evaluate.",
            "The last column of the 11 x 7 table reads the comparison the other way: the projectile's optimum "
            "under the pulse, above the pulse's own optimum.",
        ),
    )
    write_page(run, page)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
