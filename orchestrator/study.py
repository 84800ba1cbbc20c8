"""A whole study: searches over seeds, the finalists verified over the full scene, a final descent, and
what a designer needs to trust the answer (the other diagonal rule's optimum, the order under changed
cases).

The study only composes: every simulation goes through the objective (what is minimised, at which
fidelity) and the one Evaluator (cache, journal, guarded execution). Searches rank by the objective's
search fidelity; every number reported as a result is the objective's full fidelity (the whole scene at
the FMU's default accuracy).
"""
from __future__ import annotations

import itertools
import math
import shutil
import sys
import tempfile
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

from .executors import make_executor
from .journal import Journal, file_sha256
from .loop import Evaluator, SearchRun, run_search
from .objective import (AGGREGATES, FULL, OBJECTIVES, SEARCH, SEARCH_HORIZON, SEARCH_RTOL, PeakObjective,
                        close_instances, expand_cases, make_objective)
from .search import SEARCHES, make_search
from .search.local import neighbours as local_neighbours
from .simulation import material_columns, model_description
from .types import Evaluation, Order

SEARCH_METHODS = ("cmaes", "pso", "sa")
BASELINES = ("sequential", "random")
# What the study we start from published (shared/SPEC.md, issue 3): drawn as reference points, never used
# as results. Our own value of the study's order is computed like every other number.
STUDY_BEST_ORDER = (1, 7, 5, 9, 3, 6, 11, 8, 2, 4, 10)
STUDY_REFERENCE_POINTS = {
    "study best (found at evaluation 4)": 1497.89,
    "study particle swarm": 1571.88,
    "study simulated annealing": 2912.76,
    "sequential order": 1747.78,
}
DIAGONAL_RULES = ("receiver", "mean")
# The other rule's search in "which model": the two methods that did best there, one seed each.
WHICH_MODEL_METHODS = ("sa", "cmaes")
# "How the chosen order holds up": for each variation, annealing from the sequential order and an iterated
# local search from the chosen order (the best order of a nearby case is often a few moves from it).
SENSITIVITY_METHODS = ("sa", "local")
MAX_HORIZON = 3600.0  # s: a longer horizon is refused (one evaluation must end)

__all__ = ["StudyConfig", "Study", "run_study"]


