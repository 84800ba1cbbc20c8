"""Genetic algorithm: pymoo's GA on the space's genome (``pymoo_search.Genome``).

Permutation genomes (a permutation of all M materials, decoded by its first C columns) with order crossover
and inversion mutation, as pymoo's documentation sets up permutation problems (its travelling-salesman
example); integer genomes (with repetition) with pymoo's discrete-variable operators. Duplicate individuals
are eliminated; selection is pymoo's default binary tournament, survival its fitness survival. The ask/tell
plumbing, failures (+inf) and restarts are ``pymoo_search.PymooSearch``'s.

Start and polishing follow the other optimisers: with ``x0="sequential"`` individual 0 of the first
population is the space's baseline (the design a designer already has) and the rest are random; the last
``polish`` fraction of ``budget`` goes to the descent by single moves from the best design
(``polish.Polished``, which ``make_search`` wraps it in; the share as for CMA-ES, python -m bench.search_convergence).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from pymoo.algorithms.soo.nonconvex.ga import GA
from pymoo.core.problem import Problem

from ..design import Design, DesignSpace
from .pymoo_search import Genome, PymooSearch


def check_genetic_options(name: str, options: dict[str, Any]) -> None:
    """The options GA and NSGA-II share: x0, pop_size, mutation_prob."""
    if options["x0"] not in ("sequential", "random"):
        raise ValueError(f"{name}: x0 must be 'sequential' or 'random', got {options['x0']!r}")
    if int(options["pop_size"]) < 2:
        raise ValueError(f"{name}: pop_size must be at least 2, got {options['pop_size']!r}")
    if not 0.0 <= float(options["mutation_prob"]) <= 1.0:
        raise ValueError(f"{name}: mutation_prob must be in [0, 1], got {options['mutation_prob']!r}")


class GeneticAlgorithm(PymooSearch):
    """Options (defaults):
    pop_size=20        population and offspring per generation (batch size).
    mutation_prob=0.3  probability that a child is mutated (a segment inverted; with repetition,
                       polynomial mutation of its genes).
    x0="sequential"    individual 0 of the first population is the space's baseline; "random": none is.
    stagnation=20      generations of only known designs before a restart (0 = never).
    (``make_search`` adds polish=0.7, the share of ``budget`` left to the final descent, and
    polish_batch=4, see ``polish.Polished``.)
    """

    name = "ga"
    POLISH = 0.7  # the default share of the budget polished (polish.Polished), as CMA-ES and PSO
    OPTIONS = {"pop_size": 20, "mutation_prob": 0.3, "x0": "sequential", "stagnation": 20, "budget": None}

    def __init__(self, space: DesignSpace | int, seed: int, **options: Any) -> None:
        check_genetic_options(self.name, {**self.OPTIONS, **options})
        super().__init__(space, seed, **options)

    def _problem(self) -> Problem:
        self.genome = Genome(self.space)
        return self.genome.problem()

    def _initial_X(self, first: bool) -> np.ndarray:
        X = self.genome.sample(self.problem, int(self.options["pop_size"]), self.rng)
        if first and self.options["x0"] == "sequential":
            starts = self.start_designs()[: len(X)]
            X[: len(starts)] = [self.genome.encode(d) for d in starts]
        return X

    def _algorithm(self, initial_X: np.ndarray) -> GA:
        return GA(
            pop_size=int(self.options["pop_size"]),
            sampling=initial_X,
            **self.genome.operators(float(self.options["mutation_prob"])),
            eliminate_duplicates=self.genome.duplicates(),
        )

    def _decode(self, x: np.ndarray) -> Design:
        return self.genome.decode(x)
