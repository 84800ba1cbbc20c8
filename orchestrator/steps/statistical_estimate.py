"""How far the answer may lie above the optimum where no sweep fits: a statistical estimate from random designs.

A search's answer in a space too large to sweep is the best found, which says nothing of the designs it did not
evaluate. With ``--statistical-bound N``, N uniformly random designs are evaluated at the search fidelity under
each rule and the lower tail of their values gives the optimum's estimate and a lower confidence limit
(``orchestrator.statistical_bound.tail_bound``): the probability that the answer is within X of the optimum.
It is a statistical estimate resting on the tail's law, never a certificate; ``python -m bench.statistical_bound``
measures how often its limit held where the optimum is certified.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..exhaustive import MAX_LOCAL_DESIGNS
from ..objective import SEARCH, Objective
from ..options import check_options, integer, option
from ..statistical_bound import KIND, MIN_DESIGNS, random_values, tail_bound
from ..study import Step, StudyContext
from ..types import Order
from .answers import Answers
from .searches import Searches, rule_label

CONFIDENCE = 0.95


@dataclass(frozen=True)
class StatisticalEstimateConfig:
    designs: int = option(
        0,
        "random designs whose values estimate the optimum and how far the answer may lie above it (a "
        f"statistical estimate, never a certificate; at least {MIN_DESIGNS}; 0: none)",
        flag="--statistical-bound",
        type=integer("--statistical-bound", 0, 10**9),
    )

    def __post_init__(self):
        check_options(self)
        if 0 < self.designs < MIN_DESIGNS:
            raise ValueError(
                f"--statistical-bound must be 0 (none) or at least {MIN_DESIGNS} random designs, got {self.designs}"
            )


@dataclass(frozen=True)
class RuleEstimate:
    """The estimate under one rule, beside that rule's answer (both at the search fidelity)."""

    diagonal_rule: str
    answer: Order
    answer_value: float  # the answer at the search fidelity, where the random designs were evaluated
    designs: int
    tail: int  # the smallest values fitted
    confidence: float
    estimate: float  # the fitted lower end, at most the answer's value (a design's value bounds the optimum)
    lower: float | None  # the optimum is at least this with probability ``confidence``; None: not bounded
    best_seen: float  # the best of the random designs
    exponent: float
    exponent_upper: float | None  # None: not bounded
    sentence: str  # the estimate for a reader, beside the answer
    kind: str = KIND

    @property
    def within(self) -> float | None:
        """How far the answer may lie above the optimum with probability ``confidence`` (None: not bounded, or
        the answer lies below the limit, which the tail's law then does not describe)."""
        if self.lower is None or self.answer_value < self.lower:
            return None
        return self.answer_value - self.lower


@dataclass(frozen=True)
class StatisticalEstimateResult:
    estimates: tuple[RuleEstimate, ...]
    sweepable: bool  # the space is small enough to sweep here: the sweep would certify the optimum instead
    unit: str
    unfitted: tuple[str, ...] = ()  # a rule whose values could not be fitted, and why

    def for_rule(self, label: str) -> RuleEstimate | None:
        return next((e for e in self.estimates if e.diagonal_rule == label), None)


def finite_or_none(value: float) -> float | None:
    return value if math.isfinite(value) else None


class StatisticalEstimate(Step):
    name = "statistical_estimate"
    title = "How far the answer may lie above the optimum: a statistical estimate"
    template = "statistical_estimate.html.j2"
    Config = StatisticalEstimateConfig

    def applies(self, context: StudyContext) -> bool:
        answers = context.result(Answers)
        return self.config.designs > 0 and answers is not None and answers.chosen is not None

    def check(self, context: StudyContext) -> None:
        if self.config.designs and len(context.case.outputs) > 1:
            raise ValueError("--statistical-bound: with one objective only (a front has no single optimum)")

    def run(self, context: StudyContext) -> StatisticalEstimateResult:
        answers = context.result(Answers)
        objective = context.objective(context.rules[0])
        unit = objective.describe().units[0]
        seed = context.config(Searches).seed
        estimates, unfitted = [], []
        for index, rule in enumerate(context.rules):
            answer = answers.for_rule(rule_label(rule))
            if answer is None:
                continue
            objective = context.objective(rule)
            (at_search,) = objective.evaluate([answer.order], context.evaluator, SEARCH)
            if not at_search.ok:
                continue
            answer_value = at_search.ok_value

            def evaluate(drawn: list, objective: Objective = objective) -> list:
                return list(objective.evaluate(drawn, context.evaluator, SEARCH))

            values = random_values(
                evaluate,
                context.case.space,
                self.config.designs,
                np.random.default_rng([seed, index]),
            )
            try:
                bound = tail_bound(values, CONFIDENCE)
            except ValueError as exc:  # too few distinct values in a small space: say why, keep the run's answer
                unfitted.append(f"{answer.diagonal_rule} rule: no estimate ({exc})")
                continue
            estimates.append(
                RuleEstimate(
                    diagonal_rule=answer.diagonal_rule,
                    answer=answer.order,
                    answer_value=answer_value,
                    designs=bound.designs,
                    tail=bound.tail,
                    confidence=bound.confidence,
                    estimate=min(bound.estimate, answer_value),
                    lower=finite_or_none(bound.lower),
                    best_seen=bound.best_seen,
                    exponent=bound.exponent,
                    exponent_upper=finite_or_none(bound.exponent_upper),
                    sentence=bound.text(answer_value, unit),
                )
            )
        sweepable = context.case.space.size <= MAX_LOCAL_DESIGNS
        return StatisticalEstimateResult(tuple(estimates), sweepable, unit, tuple(unfitted))

    def cost_note(self, context: StudyContext) -> str:
        return (
            f"{self.config.designs:,} random designs under each rule at the search fidelity, for the statistical "
            "estimate of the optimum"
        )


__all__ = ["RuleEstimate", "StatisticalEstimate", "StatisticalEstimateConfig", "StatisticalEstimateResult"]
