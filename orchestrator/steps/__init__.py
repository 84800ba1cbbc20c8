"""The study's steps, in the order they run: one file per feature, one line here."""

from __future__ import annotations

from .accuracy import Accuracy
from .answers import Answers
from .codesign import CoDesign
from .final_descent import FinalDescent
from .exhaustive import Exhaustive
from .finalists import Finalists
from .optuna_export import OptunaExport
from .pareto import Pareto
from .searches import Searches
from .sensitivity import Sensitivity
from .starts import Starts
from .statistical_estimate import StatisticalEstimate
from .trajectories import Trajectories
from .work_precision import WorkPrecision

STEPS = (
    Searches,
    Exhaustive,
    Finalists,
    FinalDescent,
    Pareto,
    CoDesign,
    Answers,
    Starts,
    StatisticalEstimate,
    Sensitivity,
    Accuracy,
    Trajectories,
    WorkPrecision,
    OptunaExport,
)

__all__ = ["STEPS"] + [step.__name__ for step in STEPS]