@dataclass
class StudyConfig:
    """Everything a study needs; the CLI fills it, tests and benchmarks build it directly."""

    methods: tuple = SEARCH_METHODS + BASELINES
    budget: int = 200
    seed: int = 0
    repeats: int = 3
    objective: str = "sampled"
    executor: str = "process"
    workers: int | None = None
    scheduler: str | None = None
    out: str = "results"
    scene: str = "armour_11x11"
    fmu: str | None = None
    horizon: float | None = None  # the full scene horizon; None: the scene's (8 s for the armour scene)
    search_horizon: float | None = SEARCH_HORIZON  # None: search over the full horizon
    search_rtol: float | None = SEARCH_RTOL  # None: the FMU's default tolerance
    parameters: dict = field(default_factory=dict)  # FMU parameters for every run (F_total, diagonal_rule, ...)
    cases: dict = field(default_factory=dict)  # {"F_total": [600, 1200, 2400], ...}: the product is the cases
    aggregate: str | None = None  # "worst" (default with cases) or "mean"
    finalists: int = 3  # per run, the best distinct orders re-evaluated over the full scene
    local_check: bool = True
    which_model: bool = True  # also search under the other diagonal rule, and compare
    which_model_budget: int = 300
    sensitivity: bool = True  # the chosen order under standard variations of the case
    sensitivity_budget: int = 100
    time_limit: float | None = 120.0  # s per evaluation; a slower one is failed
    checkpoint: str | None = None  # the exhaustive sweep's checkpoint folder (default OUT/exhaustive)
    confirm_exhaustive: bool = False  # a sweep beyond 10! orders runs only on Dask, confirmed
    chunk_size: int | None = None  # orders per chunk of the exhaustive sweep (default: about 200 chunks)
    resume: bool = False
    progress: bool = True

    def __post_init__(self):
        allowed = tuple(SEARCHES) + ("exhaustive", "all")
        methods = []
        for method in self.methods:
            if method not in allowed:
                raise ValueError(f"method {method!r}: allowed values are {', '.join(allowed)}")
            methods += list(SEARCH_METHODS + BASELINES) if method == "all" else [method]
        self.methods = tuple(dict.fromkeys(methods))
        if self.objective not in OBJECTIVES:
            raise ValueError(f"objective {self.objective!r}: allowed values are {', '.join(OBJECTIVES)}")
        for name in ("budget", "repeats", "finalists", "which_model_budget", "sensitivity_budget"):
            value = getattr(self, name)
            if isinstance(value, bool) or int(value) != value or value < 1:
                raise ValueError(f"{name} must be a positive integer, got {value!r}")
        if isinstance(self.seed, bool) or int(self.seed) != self.seed or not 0 <= self.seed < 2**32 - 1000:
            raise ValueError(f"seed must be an integer in [0, {2**32 - 1000}), got {self.seed!r}")
        for name in ("horizon", "search_horizon", "search_rtol", "time_limit"):
            value = getattr(self, name)
            if value is not None and not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
        if self.horizon is not None and self.horizon > MAX_HORIZON:
            raise ValueError(f"horizon must be at most {MAX_HORIZON:g} s, got {self.horizon!r}")
        if self.workers is not None and (int(self.workers) != self.workers or self.workers < 1):
            raise ValueError(f"workers must be a positive integer, got {self.workers!r}")
        if "exhaustive" in self.methods and self.cases:
            raise ValueError("method exhaustive: one case only (without --case); allowed: a single scene")
        if self.chunk_size is not None and (int(self.chunk_size) != self.chunk_size or self.chunk_size < 1):
            raise ValueError(f"chunk_size must be a positive integer, got {self.chunk_size!r}")
        if self.aggregate is not None:
            if not self.cases:
                raise ValueError("aggregate: only with cases (--case NAME=V1,V2,...); allowed values are "
                                 + ", ".join(AGGREGATES))
            if self.aggregate not in AGGREGATES:
                raise ValueError(f"aggregate {self.aggregate!r}: allowed values are {', '.join(AGGREGATES)}")

    @property
    def diagonal_rule(self) -> str:
        rule = self.parameters.get("diagonal_rule", "receiver")
        return DIAGONAL_RULES[rule] if isinstance(rule, int) else str(rule)

    def settings(self) -> dict:
        """What decides the results (a resumed run must match it); not where or how fast it runs."""
        kept = asdict(self)
        for name in ("executor", "workers", "scheduler", "out", "resume", "progress", "time_limit", "checkpoint",
                     "confirm_exhaustive"):
            kept.pop(name)
        kept["methods"] = list(self.methods)
        return kept


@dataclass
class Study:
    config: StudyConfig
    fmu_path: Path
    horizon: float
    objective: PeakObjective
    runs: list[SearchRun]
    verified: dict[Order, Evaluation]  # each order at full fidelity
    finalist_disagreements: list[dict]
    local_check: dict | None
    wall_seconds: float
    rows: int
    which_model: dict | None = None
    sensitivity: dict | None = None
    exhaustive: dict | None = None
    evaluator_state: dict = field(default_factory=dict)

    @property
    def search_horizon(self) -> float:
        return self.objective.search_horizon

    def best_verified(self) -> Evaluation | None:
        """The best order over every run's finalists and the final descent, at full fidelity."""
        good = [v for v in self.verified.values() if v.ok]
        return min(good, key=lambda v: v.peak) if good else None

    def run_best(self, run: SearchRun) -> Evaluation | None:
        """A run's answer: its best finalist at full fidelity."""
        finalists = [self.verified[o] for o in finalist_orders(run, self.config.finalists) if o in self.verified]
        good = [v for v in finalists if v.ok]
        return min(good, key=lambda v: v.peak) if good else None


