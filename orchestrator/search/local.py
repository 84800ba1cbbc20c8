"""The one local search over permutations: swap and insertion neighbourhoods.

It serves three places: the polishing phase that ends every optimiser's budget
(``polish.Polished``), the study's final descent from its best order
(``LocalSearch`` with no kicks, which stops at a local optimum), and the
annealing's moves (``random_move``).

Why a polishing phase: CMA-ES and the particle swarm work on random keys,
where one small step in key space can change an order in several places at
once and where, late in a run, most samples decode to orders already seen.
Neither is good at the last few improvements, which are single swaps or
insertions of materials.  A plain first-improvement descent over those moves
is: on the 11-column lattice, from the sequential order, it gets within about
0.5 % of the best order we know in 100 evaluations.  So every optimiser
(``cmaes``, ``pso``, ``sa``) hands the last ``polish`` fraction of its budget
to a :class:`Descent` started at its best order (see ``base.Search``).

Why a kick at a local optimum (iterated local search): with a large budget the
descent reaches a local optimum (no single swap or insertion improves it)
long before the budget is spent.  Rather than stop, it perturbs the best local
optimum found by ``kick`` random moves and descends again; the best local
optimum is kept as the home from which the next kick starts.
"""
from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from ..types import Order
from .base import Search


def neighbours(order: Sequence[int]) -> list[Order]:
    """Every distinct order one swap or one insertion away from ``order`` (swaps first).

    For n columns: n(n-1)/2 swaps and (n-1)^2 distinct insertions, of which
    the n-1 moving a material by one column are adjacent swaps: n = 11 gives
    55 + 100 - 10 = 145 neighbours.
    """
    p = tuple(order)
    n = len(p)
    out: dict[Order, None] = {}
    for i in range(n):
        for j in range(i + 1, n):
            q = list(p)
            q[i], q[j] = q[j], q[i]
            out[tuple(q)] = None
    for i in range(n):
        for j in range(n):
            if i != j:
                q = list(p)
                q.insert(j, q.pop(i))
                out[tuple(q)] = None
    out.pop(p, None)
    return list(out)


def random_move(rng: np.random.Generator, order: Order, swap_prob: float = 0.5) -> Order:
    """One random swap (probability ``swap_prob``) or insertion."""
    n = len(order)
    if n < 2:
        return order
    p = list(order)
    i, j = (int(k) for k in rng.choice(n, size=2, replace=False))
    if rng.random() < swap_prob:
        p[i], p[j] = p[j], p[i]
    else:
        p.insert(j, p.pop(i))
    return tuple(p)


def sequential_keys(n: int) -> np.ndarray:
    """Random keys in [0, 1], evenly spaced, that decode to the sequential order 1..n."""
    return order_to_keys(tuple(range(1, n + 1)))


def order_to_keys(order: Sequence[int], dim: int | None = None) -> np.ndarray:
    """Evenly spaced keys in [0, 1] that decode (``keys_to_order``) to ``order``.

    Key of material m = (column of m - 1) / (n - 1); extra dimensions (``dim`` > n,
    ignored by the decoding) get 0.5.
    """
    n = len(order)
    keys = np.full(max(dim or n, n), 0.5)
    for column, material in enumerate(order):
        keys[int(material) - 1] = column / (n - 1) if n > 1 else 0.5
    return keys


