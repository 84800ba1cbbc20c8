"""The designer's answer: for each diagonal rule searched, the design to build, its value under every rule,
and how sure we are (how many runs reached it, whether it is a local optimum, whether it is certified, for
which objective, whether its runner-up is as good for practical purposes, and what would settle it)."""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path

import matplotlib
import numpy as np

from fmu_src.published import PUBLISHED_CONDITIONS

from ..charts import plt, save
from ..codesign import ColumnProperties, table_columns
from ..exhaustive import MAX_LOCAL_DESIGNS, SWEEP_METHOD
from ..known_optima import KnownOptimum, known_optimum
from ..objective import FULL, SEARCH
from ..plate_picture import draw_plate_answers
from ..study import PROJECTILE, Step, StudyContext, Verdict
from ..types import Evaluation, Order, RunOutputs
from .codesign import FOUND_BY_CODESIGN, CoDesign
from .final_descent import FinalDescent, rule_best
from .exhaustive import FULL_ERROR, Exhaustive, SweepCost, objective_covered, sweep_cost
from .finalists import Finalists, best_of, finalist_orders
from .searches import Searches, rule_label

CERTIFIED, KNOWN, BEST_FOUND = "certified", "known", "best_found"
BASELINE_METHODS = ("sequential", "random")
STUDY_RULE = PUBLISHED_CONDITIONS["diagonal_rule"]  # the rule the study computed and published with
BUDGET_FACTOR = 10  # the budget an unsettled answer suggests: this many times the run's (an order of magnitude)
DESIGN_FILE_ROLE = "your design file"
# Where an answer came from (Evidence.found_by).
FOUND_BY_RUNS = "the searches' runs"
FOUND_BY_SWEEP = "this run's exhaustive sweep"
FOUND_BY_DESCENT = "the final descent from the runs' best"
FOUND_BY_KNOWN = "the recorded known optimum, evaluated among the finalists"
FOUND_BY_FINALISTS = "the finalists at full fidelity"
STUDY_MODEL_ROLE = "the study's model: reproduces its published numbers"


@dataclass(frozen=True)
class Settlement:
    """What would settle an answer fewer than half the runs reached: a larger budget, or the exhaustive sweep,
    each with its projected cost (core-hours, from what this run measured)."""

    budget: int
    budget_factor: int  # the budget as a multiple of the run's
    budget_core_hours: float  # this rule's searches' evaluation time, scaled to the budget
    sweep: SweepCost | None  # None: the projection's chunk could not be timed
    sweep_command: str  # the options that sweep it (on Dask beyond the local limit)

    def line(self) -> str:
        """The advice in one sentence (the console's and the report's)."""
        sweep = (
            f"; or `{self.sweep_command}` (every design, certified: projected {self.sweep.core_hours:,.2g} "
            f"core-hours at {self.sweep.designs_per_core_second:,.0f} designs per core-second, measured here "
            "with the force limit at the searches' best)"
            if self.sweep
            else f"; or `{self.sweep_command}`"
        )
        return (
            f"to settle it: `--budget {self.budget}` (projected {self.budget_core_hours:,.2g} core-hours, "
            f"{self.budget_factor} times this run's search time){sweep}"
        )


@dataclass(frozen=True)
class Evidence:
    runs_reaching: int  # optimiser runs whose own answer (best finalist at full fidelity) is this design
    runs: int  # optimiser runs under this rule (the baselines not counted)
    local_optimum: bool | None  # None: not checked (--no-local-check, or the check's cap came first)
    status: str  # certified, known or best_found
    status_source: str  # what the status rests on
    covers: str = ""  # the objective the status holds for (a certificate says nothing of another objective)
    swept: bool = False  # every design of the space was evaluated (this run's sweep)
    settlement: Settlement | None = None  # what would settle it, when fewer than half the runs reached it
    found_by: str = FOUND_BY_RUNS  # where the design came from: FOUND_BY_* or a baseline's name
    local_unchecked: str = ""  # why local_optimum is None when the local check ran

    def local_text(self) -> str:
        """Whether the answer is a local optimum, in a few words (the console's and the report's)."""
        if self.local_optimum is None:
            return f"local optimum not checked{f' ({self.local_unchecked})' if self.local_unchecked else ''}"
        return "a local optimum" if self.local_optimum else "not a local optimum"

    @property
    def few_runs(self) -> bool:
        """Fewer than half the runs reached the answer (and nothing else settles it)."""
        return self.runs > 0 and 2 * self.runs_reaching < self.runs and self.status != CERTIFIED

    @property
    def co_designed(self) -> bool:
        """The answer is a co-design's: no search or sweep of the orders reached its design."""
        return self.found_by.startswith(FOUND_BY_CODESIGN)

    def origin(self) -> str:
        """Where the answer came from and how many runs reached it on their own, in one phrase (the console's
        and the report's): a count of runs is never read as the answer's only source."""
        if self.found_by.startswith(
            FOUND_BY_CODESIGN
        ):  # no search, nor the sweep of orders, reaches a design of its own
            return f"found by {self.found_by}"
        if self.swept and not self.runs:
            return "every design swept"
        only = "only " if self.few_runs else ""
        if self.found_by == FOUND_BY_RUNS:
            return f"{only}{self.runs_reaching} of {self.runs} runs reached it"
        return f"found by {self.found_by}; {only}{self.runs_reaching} of {self.runs} runs reached it on their own"


