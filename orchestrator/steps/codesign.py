"""Co-design (docs/model.md section 12): each rule's best order, its columns' properties varied with it.

With ``--vary`` the order search runs as without it (at the table's values: the sweep still certifies the order
there); then, under each rule, CMA-ES (or pymoo's mixed-variable GA, ``--codesign-method mixed-ga``) searches the
order and every column's factors together from that rule's best order, within the mass budget, and SLSQP polishes
the factors at the order the search ends at, on the epigraph of the sampled peak (``codesign.polish``). The
answer is the better, at full fidelity, of the polished design and the order at the table's values, so it is
never above the order search's answer.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ..codesign import (
    DEFAULT_RANGE,
    FRONT_BUDGETS,
    CoDesignObjective,
    CoDesignPoint,
    CoDesignSpace,
    ColumnProperties,
    FrontSeed,
    Polish,
    cmaes_search,
    finite_difference_jacobian,
    minimax_refusal,
    mixed_ga_search,
    parse_vary,
    parse_vary_range,
    polish,
    seed_budgets,
    seeded_front,
)
from ..objective import FULL
from ..options import check_options, given, integer, number, option
from ..simulation import declared_parameters, model_description
from ..study import Step, StudyContext
from ..types import RunOutputs
from .final_descent import rule_best
from .pareto import Pareto, knee
from .searches import rule_label

MASS_OUTPUT = "stack_mass"
FOUND_BY_CODESIGN = "co-design:"  # how a co-design answer was found begins so (Evidence.found_by)
CMAES = "cmaes"
MIXED_GA = "mixed-ga"
CODESIGN_METHODS = (CMAES, MIXED_GA)


@dataclass(frozen=True)
class CoDesignConfig:
    vary: str | None = option(
        None,
        "co-design: the material properties each column may vary, separated by commas, any of docs/model.md "
        "section 12's: k, k_diag, c, alpha, alpha_diag, mass, damping_exponent",
        metavar="NAMES",
        show_default="none: the order alone, at the table's values",
    )
    vary_range: str = option(
        f"{DEFAULT_RANGE[0]:g},{DEFAULT_RANGE[1]:g}",
        "with --vary: the factor range LOW,HIGH each varied property of a column may take of its material's value "
        "(a material table's columns NAME_min, NAME_max give a material's own bounds instead)",
        metavar="LOW,HIGH",
    )
    mass_budget: float | None = option(
        None,
        "with --vary: the stack's largest total mass in kg (a heavier design is infeasible)",
        show_default="the mass of each rule's best order at the table's values; with --objective ...,mass (where "
        "it is the front's upper end) the heaviest stack the factors allow",
        metavar="KG",
        type=number("--mass-budget", 0),
    )
    vary_budget: int = option(
        2000,
        "with --vary: designs (order and factors) the co-design search evaluates under each rule, before the polish",
        type=integer("--vary-budget", 2, 10**7),
    )
    front_budgets: int = option(
        FRONT_BUDGETS,
        "with --vary and --objective ...,mass: the mass budgets, evenly spaced over the front's masses up to its "
        "upper end (one: the upper end), within each of which CMA-ES (then the polish) seeds the front before "
        "NSGA-II; the seeds share half of --vary-budget evenly (0: NSGA-II alone)",
        metavar="N",
        type=integer("--front-budgets", 0, 100),
    )
    codesign_method: str = option(
        CMAES,
        "with --vary: the search over order and factors: cmaes (pycma over the order's random keys and the factors) "
        "or mixed-ga (pymoo's mixed-variable GA: each column's material a choice, its factors reals)",
        choices=CODESIGN_METHODS,
    )

    def __post_init__(self):
        check_options(self)
        if self.vary is not None:
            parse_vary(self.vary)
        parse_vary_range(self.vary_range)


@dataclass(frozen=True)
class CoDesignAnswer:
    """A rule's co-design: the design (order and factors), its columns, its mass against the budget, its value
    at full fidelity against the order's at the table's values, and how it was found."""

    diagonal_rule: str
    point: CoDesignPoint
    columns: tuple[ColumnProperties, ...]
    total_mass: float  # kg
    mass_budget: float  # kg
    peak: float  # the objective at full fidelity
    outputs: RunOutputs | None
    start_order: tuple[int, ...]  # the order search's answer under the rule
    start_peak: float  # its value at full fidelity at the table's values
    search_evaluations: int
    search_best: float | None  # the search's best feasible value at the search fidelity
    search_stop: str
    search_method: str  # --codesign-method
    polish: Polish | None
    varied: dict[str, float]  # the FMU parameters name[m] the design sets away from the table
    polish_note: str = ""  # why there is no polish: the objective is no maximum over samples, or a run failed

    @property
    def improvement(self) -> float:
        return self.start_peak - self.peak

    @property
    def found_by(self) -> str:
        """How the design was found, in one phrase (the answer's evidence): the search that ran and what the polish
        did, so an answer is never credited to a method that did not run."""
        search = "pymoo's mixed-variable GA" if self.search_method == MIXED_GA else "CMA-ES"
        if self.polish is None:
            return f"{FOUND_BY_CODESIGN} {search} over the order and the factors together, not polished"
        met = "met" if self.polish.converged else "not met"
        return (
            f"{FOUND_BY_CODESIGN} {search} over the order and the factors together, then SLSQP on the epigraph of "
            f"the sampled peak (first-order conditions {met})"
        )


@dataclass(frozen=True)
class FrontLayer:
    """A design of a rule's co-design front: order and factors, its columns, its values (the objective, then
    the stack's mass) at the search fidelity that chose it and at full fidelity (None: that run failed)."""

    point: CoDesignPoint
    columns: tuple[ColumnProperties, ...]
    search_values: tuple[float, ...]
    full_values: tuple[float, ...] | None


@dataclass(frozen=True)
class FrontChoice:
    """A design of a co-design front to look at first (its lowest peak, its knee, its lightest), with the design
    file that sets its order and its layers' properties."""

    label: str
    design: FrontLayer
    design_file: str
    varied: dict[str, float]  # the FMU parameters the design sets away from the table (its design file's)


FRONT_CHOICES = (("lowest peak", "lowest_peak"), ("the knee", "knee"), ("lightest", "lightest"))


@dataclass(frozen=True)
class RuleFront:
    diagonal_rule: str
    designs: tuple[FrontLayer, ...]  # by the objective, lowest first
    evaluations: int  # designs NSGA-II evaluated
    mass_range: tuple[float, float] = (0.0, 0.0)  # kg: the lightest stack the factors allow and the front's upper end
    evaluated_masses: tuple[float, float] = (0.0, 0.0)  # kg: the lightest and heaviest design evaluated within it
    seeds: tuple[FrontSeed, ...] = ()  # the CMA-ES runs within each --front-budgets budget that seeded NSGA-II
    chosen: tuple[FrontChoice, ...] = ()  # at full fidelity: the designs the report's first screen shows


def front_choices(space: CoDesignSpace, label: str, designs: Sequence[FrontLayer]) -> tuple[FrontChoice, ...]:
    """The front's lowest peak, its knee (``pareto.knee``: where more mass stops buying much less force) and its
    lightest design, by their full-fidelity values (a design chosen twice is listed once, under its first name)."""
    valued = [d for d in designs if d.full_values is not None]
    if not valued:
        return ()
    values = np.array([d.full_values for d in valued])
    picks = {
        "lowest_peak": int(np.argmin(values[:, 0])),
        "knee": knee(values[:, :2]),
        "lightest": int(np.argmin(values[:, 1])),
    }
    chosen: dict[int, FrontChoice] = {}
    for name, slug in FRONT_CHOICES:
        index = picks[slug]
        if index not in chosen:
            design = valued[index]
            chosen[index] = FrontChoice(
                name, design, f"design_codesign_{label}_{slug}.ssp", varied_parameters(space, design.point)
            )
    return tuple(chosen.values())


@dataclass(frozen=True)
class CoDesignResult:
    names: tuple[str, ...]
    factor_range: tuple[float, float]
    answers: tuple[CoDesignAnswer, ...]
    fronts: tuple[RuleFront, ...] = ()

    def for_rule(self, label: str) -> CoDesignAnswer | None:
        return next((a for a in self.answers if a.diagonal_rule == label), None)


def codesign_space(context: StudyContext, config: CoDesignConfig) -> CoDesignSpace:
    low, high = parse_vary_range(config.vary_range)
    case = context.case
    return CoDesignSpace(
        case.space,
        case.materials,
        parse_vary(config.vary or ""),
        low,
        high,
        case.rows * case.depth,
        config.mass_budget,
    )


class CoDesign(Step):
    name = "codesign"
    title = "Co-design: order and properties"
    template = "codesign.html.j2"
    Config = CoDesignConfig

    def applies(self, context: StudyContext) -> bool:
        return self.config.vary is not None

    def check(self, context: StudyContext) -> None:
        """Refuses, before any simulation: the options of --vary without it, a design space or objective it has
        no meaning in, an FMU without the varied parameters, and a range outside the FMU's declared ranges."""
        config = self.config
        if config.vary is None:
            stray = sorted(given(config) - {"vary"})
            if stray:
                raise ValueError(f"--{stray[0].replace('_', '-')}: only with --vary (co-design)")
            return
        if "front_budgets" in given(config) and len(context.case.outputs) != 2:
            raise ValueError("--front-budgets: only with --objective ...,mass (the co-design front)")
        if context.case.space.kind == "repetition":
            raise ValueError("--vary: not with --repeat (a material in several columns has one value of each property)")
        outputs = context.case.outputs
        if len(outputs) > 1 and (len(outputs) != 2 or outputs[1] != MASS_OUTPUT or outputs[0] == MASS_OUTPUT):
            raise ValueError(
                f"--vary: one objective, or an objective and the stack's mass (--objective sampled,mass), not "
                f"{','.join(outputs)}"
            )
        space = codesign_space(context, config)
        declared = declared_parameters(model_description(context.fmu.path))
        for name in space.names:
            for m, material in enumerate(space.table.materials, start=1):
                parameter = declared.get(f"{name}[{m}]")
                if parameter is None:
                    raise ValueError(
                        f"--vary {name}: {context.fmu.path.name} has no parameter {name}[{m}] (rebuild it from "
                        "these sources)"
                    )
                base = float(getattr(material, name))
                for factor in space.factor_range(m, name):
                    parameter.value(base * factor, f"--vary-range {config.vary_range}: ")

    def run(self, context: StudyContext) -> CoDesignResult:
        config = self.config
        space = codesign_space(context, config)
        if len(context.case.outputs) == 2:
            return self.fronts(context, space)
        answers = []
        for index, rule in enumerate(context.rules):
            label = rule_label(rule)
            best = rule_best(context, label)
            if best is None:
                continue
            objective = CoDesignObjective(context.objective(rule), space)
            budget = space.budget_for(best.order)
            start = space.unit_point(best.order)
            (start_full,) = objective.evaluate([start], context.evaluator, FULL)
            search = mixed_ga_search if config.codesign_method == MIXED_GA else cmaes_search
            outcome = search(objective, context.evaluator, best.order, budget, config.vary_budget, seed=index)
            found = outcome.best.point if outcome.best is not None else start
            if space.mass_excess(start, budget) > 0 and outcome.best is None:
                continue  # the order search's answer is above the budget and the search found nothing within it
            polished: Polish | None = None
            polish_note = minimax_refusal(objective) or ""
            if not polish_note:
                try:
                    polished = polish(
                        objective, context.evaluator, found, budget, FULL, jacobian=finite_difference_jacobian
                    )
                except RuntimeError as exc:  # a run of the polish failed: the search's design stands, unpolished
                    polish_note = str(exc)
            end = polished.end if polished is not None else found
            candidates = [end] + ([start] if space.mass_excess(start, budget) == 0 else [])
            evaluations = objective.evaluate(candidates, context.evaluator, FULL)
            valued = [(p, e) for p, e in zip(candidates, evaluations) if e.ok and e.value is not None]
            if not valued:
                continue  # no candidate has a value at full fidelity: the order search's answer stands
            chosen, evaluation = min(valued, key=lambda pair: float(pair[1].value or 0.0))
            answers.append(
                CoDesignAnswer(
                    diagonal_rule=label,
                    point=chosen,
                    columns=space.columns_of(chosen),
                    total_mass=space.total_mass(chosen),
                    mass_budget=budget,
                    peak=float(evaluation.value or 0.0),
                    outputs=evaluation.outputs,
                    start_order=best.order,
                    start_peak=float(start_full.value) if start_full.value is not None else float("nan"),
                    search_evaluations=outcome.evaluations,
                    search_best=outcome.best.value if outcome.best is not None else None,
                    search_stop=outcome.stop,
                    search_method=config.codesign_method,
                    polish=polished,
                    polish_note=polish_note,
                    varied=varied_parameters(space, chosen),
                )
            )
        return CoDesignResult(space.names, (space.low, space.high), tuple(answers))

    def fronts(self, context: StudyContext, space: CoDesignSpace) -> CoDesignResult:
        """Under each rule, NSGA-II's front of the objective against the stack's mass, from the rule's best order
        (``front_start``) at the table's values, at evenly spaced masses and CMA-ES's polished answers within
        ``--front-budgets`` budgets spread over the masses (``seeded_front``). ``--mass-budget`` is the front's
        upper end; without it the front spans every mass the factors allow."""
        fronts = []
        for index, rule in enumerate(context.rules):
            objective = CoDesignObjective(context.objective(rule), space)
            start = front_start(context, rule_label(rule))

            def polished(point: CoDesignPoint, budget: float, objective=objective) -> CoDesignPoint | None:
                if minimax_refusal(objective) is not None:  # no epigraph polish for this objective: CMA-ES's stands
                    return None
                try:
                    return polish(objective, context.evaluator, point, budget, FULL).end
                except RuntimeError:  # a run of the polish failed: CMA-ES's design seeds the front
                    return None

            front = seeded_front(
                objective,
                context.evaluator,
                start,
                self.config.vary_budget,
                seed_budgets(space, start, space.mass_budget, self.config.front_budgets),
                seed=index,
                mass_budget=space.mass_budget,
                refine=polished,
            )
            layers = tuple(
                FrontLayer(d.point, space.columns_of(d.point), d.search_values, d.full_values) for d in front.designs
            )
            fronts.append(
                RuleFront(
                    rule_label(rule),
                    layers,
                    front.evaluations,
                    front.mass_range,
                    (
                        (min(v[1] for v in front.evaluated), max(v[1] for v in front.evaluated))
                        if front.evaluated
                        else (0.0, 0.0)
                    ),
                    front.seeds,
                    front_choices(space, rule_label(rule), layers),
                )
            )
        return CoDesignResult(space.names, (space.low, space.high), (), tuple(fronts))

    def design_files(self, study):
        result = study.result(type(self))
        return [
            (c.design_file, c.design.point.order, f.diagonal_rule)
            for f in (result.fronts if result else ())
            for c in f.chosen
        ]

    def design_parameters(self, study) -> dict[str, dict[str, float]]:
        result = study.result(type(self))
        return {c.design_file: dict(c.varied) for f in (result.fronts if result else ()) for c in f.chosen}

    def cost_note(self, context: StudyContext) -> str:
        return (
            "CMA-ES or the mixed-variable GA over order and factors (--vary-budget designs per rule), then the "
            "polish's recorded runs (a forward difference per varied property and column at each SLSQP iterate); "
            "with --objective ...,mass CMA-ES within each --front-budgets budget and NSGA-II (--vary-budget designs "
            "per rule between them), each CMA-ES answer's polish, and the front at full fidelity"
        )


def front_start(context: StudyContext, label: str) -> tuple[int, ...]:
    """The order a rule's co-design front starts from: the order search's lowest value of the first objective
    (its answer, or the end of its Pareto front on that objective), else the space's baseline order."""
    best = rule_best(context, label)
    if best is not None:
        return best.order
    pareto = context.result(Pareto)
    front = next((f for f in pareto.fronts if f.diagonal_rule == label), None) if pareto else None
    if front is not None and front.points:
        return min(front.points, key=lambda p: p.values[0]).order
    return context.case.space.baseline()


def varied_parameters(space: CoDesignSpace, point: CoDesignPoint) -> dict[str, float]:
    """The FMU parameters ``name[m]`` the point sets away from the table's values, by column order."""
    values = space.parameters(point)
    varied = {}
    for material in point.order:
        for name in space.names:
            key = f"{name}[{material}]"
            if values[key] != float(getattr(space.table.materials[material - 1], name)):
                varied[key] = values[key]
    return varied


__all__ = [
    "CoDesign",
    "CoDesignAnswer",
    "CoDesignConfig",
    "CoDesignResult",
    "FrontChoice",
    "FrontLayer",
    "RuleFront",
    "front_choices",
]
