"""Pareto fronts of minimised objectives: the non-dominated set and its hypervolume.

Pure functions on arrays of objective vectors (one row a design, every objective minimised), for the
multi-objective search (``nsga2.py``), the report and the tests. The hypervolume is moocore's where moocore
is installed (exact, fast in 2 and 3 objectives) and pymoo's indicator otherwise; both measure the region
dominated by the points and bounded by the reference point, to which a point not strictly better than the
reference on every objective adds nothing.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ..design import Design

try:
    import moocore
except ImportError:  # the project's dependencies do not require it; pymoo's indicator then
    moocore = None


@dataclass(frozen=True)
class ParetoPoint:
    """A design and its objective values (every one minimised)."""

    design: Design
    objectives: tuple[float, ...]


def objective_matrix(points: Sequence[Sequence[float]] | np.ndarray, what: str = "points") -> np.ndarray:
    """``points`` as a finite 2-D float array (a row a point), or a one-line ValueError saying why not."""
    array = np.asarray(points, dtype=float)
    if array.ndim == 1 and array.size == 0:
        return array.reshape(0, 0)
    if array.ndim != 2:
        raise ValueError(f"{what} must be a list of objective vectors (a 2-D array), got shape {array.shape}")
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{what} must be finite; a failed design has no objective values")
    return array


def non_dominated(points: Sequence[Sequence[float]] | np.ndarray) -> np.ndarray:
    """A boolean mask: True for each point that no other point dominates (at least as good on every
    objective, better on one). Equal points do not dominate each other, so all of them are kept."""
    F = objective_matrix(points)
    if F.shape[0] == 0:
        return np.zeros(0, dtype=bool)
    if moocore is not None:
        return np.asarray(moocore.is_nondominated(F, keep_weakly=True), dtype=bool)
    at_most = np.all(F[:, None, :] <= F[None, :, :], axis=2)  # at_most[j, i]: j is at most i everywhere
    better = np.any(F[:, None, :] < F[None, :, :], axis=2)
    return ~np.any(at_most & better, axis=0)


def dominated_by(
    points: Sequence[Sequence[float]] | np.ndarray, others: Sequence[Sequence[float]] | np.ndarray
) -> np.ndarray:
    """A boolean mask: True for each of ``points`` that some row of ``others`` dominates (at least as good on
    every objective, better on one). What a reported front must never contain: a point that a design the
    study evaluated, or a known optimum, dominates."""
    F = objective_matrix(points)
    G = objective_matrix(others, "others")
    if F.shape[0] == 0 or G.shape[0] == 0:
        return np.zeros(F.shape[0], dtype=bool)
    if F.shape[1] != G.shape[1]:
        raise ValueError(f"points have {F.shape[1]} objectives but others have {G.shape[1]}")
    at_most = np.all(G[:, None, :] <= F[None, :, :], axis=2)  # at_most[j, i]: other j is at most point i
    better = np.any(G[:, None, :] < F[None, :, :], axis=2)
    return np.any(at_most & better, axis=0)


def hypervolume(points: Sequence[Sequence[float]] | np.ndarray, reference_point: Sequence[float] | np.ndarray) -> float:
    """The hypervolume of ``points`` (minimised objectives) with respect to ``reference_point``: the measure
    of the region each point dominates and the reference point bounds. Points not strictly better than the
    reference on every objective add nothing; no points: 0."""
    reference = np.asarray(reference_point, dtype=float)
    if reference.ndim != 1 or reference.size < 1 or not np.all(np.isfinite(reference)):
        raise ValueError(f"reference_point must be a finite vector, got {reference_point!r}")
    F = objective_matrix(points)
    if F.shape[0] == 0:
        return 0.0
    if F.shape[1] != reference.size:
        raise ValueError(f"points have {F.shape[1]} objectives but reference_point has {reference.size}")
    F = F[np.all(F < reference, axis=1)]
    if F.shape[0] == 0:
        return 0.0
    if moocore is not None:
        return float(moocore.hypervolume(F, ref=reference))
    from pymoo.indicators.hv import HV

    return float(HV(ref_point=reference)(F))


def reference_point(points: Sequence[Sequence[float]] | np.ndarray, margin: float = 0.1) -> np.ndarray:
    """A reference point for comparing fronts of one problem: the nadir of ``points`` (their worst value per
    objective) moved out by ``margin`` times their range on that objective (by ``margin`` when the range is
    0), so that the ends of the front count."""
    F = objective_matrix(points)
    if F.shape[0] == 0:
        raise ValueError("reference_point needs at least one point")
    if not margin >= 0:
        raise ValueError(f"margin must be non-negative, got {margin!r}")
    worst, best = F.max(axis=0), F.min(axis=0)
    spread = np.where(worst > best, worst - best, 1.0)
    return worst + margin * spread


def pareto_front(designs: Sequence[Design], points: Sequence[Sequence[float]] | np.ndarray) -> list[ParetoPoint]:
    """The non-dominated designs with their objective values, sorted by the objectives."""
    F = objective_matrix(points)
    if len(designs) != F.shape[0]:
        raise ValueError(f"{len(designs)} designs but {F.shape[0]} objective vectors")
    mask = non_dominated(F) if F.shape[0] else np.zeros(0, dtype=bool)
    front = [ParetoPoint(tuple(d), tuple(float(v) for v in row)) for d, row, keep in zip(designs, F, mask) if keep]
    return sorted(front, key=lambda p: (p.objectives, p.design))


__all__ = ["ParetoPoint", "dominated_by", "hypervolume", "non_dominated", "pareto_front", "reference_point"]