@dataclass(frozen=True)
class Equivalence:
    """The answer and its runner-up compared with what the objective itself is sure of: the gap between them
    against the largest |sampled - continuous| peak of the two designs and the integration error."""

    gap: float  # the runner-up's value minus the answer's
    sampling: float | None  # the largest |sampled - continuous| peak of the two (None: not the sampled peak)
    integration: float  # the full fidelity's error on the two (the second integrator's, or its stated bound)
    runner_up_outputs: RunOutputs | None

    @property
    def equivalent(self) -> bool:
        return self.gap < max(self.sampling or 0.0, self.integration)

    def reason(self, unit: str) -> str:
        """Why the two are equivalent, in one phrase (the console's and the report's)."""
        if self.sampling is not None and self.sampling >= self.integration:
            return (
                f"{self.gap:.4f} {unit} apart, less than the {self.sampling:.2f} {unit} between the sampled and "
                "the continuous peak"
            )
        return f"{self.gap:.2g} {unit} apart, less than the integration error ({self.integration:.2g} {unit})"


@dataclass(frozen=True)
class EnergyFlows:
    external_work: float
    nonreciprocal_work: float
    dissipated_energy: float
    start_energy: float = 0.0  # what the run starts with: under a projectile, its kinetic energy (none is put in)

    @property
    def energy_in(self) -> float:
        return self.external_work + self.start_energy


@dataclass(frozen=True)
class Answer:
    diagonal_rule: str
    order: Order
    materials: tuple[str, ...]  # the material of each column, by name
    objective: str  # the FMU output minimised
    peak: float  # the objective's value at full fidelity (the peak backplate force by default)
    peak_other_rule: float | None  # the same design's value under the other rule (two rules searched)
    values_by_rule: dict[str, float | None]
    energy_by_rule: dict[str, EnergyFlows | None]
    outputs: RunOutputs | None
    evidence: Evidence
    design_file: str
    runner_up: Order | None  # the next best design known under the rule: evaluated here, or the sweep's
    runner_up_peak: float | None
    search_relative_error: float | None  # the search fidelity's value of this design against its full one
    roles: tuple[str, ...] = ()  # what this answer is to the reader: the design file, the study's model
    equivalence: Equivalence | None = None  # against the runner-up (None: no runner-up with a value)
    # every start value the answer needs in any FMI tool, by the FMU's variable names (start_values_for)
    parameters: dict[str, int | float] = field(default_factory=dict)
    # each column's material and section 12's properties (with --vary, each varied one's factor too)
    columns: tuple[ColumnProperties, ...] = ()
    total_mass: float | None = None  # kg: the stack's mass, R D times the sum of its columns' masses

    def start_values_text(self, separator: str = "=") -> str:
        """The parameters as a user types them: ``material[1]=3 ... diagonal_rule=1`` (``separator`` " ":
        the words of ``fmpy simulate --start-values``)."""
        return " ".join(f"{name}{separator}{value_text(value)}" for name, value in self.parameters.items())


@dataclass(frozen=True)
class AnswersResult:
    answers: tuple[Answer, ...]
    known_optima: dict[str, KnownOptimum | None]  # by rule: the known optimum of this case, if any

    def for_rule(self, label: str) -> Answer | None:
        return next((a for a in self.answers if a.diagonal_rule == label), None)

    @property
    def chosen(self) -> Answer | None:
        """The answer of the rule the user chose (the first searched)."""
        return self.answers[0] if self.answers else None


