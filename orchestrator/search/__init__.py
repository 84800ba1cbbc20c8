"""Search strategies behind one ask/tell protocol (see ``base.py``).

    search = make_search("sa", n=11, seed=0, budget=100)
    while not search.stop():
        orders = search.ask()
        search.tell(orders, [value_or_None(o) for o in orders])

``orchestrator.loop.run_search`` does this with a cache, a budget and an
executor.  Searches never see an objective or an executor.
"""
from __future__ import annotations

from typing import Any

from .annealing import Annealing
from .base import FAILURE, Search, keys_to_order
from .baselines import RandomSearch, Sequential
from .cmaes import CMAES
from .pso import PSO

SEARCHES: dict[str, type[Search]] = {
    "cmaes": CMAES,
    "pso": PSO,
    "sa": Annealing,
    "random": RandomSearch,
    "sequential": Sequential,
}


def make_search(name: str, n: int, seed: int, **options: Any) -> Search:
    """Build a search by name.  Unknown name or option -> ValueError naming the allowed ones."""
    try:
        cls = SEARCHES[name]
    except (KeyError, TypeError):
        raise ValueError(f"unknown search {name!r}; allowed: {', '.join(SEARCHES)}") from None
    return cls(n, seed, **options)


__all__ = ["SEARCHES", "make_search", "Search", "CMAES", "PSO", "Annealing", "RandomSearch",
           "Sequential", "FAILURE", "keys_to_order"]
