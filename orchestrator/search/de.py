"""Differential evolution on random keys: pymoo's DE on [0, 1]^d, decoded by ``DesignSpace.from_keys``.

d is ``space.key_dimension`` and each point decodes as CMA-ES and the particle swarm decode theirs. The
ask/tell plumbing, failures (+inf) and restarts are ``pymoo_search.PymooSearch``'s.

Start and polishing follow the particle swarm (``pso.py``): with ``x0="sequential"`` vector 0 of the first
population is the keys of the space's baseline and the others scatter around them with Gaussian noise of
``spread`` per key (clipped to [0, 1]; ``spread=None``: uniform); the last ``polish`` fraction of
``budget`` goes to the descent by single moves from the best design (``polish.Polished``; the share as for
CMA-ES and the swarm, python -m bench.search_convergence). Restarts scatter uniformly.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from pymoo.algorithms.soo.nonconvex.de import DE
from pymoo.core.problem import Problem

from ..design import Design, DesignSpace
from .pymoo_search import PymooSearch

VARIANTS = ("DE/rand/1/bin", "DE/best/1/bin", "DE/rand/1/exp", "DE/best/1/exp", "DE/target-to-best/1/bin")


class DifferentialEvolution(PymooSearch):
    """Options (defaults):
    pop_size=20            population and trial vectors per generation (batch size).
    variant="DE/rand/1/bin"  pymoo's variant string (selection/differences/crossover).
    CR=0.9                 crossover rate.
    F=0.8                  differential weight.
    x0="sequential"        vector 0 on the baseline's keys, the rest around them; "random": uniform.
    spread=0.3             standard deviation of the keys around the start (None: uniform).
    stagnation=20          generations of only known designs before a restart (0 = never).
    (``make_search`` adds polish=0.7, the share of ``budget`` left to the final descent, and
    polish_batch=4, see ``polish.Polished``.)
    """

    name = "de"
    POLISH = 0.7  # the default share of the budget polished (polish.Polished), as CMA-ES and PSO
    OPTIONS = {
        "pop_size": 20,
        "variant": "DE/rand/1/bin",
        "CR": 0.9,
        "F": 0.8,
        "x0": "sequential",
        "spread": 0.3,
        "stagnation": 20,
        "budget": None,
    }

    def __init__(self, space: DesignSpace | int, seed: int, **options: Any) -> None:
        merged = {**self.OPTIONS, **options}
        if merged["x0"] not in ("sequential", "random"):
            raise ValueError(f"de: x0 must be 'sequential' or 'random', got {merged['x0']!r}")
        if merged["variant"] not in VARIANTS:
            raise ValueError(f"de: variant must be one of {', '.join(VARIANTS)}, got {merged['variant']!r}")
        if int(merged["pop_size"]) < 4:
            raise ValueError(f"de: pop_size must be at least 4, got {merged['pop_size']!r}")
        if not 0.0 <= float(merged["CR"]) <= 1.0:
            raise ValueError(f"de: CR must be in [0, 1], got {merged['CR']!r}")
        if not float(merged["F"]) > 0.0:
            raise ValueError(f"de: F must be positive, got {merged['F']!r}")
        super().__init__(space, seed, **options)

    def _problem(self) -> Problem:
        return Problem(n_var=self.space.key_dimension, n_obj=1, xl=0.0, xu=1.0)

    def _initial_X(self, first: bool) -> np.ndarray:
        size = int(self.options["pop_size"])
        X = self.rng.uniform(0.0, 1.0, (size, self.space.key_dimension))
        if first and self.options["x0"] == "sequential":
            starts = self.start_designs()[:size]
            centre = self.space.to_keys(starts[0])
            if self.options["spread"] is not None:
                X = np.clip(centre + self.rng.normal(0.0, float(self.options["spread"]), X.shape), 0.0, 1.0)
            X[: len(starts)] = [self.space.to_keys(d) for d in starts]
        return X

    def _algorithm(self, initial_X: np.ndarray) -> DE:
        return DE(
            pop_size=int(self.options["pop_size"]),
            sampling=initial_X,
            variant=self.options["variant"],
            CR=float(self.options["CR"]),
            F=float(self.options["F"]),
        )

    def _decode(self, x: np.ndarray) -> Design:
        return self.space.from_keys(x)