def value_text(value: int | float) -> str:
    """A start value as typed: an integer as such, a real number in its shortest exact form."""
    return str(value) if isinstance(value, int) else repr(float(value))


def start_values_for(context: StudyContext, order: Order, rule: str | None) -> dict[str, int | float]:
    """Every start value a design needs in any FMI tool: each column's material, the diagonal rule by its code
    (FMPy sets an FMI 3 Enumeration only by its code; the FMU's default rule is not the mean one, so the rule is
    always given), and every parameter the run set away from the FMU's defaults (enumerations by their codes).
    Load cases (--case) vary their parameters per run: they are the case's, not the answer's."""
    fmu = context.fmu
    values: dict[str, int | float] = {f"material[{column}]": int(m) for column, m in enumerate(order, start=1)}
    rule_parameter = fmu.parameters.get("diagonal_rule")
    if rule is not None and rule_parameter is not None:
        values["diagonal_rule"] = rule_parameter.value(rule)
    for name, value in context.case.parameters.items():
        values[name] = fmu.parameters[name].value(value)
    return values


def design_file(index: int, label: str) -> str:
    return "best_design.ssp" if index == 0 else f"design_{label}.ssp"


def run_answer(run, context: StudyContext, label: str) -> Order | None:
    """A search run's own answer: its best finalist at full fidelity."""
    finalists = context.result(Finalists).for_rule(label)
    full = [finalists.value_of(o) for o in finalist_orders(run, context.config(Finalists).per_run)]
    best = best_of([e for e in full if e is not None])
    return best.order if best else None


