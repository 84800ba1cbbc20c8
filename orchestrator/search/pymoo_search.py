"""pymoo's single-objective algorithms behind our ask/tell protocol (``base.Search``).

Why pymoo and not hand-written operators: the study compared a genetic
algorithm and differential evolution; pymoo has both, with permutation
operators, in a well-kept library with its own ask/tell interface:

    algorithm.setup(problem, seed=..., termination=...)
    pop = algorithm.ask()                       # a Population with X
    algorithm.evaluator.eval(StaticProblem(problem, F=F), pop)
    algorithm.tell(infills=pop)

Here ``ask`` decodes ``pop.get("X")`` into orders and keeps ``pop``; ``tell``
hands the told values back as the population's F through pymoo's own
evaluator (``StaticProblem`` only sets the given F, it simulates nothing), so
pymoo's bookkeeping (``n_eval``, which individuals are evaluated) stays its
own.  The loop does the simulating, the caching and the budget.

Failures: a failed evaluation (None) is told to pymoo as ``+inf``, the worst
value: it loses every tournament (GA), is never selected as a survivor while
a real value competes, and never replaces a target vector (DE).

Why restarts: pymoo's GA stops producing offspring when its mating cannot find
new (non-duplicate) children, and a converged population keeps asking orders
the loop has already answered.  Either way, rather than let the budget go
unused, the algorithm is set up again on a fresh random population (a new seed
drawn from this search's generator), as CMA-ES restarts.  pymoo's own
termination is switched off (the loop decides when to stop).
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np
from pymoo.core.problem import Problem
from pymoo.problems.static import StaticProblem
from pymoo.termination.max_gen import MaximumGenerationTermination

from ..types import Order
from .base import FAILURE, Search

NEVER = MaximumGenerationTermination(math.inf)


class PymooSearch(Search):
    """Base for a pymoo algorithm on a problem of ``n`` variables.

    Subclasses implement ``_problem()``, ``_algorithm(initial_X)`` (a fresh,
    not yet set-up pymoo algorithm), ``_initial_X(first)`` (the first
    population as an array: the start rule) and ``_decode(x) -> Order``.
    Option ``stagnation``: generations in a row whose offspring were all
    orders already known before a restart (0 = never).
    """

    def __init__(self, n: int, seed: int, **options: Any) -> None:
        super().__init__(n, seed, **options)
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

    def _decode(self, x: np.ndarray) -> Order:
        raise NotImplementedError

    # -- pymoo ask/tell -------------------------------------------------------
    def _start(self, first: bool) -> None:
        pymoo_seed = int(self.rng.integers(0, 2**31 - 1))
        self.algorithm = self._algorithm(self._initial_X(first))
        self.algorithm.setup(self.problem, seed=pymoo_seed, termination=NEVER, verbose=False)

    def _restart(self, reason: str) -> None:
        self.restarts += 1
        self.restart_reasons.append(reason)
        self._start(first=False)

    def _ask(self) -> list[Order]:
        for _ in range(3):
            pop = self.algorithm.ask()
            if pop is not None and len(pop) > 0:
                break
            self._restart("mating found no new offspring")
        else:
            raise RuntimeError(f"{self.name}: pymoo produced no population after restarting")
        self._pop = pop
        return [self._decode(x) for x in pop.get("X")]

    def _tell(self, orders: list[Order], values: list[float]) -> None:
        F = np.asarray(values, dtype=float).reshape(-1, 1)  # failures are already +inf (FAILURE)
        pop, self._pop = self._pop, None
        self.algorithm.evaluator.eval(StaticProblem(self.problem, F=F), pop)
        self.algorithm.tell(infills=pop)
        self.generations += 1
        limit = int(self.options.get("stagnation") or 0)
        self.known_in_a_row = self.known_in_a_row + 1 if self._all_known else 0
        if limit and self.known_in_a_row >= limit:
            self.known_in_a_row = 0
            self._restart(f"{limit} generations in a row asked only orders already known")

    def ask(self) -> list[Order]:
        orders = super().ask()
        self._all_known = all(o in self.memo for o in orders)  # for the stagnation rule
        return orders

    def _state(self) -> dict[str, Any]:
        best = None
        opt = getattr(self.algorithm, "opt", None)
        if opt is not None and len(opt) > 0:
            value = float(opt.get("F")[0, 0])
            best = value if value != FAILURE else None
        return {"generations": self.generations, "restarts": self.restarts,
                "restart_reasons": self.restart_reasons[-10:], "population_best": best,
                "pymoo_evaluations": int(self.algorithm.evaluator.n_eval)}
