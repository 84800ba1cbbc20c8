"""Speed against accuracy of the FMU's solvers for the chosen design: each solver setting over the full
scene, against the accuracy step's tight reference (bench/work_precision.py does it over many designs)."""
from __future__ import annotations

from dataclasses import dataclass, replace

from ..objective import FULL
from ..study import Step, StudyContext
from .accuracy import Accuracy, relative_difference
from .answers import Answers

TARGET = 1e-6  # the relative accuracy the FMU's default promises for the reported peaks
DEFAULT_SETTING = ("DOP853 (adaptive)", "rtol 1e-07")
SETTINGS = ([("DOP853 (adaptive)", {"solver": "dop853", "rtol": r, "atol": r * 1e-2}, f"rtol {r:g}")
             for r in (1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10)]
            + [("RK4 (fixed step)", {"solver": "rk4", "fixed_step": h}, f"step {h:g} s")
               for h in (1e-3, 3e-3, 1e-2, 2e-2, 4e-2)]
            + [("semi-implicit Euler (fixed step)", {"solver": "semi_implicit_euler", "fixed_step": h}, f"step {h:g} s")
               for h in (1e-4, 3e-4, 1e-3, 3e-3)])


@dataclass(frozen=True)
class SolverPoint:
    solver: str
    setting: str
    seconds: float  # the run's own time (CPU contention on a busy machine shows here)
    relative_error: float | None
    status: str  # ok (within TARGET), inaccurate, or failed
    message: str = ""


@dataclass(frozen=True)
class WorkPrecisionResult:
    diagonal_rule: str
    target: float
    points: tuple[SolverPoint, ...]


class WorkPrecision(Step):
    name = "work_precision"
    title = "Speed against accuracy of the FMU's solvers"
    template = "work_precision.html.j2"

    def applies(self, context: StudyContext) -> bool:
        accuracy = context.result(Accuracy)
        return accuracy is not None and accuracy.reference_value is not None

    def run(self, context: StudyContext) -> WorkPrecisionResult:
        answer = context.result(Answers).chosen
        reference = context.result(Accuracy).reference_value
        rule = answer.diagonal_rule if answer.diagonal_rule in context.case.rules else None
        full, = context.objective(rule).tasks(FULL)
        runs = [replace(full, parameters=tuple(sorted({**dict(full.parameters), **settings}.items())))
                for _, settings, _ in SETTINGS]
        results = context.evaluator.evaluate([(run, answer.order) for run in runs])
        points = []
        for (family, _, label), evaluation in zip(SETTINGS, results):
            if evaluation.ok:
                error = relative_difference(evaluation.value, reference)
                points.append(SolverPoint(family, label, evaluation.seconds, error,
                                          "ok" if error <= TARGET else "inaccurate"))
            else:
                points.append(SolverPoint(family, label, evaluation.seconds, None, "failed", evaluation.message))
        return WorkPrecisionResult(answer.diagonal_rule, TARGET, tuple(points))


__all__ = ["DEFAULT_SETTING", "SETTINGS", "SolverPoint", "WorkPrecision", "WorkPrecisionResult"]