class Answers(Step):
    name = "answers"
    title = "The answer"
    template = "answers.html.j2"
    chart_file = "lattice.png"

    def applies(self, context: StudyContext) -> bool:
        return context.result(Finalists) is not None

    def verdict(self, result: AnswersResult | None, study) -> Verdict:
        """No answer when no design has a value, or when no design touches the backplate (a peak force of 0 N
        everywhere leaves nothing to minimise)."""
        if result is None or not result.answers:
            return Verdict.no_answer(f"no design was evaluated successfully: {study.failure_summary()}")
        if study.case.objective.units[0] == "N" and all(
            a.outputs is not None and a.outputs["last_contact_time"] == 0 and a.peak == 0 for a in result.answers
        ):
            options = (
                "--projectile-mass, --projectile-speed"
                if study.case.load.get("load_mode") == PROJECTILE
                else "--load, --load-angle"
            )
            return Verdict.no_answer(
                "no design touches the backplate in this case (every peak is 0 N): there is "
                f"nothing to minimise; check {options} and the scene"
            )
        return Verdict.answer()

    def run(self, context: StudyContext) -> AnswersResult:
        searched = context.result(Searches)
        descent = context.result(FinalDescent)
        swept = context.result(Exhaustive)
        rules = context.rules
        answers = []
        for index, rule in enumerate(rules):
            label = rule_label(rule)
            best = rule_best(context, label)
            if best is None:
                continue
            values, energy = {}, {}
            for judge in rules:
                evaluation = (
                    best
                    if judge == rule
                    else context.objective(judge).evaluate([best.order], context.evaluator, FULL)[0]
                )
                values[rule_label(judge)] = evaluation.value
                outputs = evaluation.outputs
                energy[rule_label(judge)] = (
                    None
                    if outputs is None
                    else EnergyFlows(
                        outputs["external_work"],
                        outputs["nonreciprocal_work"],
                        outputs["dissipated_energy"],
                        start_energy(context),
                    )
                )
            other_values = [v for k, v in values.items() if k != label]
            runs = [r for r in (searched.runs_for(label) if searched else []) if r.method not in BASELINE_METHODS]
            reaching = sum(1 for r in runs if run_answer(r, context, label) == best.order)
            check = descent.for_rule(label) if descent else None
            local = (
                None
                if check is None or (check.order == best.order and not check.complete)
                else check.locally_optimal and check.order == best.order
            )
            status, source = self.status(context, rule, label, best.order, swept)
            objective = context.objective(rule)
            sweep = swept.for_rule(label) if swept else None
            runner = self.runner_up(context, rule, best, sweep)
            search = objective.evaluate([best.order], context.evaluator, SEARCH)[0]
            peak = best.ok_value  # rule_best's is ok
            evidence = Evidence(
                reaching,
                len(runs),
                local,
                status,
                source,
                covers=objective_covered(context, label),
                swept=sweep is not None and sweep.certificate.covered_once,
                found_by=found_by(context, rule, label, best.order, reaching, sweep, check),
                local_unchecked=""
                if check is None or check.complete
                else (
                    f"the local check stopped at its cap of {check.evaluations:,} designs, which "
                    "--budget sets, before every neighbour was evaluated"
                ),
            )
            if (
                evidence.few_runs
                and status == BEST_FOUND
                and known_optimum(context.case, rule or context.case.rule_default) is None
            ):
                evidence = replace(evidence, settlement=settlement(context, rule, runs))
            roles = tuple(
                role
                for role, holds in (
                    (DESIGN_FILE_ROLE, index == 0),
                    (STUDY_MODEL_ROLE, label == STUDY_RULE and len(rules) > 1),
                )
                if holds
            )
            answers.append(
                Answer(
                    diagonal_rule=label,
                    order=best.order,
                    materials=tuple(context.case.materials.name_of(m) for m in best.order),
                    objective=context.case.outputs[0],
                    peak=peak,
                    peak_other_rule=other_values[0] if len(other_values) == 1 else None,
                    values_by_rule=values,
                    energy_by_rule=energy,
                    outputs=best.outputs,
                    evidence=evidence,
                    design_file=design_file(index, label),
                    runner_up=runner.order if runner else None,
                    runner_up_peak=runner.ok_value if runner else None,
                    search_relative_error=abs(search.ok_value / peak - 1) if search.ok and peak else None,
                    roles=roles,
                    equivalence=equivalence(context, best, runner, sweep),
                    parameters=start_values_for(context, best.order, rule),
                    columns=table_columns(context.case.materials, best.order),
                    total_mass=context.case.materials.stack_mass(best.order, context.case.rows * context.case.depth),
                )
            )
            codesign = context.result(CoDesign)
            found = codesign.for_rule(label) if codesign else None
            if found is not None:
                answers[-1] = with_codesign(answers[-1], found, context, rule)
        known = {rule_label(r): known_optimum(context.case, r or context.case.rule_default) for r in rules}
        return AnswersResult(tuple(answers), known)

    @staticmethod
    def runner_up(context: StudyContext, rule, best: Evaluation, sweep) -> Evaluation | None:
        """The next best design known under the rule at full fidelity: every design this run evaluated there
        (a sweep verifies its candidates there, the finalists evaluate a known optimum's runner-up), else the
        sweep's runner-up by its recorded value."""
        objective = context.objective(rule)
        (full_task,) = objective.with_cases(None).tasks(FULL) if len(context.case.cases) == 1 else (None,)
        known = context.evaluator.known(full_task) if full_task else []
        others = [e for e in known if e.ok and e.order != best.order]
        if (
            sweep
            and sweep.certificate.optimum
            and sweep.certificate.optimum.order == best.order
            and sweep.certificate.runner_up
            and sweep.certificate.runner_up.full is not None
            and not any(e.order == sweep.certificate.runner_up.order for e in others)
        ):
            others.append(Evaluation(sweep.certificate.runner_up.order, sweep.certificate.runner_up.full, "ok"))
        return min(others, key=lambda e: e.ok_value) if others else None

    @staticmethod
    def status(context: StudyContext, rule, label: str, order: Order, swept) -> tuple[str, str]:
        sweep = swept.for_rule(label) if swept else None
        if sweep is not None and sweep.certificate.optimum and sweep.certificate.optimum.order == order:
            if sweep.certificate.certified:
                return CERTIFIED, "this run's exhaustive sweep (exhaustive/certificate.json)"
            return KNOWN, "this run's exhaustive sweep, not certified: " + "; ".join(sweep.certificate.reasons)
        known = known_optimum(context.case, rule or context.case.rule_default)
        if known is not None and known.order == order:
            return (CERTIFIED if known.certified else KNOWN), (
                f"{known.source} (orchestrator/known_optima.json; to sweep it again: `{known.command}`)"
            )
        if known is not None:
            return BEST_FOUND, (
                f"the known optimum is {list(known.order)} at {known.peak:.4f} N "
                f"({'certified' if known.certified else 'exhaustive sweep'})"
            )
        return BEST_FOUND, "the best design the searches found; no exhaustive sweep of this case"

    def cost_note(self, context: StudyContext) -> str:
        return "each rule's answer under the other rules and at the search fidelity: a few runs, whatever the budget"

    def chart(self, study, path):
        return draw_lattice(study, path)

    def design_files(self, study):
        result = study.result(type(self))
        return [(a.design_file, a.order, a.diagonal_rule) for a in (result.answers if result else ())]


