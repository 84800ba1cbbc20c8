"""Independent numpy/scipy reference implementation of the lattice model (docs/model.md).

Public API::

    Scene, default_material_table, DIAGONAL_RULES, SPRING_LAWS
    rhs(scene, t, y, load_on=None)           -> dydt (4N,)
    powers(scene, t, y, load_on=None)        -> (P_ext, P_diss, P_nonreciprocal)
    rhs_with_powers(scene, t, y, load_on=None)
    energies(scene, y)                       -> (kinetic, potential)
    backplate_force(scene, y)                -> float (or array for stacked states)
    forces / internal_forces / wall_forces / external_forces -> (N, 2) arrays
    spring_scale, spring_potential           (the spring law, f = s r)
    simulate(scene, horizon=8.0, sample_interval=0.01, rtol=1e-10, atol=1e-12,
             method="DOP853", ...)            -> SimulationResult
    sample_times(horizon, sample_interval)
"""

from .lattice import (
    DIAGONAL_RULES,
    SPRING_LAWS,
    Scene,
    backplate_force,
    default_material_table,
    energies,
    external_forces,
    forces,
    internal_forces,
    powers,
    rhs,
    rhs_with_powers,
    spring_potential,
    spring_scale,
    wall_forces,
)
from .simulate import SimulationResult, sample_times, simulate

from fmu_src.published import SEQUENTIAL_ORDER, STUDY_BEST_ORDER as PUBLISHED_ORDER  # noqa: E402

__all__ = [
    "DIAGONAL_RULES",
    "SPRING_LAWS",
    "Scene",
    "SimulationResult",
    "backplate_force",
    "default_material_table",
    "energies",
    "external_forces",
    "forces",
    "internal_forces",
    "powers",
    "rhs",
    "rhs_with_powers",
    "sample_times",
    "simulate",
    "spring_potential",
    "spring_scale",
    "wall_forces",
    "PUBLISHED_ORDER",
    "SEQUENTIAL_ORDER",
]