def ensure_fmu(scene: str, fmu: str | None = None) -> Path:
    """The FMU to use: the given path, or the scene's FMU in models/, (re)built when missing or stale."""
    import build_fmu

    loaded = load_scene(scene)
    if fmu:
        path = Path(fmu)
        if not path.is_file():
            raise FileNotFoundError(f"--fmu {fmu}: no such file (build one with `python build_fmu.py`)")
        check_fmu_matches_scene(path, loaded)
        return path
    path = build_fmu.MODELS_DIR / f"{loaded.model_identifier}.fmu"
    expected = build_fmu.model_guid(loaded.interface(), loaded.model_identifier)
    if not path.is_file():
        print(f"building {path} (scene {scene}) ...", file=sys.stderr)
        build_fmu.build_fmu(loaded, path)
    elif stale_fmu(path, expected):
        print(f"rebuilding {path}: it was built from other sources or for another scene", file=sys.stderr)
        build_fmu.build_fmu(loaded, path)
    return path


def stale_fmu(path: Path, expected_guid: str) -> bool:
    try:
        return model_description(path).guid != expected_guid
    except Exception:  # noqa: BLE001
        return True


def check_fmu_matches_scene(path: Path, scene) -> None:
    """An explicit --fmu must be the scene's model (its model identifier); else a one-line refusal."""
    try:
        description = model_description(path)
    except Exception as exc:  # noqa: BLE001
        raise ValueError(f"--fmu {path}: not a readable FMU ({type(exc).__name__}: {exc})") from None
    identifier = description.coSimulation.modelIdentifier if description.coSimulation else None
    if identifier != scene.model_identifier:  # another lattice size of the same scene (--cols 8) is its own
        raise ValueError(f"--fmu {path}: it is a {identifier} FMU, but scene {scene.name} is "
                         f"{scene.model_identifier}; give the scene's FMU or the FMU's --scene")


def load_scene(scene: str):
    from scenes import Scene

    return Scene.load(scene)


def finalist_orders(run: SearchRun, count: int) -> list[Order]:
    """The run's best `count` distinct orders by their search value."""
    good = sorted((e for e in run.evaluations if e.ok), key=lambda e: e.peak)
    return [e.order for e in good[:count]]


def neighbours(order: Order) -> dict[str, list[Order]]:
    """Every order one swap or one insertion (take a column out, put it elsewhere) away, by kind."""
    moves = local_neighbours(order)  # swaps first, then the insertions that are not swaps
    swaps = len(order) * (len(order) - 1) // 2
    return {"swap": moves[:swaps], "insertion": moves[swaps:]}


def verify(objective: PeakObjective, evaluator: Evaluator, orders: list[Order]) -> dict[Order, Evaluation]:
    """Every order at full fidelity; failures stay failures."""
    orders = list(dict.fromkeys(orders))
    return dict(zip(orders, objective.evaluate(orders, evaluator, FULL)))


def plan_runs(config: StudyConfig) -> list[tuple[str, int]]:
    seeds = [config.seed + r for r in range(config.repeats)]
    return [(method, seed) for method in config.methods if method in SEARCHES
            for seed in (seeds[:1] if SEARCHES[method].deterministic else seeds)]


def run_searches(objective: PeakObjective, evaluator: Evaluator, plan, budget: int, bar=None,
                 options: dict | None = None) -> list[SearchRun]:
    """Each (method, seed) of the plan for ``budget`` evaluations; ``options[method]``: its search options."""
    runs = []
    done_before = 0
    for method, seed in plan:
        search = make_search(method, objective.n_var, seed, budget=budget, **(options or {}).get(method, {}))
        cap = min(budget, SEARCHES[method].max_evaluations or budget)

        def progress(done, offset=done_before):
            if bar is not None:
                bar.n = offset + done
                bar.refresh()

        runs.append(run_search(search, objective, budget, evaluator, method_name=method, seed=seed,
                               progress=progress))
        done_before += cap
    return runs


def best_of(runs: list[SearchRun], objective: PeakObjective, evaluator: Evaluator, finalists: int,
            extra: tuple = ()) -> tuple[dict[Order, Evaluation], Evaluation | None]:
    orders = list(itertools.chain.from_iterable(finalist_orders(run, finalists) for run in runs))
    orders += [o for o in extra if len(o) == objective.n_var]
    verified = verify(objective, evaluator, orders)
    good = [v for v in verified.values() if v.ok]
    return verified, (min(good, key=lambda v: v.peak) if good else None)


