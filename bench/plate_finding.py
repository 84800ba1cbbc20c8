"""The finding of the plate (docs/model.md section 10): does the 2-D study's best order survive in three dimensions?

    python -m bench.plate_finding            # about 7 min on 2 idle cores: plates 11 masses deep
    python -m bench.plate_finding --quick    # about 3 min: plates 3 masses deep, smaller search budgets

Why: the study optimises a 2-D lattice loaded over its whole face; a designer's plate is struck over a
projectile's footprint and spreads the load sideways in two directions. For each load (a centred 3 x 3 patch
and the whole face) and each diagonal rule this page answers it with the orchestrator's own studies
(``run_in_folder``, the steps ``python orchestrator/run.py`` runs, sensitivity off):

- *7 layers, certified*: the 11 x 7 x 11 plate (the study's first 7 materials, 5,040 orders) swept
  (``--method exhaustive``) and certified, against the 11 x 7 lattice's optimum certified by the same sweep
  in 2-D, evaluated in the plate: its peak, its excess over the plate's optimum, and its rank among the 5,040
  orders at the search fidelity (every order screened with its value kept, ``orchestrator.exhaustive.ScreenChunk``
  through the Evaluator). The plate's optimum is also evaluated in the 2-D lattice, the other way round.
- *11 layers, searched*: the 11 x 11 x 11 plate (11! orders, beyond a sweep on this machine) searched by
  CMA-ES, particle swarm and simulated annealing (the random and sequential baselines beside them), and its
  answer with its evidence, against the 11 x 11 lattice's certified optima (``orchestrator/known_optima.json``)
  and the study's published best order, each evaluated in the plate.

Every peak in the tables is the sampled peak over 8 s at the FMU's default setting (the answers' full
fidelity), computed here through ``FMURun`` and the Evaluator; each answer's own reported peak must agree with it
to 1e-9 or the benchmark stops.
"""

from __future__ import annotations

import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

from fmu_src.published import STUDY_BEST_ORDER
from orchestrator.design import DesignSpace
from orchestrator.executors import make_executor
from orchestrator.known_optima import known_optima
from orchestrator.loop import Evaluator
from orchestrator.objective import FMURun, close_instances
from orchestrator.runner import RunConfig, run_in_folder
from orchestrator.steps import STEPS, Answers, Exhaustive, Searches
from orchestrator.steps.searches import SearchesConfig
from orchestrator.steps.sensitivity import Sensitivity, SensitivityConfig
from orchestrator.study import CaseConfig

from .common import FULL_HORIZON, check_agrees, order_text, percent, rank_of, screened_values
from .measurements import Page, Run, Table, write_page

PLATE_SCENE = "plate_11x11x11"
RULES = ("mean", "receiver")
LOADS = {"3 x 3 patch": 3, "whole face": 0}
SWEPT_COLUMNS = 7
SEARCHES = ("cmaes", "pso", "sa", "random", "sequential")


@dataclass(frozen=True)
class Setting:
    depth: int
    budget: int
    repeats: int
    workers: int


COSTS: list[tuple] = []  # (study, designs evaluated, wall seconds) of every study this run made


def study(folder: Path, case: CaseConfig, methods, setting: Setting, budget: int | None = None):
    """The orchestrator's own study of ``case`` (what run.py runs, sensitivity off), and its wall seconds."""
    configs = {step: None for step in STEPS}
    configs[Searches] = SearchesConfig(methods=tuple(methods), budget=budget or setting.budget, repeats=setting.repeats)
    configs[Sensitivity] = SensitivityConfig(enabled=False)
    start = time.perf_counter()
    outcome = run_in_folder(
        RunConfig(out=str(folder), workers=setting.workers, progress=False),
        case,
        {k: v for k, v in configs.items() if v is not None},
        STEPS,
    )
    seconds = time.perf_counter() - start
    COSTS.append((outcome.study.case.line(), " ".join(methods), f"{seconds:.0f}"))
    return outcome, seconds


def full_peaks(fmu_path, rule: str, patch: int | None, orders, workers: int) -> dict:
    """The sampled 8 s peak of each order at the FMU's default setting, through the Evaluator."""
    parameters = {"diagonal_rule": rule}
    if patch is not None:
        parameters["load_patch"] = patch
    run = FMURun(str(fmu_path), FULL_HORIZON, tuple(sorted(parameters.items())))
    orders = list(dict.fromkeys(tuple(order) for order in orders))
    with make_executor("process", workers=workers) as executor:
        evaluations = Evaluator(executor).evaluate([(run, order) for order in orders])
    close_instances()
    bad = [e for e in evaluations if not e.ok]
    if bad:
        raise SystemExit(f"{len(bad)} full evaluations failed, first {order_text(bad[0].order)}: {bad[0].message}")
    return {e.order: e.value for e in evaluations}


