"""Genetic algorithm over permutations: pymoo's GA with its permutation operators.

The study's genetic algorithm has no counterpart among our random-key
searches, so this is pymoo's ``GA`` as its documentation sets it up for
permutation problems (the travelling-salesman example): permutation random
sampling, order crossover (OX: a segment of one parent, the rest in the other
parent's order), inversion mutation (a segment reversed) and elimination of
duplicate individuals, with pymoo's default binary tournament selection and
fitness survival.  The ask/tell plumbing, failures (+inf) and restarts are
``pymoo_search.PymooSearch``'s.

Start, budget and polishing follow the other optimisers (``polish.py``): with
``x0="sequential"`` individual 0 of the first population is the sequential
order 1..n (the user's baseline) and the rest are random permutations; the
last ``polish`` fraction of ``budget`` goes to the descent by swaps and
insertions from the best order (``polish.Polished``, which ``make_search`` wraps it in).
"""
from __future__ import annotations

from typing import Any

import numpy as np
from pymoo.algorithms.soo.nonconvex.ga import GA
from pymoo.core.problem import Problem
from pymoo.operators.crossover.nox import NoCrossover
from pymoo.operators.crossover.ox import OrderCrossover
from pymoo.operators.mutation.inversion import InversionMutation
from pymoo.operators.sampling.rnd import PermutationRandomSampling

from ..types import Order
from .pymoo_search import PymooSearch


class GeneticAlgorithm(PymooSearch):
    """Options (defaults):
      pop_size=20        population and offspring per generation (batch size).
      mutation_prob=0.3  probability that a child's segment is inverted.
      x0="sequential"    individual 0 of the first population is 1..n; "random": none is.
      stagnation=20      generations of only known orders before a restart (0 = never).
      (``make_search`` adds polish=0.7, the share of ``budget`` left to the final descent, and
      polish_batch=4, see ``polish.Polished``.)
    """

    name = "ga"
    POLISH = 0.7  # the default share of the budget polished (polish.Polished), as CMA-ES and PSO
    OPTIONS = {"pop_size": 20, "mutation_prob": 0.3, "x0": "sequential", "stagnation": 20,
               "budget": None}

    def __init__(self, n: int, seed: int, **options: Any) -> None:
        merged = {**self.OPTIONS, **options}
        if merged["x0"] not in ("sequential", "random"):
            raise ValueError("ga: x0 must be 'sequential' or 'random'")
        if int(merged["pop_size"]) < 2:
            raise ValueError("ga: pop_size must be at least 2")
        if not 0.0 <= float(merged["mutation_prob"]) <= 1.0:
            raise ValueError("ga: mutation_prob must be in [0, 1]")
        super().__init__(n, seed, **options)

    def _problem(self) -> Problem:
        return Problem(n_var=self.n, n_obj=1, xl=0, xu=self.n - 1, vtype=int)

    def _initial_X(self, first: bool) -> np.ndarray:
        size = int(self.options["pop_size"])
        X = PermutationRandomSampling()(self.problem, size, random_state=self.rng).get("X").astype(int)
        if first and self.options["x0"] == "sequential":
            X[0] = np.arange(self.n)
        return X

    def _algorithm(self, initial_X: np.ndarray) -> GA:
        # OX draws two distinct cut points; below 3 columns inversion alone reaches every order
        crossover = OrderCrossover() if self.n >= 3 else NoCrossover()
        return GA(pop_size=int(self.options["pop_size"]), sampling=initial_X, crossover=crossover,
                  mutation=InversionMutation(prob=float(self.options["mutation_prob"])),
                  eliminate_duplicates=True)

    def _decode(self, x: np.ndarray) -> Order:
        return tuple(int(v) + 1 for v in x)
