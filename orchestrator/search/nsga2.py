"""NSGA-II (pymoo) on the space's genome: several objectives, a Pareto front instead of one best design.

The same genomes and operators as the genetic algorithm (``pymoo_search.Genome``: a permutation of the
materials with order crossover and inversion mutation, or integers with pymoo's discrete-variable
operators), pymoo's rank-and-crowding survival and its ask/tell interface as in ``pymoo_search``.

Each design is told a vector of ``objectives`` values (all minimised), or None for a failure. Why failures
are a constraint: NSGA-II's crowding distance subtracts objective values, so an infinite one would poison the
front it falls in; a failed design is told to pymoo as infeasible instead (one inequality constraint, 1 for
a failure, 0 otherwise), which pymoo's constrained domination ranks behind every feasible design, i.e. worst
on every objective; its objective values are the worst seen so far, never read for ranking.

Why children are new designs: a converged population breeds mostly designs already evaluated, and a batch
of cache hits costs a generation without news. So once the first population is told, a child whose design
is already known counts as a duplicate (pymoo then breeds another); when pymoo finds no new child at all,
the search restarts.

Why seeds: a front found from random designs alone can miss the ends a single-objective search or an
exhaustive sweep already knows (the best design on one objective is an end of the true front), and then
report as an end a design that known design dominates. ``seeds`` (the known single-objective answers) join
the first population after the baseline, so the front starts from what is known and works inwards.

The answer is ``pareto_front()``: the non-dominated set of every design told so far (not only of the current
population, which survival may have thinned). Restarts (see ``pymoo_search``) begin from that front, topped
up with random designs, so that a restart keeps what the search knows.
"""

from __future__ import annotations

import math
from typing import Any, Sequence

import numpy as np
from pymoo.algorithms.moo.nsga2 import NSGA2 as PymooNSGA2
from pymoo.core.duplicate import DefaultDuplicateElimination
from pymoo.core.problem import Problem
from pymoo.problems.static import StaticProblem

from ..design import Design, DesignSpace
from ..types import Above
from .base import FAILURE, as_space
from .ga import check_genetic_options
from .pareto import ParetoPoint, pareto_front
from .pymoo_search import DecodedGenes, Genome, PymooSearch

OBJECTIVE_COUNTS = (2, 3)  # NSGA-II's crowding distance loses its selection pressure beyond three objectives


class NewDesigns(DefaultDuplicateElimination):
    """pymoo's duplicate elimination by design, and once ``known`` is set, of every design in it."""

    def __init__(self, genome: Genome) -> None:
        super().__init__(func=DecodedGenes(genome.space.columns))
        self.genome = genome
        self.known: dict | None = None

    def _do(self, pop, other, is_duplicate):
        is_duplicate = super()._do(pop, other, is_duplicate)
        if other is None and self.known:
            for i, x in enumerate(pop.get("X")):
                is_duplicate[i] |= self.genome.decode(x) in self.known
        return is_duplicate