def seven_layers(root: Path, setting: Setting, log) -> tuple[list, list]:
    """The swept plate against the swept 2-D lattice of the same materials: rows of the table, and findings."""
    flat, seconds = study(
        root / "lattice_11x7", CaseConfig(cols=SWEPT_COLUMNS, diagonal_rules=RULES), ("exhaustive",), setting, budget=1
    )
    log(f"11 x {SWEPT_COLUMNS} lattice swept in {seconds:.0f} s")
    flat_sweeps = flat.study.result(Exhaustive)
    flat_fmu = flat.study.fmu_path
    rows, findings = [], []
    for load, patch in LOADS.items():
        case = CaseConfig(
            scene=PLATE_SCENE, cols=SWEPT_COLUMNS, depth=setting.depth, load_patch=patch, diagonal_rules=RULES
        )
        plate, seconds = study(root / f"plate_7_{patch}", case, ("exhaustive",), setting, budget=1)
        log(f"{plate.study.case.line()}: swept in {seconds:.0f} s")
        sweeps = plate.study.result(Exhaustive)
        for rule in RULES:
            certificate = sweeps.for_rule(rule).certificate
            flat_certificate = flat_sweeps.for_rule(rule).certificate
            if certificate.optimum is None or flat_certificate.optimum is None:
                raise SystemExit(f"{load}, {rule} rule: a sweep has no optimum ({'; '.join(certificate.reasons)})")
            optimum, flat_optimum = certificate.optimum.order, flat_certificate.optimum.order
            in_plate = full_peaks(plate.study.fmu_path, rule, patch, [optimum, flat_optimum], setting.workers)
            in_lattice = full_peaks(flat_fmu, rule, None, [optimum, flat_optimum], setting.workers)
            check_agrees(f"{load}, {rule}: the plate's optimum", certificate.optimum.full, in_plate[optimum])
            check_agrees(f"{rule}: the lattice's optimum", flat_certificate.optimum.full, in_lattice[flat_optimum])
            space = DesignSpace.permutations(SWEPT_COLUMNS)
            values = screened_values(
                plate.study.fmu_path, space, setting.workers, {"diagonal_rule": rule, "load_patch": patch}
            )
            rank, screened = rank_of(flat_optimum, space, values)
            same = optimum == flat_optimum
            rows.append(
                (
                    load,
                    rule,
                    order_text(optimum),
                    f"{in_plate[optimum]:.2f}",
                    f"{certificate.gap:.3f}" if certificate.gap is not None else "n/a",
                    "yes" if certificate.certified else "no: " + "; ".join(certificate.reasons),
                    order_text(flat_optimum),
                    f"{in_plate[flat_optimum]:.2f}",
                    percent(in_plate[flat_optimum], in_plate[optimum]),
                    f"{rank:,} of {screened:,}",
                    percent(in_lattice[optimum], in_lattice[flat_optimum]),
                )
            )
            findings.append((load, rule, same, in_plate[flat_optimum] / in_plate[optimum] - 1.0, rank))
    return rows, findings


def eleven_layers(root: Path, setting: Setting, log) -> tuple[list, list]:
    """The searched 11-layer plate against the 2-D optima and the study's best order, evaluated in the plate."""
    flat_optima = {k.diagonal_rule: k for k in known_optima() if k.rows == 11 and k.columns == 11}
    rows, findings = [], []
    for load, patch in LOADS.items():
        case = CaseConfig(scene=PLATE_SCENE, depth=setting.depth, load_patch=patch, diagonal_rules=RULES)
        plate, seconds = study(root / f"plate_11_{patch}", case, SEARCHES, setting)
        log(f"{plate.study.case.line()}: searched in {seconds:.0f} s")
        answers = plate.study.result(Answers)
        for rule in RULES:
            answer = answers.for_rule(rule)
            flat = flat_optima[rule]
            peaks = full_peaks(
                plate.study.fmu_path, rule, patch, [answer.order, flat.order, STUDY_BEST_ORDER], setting.workers
            )
            check_agrees(f"{load}, {rule}: the plate's answer", answer.peak, peaks[answer.order])
            best = min(peaks, key=peaks.get)
            evidence = answer.evidence
            rows.append(
                (
                    load,
                    rule,
                    order_text(answer.order),
                    f"{peaks[answer.order]:.2f}",
                    f"{evidence.status.replace('_', ' ')}; {evidence.runs_reaching} of {evidence.runs} "
                    "search runs ended at it",
                    order_text(flat.order),
                    f"{peaks[flat.order]:.2f}",
                    percent(peaks[flat.order], peaks[answer.order]),
                    f"{peaks[STUDY_BEST_ORDER]:.2f}",
                    "the answer" if best == answer.order else order_text(best),
                )
            )
            findings.append(
                (load, rule, answer.order == flat.order, peaks[flat.order] / peaks[best] - 1.0, best == answer.order)
            )
    return rows, findings


