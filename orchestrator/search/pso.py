"""Particle swarm on random keys (decoded by ``DesignSpace.from_keys``, as CMA-ES decodes its samples).

Why these constants: inertia 0.7298 and acceleration 1.49618 are Clerc and Kennedy's constriction values,
the standard convergent setting. Why velocity clamping and a [0, 1] box: random keys only matter relative to
each other (or, with repetition, within [0, 1]), so without a bound the swarm can drift or blow up while
decoding to the same designs. Why restarts: a collapsed swarm decodes to one design over and over; after
``stagnation`` iterations without improving its global best, the swarm is scattered again uniformly (the
overall best is kept in ``state()``); re-scattering around the best design (``rescatter_best=True``) costs
the diversity a restart is for.

Why the defaults (python -m bench.search_convergence with ``--option``, on the study's lattice at the study's budget):
- ``x0="sequential"``, ``spread=0.3``: the swarm starts around the keys of the baseline a designer already has
  (particle 0 exactly on it, the others with Gaussian noise of 0.3 on each key, a few columns), not
  uniformly: placing one particle there alone does little, since in a random swarm the baseline is rarely
  even the best particle.
- ``swarm=10``: a small budget gives a larger swarm only a handful of iterations.
- ``polish=0.7``: the last 70 % of the budget goes to the descent by single moves from the best design
  (``local.py``); on random keys the swarm is weak at the last few improvements.
- ``topology="ring"``: each particle follows the best of itself and its two ring neighbours, which keeps the
  swarm diverse for longer than following the swarm's best.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..design import Design, DesignSpace
from .base import Search


class PSO(Search):
    """One batch = the whole swarm.

    Options:
      swarm       number of particles (batch size); default 10.
      x0          "sequential" (default): the swarm starts around the keys of the
                  first starting design (else the space's baseline), a particle on
                  each starting design; "random": uniform in [0, 1].
      spread      standard deviation of the keys around the start (default 0.3;
                  None: only particle 0 is placed, the rest stay uniform).
      rescatter_best  re-scatter around the best design so far, with ``spread``
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
                  swarm's best).
    """

    name = "pso"
    POLISH = 0.7  # the default share of the budget polished (polish.Polished)
    OPTIONS = {
        "swarm": 10,
        "inertia": 0.7298,
        "cognitive": 1.49618,
        "social": 1.49618,
        "vmax": 0.2,
        "stagnation": 20,
        "topology": "ring",
        "budget": None,
        "x0": "sequential",
        "spread": 0.3,
        "rescatter_best": False,
    }

    def __init__(self, space: DesignSpace | int, seed: int, **options: Any) -> None:
        super().__init__(space, seed, **options)
        if self.options["x0"] not in ("sequential", "random"):
            raise ValueError(f"pso: x0 must be 'sequential' or 'random', got {self.options['x0']!r}")
        self.dim = self.space.key_dimension
        self.size = int(self.options["swarm"] or (10 + int(2 * math.sqrt(self.dim))))
        if self.size < 1:
            raise ValueError(f"pso: swarm must be at least 1, got {self.options['swarm']!r}")
        self.w = float(self.options["inertia"])
        self.c1 = float(self.options["cognitive"])
        self.c2 = float(self.options["social"])
        self.vmax = float(self.options["vmax"])
        self.topology = self.options["topology"]
        if self.topology not in ("global", "ring"):
            raise ValueError(f"pso: topology must be 'global' or 'ring', got {self.topology!r}")
        self.restarts = 0
        self.iterations = 0
        self._scatter()

    def _scatter(self) -> None:
        self.x = self.rng.uniform(0.0, 1.0, (self.size, self.dim))
        self.v = self.rng.uniform(-self.vmax, self.vmax, (self.size, self.dim))
        centre = None
        if self.restarts == 0 and self.options["x0"] == "sequential":
            centre = self.space.to_keys(self.start_designs()[0])
        elif self.restarts > 0 and self.options["rescatter_best"] and self.best_order is not None:
            centre = self.space.to_keys(self.best_order)
        if centre is not None:
            spread = self.options["spread"]
            if spread is not None:
                self.x = np.clip(centre + self.rng.normal(0.0, float(spread), self.x.shape), 0.0, 1.0)
            self.x[0] = centre
            if self.restarts == 0:  # a particle on each further starting design
                for i, design in enumerate(self.starts[1 : self.size], start=1):
                    self.x[i] = self.space.to_keys(design)
        self.pbest_x = self.x.copy()
        self.pbest_f = np.full(self.size, np.inf)
        self.gbest_x = self.x[0].copy()
        self.gbest_f = math.inf
        self.since_improvement = 0
        self._fresh = True  # the first tell after scattering sets the personal bests

    def _ask(self) -> list[Design]:
        return [self.space.from_keys(x) for x in self.x]

    def _tell(self, designs: list[Design], values: list[float]) -> None:
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
        self.v = self.w * self.v + self.c1 * r1 * (self.pbest_x - self.x) + self.c2 * r2 * (guide - self.x)
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
        return {
            "swarm": self.size,
            "iterations": self.iterations,
            "restarts": self.restarts,
            "swarm_best": None if not np.isfinite(self.gbest_f) else self.gbest_f,
            "iterations_since_improvement": self.since_improvement,
            "key_spread": spread,
        }
