"""Search strategies behind one ask/tell protocol (see ``base.py``), over a design space
(``orchestrator.design.DesignSpace``: permutations, C of M materials, or repetition).

    search = make_search("sa", DesignSpace(5, 8), seed=0, budget=100)
    while not search.stop():
        designs = search.ask()
        search.tell(designs, [value_or_None(d) for d in designs])

The loop does this with a cache, a budget and an executor; searches never see an objective or an executor.
A search of several objectives (``SEARCHES[name].n_objectives > 1``: ``nsga2``) is told a vector per design
and answers with ``pareto_front()``; ``pareto.hypervolume`` measures a front.
"""

from __future__ import annotations

from typing import Any

from ..design import DesignSpace
from .annealing import Annealing
from .base import FAILURE, Search, as_space
from .baselines import RandomSearch, Sequential
from .cmaes import CMAES
from .de import DifferentialEvolution
from .ga import GeneticAlgorithm
from .local import LocalSearch
from .nsga2 import NSGA2
from .pareto import ParetoPoint, hypervolume, non_dominated, pareto_front, reference_point
from .polish import Polished
from .pso import PSO
from .starts import Started, parse_design

SEARCHES: dict[str, type[Search]] = {
    "cmaes": CMAES,
    "pso": PSO,
    "sa": Annealing,
    "ga": GeneticAlgorithm,
    "de": DifferentialEvolution,
    "random": RandomSearch,
    "sequential": Sequential,
    "local": LocalSearch,
    "nsga2": NSGA2,
}


def make_search(name: str, space: DesignSpace | int, seed: int, **options: Any) -> Search | Started:
    """Build a search by name over ``space`` (an int n: the permutations of n materials), composed with its
    polishing phase (``polish.Polished``) when it has one, and with its starting designs (``starts.Started``:
    evaluated first) when ``starts`` are given.

    ``polish`` (default: the search's ``POLISH``) and ``polish_batch`` configure that phase; the search
    itself is given ``budget`` minus the polished share. Unknown name or option -> ValueError naming the
    allowed ones.
    """
    search = _polished(name, space, seed, **options)
    starts = options.get("starts")
    return Started(search, starts) if starts else search


def _polished(name: str, space: DesignSpace | int, seed: int, **options: Any) -> Search:
    try:
        cls = SEARCHES[name]
    except (KeyError, TypeError):
        raise ValueError(f"unknown search {name!r}; allowed: {', '.join(SEARCHES)}") from None
    space = as_space(space)
    if cls.POLISH is None:
        return cls(space, seed, **options)
    polish = options.pop("polish", cls.POLISH)
    polish_batch = options.pop("polish_batch", 4)
    try:
        fraction = float(polish)
    except (TypeError, ValueError):
        fraction = -1.0
    if not 0.0 <= fraction <= 1.0:
        raise ValueError(f"{name}: polish must be a fraction in [0, 1], got {polish!r}")
    budget = options.get("budget")
    inner_options = dict(options)
    if budget is not None:
        inner_options["budget"] = max(1, int(budget) - round(fraction * int(budget)))
    inner = cls(space, seed, **inner_options)
    return Polished(inner, polish=fraction, polish_batch=polish_batch, budget=budget)


__all__ = [
    "SEARCHES",
    "make_search",
    "Search",
    "CMAES",
    "PSO",
    "Annealing",
    "RandomSearch",
    "Sequential",
    "LocalSearch",
    "Polished",
    "GeneticAlgorithm",
    "DifferentialEvolution",
    "NSGA2",
    "FAILURE",
    "ParetoPoint",
    "hypervolume",
    "non_dominated",
    "pareto_front",
    "reference_point",
    "Started",
    "parse_design",
]