def run_study(config: StudyConfig) -> Study:
    start = time.perf_counter()
    fmu_path = ensure_fmu(config.scene, config.fmu)
    columns = material_columns(model_description(fmu_path))
    if columns < 2:
        raise ValueError(f"{fmu_path} has {columns} column(s): there is no material order to search")
    scene = load_scene(config.scene)
    horizon = config.horizon or scene.horizon
    objective = make_objective(config.objective, fmu_path, columns, horizon, config.parameters,
                               expand_cases(config.cases), config.aggregate or "worst",
                               config.search_horizon, config.search_rtol)
    plan = plan_runs(config)
    total = sum(min(config.budget, SEARCHES[m].max_evaluations or config.budget) for m, _ in plan)
    out = Path(config.out)
    out.mkdir(parents=True, exist_ok=True)
    settings = {**config.settings(), "fmu_sha256": file_sha256(fmu_path), "horizon": horizon}

    bar = None
    if config.progress:
        from tqdm import tqdm

        bar = tqdm(total=total, unit="eval", desc="searching", file=sys.stderr, mininterval=0.5,
                   disable=None)  # None: no bar when stderr is not a terminal (CI logs)
    temp_root = tempfile.mkdtemp(prefix="lattice-run-")
    previous_tempdir = tempfile.tempdir
    tempfile.tempdir = temp_root  # this process's extractions too; removed with the run
    try:
        with Journal(out, settings, resume=config.resume) as journal, \
                make_executor(config.executor, config.workers, config.scheduler, temp_root) as executor:
            evaluator = Evaluator(executor, journal, config.time_limit)
            if "exhaustive" in config.methods:  # refused before any search when beyond the local limit
                from .exhaustive import MAX_LOCAL_ORDERS, check_cost

                check_cost(objective.tasks(SEARCH)[0], columns, config.executor, config.confirm_exhaustive,
                           MAX_LOCAL_ORDERS)
            runs = run_searches(objective, evaluator, plan, config.budget, bar)
            if bar is not None:
                bar.close()
            exhaustive = None
            if "exhaustive" in config.methods:
                exhaustive = exhaustive_sweep(objective, executor, config)
            extra = (STUDY_BEST_ORDER, tuple(range(1, columns + 1)))
            if exhaustive and exhaustive.get("optimum"):
                extra += (tuple(exhaustive["optimum"]["order"]),)
            verified, best = best_of(runs, objective, evaluator, config.finalists, extra)
            disagreements = finalist_disagreements(runs, verified, config.finalists)
            local = None
            if config.local_check and best is not None:
                local = final_descent(objective, evaluator, best, verified, seed=config.seed)
                best = min((v for v in verified.values() if v.ok), key=lambda v: v.peak)
            which = None
            if config.which_model and best is not None and not _rule_in_cases(config):
                which = which_model(objective, evaluator, best.order, config)
            sensitivity = None
            if config.sensitivity and best is not None:
                sensitivity = sensitivity_study(objective, evaluator, best.order, config)
            state = evaluator.state()
    finally:
        tempfile.tempdir = previous_tempdir
        close_instances()
        shutil.rmtree(temp_root, ignore_errors=True)
    return Study(config, fmu_path, horizon, objective, runs, verified, disagreements, local,
                 time.perf_counter() - start, scene.rows, which, sensitivity, exhaustive, state)


# The screening error bound of the search fidelity: bench/horizon_study.py and bench/solver_work_precision.py
# measure at most 2.7e-5 (relative; 2.3e-5 with the searches' Nystrom pair at rtol 8e-6); the sweep
# re-evaluates every order within 1e-4 of the incumbent at full fidelity, whose own error is at most 1e-6
# (bench/work_precision.py: 1.8e-7).
EXHAUSTIVE_SCREENING_ERROR = 1e-4
EXHAUSTIVE_FULL_ERROR = 1e-6


