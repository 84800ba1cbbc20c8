"""CMA-ES (pycma) on random keys.

Why random keys: CMA-ES is a continuous optimiser; a point x in R^d decodes to a design through
``DesignSpace.from_keys`` (d = ``space.key_dimension``): without repetition the materials sorted by their
keys fill the columns (``argsort(x) + 1`` for a permutation, its first C for C of M materials), with
repetition key j picks column j's material. Many points decode to one design, which is why the loop caches
by design.

Why restarts: on random keys the distribution soon concentrates so that every sample decodes to the same few
designs; pycma then stops (flat fitness, tolx, ...) and, rather than let the budget go unused, a fresh
CMA-ES starts from a new random mean (optionally with a larger population, IPOP-style).

Why the defaults (python -m bench.search_convergence with ``--option``, on the study's lattice at the study's budget):
- ``x0="sequential"``: the first mean is the keys of the baseline a designer already has
  (``DesignSpace.baseline``); from a random mean a small budget goes to far-away designs. Restarts
  (``restart_x0``) start from random means, for diversity.
- ``sigma0=0.3``: evenly spaced keys of neighbouring materials are about 1/(M-1) apart, so 0.3 moves a
  material by a few columns per sample; smaller steps stay too close to the start.
- ``polish=0.7``: the last 70 % of the budget goes to the descent by single moves from the best design
  (``local.py``): at a small budget the descent, more than CMA-ES, makes the last improvements.
"""

from __future__ import annotations

import contextlib
import io
import math
import warnings
from typing import Any, Iterator

import cma
import numpy as np

from ..design import Design, DesignSpace
from .base import FAILURE, Search


class CMAES(Search):
    """``cma.CMAEvolutionStrategy`` on random keys; one batch = one population.

    Options:
      popsize     population size (batch size); default pycma's 4 + floor(3 ln d), d the key dimension.
      sigma0      initial step size (default 0.3).
      x0          first mean: "sequential" (default; the keys of the first starting
                  design, else evenly spaced keys in [0, 1] decoding to the space's
                  baseline), "random" (uniform in [0, 1]).  Starting designs given
                  (``starts``) are injected into the first populations (pycma's
                  ``inject``), so CMA-ES is told their values.
      restarts    restart when pycma stops (default True); False: stop() then.
      restart_x0  mean of a restart: "random" (default), "best" (keys of the
                  best design so far) or "sequential".
      restart_sigma0  step size of a restart (default: sigma0).
      incpopsize  population factor at each restart (default 1; 2 = IPOP).
      polish      fraction of ``budget`` left to the final descent (default 0.7;
                  0 = none).  polish_batch: its batch size (default 4).
      cma_options extra pycma options (dict) for experts.

    A failed evaluation is told to pycma as a finite penalty larger than every
    real value seen so far, so it always ranks last (pycma handles infinities
    poorly in its termination statistics).

    With repetition the keys are read in [0, 1] (a key outside picks the first or
    last material), so pycma is given the bounds [0, 1] there: outside them every
    sample would decode alike and the step size drift.

    Reproducibility: pycma draws from numpy's *global* RNG.  Each pycma call
    here runs with the global state swapped for this search's own (seeded via
    pycma's ``seed`` option, the seed drawn from ``default_rng(seed)``), and the
    caller's global state is restored afterwards.  So two CMA-ES searches, or
    other code using ``np.random``, cannot disturb each other.  (Not
    thread-safe: do not step two searches in two threads at once.)
    """

    name = "cmaes"
    POLISH = 0.7  # the default share of the budget polished (polish.Polished)
    OPTIONS = {
        "popsize": None,
        "sigma0": 0.3,
        "restarts": True,
        "incpopsize": 1,
        "cma_options": None,
        "budget": None,
        "x0": "sequential",
        "restart_x0": "random",
        "restart_sigma0": None,
    }

    def __init__(self, space: DesignSpace | int, seed: int, **options: Any) -> None:
        super().__init__(space, seed, **options)
        if self.options["x0"] not in ("sequential", "random"):
            raise ValueError(f"cmaes: x0 must be 'sequential' or 'random', got {self.options['x0']!r}")
        if self.options["restart_x0"] not in ("sequential", "random", "best"):
            raise ValueError(
                f"cmaes: restart_x0 must be 'random', 'best' or 'sequential', got {self.options['restart_x0']!r}"
            )
        self.dim = max(self.space.key_dimension, 2)  # pycma needs at least 2 dimensions; extra keys are ignored
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
            x0 = self.space.to_keys(self.start_designs()[0], self.dim)
        elif how == "best" and self.best_order is not None:
            x0 = self.space.to_keys(self.best_order, self.dim)
        else:  # "random", or "best" before anything was told
            x0 = self.rng.uniform(0.0, 1.0, self.dim)
        cma_seed = int(self.rng.integers(1, 2**31 - 1))  # pycma treats 0 as "seed from the clock"
        opts = {
            "popsize": self.popsize,
            "seed": cma_seed,
            "verbose": -9,
            "verb_log": 0,
            "verb_disp": 0,
            "verb_filenameprefix": "",
            "maxfevals": math.inf,
        }
        if self.space.repeat:
            opts["bounds"] = [0.0, 1.0]
        opts.update(self.options["cma_options"] or {})
        with self._sandbox():
            self.es = cma.CMAEvolutionStrategy(x0, sigma0, opts)
            if first and self.starts:  # pycma's own way to have given points in the next populations
                self.es.inject([self.space.to_keys(d, self.dim) for d in self.starts], force=True)

    def _ask(self) -> list[Design]:
        with self._sandbox():
            self._X = [np.asarray(x, dtype=float) for x in self.es.ask()]
        return [self.space.from_keys(x) for x in self._X]

    def _tell(self, designs: list[Design], values: list[float]) -> None:
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
        return {
            "sigma": float(self.es.sigma),
            "popsize": self.popsize,
            "iterations_since_restart": int(self.es.countiter),
            "restarts": self.restarts,
            "stop_reasons": self.restart_reasons[-10:],
        }