class Descent:
    """Batched first-improvement descent by swaps and insertions, with kicks.

    ``propose(memo, above)`` returns up to ``batch`` neighbours of the current
    order whose values are not yet known, in a random order; a neighbour already
    in ``memo`` is judged on the spot for free (if it is better the descent moves
    there and scans its neighbours instead), unless it is only known to be above
    a bound (``above``: censored) below the current value, which decides nothing:
    it is asked again (after a kick the current value can be above the limit
    such a neighbour was censored at).  ``update(orders, values)`` moves
    to the best improving order of the batch, if any.  When every neighbour of
    the current order is known and none is better, the current order is a
    local optimum: the best local optimum so far becomes the home, and the next
    proposal is the home perturbed by ``kick`` random moves, which becomes the
    current order whatever its value.

    Why batches: a batch of ``batch`` neighbours is evaluated in parallel; the
    descent then takes the best of them (a batch of 2-4 lost nothing against
    one at a time in our trials on the lattice).
    """

    def __init__(self, rng: np.random.Generator, batch: int = 4, kick: int = 3,
                 max_kick_tries: int = 100, max_kicks: int | None = None) -> None:
        self.rng = rng
        self.max_kicks = max_kicks  # None: kick for ever; 0: stop at the first local optimum
        self.finished = False
        self.batch = max(1, int(batch))
        self.kick = max(1, int(kick))
        self.max_kick_tries = int(max_kick_tries)
        self.current: Order | None = None
        self.current_value = math.inf
        self.home: Order | None = None
        self.home_value = math.inf
        self._queue: list[Order] = []
        self._kicked: Order | None = None
        self.moves = self.free_moves = self.kicks = self.local_optima = 0
        self.asked_again = 0  # neighbours censored below the current value, asked again

    def start(self, order: Order, value: float) -> None:
        self._set_current(order, value)

    def _set_current(self, order: Order, value: float) -> None:
        self.current, self.current_value = tuple(order), float(value)
        queue = neighbours(self.current)
        self.rng.shuffle(queue)
        self._queue = queue

    def propose(self, memo: dict[Order, float], above: dict[Order, float] | None = None) -> list[Order]:
        above = above or {}
        if self.current is None:
            raise RuntimeError("Descent.propose before start")
        self._kicked = None
        out: list[Order] = []
        tries = 0
        while len(out) < self.batch:
            if not self._queue:
                if out:
                    break  # evaluate what we have before deciding it is a local optimum
                # every neighbour is known and none is better: a local optimum
                self.local_optima += 1
                if self.current_value < self.home_value or self.home is None:
                    self.home, self.home_value = self.current, self.current_value
                if self.max_kicks is not None and self.kicks >= self.max_kicks:
                    self.finished = True
                    return []
                kicked = self.home
                for _ in range(self.kick):
                    kicked = random_move(self.rng, kicked)
                self.kicks += 1
                tries += 1
                if kicked in memo and kicked not in above:  # a censored one: asked for its value
                    self._set_current(kicked, memo[kicked])
                    if tries >= self.max_kick_tries:
                        return [kicked]  # nothing new nearby; the loop's stall guard decides
                    continue
                self._kicked = kicked
                return [kicked]
            q = self._queue.pop()
            if q in above and above[q] < self.current_value:
                self.asked_again += 1
                out.append(q)
                continue
            if q in memo:
                if memo[q] < self.current_value:
                    self.free_moves += 1
                    self._set_current(q, memo[q])
                    # a censored neighbour taken to be asked again may now be decided: not better
                    out = [o for o in out if not (o in above and above[o] >= self.current_value)]
                continue
            out.append(q)
        return out

    def limits(self, orders: list[Order]) -> list[float | None]:
        """Only a neighbour better than the current order matters: its evaluation may stop once the peak
        passes the current value. A kicked order is taken whatever its value, so it needs the value."""
        if self._kicked is not None or not math.isfinite(self.current_value):
            return [None] * len(orders)
        return [self.current_value] * len(orders)

    def update(self, orders: list[Order], values: list[float]) -> None:
        if self._kicked is not None and orders == [self._kicked]:
            self._kicked = None
            self._set_current(orders[0], values[0])
            return
        best = None
        for order, value in zip(orders, values):
            if value < self.current_value and (best is None or value < best[1]):
                best = (order, value)
        if best is not None:
            self.moves += 1
            self._set_current(*best)

    def state(self) -> dict:
        return {"current_value": None if not math.isfinite(self.current_value) else self.current_value,
                "moves": self.moves, "free_moves": self.free_moves, "local_optima": self.local_optima,
                "kicks": self.kicks, "asked_again": self.asked_again,
                "home_value": None if not math.isfinite(self.home_value) else self.home_value}



class LocalSearch(Search):
    """The descent as a search of its own (ask/tell): from ``start`` until a local optimum.

    ``kicks``: how many kicks after a local optimum (0: stop at the first one, the study's final descent;
    None: an iterated local search that never stops, a baseline). Registered as the ``local`` method.
    """

    name = "local"
    OPTIONS = {"start": None, "batch": 4, "kicks": None, "budget": None}

    def __init__(self, n: int, seed: int, **options) -> None:
        super().__init__(n, seed, **options)
        start = self.options["start"]
        self.start = tuple(int(m) for m in start) if start is not None else tuple(range(1, self.n + 1))
        if sorted(self.start) != list(range(1, self.n + 1)):
            raise ValueError(f"local: start must be a permutation of 1..{self.n}, got {list(self.start)}")
        kicks = self.options["kicks"]
        self.descent = Descent(self.rng, batch=int(self.options["batch"]),
                               max_kicks=None if kicks is None else int(kicks))
        self._started = False

    def _ask(self) -> list[Order]:
        if not self._started:
            self._asked = [self.start]
        else:
            self._asked = self.descent.propose(self.memo, self.censored_above)
        return self._asked

    def limits(self) -> list[float | None] | None:
        return self.descent.limits(self._asked) if self._started else None

    def _tell(self, orders: list[Order], values: list[float]) -> None:
        if not self._started:
            self._started = True
            self.descent.start(orders[0], values[0])
        else:
            self.descent.update(orders, values)

    def _stop(self) -> bool:
        return self.descent.finished

    def _state(self) -> dict:
        return {"descent": self.descent.state(),
                "local_optimum": list(self.descent.current) if self.descent.finished else None}
