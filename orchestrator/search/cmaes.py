"""CMA-ES (pycma) on random keys.

Why random keys: CMA-ES is a continuous optimiser; a point x in R^n decodes to
the order ``argsort(x) + 1``.  Why restarts: on random keys the distribution
soon concentrates so that every sample decodes to the same few orders; pycma
then stops (flat fitness, tolx, ...) and, rather than let the budget go
unused, we start a fresh CMA-ES from a new random mean (optionally with a
larger population, IPOP-style).

Why the defaults (measured on the 11-column lattice: searches on the 1 s
search objective with 100 evaluations, the best order re-evaluated over the
full 8 s, median over seeds; the best order we know is at 1405.9 N, the
sequential one at 1747.8 N):
- ``x0="sequential"``: the first mean is the keys of the sequential order
  1..n, the baseline a user already has, rather than a random point.  A random
  mean spends the small budget on far-away orders (median 1723 N over seeds
  0-9, no polishing); started at the baseline, CMA-ES searches its
  neighbourhood (1440 N).
  Restarts (``restart_x0``) still start from random means, for diversity.
- ``sigma0=0.3``: the keys of neighbouring materials are 1/(n-1) = 0.1 apart,
  so 0.3 moves a material by a few columns per sample; 0.1 and 0.2 stayed too
  close to the start (1479 N and 1449 N against 1440 N; seeds 0-9, no
  polishing).
- ``polish=0.7``: the last 70 % of the budget goes to a descent by single
  swaps and insertions from the best order (see ``local.py``).  On the
  rtol 1e-5 search objective, seeds 0-19 (``python bench/search_convergence.py
  --methods cmaes --seeds 20 --workers 2 --option polish=0.5``, then 0.7):
  median 1412.5 N, quartiles 1407.9-1417.6, against 1416.3 N and
  1412.2-1421.9 with half the budget (1440 N without polishing, rtol 1e-6).
  At 100 evaluations the local descent, more than CMA-ES, is what wins; with
  2000 evaluations CMA-ES still spends 600 of them, and the polishing phase
  (an iterated local search) found the best known order in each of seeds 0-2.
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
from .local import order_to_keys, sequential_keys


class CMAES(Search):
    """``cma.CMAEvolutionStrategy`` on random keys; one batch = one population.

    Options:
      popsize     population size (batch size); default pycma's 4 + floor(3 ln n).
      sigma0      initial step size (default 0.3).
      x0          first mean: "sequential" (default; keys evenly spaced in [0, 1]
                  decoding to 1..n), "random" (uniform in [0, 1]).
      restarts    restart when pycma stops (default True); False: stop() then.
      restart_x0  mean of a restart: "random" (default) or "best" (keys of the
                  best order so far).
      restart_sigma0  step size of a restart (default: sigma0).
      incpopsize  population factor at each restart (default 1; 2 = IPOP).
      polish      fraction of ``budget`` left to the final descent (default 0.7;
                  0 = none).  polish_batch: its batch size (default 4).
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
    POLISH = 0.7  # the default share of the budget polished (polish.Polished)
    OPTIONS = {"popsize": None, "sigma0": 0.3, "restarts": True, "incpopsize": 1,
               "cma_options": None, "budget": None, "x0": "sequential", "restart_x0": "random",
               "restart_sigma0": None}

    def __init__(self, n: int, seed: int, **options: Any) -> None:
        super().__init__(n, seed, **options)
        if self.options["x0"] not in ("sequential", "random"):
            raise ValueError("cmaes: x0 must be 'sequential' or 'random'")
        if self.options["restart_x0"] not in ("sequential", "random", "best"):
            raise ValueError("cmaes: restart_x0 must be 'random', 'best' or 'sequential'")
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
        first = self.restarts == 0
        how = self.options["x0"] if first else self.options["restart_x0"]
        sigma0 = self.sigma0 if first else float(self.options["restart_sigma0"] or self.sigma0)
        if how == "sequential":
            x0 = sequential_keys(self.n)
            x0 = np.concatenate([x0, np.full(self.dim - self.n, 0.5)])
        elif how == "best" and self.best_order is not None:
            x0 = order_to_keys(self.best_order, self.dim)
        else:  # "random", or "best" before anything was told
            x0 = self.rng.uniform(0.0, 1.0, self.dim)
        cma_seed = int(self.rng.integers(1, 2**31 - 1))  # pycma treats 0 as "seed from the clock"
        opts = {"popsize": self.popsize, "seed": cma_seed, "verbose": -9, "verb_log": 0,
                "verb_disp": 0, "verb_filenameprefix": "", "maxfevals": math.inf}
        opts.update(self.options["cma_options"] or {})
        with self._sandbox():
            self.es = cma.CMAEvolutionStrategy(x0, sigma0, opts)

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
