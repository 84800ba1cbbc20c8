"""How the chosen design holds up when the case changes: each standard variation of the load, the duration,
the angle and the diagonal rule, the designs compared against the best design known for that variation."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ..objective import FULL
from ..options import check_options, integer, option
from ..study import PROJECTILE, Step, StudyContext
from ..types import Evaluation, Order
from .answers import Answers
from .finalists import Finalists, baselines, best_of, finalist_orders
from .searches import Searches, run_searches

METHODS = ("sa", "local")  # annealing from the baseline, an iterated local search from the chosen design
DEFAULT_BUDGET = 100  # designs each short search evaluates, unless the searches evaluated fewer


@dataclass(frozen=True)
class SensitivityConfig:
    enabled: bool = option(
        True,
        "do not evaluate the chosen design under the standard variations of the case",
        flag="--no-sensitivity",
        action="store_false",
    )
    budget: int | None = option(
        None,
        "designs each short search evaluates for a variation",
        flag="--sensitivity-budget",
        show_default=f"{DEFAULT_BUDGET}, fewer when the searches evaluated fewer designs under "
        "the chosen rule than the step would (--budget bounds it)",
        type=integer("--sensitivity-budget", 1, 10**9),
    )

    def __post_init__(self):
        check_options(self)


@dataclass(frozen=True)
class Compared:
    label: str
    order: Order
    value: float | None
    regret: float | None  # value minus the best known for the variation (what keeping this design costs)
    status: str
    message: str = ""


@dataclass(frozen=True)
class Variation:
    name: str
    parameters: dict[str, Any]
    best_known: Evaluation | None  # the best design this study knows for the variation (full fidelity)
    designs: tuple[Compared, ...]


@dataclass(frozen=True)
class SensitivityResult:
    budget: int
    methods: tuple[str, ...]
    diagonal_rule: str
    variations: tuple[Variation, ...]


def searched_designs(context: StudyContext, label: str) -> int | None:
    """The distinct designs the searches evaluated under a rule (None: no search ran): what --budget bounds."""
    searched = context.result(Searches)
    runs = searched.runs_for(label) if searched else []
    return sum(run.distinct for run in runs) if runs else None


def search_budget(context: StudyContext, config: SensitivityConfig, label: str, count: int) -> int:
    """Designs each short search evaluates for a variation: --sensitivity-budget when given; else DEFAULT_BUDGET,
    lowered so that the step's searches evaluate no more designs than the searches did under the chosen rule
    (so --budget bounds this step too)."""
    if config.budget is not None:
        return config.budget
    designs = searched_designs(context, label)
    if designs is None:
        return DEFAULT_BUDGET
    return max(1, min(DEFAULT_BUDGET, designs // (len(METHODS) * max(count, 1))))


def variations(context: StudyContext, rule: str) -> dict[str, dict[str, Any]]:
    """The standard variations as FMU parameters (those the FMU has): load 0.5x and 2x, load duration 0.5x and
    2x, each other diagonal rule, load angle 30 degrees; under a projectile, its mass and its speed 0.5x and 2x
    and each other diagonal rule (a projectile strikes along +x with its own momentum)."""
    fmu, parameters = context.fmu, context.case.parameters

    def scaled(name: str) -> dict[str, dict[str, float]]:
        value = float(parameters.get(name, fmu.start(name, 0.0)))
        label = name.replace("_", " ")
        return {f"{label} 0.5x": {name: 0.5 * value}, f"{label} 2x": {name: 2.0 * value}}

    found: dict[str, dict[str, Any]]
    if context.case.load_mode == PROJECTILE:
        found = {**scaled("projectile_mass"), **scaled("projectile_speed")}
    else:
        load = float(parameters.get("F_total", fmu.start("F_total", 1200.0)))
        duration = float(parameters.get("t_active", fmu.start("t_active", 0.15)))
        found = {
            "load 0.5x": {"F_total": 0.5 * load},
            "load 2x": {"F_total": 2.0 * load},
            "load duration 0.5x": {"t_active": 0.5 * duration},
            "load duration 2x": {"t_active": 2.0 * duration},
        }
    rules = fmu.parameters.get("diagonal_rule")
    for other in rules.items if rules else ():
        if other != rule:
            found[f"{other} diagonal rule"] = {"diagonal_rule": other}
    if context.case.load_mode != PROJECTILE:
        found["load angle 30 deg"] = {"load_angle": 30.0}
    return {name: change for name, change in found.items() if set(change) <= set(fmu.parameters)}


class Sensitivity(Step):
    name = "sensitivity"
    title = "How the chosen design holds up when the case changes"
    template = "sensitivity.html.j2"
    Config = SensitivityConfig

    def applies(self, context: StudyContext) -> bool:
        answers = context.result(Answers)
        return self.config.enabled and answers is not None and answers.chosen is not None

    def check(self, context: StudyContext) -> None:
        if not self.config.enabled and "budget" in context.given(Sensitivity):
            raise ValueError("--sensitivity-budget: not with --no-sensitivity")

    def run(self, context: StudyContext) -> SensitivityResult:
        answers = context.result(Answers)
        chosen = answers.chosen
        rule = chosen.diagonal_rule
        base = context.objective(rule if rule in context.case.rules else None).with_cases(None)
        compared = {"chosen": chosen.order}
        for answer in answers.answers[1:]:
            compared[f"{answer.diagonal_rule} rule's answer"] = answer.order
        for label, order in baselines(context).items():
            compared.setdefault(label, order)
        found = []
        varied_cases = variations(context, rule)
        budget = search_budget(context, self.config, rule, len(varied_cases))
        for name, change in varied_cases.items():
            varied = base.with_parameters(**change)
            seed = context.config(Searches).seed
            runs = run_searches(
                context,
                varied,
                METHODS,
                seed,
                1,
                budget,
                name,
                options={"local": {"start": chosen.order}},
                progress_label=f"sensitivity: {name}",
            )
            finalists = [o for run in runs for o in finalist_orders(run, context.config(Finalists).per_run)]
            orders = list(dict.fromkeys(list(compared.values()) + finalists))
            full = dict(zip(orders, varied.evaluate(orders, context.evaluator, FULL)))
            (full_task,) = varied.tasks(FULL)
            best = best_of(list(full.values()) + context.evaluator.known(full_task))
            designs = tuple(
                Compared(
                    label,
                    order,
                    full[order].value,
                    (full[order].value - best.value) if full[order].ok and best else None,
                    full[order].status,
                    "" if full[order].ok else full[order].message,
                )
                for label, order in compared.items()
            )
            found.append(Variation(name, change, best, designs))
        return SensitivityResult(budget, METHODS, rule, tuple(found))

    def cost_note(self, context: StudyContext) -> str:
        result = context.result(Sensitivity)
        count = len(result.variations) if result else 0
        budget = result.budget if result else self.config.budget or DEFAULT_BUDGET
        return (
            f"{len(METHODS)} short searches of {budget} designs for each of {count} variations of the case, "
            "then the compared designs at full fidelity; --sensitivity-budget N or --no-sensitivity bounds it"
        )


__all__ = [
    "Compared",
    "Sensitivity",
    "SensitivityConfig",
    "SensitivityResult",
    "Variation",
    "search_budget",
    "searched_designs",
    "variations",
]