def main(argv=None) -> int:
    run = Run.start(__file__, argv)
    parser = run.parser(__doc__, quick="plates 3 masses deep, budget 100 per search run")
    parser.add_argument("--workers", type=int, default=2, help="worker processes of every study and sweep")
    parser.add_argument("--budget", type=int, default=500, help="designs per search run on the 11-layer plate")
    parser.add_argument("--repeats", type=int, default=3, help="seeds per search method on the 11-layer plate")
    args = parser.parse_args(argv)
    setting = Setting(
        depth=3 if args.quick else 11,
        budget=100 if args.quick else args.budget,
        repeats=args.repeats,
        workers=args.workers,
    )

    def log(text: str) -> None:
        print(text, flush=True)

    with tempfile.TemporaryDirectory(prefix="plate_finding_") as folder:
        seven_rows, seven = seven_layers(Path(folder), setting, log)
        eleven_rows, eleven = eleven_layers(Path(folder), setting, log)
    depth = setting.depth
    survived = [f for f in seven if f[2]]
    worst = max(seven, key=lambda f: f[3])
    above = [100 * f[3] for f in eleven]
    headline = (
        f"11 x 7 x {depth} plate, certified: the 2-D optimum is the plate's optimum in {len(survived)} of "
        f"{len(seven)} cases (load x rule), at worst {100 * worst[3]:.1f}% above it ({worst[0]}, {worst[1]} "
        f"rule: rank {worst[4]:,} of 5,040); 11 x 11 x {depth} plate, searched: the 2-D optimum is "
        f"{min(above):.2f}-{max(above):.2f}% above the best order known in the plate"
    )
    seven_table = Table(
        (
            "load",
            "rule",
            f"plate 11 x 7 x {depth}: certified optimum",
            "its peak (N)",
            "runner-up gap (N)",
            "certified",
            "11 x 7 lattice's optimum (2-D)",
            "its peak in the plate (N)",
            "above the plate's optimum (%)",
            "its rank in the plate (search fidelity)",
            "the plate's optimum in 2-D, above the 2-D optimum (%)",
        ),
        tuple(seven_rows),
        caption="7 layers (the study's materials 1-7, 5,040 orders), swept in the plate and in the lattice",
    )
    eleven_table = Table(
        (
            "load",
            "rule",
            f"plate 11 x 11 x {depth}: best found",
            "its peak (N)",
            "evidence",
            "11 x 11 lattice's certified optimum (2-D)",
            "its peak in the plate (N)",
            "above the plate's answer (%)",
            "the study's best order in the plate (N)",
            "best of these in the plate",
        ),
        tuple(eleven_rows),
        caption=(
            f"11 layers (11! orders): searched with {', '.join(SEARCHES)}, {setting.repeats} seeds, "
            f"{setting.budget} designs per run"
        ),
    )
    page = Page(
        name=run.name,
        title="The plate's finding: the 2-D optimum in three dimensions",
        headline=headline,
        summary=(
            f"Plates {depth} masses deep (docs/model.md section 10), 11 rows, the study's load of 1200 N for "
            "0.15 s on column 1 over a centred 3 x 3 patch or the whole face, backplate behind the last layer; "
            "both diagonal rules. Peaks: the sampled peak over 8 s at the FMU's default setting, through "
            "the Evaluator. Ranks: among every order screened at the search fidelity (1 s, the searches' "
            "tolerance). The studies are the orchestrator's own (`run_in_folder`, sensitivity off), each "
            f"on {setting.workers} worker processes."
        ),
        tables=(
            seven_table,
            eleven_table,
            Table(("study", "methods", "wall s"), tuple(COSTS), caption="What each study cost"),
        ),
        notes=(
            "A certified optimum is the sweep's (every order screened, the best re-run at full fidelity and by a "
            "second integrator, the screening bound held); a best found is the searches' answer and says nothing "
            "of orders they did not evaluate.",
            "The last column of the first table reads the comparison the other way: the plate's optimum built "
            "as a 2-D lattice, above that lattice's own optimum.",
        ),
    )
    write_page(run, page)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