def exhaustive_sweep(objective: PeakObjective, executor, config: StudyConfig) -> dict:
    """Every order of 1..C (orchestrator.exhaustive), screened at the search fidelity with the incumbent as
    the FMU's force limit, checkpointed in config.checkpoint (default OUT/exhaustive), the candidates
    verified at full fidelity: the optimum to a stated tolerance."""
    from .exhaustive import run_exhaustive

    screening, = objective.tasks(SEARCH)
    full, = objective.tasks(FULL)
    total = math.factorial(objective.n_var)
    chunk_size = config.chunk_size or max(1, -(-total // 200))
    return run_exhaustive(
        screening, objective.n_var, executor, config.checkpoint or str(Path(config.out) / "exhaustive"),
        chunk_size, full_objective=full, screening_error=EXHAUSTIVE_SCREENING_ERROR,
        full_error=EXHAUSTIVE_FULL_ERROR, scene=config.scene, executor_kind=config.executor,
        confirm=config.confirm_exhaustive,
        objective_with_limit=screening.with_limit if objective.supports_limits else None)


def _rule_in_cases(config: StudyConfig) -> bool:
    return "diagonal_rule" in config.cases


def finalist_disagreements(runs: list[SearchRun], verified: dict[Order, Evaluation], count: int) -> list[dict]:
    """Where the full scene ranks a run's finalists differently from the search fidelity."""
    found = []
    for run in runs:
        orders = finalist_orders(run, count)
        by_search = {e.order: e.peak for e in run.evaluations if e.ok}
        full = {o: verified[o].peak for o in orders if o in verified and verified[o].ok}
        if len(full) < 2:
            continue
        search_rank = sorted(full, key=lambda o: by_search[o])
        full_rank = sorted(full, key=lambda o: full[o])
        largest = max(abs(full[o] - by_search[o]) / abs(full[o]) if full[o] else 0.0 for o in full)
        if search_rank != full_rank:
            found.append({"method": run.method, "seed": run.seed, "search_ranking": [list(o) for o in search_rank],
                          "full_ranking": [list(o) for o in full_rank], "largest_relative_difference": largest})
    return found


def final_descent(objective: PeakObjective, evaluator: Evaluator, best: Evaluation,
                  verified: dict[Order, Evaluation], seed: int = 0, max_evaluations: int = 5000) -> dict:
    """The one local search (``local`` method, no kicks) from the best order until no single swap or
    insertion improves it at the search fidelity; the order it ends at is verified at full fidelity and
    added to ``verified``. Returns the local-optimality check of the order it ends at."""
    descent = make_search("local", objective.n_var, seed, start=best.order, kicks=0)
    run = run_search(descent, objective, max_evaluations, evaluator, method_name="local", seed=seed)
    end = tuple(run.diagnostics["local_optimum"] or run.best_order or best.order)
    verified.update(verify(objective, evaluator, [end]))
    moves = neighbours(end)
    values = {e.order: e for e in run.evaluations}
    own = values.get(end)
    around = [values[o] for o in moves["swap"] + moves["insertion"] if o in values]
    checked = len(around) == len(moves["swap"]) + len(moves["insertion"])
    good = [e for e in around if e.ok]
    above = [e for e in around if e.censored]  # stopped once they passed the value they had to beat
    return {
        "start": list(best.order),
        "order": list(end),
        "descent_evaluations": run.n_evaluations,
        "moves": run.diagnostics["descent"]["moves"] + run.diagnostics["descent"]["free_moves"],
        "swaps_checked": sum(1 for o in moves["swap"] if o in values),
        "insertions_checked": sum(1 for o in moves["insertion"] if o in values),
        "failed": sum(1 for e in around if not e.ok and not e.censored),
        "censored": len(above),
        "locally_optimal": bool(checked and own is not None and own.ok and len(good) + len(above) == len(around)
                                and all(e.peak >= own.peak for e in good)
                                and all(e.lower_bound >= own.peak for e in above)),
        "nearest_neighbour_gap": (min(e.peak for e in good) - own.peak) if good and own is not None and own.ok
        else None,
        "improvement_full": (best.peak - verified[end].peak) if verified[end].ok else None,
        "stop_reason": run.stop_reason,
    }


def _other_rule(rule: str) -> str:
    return "mean" if rule == "receiver" else "receiver"


def which_model(objective: PeakObjective, evaluator: Evaluator, best_order: Order, config: StudyConfig) -> dict:
    """The optimum under each diagonal rule, each evaluated under both (full fidelity), with the energy
    flows that explain the difference. The run's own rule has its searches; the other gets a search here."""
    rule = config.diagonal_rule
    other = _other_rule(rule)
    objectives = {rule: objective.with_parameters(diagonal_rule=rule),
                  other: objective.with_parameters(diagonal_rule=other)}
    plan = [(method, config.seed) for method in WHICH_MODEL_METHODS]
    runs = run_searches(objectives[other], evaluator, plan, config.which_model_budget)
    _, other_best = best_of(runs, objectives[other], evaluator, config.finalists, (tuple(range(1, objective.n_var + 1)),))
    optima = {rule: tuple(best_order)}
    if other_best is not None:
        descent = final_descent(objectives[other], evaluator, other_best, {}, seed=config.seed)
        optima[other] = tuple(descent["order"])
    result: dict = {}
    for name, order in optima.items():
        entry = {"order": list(order), "found_under": name}
        for judged_by, judge in objectives.items():
            evaluation = judge.evaluate([order], evaluator, FULL)[0]
            entry[f"peak_{judged_by}"] = evaluation.peak
            entry[f"energy_{judged_by}"] = {k: evaluation.details.get(k) for k in
                                            ("external_work", "nonreciprocal_work", "dissipated_energy")}
            if not evaluation.ok:
                entry[f"error_{judged_by}"] = evaluation.message
        result[name] = entry
    result["searches"] = [{"method": r.method, "seed": r.seed, "rule": other, "budget": r.budget,
                           "best_order": list(r.best_order) if r.best_order else None, "best_peak": r.best_peak}
                          for r in runs]
    return result


def sensitivity_variations(objective: PeakObjective, config: StudyConfig) -> dict[str, dict]:
    """The standard variations of the case, as FMU parameters: load 0.5x and 2x, load duration 0.5x and
    2x, the other diagonal rule, load angle 30 degrees."""
    defaults = {v.name: v.start for v in model_description(objective.fmu_path).modelVariables}
    load = float(objective.parameters.get("F_total", defaults.get("F_total") or 1200.0))
    duration = float(objective.parameters.get("t_active", defaults.get("t_active") or 0.15))
    variations = {
        "load 0.5x": {"F_total": 0.5 * load},
        "load 2x": {"F_total": 2.0 * load},
        "load duration 0.5x": {"t_active": 0.5 * duration},
        "load duration 2x": {"t_active": 2.0 * duration},
        "other diagonal rule": {"diagonal_rule": _other_rule(config.diagonal_rule)},
        "load angle 30 deg": {"load_angle": 30.0},
    }
    known = set(defaults)
    return {name: change for name, change in variations.items() if set(change) <= known}


def sensitivity_study(objective: PeakObjective, evaluator: Evaluator, best_order: Order,
                      config: StudyConfig) -> dict:
    """The chosen order, the study's and the sequential one under each variation, beside the best order a
    short search finds for that variation: what keeping the chosen order costs (its regret)."""
    base = objective.with_cases(None)  # variations change the single case the designer chose
    columns = objective.n_var
    compared = {"chosen": tuple(best_order), "sequential": tuple(range(1, columns + 1))}
    if len(STUDY_BEST_ORDER) == columns:
        compared["study best"] = STUDY_BEST_ORDER
    result = {"budget": config.sensitivity_budget, "methods": list(SENSITIVITY_METHODS), "variations": []}
    for name, change in sensitivity_variations(objective, config).items():
        varied = base.with_parameters(**change)
        plan = [(method, config.seed) for method in SENSITIVITY_METHODS]
        runs = run_searches(varied, evaluator, plan, config.sensitivity_budget,
                            options={"local": {"start": tuple(best_order)}})
        _, found = best_of(runs, varied, evaluator, config.finalists, tuple(compared.values()))
        full = dict(zip(compared, varied.evaluate(list(compared.values()), evaluator, FULL)))
        entry = {"variation": name, "parameters": change,
                 "best_found": {"order": list(found.order), "peak": found.peak} if found else None,
                 "orders": {}}
        for label, evaluation in full.items():
            entry["orders"][label] = {
                "order": list(compared[label]), "peak": evaluation.peak,
                "regret": (evaluation.peak - found.peak) if evaluation.ok and found else None,
                **({"error": evaluation.message} if not evaluation.ok else {})}
        result["variations"].append(entry)
    return result
