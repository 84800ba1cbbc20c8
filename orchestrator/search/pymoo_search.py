"""pymoo's algorithms behind our ask/tell protocol (``base.Search``), and the genomes they search.

Why pymoo: a genetic algorithm, differential evolution and NSGA-II with operators for permutation and
integer genomes, in a well-kept library with its own ask/tell interface:

    algorithm.setup(problem, seed=..., termination=...)
    pop = algorithm.ask()                       # a Population with X
    algorithm.evaluator.eval(StaticProblem(problem, F=F), pop)
    algorithm.tell(infills=pop)

Here ``ask`` decodes ``pop.get("X")`` into designs and keeps ``pop``; ``tell`` hands the told values back as
the population's F through pymoo's own evaluator (``StaticProblem`` only sets the given outputs, it
simulates nothing), so pymoo's bookkeeping (``n_eval``, which individuals are evaluated) stays its own. The
loop does the simulating, the caching and the budget.

Genomes (``Genome``), as pymoo's documentation sets them up:
- without repetition, a permutation of all M materials decoded by its first C (the columns), with pymoo's
  permutation operators: random permutations, order crossover (a segment of one parent, the rest in the
  other parent's order) and inversion mutation (a segment reversed); for M = C it is the permutation itself;
- with repetition, one integer in 0..M-1 per column with pymoo's operators for discrete variables: integer
  random sampling, simulated binary crossover and polynomial mutation, each followed by rounding.

Why restarts: pymoo stops producing offspring when its mating finds no new (non-duplicate) children, and a
converged population keeps asking designs the loop has already answered. Either way, rather than let the
budget go unused, the algorithm is set up again on a fresh population (a new seed drawn from this search's
generator). pymoo's own termination is switched off (the loop decides when to stop).
"""

from __future__ import annotations

import math
from typing import Any, Sequence

import numpy as np
from pymoo.core.duplicate import DefaultDuplicateElimination
from pymoo.core.problem import Problem
from pymoo.operators.crossover.nox import NoCrossover
from pymoo.operators.crossover.ox import OrderCrossover
from pymoo.operators.crossover.sbx import SBX
from pymoo.operators.mutation.inversion import InversionMutation
from pymoo.operators.mutation.pm import PM
from pymoo.operators.repair.rounding import RoundingRepair
from pymoo.operators.sampling.rnd import IntegerRandomSampling, PermutationRandomSampling
from pymoo.problems.static import StaticProblem
from pymoo.termination.max_gen import MaximumGenerationTermination

from ..design import Design, DesignSpace
from .base import FAILURE, Search

NEVER = MaximumGenerationTermination(math.inf)
PERMUTATION_GENOME, INTEGER_GENOME = "permutation", "integer"


class Genome:
    """How pymoo's GA and NSGA-II represent the designs of ``space`` (see the module docstring)."""

    def __init__(self, space: DesignSpace) -> None:
        self.space = space
        self.kind = INTEGER_GENOME if space.repeat else PERMUTATION_GENOME
        self.length = space.columns if space.repeat else space.materials

    def problem(self, n_obj: int = 1, n_ieq_constr: int = 0) -> Problem:
        return Problem(
            n_var=self.length, n_obj=n_obj, n_ieq_constr=n_ieq_constr, xl=0, xu=self.space.materials - 1, vtype=int
        )

    def sample(self, problem: Problem, size: int, rng: np.random.Generator) -> np.ndarray:
        sampling = IntegerRandomSampling() if self.kind == INTEGER_GENOME else PermutationRandomSampling()
        return sampling(problem, size, random_state=rng).get("X").astype(int)

    def operators(self, mutation_prob: float) -> dict[str, Any]:
        """pymoo's crossover and mutation for this genome; ``mutation_prob``: the probability that a child
        is mutated."""
        if self.kind == INTEGER_GENOME:
            # pymoo's discrete-variable setting: SBX and PM on the integers, rounded back to integers
            return {
                "crossover": SBX(prob=1.0, eta=3.0, vtype=float, repair=RoundingRepair()),
                "mutation": PM(prob=mutation_prob, eta=3.0, vtype=float, repair=RoundingRepair()),
            }
        # order crossover draws two distinct cut points; below 3 genes inversion alone reaches every genome
        crossover = OrderCrossover() if self.length >= 3 else NoCrossover()
        return {"crossover": crossover, "mutation": InversionMutation(prob=mutation_prob)}

    def duplicates(self) -> DefaultDuplicateElimination:
        """pymoo's elimination of duplicate children, by design: two genomes that differ only in the unused
        materials after the first C are the same design (for a permutation, the same genome)."""
        return DefaultDuplicateElimination(func=DecodedGenes(self.space.columns))

    def decode(self, x: np.ndarray) -> Design:
        if self.kind == INTEGER_GENOME:
            top = self.space.materials - 1
            return tuple(int(min(top, max(0, round(float(v))))) + 1 for v in x)
        return tuple(int(v) + 1 for v in x[: self.space.columns])

    def encode(self, design: Sequence[int]) -> np.ndarray:
        """The genome of ``design``: its materials (0-based), then, without repetition, the unused ones in
        increasing order (so the baseline's genome is 0, 1, ..., M-1)."""
        design = self.space.check(design)
        genes = [m - 1 for m in design]
        if self.kind == PERMUTATION_GENOME:
            used = set(design)
            genes += [m - 1 for m in range(1, self.space.materials + 1) if m not in used]
        return np.asarray(genes, dtype=int)


