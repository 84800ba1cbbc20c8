"""Particle swarm on random keys.

Why these constants: inertia 0.7298 and acceleration 1.49618 are Clerc and
Kennedy's constriction values, the standard convergent setting.  Why velocity
clamping and a [0, 1] box: random keys only matter relative to each other, so
without a bound the swarm can drift or blow up while decoding to the same
orders.  Why restarts: a collapsed swarm decodes to one order over and over;
after ``stagnation`` iterations without improving its global best, the swarm
is scattered again (the overall best is kept in ``state()``), uniformly:
re-scattering around the best order so far (``rescatter_best=True``) costs
the diversity a restart is for (on the 8-material quadratic-assignment test,
polishing off, it found the optimum in 0 of 6 seeds against 3 of 6).

Why the small-budget defaults (measured on the 11-column lattice: searches on
the 1 s search objective with 100 evaluations, the best order re-evaluated
over the full 8 s, median over seeds 0-19 unless said; the best order we know
is at 1405.9 N, the sequential one at 1747.8 N):
- ``x0="sequential"``, ``spread=0.3``: the swarm starts around the keys of
  the sequential order, the baseline a user already has (particle 0 exactly
  on it, the others with Gaussian noise of 0.3 on each key, about three
  columns), instead of uniformly at random.  Seeding only one particle there
  did little (1485 -> 1469 N, seeds 0-9, no polishing): in a random swarm the
  baseline is rarely even the best particle.  Spreads 0.2 and 0.4 were worse
  than 0.3 (1455 and 1458 N against 1439 N, 16 particles, polish 0.5,
  seeds 0-9).
- ``swarm=10`` (was 10 + 2 sqrt(n) = 16 for n = 11): with 100 evaluations a
  swarm of 16 gets a handful of iterations; 10 gave 1426 N against 1439 N
  (seeds 0-9, polish 0.5).  6 and 8 were within noise of 10.
- ``polish=0.7``: the last 70 % of the budget goes to a descent by single
  swaps and insertions from the best order (``local.py``).  On random keys the
  swarm is the weakest of the three at the last few improvements; 0.5, 0.6,
  0.7 gave 1428, 1421, 1414 N (1 seed in 20 above 1430 N at 0.7, 4 at 0.6).
  With 2000 evaluations the polishing phase (an iterated local search) found
  the best known order in each of seeds 0-2.
- ``topology="ring"`` stays: "global" was no better with polishing (1413 N at
  polish 0.6, 1416 N at 0.7, with 4-5 seeds in 20 above 1430 N).
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..types import Order
from .base import Search, keys_to_order
from .local import order_to_keys, sequential_keys


class PSO(Search):
    """One batch = the whole swarm.

    Options:
      swarm       number of particles (batch size); default 10.
      x0          "sequential" (default): the swarm starts around the keys of the
                  order 1..n; "random": uniform in [0, 1].
      spread      standard deviation of the keys around the start (default 0.3;
                  None: only particle 0 is placed, the rest stay uniform).
      rescatter_best  re-scatter around the best order so far, with ``spread``
                  (default False: uniformly).
      polish      fraction of ``budget`` left to the final descent (default 0.7;
                  0 = none).  polish_batch: its batch size (default 4).
      inertia     w (default 0.7298).
      cognitive   c1, pull towards the particle's own best (default 1.49618).
      social      c2, pull towards the swarm's best (default 1.49618).
      vmax        velocity clamp per key, as a fraction of the [0, 1] box (default 0.2).
      stagnation  iterations without global-best improvement before the swarm
                  is re-scattered (default 20; 0 = never).
      topology    "ring" (default: each particle follows the best of itself and
                  its two ring neighbours) or "global" (everyone follows the
                  swarm's best).  The ring keeps the swarm diverse for longer;
                  on small quadratic-assignment tests it found the optimum in
                  19/20 seeds against 13/20 for the global best (n=7, budget 400).
    """

    name = "pso"
    POLISH = 0.7  # the default share of the budget polished (polish.Polished)
    OPTIONS = {"swarm": 10, "inertia": 0.7298, "cognitive": 1.49618, "social": 1.49618,
               "vmax": 0.2, "stagnation": 20, "topology": "ring", "budget": None,
               "x0": "sequential", "spread": 0.3, "rescatter_best": False}

    def __init__(self, n: int, seed: int, **options: Any) -> None:
        super().__init__(n, seed, **options)
        if self.options["x0"] not in ("sequential", "random"):
            raise ValueError("pso: x0 must be 'sequential' or 'random'")
        self.size = int(self.options["swarm"] or (10 + int(2 * math.sqrt(self.n))))
        if self.size < 1:
            raise ValueError("pso: swarm must be at least 1")
        self.w = float(self.options["inertia"])
        self.c1 = float(self.options["cognitive"])
        self.c2 = float(self.options["social"])
        self.vmax = float(self.options["vmax"])
        self.topology = self.options["topology"]
        if self.topology not in ("global", "ring"):
            raise ValueError("pso: topology must be 'global' or 'ring'")
        self.restarts = 0
        self.iterations = 0
        self._scatter()

    def _scatter(self) -> None:
        self.x = self.rng.uniform(0.0, 1.0, (self.size, self.n))
        self.v = self.rng.uniform(-self.vmax, self.vmax, (self.size, self.n))
        centre = None
        if self.restarts == 0 and self.options["x0"] == "sequential":
            centre = sequential_keys(self.n)
        elif self.restarts > 0 and self.options["rescatter_best"] and self.best_order is not None:
            centre = order_to_keys(self.best_order)
        if centre is not None:
            spread = self.options["spread"]
            if spread is not None:
                self.x = np.clip(centre + self.rng.normal(0.0, float(spread), self.x.shape), 0.0, 1.0)
            self.x[0] = centre
        self.pbest_x = self.x.copy()
        self.pbest_f = np.full(self.size, np.inf)
        self.gbest_x = self.x[0].copy()
        self.gbest_f = math.inf
        self.since_improvement = 0
        self._fresh = True  # the first tell after scattering sets the personal bests

    def _ask(self) -> list[Order]:
        return [keys_to_order(x) for x in self.x]

    def _tell(self, orders: list[Order], values: list[float]) -> None:
        f = np.asarray(values, dtype=float)
        better = f < self.pbest_f
        if self._fresh:
            better[:] = True  # even a failed start is a (bad) personal best to move from
            self._fresh = False
        self.pbest_x[better] = self.x[better]
        self.pbest_f[better] = f[better]
        i = int(np.argmin(self.pbest_f))
        if self.pbest_f[i] < self.gbest_f:
            self.gbest_x = self.pbest_x[i].copy()
            self.gbest_f = float(self.pbest_f[i])
            self.since_improvement = 0
        else:
            self.since_improvement += 1
        self.iterations += 1
        limit = int(self.options["stagnation"] or 0)
        if limit and self.since_improvement >= limit:
            self.restarts += 1
            self._scatter()
            return
        r1 = self.rng.uniform(size=self.x.shape)
        r2 = self.rng.uniform(size=self.x.shape)
        if self.topology == "ring":  # best of self and the two ring neighbours
            idx = np.arange(self.size)
            neigh = np.stack([(idx - 1) % self.size, idx, (idx + 1) % self.size], axis=1)
            pick = neigh[idx, np.argmin(self.pbest_f[neigh], axis=1)]
            guide = self.pbest_x[pick]
        else:
            guide = self.gbest_x
        self.v = (self.w * self.v + self.c1 * r1 * (self.pbest_x - self.x)
                  + self.c2 * r2 * (guide - self.x))
        np.clip(self.v, -self.vmax, self.vmax, out=self.v)
        self.x = self.x + self.v
        # reflect at the walls of [0, 1] and reverse the velocity there
        low, high = self.x < 0.0, self.x > 1.0
        self.x[low] = -self.x[low]
        self.x[high] = 2.0 - self.x[high]
        self.v[low | high] *= -1.0
        np.clip(self.x, 0.0, 1.0, out=self.x)

    def _state(self) -> dict[str, Any]:
        spread = float(np.mean(np.std(self.x, axis=0))) if self.size > 1 else 0.0
        return {"swarm": self.size, "iterations": self.iterations, "restarts": self.restarts,
                "swarm_best": None if not np.isfinite(self.gbest_f) else self.gbest_f,
                "iterations_since_improvement": self.since_improvement,
                "key_spread": spread}
