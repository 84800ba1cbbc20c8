"""Starting designs: designs a person knows (``--start``, ``--start-file``), which every search evaluates first
and starts from (``orchestrator.search.starts``), and how much better the answer is than each of them.

The designs are read and checked against the design space before any simulation. After the answers, each
starting design is evaluated at full fidelity under each rule (the finalists' evaluation when it was one: the
evaluator's cache) and compared with that rule's answer, in the objective's unit and in per cent.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..objective import FULL
from ..study import Step, StudyContext
from ..types import Order
from .answers import Answers
from .searches import rule_label
from .starting_designs import StartsConfig, starting_designs


@dataclass(frozen=True)
class StartComparison:
    """One starting design against one rule's answer, both at full fidelity."""

    diagonal_rule: str
    order: Order
    materials: tuple[str, ...]
    value: float | None  # None: its evaluation failed (``message`` says why)
    message: str
    answer: Order
    answer_value: float
    improvement: float | None  # value - answer_value, in the objective's unit (positive: the answer is better)
    improvement_percent: float | None  # of the starting design's value


@dataclass(frozen=True)
class StartsResult:
    designs: tuple[Order, ...]
    comparisons: tuple[StartComparison, ...]  # empty with several objectives (no single answer)


class Starts(Step):
    name = "starts"
    title = "Starting designs"
    Config = StartsConfig

    def applies(self, context: StudyContext) -> bool:
        return bool(self.config.start or self.config.start_file)

    def check(self, context: StudyContext) -> None:
        starting_designs(context)

    def run(self, context: StudyContext) -> StartsResult:
        designs = starting_designs(context)
        answers = context.result(Answers)
        comparisons = []
        for rule in context.rules:
            answer = answers.for_rule(rule_label(rule)) if answers else None
            if answer is None:
                continue
            for evaluation in context.objective(rule).evaluate(designs, context.evaluator, FULL):
                value = evaluation.value if evaluation.ok else None
                improvement = None if value is None else value - answer.peak
                comparisons.append(
                    StartComparison(
                        diagonal_rule=answer.diagonal_rule,
                        order=evaluation.order,
                        materials=tuple(context.case.materials.name_of(m) for m in evaluation.order),
                        value=value,
                        message=evaluation.message,
                        answer=answer.order,
                        answer_value=answer.peak,
                        improvement=improvement,
                        improvement_percent=None if improvement is None or not value else 100.0 * improvement / value,
                    )
                )
        return StartsResult(designs, tuple(comparisons))


def comparison_line(comparison: StartComparison, unit: str) -> str:
    """The comparison in the words of the first screen."""
    start = f"starting design {list(comparison.order)}"
    if comparison.value is None or comparison.improvement is None:  # both None together
        return f"{start}: its evaluation failed ({comparison.message}) under the {comparison.diagonal_rule} rule"
    if comparison.answer == comparison.order:
        return (
            f"{start}: {comparison.value:.2f} {unit} under the {comparison.diagonal_rule} rule; the searches "
            "found nothing better: it is the answer"
        )
    if comparison.improvement > 0:
        how = f"the answer is {comparison.improvement:.2f} {unit} ({comparison.improvement_percent:.1f} %) lower"
    else:
        how = f"the answer is {-comparison.improvement:.2f} {unit} higher (see the answer's evidence)"
    return f"{start}: {comparison.value:.2f} {unit} under the {comparison.diagonal_rule} rule; {how}"


__all__ = ["StartComparison", "Starts", "StartsResult", "comparison_line"]
