"""Speed against accuracy of the FMU's solvers for the chosen design: each solver setting over the full
scene, against the accuracy step's tight reference (python -m bench.work_precision does it over many designs)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from ..charts import legend_below, plt, save
from ..objective import FULL
from ..study import Step, StudyContext
from ..types import Evaluation
from .accuracy import Accuracy, relative_difference
from .answers import Answers

TARGET = 1e-6  # the relative accuracy the FMU's default promises for the reported peaks
SETTINGS = (
    [
        ("DOP853 (adaptive)", {"solver": "dop853", "rtol": r, "atol": r * 1e-2}, f"rtol {r:g}")
        for r in (1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10)
    ]
    + [
        ("RK4 (fixed step)", {"solver": "rk4", "fixed_step": h}, f"step {h:g} s")
        for h in (1e-3, 3e-3, 1e-2, 2e-2, 4e-2)
    ]
    + [
        ("semi-implicit Euler (fixed step)", {"solver": "semi_implicit_euler", "fixed_step": h}, f"step {h:g} s")
        for h in (1e-4, 3e-4, 1e-3, 3e-3)
    ]
)


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
    default: SolverPoint  # the FMU's own default setting: what every reported number used
    points: tuple[SolverPoint, ...]


class WorkPrecision(Step):
    name = "work_precision"
    title = "Speed against accuracy of the FMU's solvers"
    template = "work_precision.html.j2"
    chart_file = "work_precision.png"

    def applies(self, context: StudyContext) -> bool:
        accuracy = context.result(Accuracy)
        return accuracy is not None and accuracy.reference_value is not None

    def run(self, context: StudyContext) -> WorkPrecisionResult:
        answer = context.result(Answers).chosen
        reference = context.result(Accuracy).reference_value
        rule = answer.diagonal_rule if answer.diagonal_rule in context.case.rules else None
        (full,) = context.objective(rule).tasks(FULL)
        runs = [full.with_parameters(**settings) for _, settings, _ in SETTINGS]
        fmu = context.fmu
        default_label = (
            f"default: {fmu.start('solver', 'dop853')} at rtol {fmu.start('rtol', 0):g}, atol {fmu.start('atol', 0):g}"
        )
        results = context.evaluator.evaluate([(run, answer.order) for run in [full] + runs])
        points = [
            self.point(family, label, e, reference)
            for (family, _, label), e in zip([("the FMU's default", None, default_label), *SETTINGS], results)
        ]
        return WorkPrecisionResult(answer.diagonal_rule, TARGET, points[0], tuple(points[1:]))

    def cost_note(self, context: StudyContext) -> str:
        return (
            "each solver setting of the FMU once on the chosen design, for the work-precision chart, whatever "
            "the budget"
        )

    @staticmethod
    def point(family: str, label: str, evaluation: Evaluation, reference: float) -> SolverPoint:
        if not evaluation.ok:
            return SolverPoint(family, label, evaluation.seconds, None, "failed", evaluation.message)
        error = relative_difference(evaluation.ok_value, reference)
        return SolverPoint(family, label, evaluation.seconds, error, "ok" if error <= TARGET else "inaccurate")

    def chart(self, study, path):
        return draw_work_precision(study, path)


def draw_work_precision(study, path: Path) -> str | None:
    result = study.result(WorkPrecision)
    if result is None:
        return None
    figure, axis = plt.subplots(figsize=(8, 5))
    families = list(dict.fromkeys(p.solver for p in result.points))
    labels = []
    for family, colour in zip(families, ("tab:blue", "tab:orange", "tab:green")):
        good = [p for p in result.points if p.solver == family and p.relative_error is not None]
        bad = [p for p in result.points if p.solver == family and p.relative_error is None]
        axis.plot(
            [p.seconds for p in good], [max(p.relative_error, 1e-16) for p in good], "o-", color=colour, label=family
        )
        labels += [
            axis.annotate(
                p.setting,
                (p.seconds, max(p.relative_error, 1e-16)),
                fontsize=6,
                color=colour,
                textcoords="offset points",
                xytext=(3, 3),
            )
            for p in good
        ]
        if bad:
            axis.plot(
                [max(p.seconds, 1e-5) for p in bad],
                [1.0] * len(bad),
                "x",
                color=colour,
                ms=9,
                label=f"{family}: failed with an FMI error ({', '.join(p.setting for p in bad)})",
            )
    default = result.default
    if default.relative_error is not None:
        axis.plot(
            [default.seconds],
            [max(default.relative_error, 1e-16)],
            "*",
            ms=15,
            color="gold",
            markeredgecolor="k",
            label=f"the FMU's {default.setting}: what every number above used",
        )
    axis.axhline(result.target, color="crimson", ls="--", lw=1, label=f"{result.target:g}: the accuracy target")
    if any(p.relative_error is not None for p in result.points):
        axis.set_xscale("log")
        axis.set_yscale("log")
    axis.set_xlabel("seconds per run of the full scene (this machine, during the study)")
    axis.set_ylabel("relative error of the peak against rtol 1e-12")
    axis.set_title(f"Each solver setting of the FMU for the chosen design ({result.diagonal_rule} rule)", fontsize=9)
    axis.grid(alpha=0.3, which="both")
    if axis.get_legend_handles_labels()[0]:
        legend_below(axis, columns=2)
    return save(figure, path, labels=labels)


__all__ = ["SETTINGS", "SolverPoint", "WorkPrecision", "WorkPrecisionResult"]
