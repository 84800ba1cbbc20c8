"""CMA-ES (pycma) on random keys.

Why random keys: CMA-ES is a continuous optimiser; a point x in R^n decodes to
the order ``argsort(x) + 1``.  Why restarts: on random keys the distribution
soon concentrates so that every sample decodes to the same few orders; pycma
then stops (flat fitness, tolx, ...) and, rather than let the budget go
unused, we start a fresh CMA-ES from a new random mean (optionally with a
larger population, IPOP-style).
"""
from __future__ import annotations

import contextlib
import io
import math
import warnings
from typing import Any, Iterator

import cma
import numpy as np

from ..types import Order
from .base import FAILURE, Search, keys_to_order


class CMAES(Search):
    """``cma.CMAEvolutionStrategy`` on random keys; one batch = one population.

    Options:
      popsize     population size (batch size); default pycma's 4 + floor(3 ln n).
      sigma0      initial step size; keys start uniform in [0, 1] (default 0.3).
      restarts    restart when pycma stops (default True); False: stop() then.
      incpopsize  population factor at each restart (default 1; 2 = IPOP).
      cma_options extra pycma options (dict) for experts.

    A failed evaluation is told to pycma as a finite penalty larger than every
    real value seen so far, so it always ranks last (pycma handles infinities
    poorly in its termination statistics).

    Reproducibility: pycma draws from numpy's *global* RNG.  Each pycma call
    here runs with the global state swapped for this search's own (seeded via
    pycma's ``seed`` option, the seed drawn from ``default_rng(seed)``), and the
    caller's global state is restored afterwards.  So two CMA-ES searches, or
    other code using ``np.random``, cannot disturb each other.  (Not
    thread-safe: do not step two searches in two threads at once.)
    """

    name = "cmaes"
    OPTIONS = {"popsize": None, "sigma0": 0.3, "restarts": True, "incpopsize": 1,
               "cma_options": None, "budget": None}

    def __init__(self, n: int, seed: int, **options: Any) -> None:
        super().__init__(n, seed, **options)
        self.dim = max(self.n, 2)  # pycma needs at least 2 dimensions; extra keys are ignored
        self.popsize = int(self.options["popsize"] or (4 + int(3 * math.log(self.dim))))
        if self.popsize < 2:
            raise ValueError("cmaes: popsize must be at least 2")
        self.sigma0 = float(self.options["sigma0"])
        self.restarts = 0
        self.restart_reasons: list[str] = []
        self.worst_seen = -math.inf
        self._np_state: dict | None = None
        self._X: list[np.ndarray] | None = None
        self._finished = False
        self._start()

    @contextlib.contextmanager
    def _sandbox(self) -> Iterator[None]:
        outer = np.random.get_state()
        if self._np_state is not None:
            np.random.set_state(self._np_state)
        try:
            with warnings.catch_warnings(), contextlib.redirect_stdout(io.StringIO()):
                warnings.simplefilter("ignore")
                yield
        finally:
            self._np_state = np.random.get_state()
            np.random.set_state(outer)

    def _start(self) -> None:
        x0 = self.rng.uniform(0.0, 1.0, self.dim)
        cma_seed = int(self.rng.integers(1, 2**31 - 1))  # pycma treats 0 as "seed from the clock"
        opts = {"popsize": self.popsize, "seed": cma_seed, "verbose": -9, "verb_log": 0,
                "verb_disp": 0, "verb_filenameprefix": "", "maxfevals": math.inf}
        opts.update(self.options["cma_options"] or {})
        with self._sandbox():
            self.es = cma.CMAEvolutionStrategy(x0, self.sigma0, opts)

    def _ask(self) -> list[Order]:
        with self._sandbox():
            self._X = [np.asarray(x, dtype=float) for x in self.es.ask()]
        return [keys_to_order(x, self.n) for x in self._X]

    def _tell(self, orders: list[Order], values: list[float]) -> None:
        finite = [v for v in values if v != FAILURE]
        if finite:
            self.worst_seen = max(self.worst_seen, max(finite))
        if any(v == FAILURE for v in values):
            base = self.worst_seen if math.isfinite(self.worst_seen) else 0.0
            penalty = base + abs(base) + 1.0
            values = [penalty if v == FAILURE else v for v in values]
        with self._sandbox():
            self.es.tell(self._X, values)
            reasons = dict(self.es.stop())
        self._X = None
        if reasons:
            reason = ", ".join(f"{k}={v}" for k, v in reasons.items())
            if self.options["restarts"]:
                self.restarts += 1
                self.restart_reasons.append(reason)
                self.popsize = int(self.popsize * self.options["incpopsize"])
                self._start()
            else:
                self._finished = True
                self.restart_reasons.append(reason)

    def _stop(self) -> bool:
        return self._finished

    def _state(self) -> dict[str, Any]:
        return {"sigma": float(self.es.sigma), "popsize": self.popsize,
                "iterations_since_restart": int(self.es.countiter), "restarts": self.restarts,
                "stop_reasons": self.restart_reasons[-10:]}
