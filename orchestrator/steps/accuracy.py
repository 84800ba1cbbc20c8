"""How accurate the chosen answer's numbers are: against a tight reference, over shorter horizons, and the
search fidelity against the full one."""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import overload

from ..objective import FULL, SEARCH
from ..study import Step, StudyContext
from ..types import Order
from .answers import Answers

TIGHT = {"rtol": 1e-12, "atol": 1e-14}
HORIZONS = (0.5, 0.75, 1.0, 2.0)


@dataclass(frozen=True)
class HorizonValue:
    horizon: float
    value: float | None


@dataclass(frozen=True)
class AccuracyResult:
    diagonal_rule: str
    order: Order
    reference_rtol: float
    reference_value: float | None
    reference_message: str
    value_relative_error: float | None  # the reported value against the reference
    continuous_relative_error: float | None
    search_relative_difference: float | None  # the search fidelity against the full one, for this design
    sampling_shortfall: float | None  # how much of the continuous peak the samples miss
    last_contact_time: float | None
    by_horizon: tuple[HorizonValue, ...]


@overload
def relative_difference(value: float, reference: float) -> float: ...
@overload
def relative_difference(value: float | None, reference: float | None) -> float | None: ...
def relative_difference(value: float | None, reference: float | None) -> float | None:
    """|value / reference - 1| (the absolute difference where the reference is 0: no load, no peak)."""
    if value is None or reference is None:
        return None
    return abs(value / reference - 1) if reference else abs(value - reference)


class Accuracy(Step):
    name = "accuracy"
    title = "How accurate these numbers are"
    template = "accuracy.html.j2"

    def applies(self, context: StudyContext) -> bool:
        answers = context.result(Answers)
        return answers is not None and answers.chosen is not None and len(context.case.cases) == 1

    def run(self, context: StudyContext) -> AccuracyResult:
        answer = context.result(Answers).chosen
        rule = answer.diagonal_rule if answer.diagonal_rule in context.case.rules else None
        objective = context.objective(rule)
        (full,) = objective.tasks(FULL)
        tight = full.with_parameters(**TIGHT)
        shorter = [replace(full, horizon=h) for h in HORIZONS if h < objective.horizon]
        runs = [tight] + shorter
        results = context.evaluator.evaluate([(run, answer.order) for run in runs])
        reference, by_horizon = results[0], results[1:]
        search = objective.evaluate([answer.order], context.evaluator, SEARCH)[0]
        outputs = answer.outputs
        continuous = outputs["peak_backplate_force_continuous"] if outputs else None
        return AccuracyResult(
            diagonal_rule=answer.diagonal_rule,
            order=answer.order,
            reference_rtol=TIGHT["rtol"],
            reference_value=reference.value,
            reference_message=reference.message,
            value_relative_error=relative_difference(answer.peak, reference.value),
            continuous_relative_error=relative_difference(
                continuous, reference.outputs["peak_backplate_force_continuous"] if reference.outputs else None
            ),
            search_relative_difference=relative_difference(search.value, answer.peak) if search.ok else None,
            sampling_shortfall=(1 - outputs["peak_backplate_force"] / continuous) if outputs and continuous else None,
            last_contact_time=outputs["last_contact_time"] if outputs else None,
            by_horizon=tuple(HorizonValue(run.horizon, e.value) for run, e in zip(shorter, by_horizon)),
        )

    def cost_note(self, context: StudyContext) -> str:
        return (
            "the chosen design against a tight reference and over shorter horizons: a fixed few runs, whatever "
            "the budget"
        )


__all__ = ["Accuracy", "AccuracyResult", "HorizonValue", "relative_difference"]