def with_codesign(answer: Answer, found, context: StudyContext, rule) -> Answer:
    """The answer with the co-design's columns and mass; its design, value and parameters when the co-design
    changed the order search's answer (its value under the other rules is then not computed)."""
    columns = found.columns
    if not found.varied and found.point.order == answer.order:
        return replace(answer, columns=columns, total_mass=found.total_mass)
    return replace(
        answer,
        order=found.point.order,
        materials=tuple(c.material for c in columns),
        peak=found.peak,
        peak_other_rule=None,
        values_by_rule={answer.diagonal_rule: found.peak},
        energy_by_rule={answer.diagonal_rule: None},
        outputs=found.outputs,
        evidence=replace(
            answer.evidence,
            status=BEST_FOUND,
            status_source=(
                f"co-design within {found.mass_budget:.6g} kg; the order search's answer "
                f"{list(found.start_order)} at the table's values: {found.start_peak:.4f}"
            ),
            found_by=found.found_by,
            runs_reaching=0,
            local_optimum=None,
            local_unchecked="the order's neighbours are checked at the table's values, not at the co-design's",
            settlement=None,
        ),
        runner_up=None,
        runner_up_peak=None,
        search_relative_error=None,
        equivalence=None,
        parameters={**start_values_for(context, found.point.order, rule), **found.varied},
        columns=columns,
        total_mass=found.total_mass,
    )


def found_by(context: StudyContext, rule, label: str, order: Order, reaching: int, sweep, check) -> str:
    """Where a rule's answer came from: the runs (at least one reached it on its own), the sweep, the final
    descent from the runs' best, the recorded known optimum, a baseline (by its name), or the finalists."""
    if reaching:
        return FOUND_BY_RUNS
    if sweep is not None and sweep.certificate.optimum and sweep.certificate.optimum.order == order:
        return FOUND_BY_SWEEP
    if check is not None and check.order == order and check.start != order:
        return FOUND_BY_DESCENT
    known = known_optimum(context.case, rule or context.case.rule_default)
    if known is not None and known.order == order:
        return FOUND_BY_KNOWN
    finalists = context.result(Finalists).for_rule(label)
    baseline = next((name for name, design in finalists.baselines.items() if design == order), None)
    return f"the baseline {baseline}" if baseline else FOUND_BY_FINALISTS


def start_energy(context: StudyContext) -> float:
    """The energy a run starts with (docs/model.md section 11): under a projectile, the body's kinetic energy,
    which the contact hands to the lattice inside the model; none under the pulse, whose work is external."""
    if context.case.load_mode != PROJECTILE:
        return 0.0
    mass, speed = (
        float(context.case.parameters.get(name, context.fmu.start(name)))
        for name in ("projectile_mass", "projectile_speed")
    )
    return 0.5 * mass * speed**2


def equivalence(context: StudyContext, best: Evaluation, runner: Evaluation | None, sweep) -> Equivalence | None:
    """The runner-up's gap against what separates the sampled from the continuous peak and the integration
    error (the second integrator's where this run's sweep measured it, else the full fidelity's bound)."""
    if runner is None or best.value is None:
        return None
    outputs = [o for o in (best.outputs, runner.outputs) if o is not None]
    sampling = None
    if context.case.outputs[0] == "peak_backplate_force" and len(outputs) == 2:
        sampling = max(abs(o["peak_backplate_force"] - o["peak_backplate_force_continuous"]) for o in outputs)
    integration = FULL_ERROR * abs(best.value)
    certificate = sweep.certificate if sweep else None
    if (
        certificate
        and certificate.integration_error is not None
        and certificate.optimum
        and certificate.optimum.order == best.order
    ):
        integration = max(integration, certificate.integration_error)
    return Equivalence(runner.ok_value - best.ok_value, sampling, integration, runner.outputs)


