"""Differential evolution on random keys: pymoo's DE, decoded by ``keys_to_order``.

The study's differential evolution has no counterpart among our searches, so
this is pymoo's ``DE`` on the unit cube [0, 1]^n, each point decoded to the
order ``argsort(x) + 1`` as CMA-ES and the particle swarm decode theirs.  The
ask/tell plumbing, failures (+inf) and restarts are
``pymoo_search.PymooSearch``'s.

Start, budget and polishing follow the particle swarm (``pso.py``): with
``x0="sequential"`` vector 0 of the first population is the keys of the
sequential order 1..n and the others scatter around them with Gaussian noise
of ``spread`` per key (clipped to [0, 1]; ``spread=None``: uniform); the last
``polish`` fraction of ``budget`` goes to the descent by swaps and insertions
from the best order (``polish.Polished``).  Restarts scatter uniformly.
"""
from __future__ import annotations

from typing import Any

import numpy as np
from pymoo.algorithms.soo.nonconvex.de import DE
from pymoo.core.problem import Problem

from ..types import Order
from .base import keys_to_order
from .local import sequential_keys
from .pymoo_search import PymooSearch

VARIANTS = ("DE/rand/1/bin", "DE/best/1/bin", "DE/rand/1/exp", "DE/best/1/exp", "DE/target-to-best/1/bin")


class DifferentialEvolution(PymooSearch):
    """Options (defaults):
      pop_size=20            population and trial vectors per generation (batch size).
      variant="DE/rand/1/bin"  pymoo's variant string (selection/differences/crossover).
      CR=0.9                 crossover rate.
      F=0.8                  differential weight.
      x0="sequential"        vector 0 on the sequential order's keys, the rest around them;
                             "random": uniform.
      spread=0.3             standard deviation of the keys around the start (None: uniform).
      stagnation=20          generations of only known orders before a restart (0 = never).
      (``make_search`` adds polish=0.7, the share of ``budget`` left to the final descent, and
      polish_batch=4, see ``polish.Polished``.)
    """

    name = "de"
    POLISH = 0.7  # the default share of the budget polished (polish.Polished), as CMA-ES and PSO
    OPTIONS = {"pop_size": 20, "variant": "DE/rand/1/bin", "CR": 0.9, "F": 0.8, "x0": "sequential",
               "spread": 0.3, "stagnation": 20, "budget": None}

    def __init__(self, n: int, seed: int, **options: Any) -> None:
        merged = {**self.OPTIONS, **options}
        if merged["x0"] not in ("sequential", "random"):
            raise ValueError("de: x0 must be 'sequential' or 'random'")
        if merged["variant"] not in VARIANTS:
            raise ValueError(f"de: variant must be one of {', '.join(VARIANTS)}")
        if int(merged["pop_size"]) < 4:
            raise ValueError("de: pop_size must be at least 4")
        if not 0.0 <= float(merged["CR"]) <= 1.0:
            raise ValueError("de: CR must be in [0, 1]")
        if not float(merged["F"]) > 0.0:
            raise ValueError("de: F must be positive")
        super().__init__(n, seed, **options)

    def _problem(self) -> Problem:
        return Problem(n_var=self.n, n_obj=1, xl=0.0, xu=1.0)

    def _initial_X(self, first: bool) -> np.ndarray:
        size = int(self.options["pop_size"])
        X = self.rng.uniform(0.0, 1.0, (size, self.n))
        if first and self.options["x0"] == "sequential":
            centre = sequential_keys(self.n)
            if self.options["spread"] is not None:
                X = np.clip(centre + self.rng.normal(0.0, float(self.options["spread"]), X.shape), 0.0, 1.0)
            X[0] = centre
        return X

    def _algorithm(self, initial_X: np.ndarray) -> DE:
        return DE(pop_size=int(self.options["pop_size"]), sampling=initial_X,
                  variant=self.options["variant"], CR=float(self.options["CR"]), F=float(self.options["F"]))

    def _decode(self, x: np.ndarray) -> Order:
        return keys_to_order(x, self.n)
