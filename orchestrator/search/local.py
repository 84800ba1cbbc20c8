"""The one local search over a design space: its swap, insertion and replacement moves.

It serves three places: the polishing phase that ends every optimiser's budget (``polish.Polished``), the
study's final descent from its best design (``LocalSearch`` with no kicks, which stops at a local optimum),
and, through the same moves of ``DesignSpace``, the annealing.

Why a descent for the last improvements: on random keys (CMA-ES, the swarm, differential evolution) one
small step in key space changes a design in several columns at once, and late in a run most samples decode
to designs already seen; the last improvements are single moves, which a first-improvement descent checks
systematically (python -m bench.search_convergence compares the optimisers with and without it).

Why a kick at a local optimum (iterated local search): with a large budget the descent reaches a local
optimum (no single move improves it) long before the budget is spent. Rather than stop, it perturbs the best
local optimum found by ``kick`` random moves and descends again; the best local optimum is kept as the home
from which the next kick starts.
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from ..design import Design, DesignSpace, as_design
from .base import Search, as_space


def neighbours(design: Sequence[int], space: DesignSpace | None = None) -> list[Design]:
    """Every distinct design one move away (``DesignSpace.neighbour_list``: swaps, then insertions, then
    replacements); ``space`` defaults to the permutations of ``len(design)`` materials."""
    space = space or DesignSpace.permutations(len(design))
    return space.neighbour_list(design)


class Descent:
    """Batched first-improvement descent by the space's moves, with kicks.

    ``propose(memo, above)`` returns up to ``batch`` neighbours of the current design whose values are not
    yet known, in a random order; a neighbour already in ``memo`` is judged on the spot for free (if it is
    better the descent moves there and scans its neighbours instead), unless it is only known to be above a
    bound (``above``: censored) below the current value, which decides nothing: it is asked again (after a
    kick the current value can be above the limit such a neighbour was censored at). ``update(designs,
    values)`` moves to the best improving design of the batch, if any. When every neighbour of the current
    design is known and none is better, the current design is a local optimum: the best local optimum so far
    becomes the home, and the next proposal is the home perturbed by ``kick`` random moves, which becomes the
    current design whatever its value.

    Why batches: a batch of neighbours is evaluated in parallel; the descent then takes the best of them.
    """

    def __init__(
        self,
        rng: np.random.Generator,
        batch: int = 4,
        kick: int = 3,
        max_kick_tries: int = 100,
        max_kicks: int | None = None,
        space: DesignSpace | int | None = None,
    ) -> None:
        self.space = None if space is None else as_space(space)  # None: the permutations of the start design
        self.rng = rng
        self.max_kicks = max_kicks  # None: kick for ever; 0: stop at the first local optimum
        self.finished = False
        self.batch = max(1, int(batch))
        self.kick = max(1, int(kick))
        self.max_kick_tries = int(max_kick_tries)
        self.current: Design | None = None
        self.current_value = math.inf
        self.home: Design | None = None
        self.home_value = math.inf
        self._queue: list[Design] = []
        self._kicked: Design | None = None
        self.moves = self.free_moves = self.kicks = self.local_optima = 0
        self.asked_again = 0  # neighbours censored below the current value, asked again

    def start(self, design: Sequence[int], value: float) -> None:
        design = as_design(design)
        self.space = self.space or DesignSpace.permutations(len(design))
        self._set_current(self.space.check(design, "descent: start"), value)

    def _started_space(self) -> DesignSpace:
        """The descent's space: the one given, else the start design's permutations once started."""
        if self.space is None:
            raise RuntimeError("Descent: no design space before start")
        return self.space

    def _set_current(self, design: Design, value: float) -> None:
        self.current, self.current_value = design, float(value)
        queue = self._started_space().neighbour_list(design)
        self.rng.shuffle(queue)
        self._queue = queue

    def propose(self, memo: dict[Design, float], above: dict[Design, float] | None = None) -> list[Design]:
        above = above or {}
        if self.current is None:
            raise RuntimeError("Descent.propose before start")
        self._kicked = None
        out: list[Design] = []
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
                    kicked = self._started_space().random_move(self.rng, kicked)
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

    def limits(self, designs: list[Design]) -> list[float | None]:
        """Only a neighbour better than the current design matters: its evaluation may stop once the peak
        passes the current value. A kicked design is taken whatever its value, so it needs the value."""
        if self._kicked is not None or not math.isfinite(self.current_value):
            return [None] * len(designs)
        return [self.current_value] * len(designs)

    def update(self, designs: list[Design], values: list[float]) -> None:
        if self._kicked is not None and designs == [self._kicked]:
            self._kicked = None
            self._set_current(designs[0], values[0])
            return
        best = None
        for design, value in zip(designs, values):
            if value < self.current_value and (best is None or value < best[1]):
                best = (design, value)
        if best is not None:
            self.moves += 1
            self._set_current(*best)

    def state(self) -> dict:
        return {
            "current_value": None if not math.isfinite(self.current_value) else self.current_value,
            "moves": self.moves,
            "free_moves": self.free_moves,
            "local_optima": self.local_optima,
            "kicks": self.kicks,
            "asked_again": self.asked_again,
            "home_value": None if not math.isfinite(self.home_value) else self.home_value,
        }


class LocalSearch(Search):
    """The descent as a search of its own (ask/tell): from ``start`` (default: the space's baseline) until a
    local optimum.

    ``kicks``: how many kicks after a local optimum (0: stop at the first one, the study's final descent;
    None: an iterated local search that never stops, a baseline). Registered as the ``local`` method.
    """

    name = "local"
    OPTIONS = {"start": None, "batch": 4, "kicks": None, "budget": None}

    def __init__(self, space: DesignSpace | int, seed: int, **options) -> None:
        super().__init__(space, seed, **options)
        start = self.options["start"]
        self.start = self.space.check(start, "local: start") if start is not None else self.start_designs()[0]
        kicks = self.options["kicks"]
        self.descent = Descent(
            self.rng,
            batch=int(self.options["batch"]),
            max_kicks=None if kicks is None else int(kicks),
            space=self.space,
        )
        self._started = False

    def _ask(self) -> list[Design]:
        if not self._started:
            self._asked = [self.start]
        else:
            self._asked = self.descent.propose(self.memo, self.censored_above)
        return self._asked

    def limits(self) -> list[float | None] | None:
        return self.descent.limits(self._asked) if self._started else None

    def _tell(self, designs: list[Design], values: list[float]) -> None:
        if not self._started:
            self._started = True
            self.descent.start(designs[0], values[0])
        else:
            self.descent.update(designs, values)

    def _stop(self) -> bool:
        return self.descent.finished

    def _state(self) -> dict:
        current = self.descent.current  # set once started: a finished descent has started
        return {
            "descent": self.descent.state(),
            "local_optimum": list(current) if self.descent.finished and current is not None else None,
        }