def settlement(context: StudyContext, rule, runs) -> Settlement | None:
    """The budget and the sweep that would settle an answer few runs reached, with their projected cost: the
    searches' own evaluation time scaled to the budget; the sweep from a chunk timed with the force limit at
    the searches' best value, as the sweep would run it."""
    if not runs:
        return None
    budget = max(r.budget for r in runs) * BUDGET_FACTOR
    searched = context.result(Searches)
    every = searched.runs_for(rule_label(rule)) if searched else []
    seconds = sum(e.seconds for r in every for e in r.evaluations)
    values = [e.value for r in every for e in r.evaluations if e.ok]
    try:
        cost = sweep_cost(context, rule, min(values) if values else None)
    except ValueError:
        cost = None
    command = f"--method {SWEEP_METHOD}" + (
        " --executor dask --scheduler ADDRESS --confirm-cost" if context.case.space.size > MAX_LOCAL_DESIGNS else ""
    )
    return Settlement(budget, BUDGET_FACTOR, seconds * BUDGET_FACTOR / 3600, cost, command)


def draw_lattice(study, path: Path) -> str | None:
    answers = study.result(Answers)
    if answers is None or not answers.answers:
        return None
    case = study.case
    materials = case.materials
    designs = [(f"{a.diagonal_rule} rule's answer", a.order) for a in answers.answers]
    stiffness = np.array([m["k"] for m in materials])
    colour_map = plt.get_cmap("viridis")
    low, high = float(stiffness.min()), float(stiffness.max())
    norm = (
        matplotlib.colors.LogNorm(vmin=low, vmax=high)
        if low > 0 and high > low
        else matplotlib.colors.Normalize(vmin=low, vmax=high if high > low else low + 1.0)
    )
    if case.depth > 1:  # a plate: its layers as a stack, the loaded patch on layer 1's face
        return draw_plate_answers(case, designs, colour_map, norm, path)
    figure, axes = plt.subplots(1, len(designs), figsize=(4.6 * len(designs), 4.4), squeeze=False)
    for axis, (label, order) in zip(axes[0], designs):
        x, y = np.meshgrid(np.arange(case.columns), np.arange(case.rows))
        k = np.tile(np.array([materials[m - 1]["k"] for m in order]), (case.rows, 1))
        axis.scatter(x, y, c=k, cmap=colour_map, norm=norm, s=55, edgecolors="k", lw=0.3)
        axis.axvline(case.columns - 1 + 0.5, color="dimgray", lw=4)
        axis.annotate(
            "",
            xy=(-0.2, case.rows / 2 - 0.5),
            xytext=(-1.2, case.rows / 2 - 0.5),
            arrowprops=dict(arrowstyle="->", lw=2, color="crimson"),
        )
        axis.set_title(label, fontsize=9)
        axis.set_xticks(range(case.columns))
        axis.set_xticklabels([materials[m - 1]["name"] for m in order], fontsize=7, rotation=60)
        axis.set_yticks([])
        axis.set_xlim(-1.5, case.columns + 0.2)
    bar = figure.colorbar(matplotlib.cm.ScalarMappable(norm=norm, cmap=colour_map), ax=axes[0].tolist())
    bar.set_label("vertical spring constant k of the column's material (N)")
    load = case.load
    striker = (
        f"A {load['projectile_mass']:g} kg projectile at {load['projectile_speed']:g} m/s strikes column 1 "
        "from the left"
        if load.get("load_mode") == PROJECTILE
        else "Load from the left on column 1"
    )
    figure.suptitle(f"{striker}, backplate on the right (grey bar)", fontsize=9)
    return save(figure, path, tight=False)


__all__ = [
    "Answer",
    "Answers",
    "AnswersResult",
    "BEST_FOUND",
    "CERTIFIED",
    "EnergyFlows",
    "Equivalence",
    "Evidence",
    "FOUND_BY_DESCENT",
    "FOUND_BY_FINALISTS",
    "FOUND_BY_KNOWN",
    "FOUND_BY_RUNS",
    "FOUND_BY_SWEEP",
    "KNOWN",
    "STUDY_RULE",
    "Settlement",
    "design_file",
    "rule_best",
    "start_values_for",
    "value_text",
]
