"""The searches: each method and seed, under each diagonal rule, at the search fidelity."""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fmu_src.published import PUBLISHED_CONDITIONS, REFERENCE_POINTS

from ..charts import METHOD_NAMES, best_so_far_matrix, figure_title, legend_below, method_colour, plt, save
from ..exhaustive import SWEEP_METHOD
from ..known_optima import known_ends
from ..loop import SearchRun, run_search
from ..options import check_options, integer, option
from ..search import SEARCHES, make_search
from ..study import Step, StudyContext
from .starting_designs import starting_designs

SINGLE_DEFAULT = ("cmaes", "pso", "sa", "sequential", "random")
MULTI_DEFAULT = ("nsga2", "random")
ALL = "all"


def multi_objective(name: str) -> bool:
    return name in SEARCHES and SEARCHES[name].n_objectives > 1


def fits(name: str, objectives: int) -> bool:
    """Whether the search ``name`` runs on an objective of ``objectives`` outputs (a baseline runs on any)."""
    return SEARCHES[name].baseline or multi_objective(name) == (objectives > 1)


def methods_for(requested: tuple[str, ...], objectives: int) -> tuple[str, ...]:
    """The search methods a run uses: the requested ones ("all": every search for this many objectives), or
    the defaults; the exhaustive sweep is its own step (``SWEEP_METHOD``)."""
    if not requested:
        return MULTI_DEFAULT if objectives > 1 else SINGLE_DEFAULT
    methods: list[str] = []
    for method in requested:
        if method == ALL:
            methods += [m for m in SEARCHES if fits(m, objectives)]
        elif method in SEARCHES:
            methods.append(method)
    return tuple(dict.fromkeys(methods))


@dataclass(frozen=True)
class SearchesConfig:
    methods: tuple[str, ...] = option(
        (),
        f"searches and baselines to run; {ALL}: every search (not the exhaustive sweep); {SWEEP_METHOD}: every "
        "design of the space (its own step, beside the searches)",
        flag="--method",
        nargs="+",
        choices=tuple(SEARCHES) + (SWEEP_METHOD, ALL),
        metavar="METHOD",
        show_default=f"{' '.join(SINGLE_DEFAULT)}; with several objectives {' '.join(MULTI_DEFAULT)}",
    )
    budget: int = option(
        200,
        "distinct designs each run evaluates: a hard cap on distinct designs (a design "
        "evaluated again because its earlier run stopped at a lower force limit is counted as a "
        "re-evaluation, not against the budget)",
        type=integer("--budget", 1, 10**9),
    )
    seed: int = option(0, "first seed", type=integer("--seed", 0, 2**32 - 1001))
    repeats: int = option(
        3, "runs per method: seeds S..S+R-1 (a deterministic method runs once)", type=integer("--repeats", 1, 10**6)
    )

    def __post_init__(self):
        check_options(self)


@dataclass(frozen=True)
class SearchesResult:
    methods: tuple[str, ...]
    budget: int
    runs: tuple[SearchRun, ...]

    def runs_for(self, label: str) -> list[SearchRun]:
        return [run for run in self.runs if run.label == label]


def default_evaluations(config: "SearchesConfig") -> int:
    """The evaluations the default searches make under one rule at ``config``'s budget, seed and repeats."""
    return sum(
        min(config.budget, SEARCHES[m].max_evaluations or config.budget)
        for m, _ in plan(SINGLE_DEFAULT, config.seed, config.repeats)
    )


def rule_label(rule: str | None) -> str:
    """How results name the diagonal rule they were found under (None: the load cases or the model set it)."""
    return rule or "as set"


def plan(methods: tuple[str, ...], seed: int, repeats: int) -> list[tuple[str, int]]:
    seeds = [seed + r for r in range(repeats)]
    return [(method, s) for method in methods for s in (seeds[:1] if SEARCHES[method].deterministic else seeds)]


def run_searches(
    context: StudyContext,
    objective,
    methods,
    seed: int,
    repeats: int,
    budget: int,
    label: str,
    options: dict | None = None,
    progress_label: str | None = None,
) -> list[SearchRun]:
    """Each (method, seed) for ``budget`` designs on ``objective``; ``options[method]``: its search options."""
    runs = []
    todo = plan(methods, seed, repeats)
    total = sum(min(budget, SEARCHES[m].max_evaluations or budget) for m, _ in todo)
    with context.progress.bar(total, progress_label or f"searching ({label})") as advance:
        for method, run_seed in todo:
            search = make_search(method, context.case.space, run_seed, budget=budget, **(options or {}).get(method, {}))
            runs.append(
                run_search(
                    search,
                    objective,
                    budget,
                    context.evaluator,
                    method_name=method,
                    seed=run_seed,
                    label=label,
                    progress=advance.of_run(),
                )
            )
            advance.close_run()
    return runs