class NSGA2(PymooSearch):
    """Options (defaults):
    objectives=2       values told per design (2 or 3), every one minimised.
    pop_size=20        population and offspring per generation (batch size).
    mutation_prob=1.0  probability that a child is mutated (pymoo's default for inversion mutation, and
                       its discrete-variable example's: a child unlike its parents is more often new).
    x0="sequential"    individual 0 of the first population is the space's baseline; "random": none is.
    seeds=()           designs placed in the first population (after the baseline), e.g. known optima of
                       each objective; at most pop_size of them count.
    stagnation=20      generations of only known designs before a restart (0 = never).
    """

    name = "nsga2"
    n_objectives = 2  # the default of ``objectives``; an instance has its own
    OPTIONS = {
        "objectives": 2,
        "pop_size": 20,
        "mutation_prob": 1.0,
        "x0": "sequential",
        "seeds": (),
        "stagnation": 20,
        "budget": None,
    }

    def __init__(self, space: DesignSpace | int, seed: int, **options: Any) -> None:
        merged = {**self.OPTIONS, **options}
        check_genetic_options(self.name, merged)
        if merged["objectives"] not in OBJECTIVE_COUNTS or isinstance(merged["objectives"], bool):
            raise ValueError(
                f"nsga2: objectives must be one of {', '.join(map(str, OBJECTIVE_COUNTS))}, "
                f"got {merged['objectives']!r}"
            )
        self.n_objectives = int(merged["objectives"])
        self.seeds = tuple(
            dict.fromkeys(as_space(space).check(d, f"{self.name} seeds") for d in (merged["seeds"] or ()))
        )
        self.worst = np.zeros(self.n_objectives)  # per objective, the worst finite value told so far
        self._seen_finite = False
        super().__init__(space, seed, **options)

    # -- values -------------------------------------------------------------
    def _internal(self, value: Any) -> tuple[float, ...]:
        """A told vector as a tuple of floats; None, Above or a vector with a non-finite entry: the
        failure vector (``FAILURE`` on every objective)."""
        k = self.n_objectives
        if value is None or isinstance(value, Above):
            return (FAILURE,) * k
        if isinstance(value, (str, bytes)) or not isinstance(value, (Sequence, np.ndarray)):
            raise ValueError(f"nsga2: told {value!r}; each design takes a vector of {k} objective values or None")
        if len(value) != k:
            raise ValueError(f"nsga2: told {len(value)} objective values for a design, expected {k}")
        try:
            vector = tuple(float(v) for v in value)
        except (TypeError, ValueError):
            return (FAILURE,) * k
        return vector if all(math.isfinite(v) for v in vector) else (FAILURE,) * k

    def _is_failure(self, value: Any) -> bool:
        return value[0] == FAILURE

    # -- pymoo --------------------------------------------------------------
    def _problem(self) -> Problem:
        self.genome = Genome(self.space)
        return self.genome.problem(n_obj=self.n_objectives, n_ieq_constr=1)

    def _initial_X(self, first: bool) -> np.ndarray:
        size = int(self.options["pop_size"])
        X = self.genome.sample(self.problem, size, self.rng)
        if first:
            start = list(self.start_designs()) if self.options["x0"] == "sequential" else list(self.starts)
            start += [d for d in self.seeds if d not in start]
            for i, design in enumerate(start[:size]):
                X[i] = self.genome.encode(design)
        else:
            front = [self.genome.encode(p.design) for p in self.pareto_front()][:size]
            if front:
                X[: len(front)] = front
        return X

    def _algorithm(self, initial_X: np.ndarray) -> PymooNSGA2:
        self.new_designs = NewDesigns(self.genome)  # the first population may hold known designs (a restart's)
        return PymooNSGA2(
            pop_size=int(self.options["pop_size"]),
            sampling=initial_X,
            **self.genome.operators(float(self.options["mutation_prob"])),
            eliminate_duplicates=self.new_designs,
        )

    def _decode(self, x: np.ndarray) -> Design:
        return self.genome.decode(x)

    def _evaluate(self, pop, values: list[tuple[float, ...]]) -> None:
        F = np.asarray(values, dtype=float)
        failed = ~np.all(np.isfinite(F), axis=1)
        if np.any(~failed):
            batch_worst = F[~failed].max(axis=0)
            self.worst = np.maximum(self.worst, batch_worst) if self._seen_finite else batch_worst
            self._seen_finite = True
        F[failed] = self.worst
        G = failed.astype(float).reshape(-1, 1)
        self.algorithm.evaluator.eval(StaticProblem(self.problem, F=F, G=G), pop)
        self.new_designs.known = self.memo  # from now on a child must be a design not yet evaluated

    # -- the answer -------------------------------------------------------------
    def pareto_front(self) -> list[ParetoPoint]:
        """The non-dominated set of every design told so far (failures excluded), sorted by objectives."""
        told = [(design, value) for design, value in self.memo.items() if not self._is_failure(value)]
        return pareto_front([d for d, _ in told], [v for _, v in told]) if told else []

    def _state(self) -> dict[str, Any]:
        front = self.pareto_front()
        state = super()._state()
        state.update(
            {
                "objectives": self.n_objectives,
                "front_size": len(front),
                "front": [{"design": list(p.design), "objectives": list(p.objectives)} for p in front],
            }
        )
        return state
