"""What the study the project starts from published: its orders and peaks, and its searches' reference points.

The one table code, tests, the FMU's documentation and the examples import (docs/model.md section 6). The
peaks are the study's own numbers for the 11 x 11 armour scene at the conditions of `PUBLISHED_CONDITIONS`;
the FMU's defaults reproduce them. They are reference points to draw and compare with, never results.
"""

from __future__ import annotations

from dataclasses import dataclass

SEQUENTIAL_ORDER = (1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11)
STUDY_BEST_ORDER = (1, 7, 5, 9, 3, 6, 11, 8, 2, 4, 10)

# peak_backplate_force (N) of each published order
PUBLISHED_PEAKS: dict[tuple[int, ...], float] = {
    SEQUENTIAL_ORDER: 1747.779979851872,
    STUDY_BEST_ORDER: 1497.8867334973704,
}

# The conditions the published peaks hold at (the armour scene's defaults), by FMU parameter name; the horizon
# in s.
PUBLISHED_HORIZON = 8.0
PUBLISHED_CONDITIONS = {"peak_sample_interval": 0.01, "diagonal_rule": "receiver", "load_angle": 0.0, "F_total": 1200.0}


@dataclass(frozen=True)
class ReferencePoint:
    """One number the study reported for a search: its best peak (N) and, where it says, at which
    evaluation that search found it."""

    label: str
    peak: float
    evaluation: int | None = None


STUDY_BEST = ReferencePoint("study best", PUBLISHED_PEAKS[STUDY_BEST_ORDER], evaluation=4)
STUDY_PARTICLE_SWARM = ReferencePoint("study particle swarm", 1571.88)
STUDY_SIMULATED_ANNEALING = ReferencePoint("study simulated annealing", 2912.76)
STUDY_SEQUENTIAL = ReferencePoint("sequential order", PUBLISHED_PEAKS[SEQUENTIAL_ORDER])
REFERENCE_POINTS = (STUDY_BEST, STUDY_PARTICLE_SWARM, STUDY_SIMULATED_ANNEALING, STUDY_SEQUENTIAL)

__all__ = [
    "PUBLISHED_CONDITIONS",
    "PUBLISHED_HORIZON",
    "PUBLISHED_PEAKS",
    "REFERENCE_POINTS",
    "ReferencePoint",
    "SEQUENTIAL_ORDER",
    "STUDY_BEST",
    "STUDY_BEST_ORDER",
    "STUDY_PARTICLE_SWARM",
    "STUDY_SEQUENTIAL",
    "STUDY_SIMULATED_ANNEALING",
]