class Searches(Step):
    name = "searches"
    title = "Searches"
    template = "searches.html.j2"
    chart_file = "convergence.png"
    Config = SearchesConfig

    def applies(self, context: StudyContext) -> bool:
        return bool(self.methods(context))

    def methods(self, context: StudyContext) -> tuple[str, ...]:
        return methods_for(self.config.methods, len(context.case.outputs))

    def check(self, context: StudyContext) -> None:
        objectives = len(context.case.outputs)
        for method in self.methods(context):
            if not fits(method, objectives):
                raise ValueError(
                    f"--method {method}: it minimises {'several objectives' if objectives == 1 else 'one'}"
                    f", the objective has {objectives}; allowed: "
                    + ", ".join(m for m in SEARCHES if fits(m, objectives))
                )

    def run(self, context: StudyContext) -> SearchesResult:
        methods = self.methods(context)
        objectives = len(context.case.outputs)
        starts = starting_designs(context)
        runs = []
        for rule in context.rules:
            # NSGA-II starts from the known optimum of each objective alone: the ends of the true front
            options = (
                {
                    "nsga2": {
                        "objectives": objectives,
                        "seeds": tuple(k.order for k in known_ends(context.case, rule or context.case.rule_default)),
                    }
                }
                if objectives > 1
                else {}
            )
            if starts:  # every search evaluates them first and starts from them
                options = {method: {**options.get(method, {}), "starts": starts} for method in methods}
            runs += run_searches(
                context,
                context.objective(rule),
                methods,
                self.config.seed,
                self.config.repeats,
                self.config.budget,
                rule_label(rule),
                options=options or None,
            )
        return SearchesResult(methods, self.config.budget, tuple(runs))

    def chart(self, study, path):
        return draw_convergence(study, path, study.case.line(), {})


def draw_convergence(study, path: Path, context_line: str, known: dict) -> str | None:
    """Best value so far against evaluations, median and quartiles over seeds, one panel per rule, with the
    known optimum of each rule in ``known`` (by rule label; the answers find them, and the report, which reads
    both steps, composes the chart with them)."""
    searches = study.result(Searches)
    if searches is None or not searches.runs:
        return None
    labels = list(dict.fromkeys(run.label for run in searches.runs))
    figure, axes = plt.subplots(1, len(labels), figsize=(6.5 * len(labels), 6.2), squeeze=False)
    unit = study.case.objective.units[0]
    for axis, label in zip(axes[0], labels):
        runs = [r for r in searches.runs if r.label == label and r.n_evaluations]
        for method in dict.fromkeys(r.method for r in runs):
            own = [r for r in runs if r.method == method]
            matrix = best_so_far_matrix(own)
            if not np.isfinite(matrix).any():  # every evaluation failed: nothing to draw
                continue
            with np.errstate(all="ignore"), warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)
                median = np.nanmedian(matrix, axis=0)
                low, high = np.nanpercentile(matrix, 25, axis=0), np.nanpercentile(matrix, 75, axis=0)
            name = f"{METHOD_NAMES.get(method, method)} (median of {len(own)})"
            colour = method_colour(method, [r.method for r in runs])
            if len(median) == 1:
                axis.axhline(median[-1], color=colour, lw=1, ls=":", label=f"{name}: one design")
                continue
            x = np.arange(1, matrix.shape[1] + 1)
            axis.plot(x, median, color=colour, label=name)
            if len(own) > 1:
                axis.fill_between(x, low, high, color=colour, alpha=0.2, lw=0)
        optimum = known.get(label)
        if optimum is not None:
            axis.axhline(
                optimum.peak,
                color="crimson",
                lw=1,
                ls="--",
                label=f"{'certified' if optimum.certified else 'known'} optimum: {optimum.peak:.2f} {unit}",
            )
        published = (
            study.case.objective.outputs == ("peak_backplate_force",)
            and known.get(label)
            and label == PUBLISHED_CONDITIONS["diagonal_rule"]
        )
        if published:  # at the evaluation the study found it, or at the last one where the study does not say
            last = max(r.n_evaluations for r in runs) if runs else 1
            for point, marker in zip(REFERENCE_POINTS, "o^sD"):
                where = (
                    f"found at its evaluation {point.evaluation}"
                    if point.evaluation
                    else "at which evaluation not published: drawn at the last"
                )
                axis.plot(
                    [point.evaluation or last],
                    [point.peak],
                    marker=marker,
                    color="crimson",
                    ls="none",
                    label=f"published {point.label}: {point.peak:.2f} N, {where}",
                )
        if axis.lines:
            axis.set_xscale("log")
        else:
            axis.text(0.5, 0.5, "no evaluation gave a value", ha="center", transform=axis.transAxes)
        axis.set_xlabel("evaluations (distinct designs)")
        axis.set_ylabel(f"best {study.case.objective.outputs[0]} so far ({unit}), search fidelity")
        axis.set_title(f"{label} diagonal rule", fontsize=9)
        axis.grid(alpha=0.3)
        if axis.get_legend_handles_labels()[0]:
            legend_below(axis, fontsize=7.5)
    figure_title(figure, f"Convergence over seeds: median and quartiles. {context_line}")
    return save(figure, path)


__all__ = [
    "Searches",
    "SearchesConfig",
    "SearchesResult",
    "default_evaluations",
    "fits",
    "methods_for",
    "multi_objective",
    "plan",
    "rule_label",
    "run_searches",
]
