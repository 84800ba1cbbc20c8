"""The force on the backplate over time for the answers and the baselines, and the energy balance of each
answer: the report's charts, computed as tasks of the evaluator (journalled, resumed, parallel)."""
from __future__ import annotations

from dataclasses import dataclass

from ..objective import FULL, RecordRun, Trajectory
from ..simulation import ENERGY_OUTPUTS
from ..study import Step, StudyContext
from .answers import Answers
from .finalists import baselines

FORCE_HORIZON = 1.0  # s: the force peaks and ends well before (bench/horizon_study.py)
FORCE_STEP = 1e-3
ENERGY_STEP = 1e-2


@dataclass(frozen=True)
class LabelledTrajectory:
    label: str
    diagonal_rule: str
    trajectory: Trajectory


@dataclass(frozen=True)
class TrajectoriesResult:
    force: tuple[LabelledTrajectory, ...]  # backplate_force under the chosen design's rule
    energy: tuple[LabelledTrajectory, ...]  # each answer's energy terms under its own rule


def record(context: StudyContext, rule_label: str, order, horizon: float, step: float, outputs) -> RecordRun:
    rule = rule_label if rule_label in context.case.rules else None
    full, = context.objective(rule).with_cases(None).tasks(FULL)
    return RecordRun(full.fmu_path, order, horizon, step, full.parameters, tuple(outputs))


class Trajectories(Step):
    name = "trajectories"
    title = "Force over time and energy balance"
    template = "trajectories.html.j2"

    def applies(self, context: StudyContext) -> bool:
        answers = context.result(Answers)
        return answers is not None and answers.chosen is not None

    def run(self, context: StudyContext) -> TrajectoriesResult:
        answers = context.result(Answers).answers
        chosen = answers[0]
        designs = {f"{a.diagonal_rule} rule's answer": a.order for a in answers}
        for label, order in baselines(context).items():
            designs.setdefault(label, order)
        horizon = min(FORCE_HORIZON, context.case.horizon)
        force_tasks = [record(context, chosen.diagonal_rule, order, horizon, FORCE_STEP, ("backplate_force",))
                       for order in designs.values()]
        energy_tasks = [record(context, a.diagonal_rule, a.order, context.case.horizon, ENERGY_STEP, ENERGY_OUTPUTS)
                        for a in answers]
        results = context.evaluator.run(force_tasks + energy_tasks)
        force = tuple(LabelledTrajectory(label, chosen.diagonal_rule, t)
                      for label, t in zip(designs, results[:len(force_tasks)]))
        energy = tuple(LabelledTrajectory(f"{a.diagonal_rule} rule's answer", a.diagonal_rule, t)
                       for a, t in zip(answers, results[len(force_tasks):]))
        return TrajectoriesResult(force, energy)


__all__ = ["LabelledTrajectory", "Trajectories", "TrajectoriesResult"]