class DecodedGenes:
    """The genes that make the design: the first ``columns`` of each individual's genome."""

    def __init__(self, columns: int) -> None:
        self.columns = columns

    def __call__(self, pop) -> np.ndarray:
        return pop.get("X")[:, : self.columns]


class PymooSearch(Search):
    """Base for a pymoo algorithm.

    Subclasses implement ``_problem()``, ``_algorithm(initial_X)`` (a fresh, not yet set-up pymoo algorithm),
    ``_initial_X(first)`` (the first population as an array: the start rule) and ``_decode(x) -> Design``;
    ``_evaluate(pop, values)`` hands the told values to pymoo (one objective: F = the values, a failure +inf).
    Option ``stagnation``: generations in a row whose offspring were all designs already known before a
    restart (0 = never).
    """

    def __init__(self, space: DesignSpace | int, seed: int, **options: Any) -> None:
        super().__init__(space, seed, **options)
        self.problem = self._problem()
        self.restarts = 0
        self.restart_reasons: list[str] = []
        self.generations = 0
        self.known_in_a_row = 0
        self._pop = None
        self._start(first=True)

    # -- to implement -----------------------------------------------------
    def _problem(self) -> Problem:
        raise NotImplementedError

    def _algorithm(self, initial_X: np.ndarray):
        raise NotImplementedError

    def _initial_X(self, first: bool) -> np.ndarray:
        raise NotImplementedError

    def _decode(self, x: np.ndarray) -> Design:
        raise NotImplementedError

    def _evaluate(self, pop, values: list[Any]) -> None:
        """One objective: a failure is +inf (``FAILURE``), the worst value: it loses every tournament (GA),
        is never selected as a survivor while a real value competes, and never replaces a target (DE)."""
        F = np.asarray(values, dtype=float).reshape(-1, 1)
        self.algorithm.evaluator.eval(StaticProblem(self.problem, F=F), pop)

    # -- pymoo ask/tell -------------------------------------------------------
    def _start(self, first: bool) -> None:
        pymoo_seed = int(self.rng.integers(0, 2**31 - 1))
        self.algorithm = self._algorithm(self._initial_X(first))
        self.algorithm.setup(self.problem, seed=pymoo_seed, termination=NEVER, verbose=False)

    def _restart(self, reason: str) -> None:
        self.restarts += 1
        self.restart_reasons.append(reason)
        self._start(first=False)

    def _ask(self) -> list[Design]:
        for _ in range(3):
            pop = self.algorithm.ask()
            if pop is not None and len(pop) > 0:
                break
            self._restart("mating found no new offspring")
        else:
            raise RuntimeError(f"{self.name}: pymoo produced no population after restarting")
        self._pop = pop
        return [self._decode(x) for x in pop.get("X")]

    def _tell(self, designs: list[Design], values: list[Any]) -> None:
        pop, self._pop = self._pop, None
        self._evaluate(pop, values)
        self.algorithm.tell(infills=pop)
        self.generations += 1
        limit = int(self.options.get("stagnation") or 0)
        self.known_in_a_row = self.known_in_a_row + 1 if self._all_known else 0
        if limit and self.known_in_a_row >= limit:
            self.known_in_a_row = 0
            self._restart(f"{limit} generations in a row asked only designs already known")

    def ask(self) -> list[Design]:
        designs = super().ask()
        self._all_known = all(d in self.memo for d in designs)  # for the stagnation rule
        return designs

    def _state(self) -> dict[str, Any]:
        best = None
        opt = getattr(self.algorithm, "opt", None)
        if self.n_objectives == 1 and opt is not None and len(opt) > 0:
            value = float(opt.get("F")[0, 0])
            best = value if value != FAILURE else None
        return {
            "generations": self.generations,
            "restarts": self.restarts,
            "restart_reasons": self.restart_reasons[-10:],
            "population_best": best,
            "pymoo_evaluations": int(self.algorithm.evaluator.n_eval),
        }
