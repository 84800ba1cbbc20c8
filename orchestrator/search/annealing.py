"""Simulated annealing over permutations, with several chains in parallel.

Why several chains: a batch is one proposal per chain, so ``chains``
evaluations run in parallel and independent chains hedge against one chain
freezing in a poor basin.

Why an automatic initial temperature: the study's annealing did worse than the
plain sequential order; a temperature that is too low makes annealing a greedy
descent from a random start, one that is too high makes it a random walk.  So
T0 is measured: the chains first take ``calibration`` greedy steps, and T0 is
chosen so that the mean Metropolis acceptance ``exp(-delta/T0)`` of the
*worsening* moves seen equals ``initial_acceptance`` (default 0.2, see below).
A forced ``t0`` skips this.  Either way T0 is checked against the worsening
moves the chains actually meet once annealing has begun: if the first
``window`` of them would be accepted at T0 with a mean probability
``exp(-delta/T0)`` of ~0 or ~1, ``state()["poor_temperature"]`` says so.  The
check uses T0, not the moves' own (falling) temperatures: with a short budget
the temperature drops a hundredfold within those moves, so how many were
actually accepted (reported too) mostly measures the schedule and the luck of
which deltas came first, not T0.  The calibration itself can misfire when few of
its steps worsen: seed 2 on the 11-column lattice saw two worsening deltas,
0.4 N and 83 N, and the mean acceptance of 0.2 puts T0 at 0.45 N, where the
moves met next (mostly 50 to 4000 N) are accepted with probability 0.02; the
check flags it.  Calibrating only after 3, 5 or 8 worsening deltas did not
help at 100 evaluations (medians 1411.9, 1418.7, 1418.0 N over seeds 0-19,
against 1412.1 N), because such a run becomes a greedy descent that the
polishing phase continues, which is about as good at that budget.

Why cooling by budget: the temperature falls geometrically from T0 to
``t_final_ratio * T0`` as the number of *distinct* orders evaluated goes from
the end of calibration to the start of the polishing phase
(``budget - round(polish * budget)``, see ``polish.py``), so the schedule ends
when the annealing's share of the budget does, whatever the cache-hit rate.

Why free steps: the search remembers every value it was told.  A proposal whose
value is already known is accepted or rejected on the spot (exactly what would
happen if it were asked and answered from the loop's cache), and the chain
proposes again; so nearly every asked order is new and costs budget, instead of
batches of cache hits.  A chain that cannot find an unknown neighbour within
``max_free`` tries (it sits in a fully explored local optimum) is kicked: a few
random moves from its current order, accepted unconditionally.

Why the small-budget defaults (measured on the 11-column lattice: searches on
the 1 s search objective with 100 evaluations, the best order re-evaluated
over the full 8 s, median over seeds 0-19; the best order we know is at
1405.9 N, the sequential one at 1747.8 N; each step adds to the previous):
- ``x0="sequential"``: chain 0 starts at the sequential order 1..n, the
  baseline a user already has, the other chains at one random move from it,
  instead of at random orders: 1493 -> 1446 N.
- ``chains=4`` (was 8): with 100 evaluations, 8 chains get about 12 steps
  each; 4 chains still fill a batch for a couple of workers: 1446 -> 1430 N.
- ``initial_acceptance=0.2`` (was 0.5): T0 is calibrated on the deltas seen
  near the start, which are large when the start is far from good orders
  (hundreds of N from the sequential one, a few N between good orders), so a
  high target acceptance makes the first part of a short run a random walk:
  1430 -> 1422 N.  (With polishing: 0.1, 0.2, 0.3, 0.5 gave 1415, 1412, 1411,
  1418 N.)
- ``polish=0.3``: the last 30 % of the budget goes to a descent by single
  swaps and insertions from the best order (``local.py``), which checks
  neighbours systematically where the cold end of the annealing samples them
  at random: 1422 -> 1412 N (0.5: 1410 N but 5 seeds in 20 above 1430 N
  against 2 at 0.3).  With 2000 evaluations SA found the best known order in
  each of seeds 0-2.
"""
from __future__ import annotations

import math
from collections import deque
from typing import Any

import numpy as np

from ..types import Order
from .base import FAILURE, Search, random_order
from .local import random_move


class Annealing(Search):
    """Options (defaults):
      chains=4               chains; batch size.
      budget=None            distinct evaluations the loop will allow; scales the
                             cooling.  Pass the loop's budget (1000 assumed if None).
      t0=None                force the initial temperature (skips calibration).
      initial_acceptance=0.2 target acceptance of worsening moves at T0.
      t_final_ratio=1e-3     final temperature / T0.
      swap_prob=0.5          probability of a swap move (else an insertion move).
      calibration=None       worsening/improving deltas sampled before T0 is set
                             (default max(10, 2 * chains)).
      window=30              worsening moves after T0 used to check the temperature.
      poor_low=0.02, poor_high=0.98   bounds of their mean acceptance at T0.
      max_free=500           proposals tried per chain and batch before a kick.
      kick=3                 random moves in a kick.
      x0="sequential"        chain 0 starts at 1..n, the others one random move from
                             it; "random": every chain at a random order.
      polish=0.3             fraction of ``budget`` left to the final descent (0 = none).
      polish_batch=4         batch size of that descent.
    """

    name = "sa"
    POLISH = 0.3  # the default share of the budget polished (polish.Polished)
    OPTIONS = {"chains": 4, "budget": None, "t0": None, "initial_acceptance": 0.2,
               "t_final_ratio": 1e-3, "swap_prob": 0.5, "calibration": None, "window": 30,
               "poor_low": 0.02, "poor_high": 0.98, "max_free": 500, "kick": 3,
               "x0": "sequential"}

    def __init__(self, n: int, seed: int, **options: Any) -> None:
        super().__init__(n, seed, **options)
        o = self.options
        if o["x0"] not in ("sequential", "random"):
            raise ValueError("sa: x0 must be 'sequential' or 'random'")
        self.chains = int(o["chains"])
        if self.chains < 1:
            raise ValueError("sa: chains must be at least 1")
        self.budget_assumed = o["budget"] is None
        self.budget = int(o["budget"] if o["budget"] is not None else 1000)
        # the budget is the annealing's own share: Polished hands it the part before its polishing phase
        self.anneal_budget = max(1, self.budget)
        if not 0.0 < float(o["initial_acceptance"]) < 1.0:
            raise ValueError("sa: initial_acceptance must be in (0, 1)")
        if not 0.0 < float(o["t_final_ratio"]) <= 1.0:
            raise ValueError("sa: t_final_ratio must be in (0, 1]")
        self.calibration = int(o["calibration"] or max(10, 2 * self.chains))
        self.total_orders = math.factorial(self.n) if self.n <= 12 else None
        self.current: list[Order | None] = [None] * self.chains
        self.current_value = [FAILURE] * self.chains
        self._proposals: list[tuple[Order, str]] = []
        self.deltas: list[float] = []
        self.t0: float | None = None if o["t0"] is None else float(o["t0"])
        if self.t0 is not None and not self.t0 > 0:
            raise ValueError("sa: t0 must be positive")
        self.t0_source = "forced" if self.t0 is not None else "automatic"
        self.memo_at_t0 = 0
        # statistics
        self.steps = self.free_steps = self.accepted = 0
        self.uphill = self.uphill_accepted = 0
        self.kicks = 0
        self.window_uphill: list[bool] = []  # accepted or not, at the temperature of the time
        self.window_deltas: list[float] = []
        self.recent: deque[bool] = deque(maxlen=200)

    # -- temperature ------------------------------------------------------
    @property
    def temperature(self) -> float | None:
        if self.t0 is None:
            return None
        span = max(1, self.anneal_budget - self.memo_at_t0)
        progress = min(1.0, max(0.0, (len(self.memo) - self.memo_at_t0) / span))
        return self.t0 * float(self.options["t_final_ratio"]) ** progress

    def _calibrate(self) -> None:
        """T0 such that mean(exp(-d / T0)) over the worsening deltas = target."""
        target = float(self.options["initial_acceptance"])
        up = np.array([d for d in self.deltas if d > 0], dtype=float)
        if up.size == 0:
            nonzero = [abs(d) for d in self.deltas if d != 0]
            t0 = float(np.mean(nonzero)) if nonzero else 1.0
        else:
            lo, hi = math.log(up.min()) - 20, math.log(up.max()) + 20
            for _ in range(200):  # bisection on log T; acceptance increases with T
                mid = 0.5 * (lo + hi)
                if np.mean(np.exp(-up / math.exp(mid))) < target:
                    lo = mid
                else:
                    hi = mid
            t0 = math.exp(0.5 * (lo + hi))
        self.t0 = t0
        self.memo_at_t0 = len(self.memo)

    # -- moves ------------------------------------------------------------
    def _neighbour(self, order: Order) -> Order:
        return random_move(self.rng, order, float(self.options["swap_prob"]))

    def _step(self, c: int, proposal: Order, value: float, free: bool) -> None:
        """One Metropolis step of chain c (greedy while calibrating)."""
        current = self.current_value[c]
        self.steps += 1
        self.free_steps += free
        temperature = self.temperature
        if value == FAILURE:
            accept = current == FAILURE  # a failure never replaces a real value
        elif current == FAILURE:
            accept = True
        else:
            delta = value - current
            if temperature is None:
                self.deltas.append(delta)
                accept = delta <= 0
            elif delta <= 0:
                accept = True
            else:
                accept = bool(self.rng.random() < math.exp(-delta / temperature))
                self.uphill += 1
                self.uphill_accepted += accept
                if len(self.window_uphill) < int(self.options["window"]):
                    self.window_uphill.append(accept)
                    self.window_deltas.append(delta)
        self.accepted += accept
        self.recent.append(accept)
        if accept:
            self.current[c], self.current_value[c] = proposal, value
        if self.t0 is None and len(self.deltas) >= self.calibration:
            self._calibrate()

    # -- protocol ---------------------------------------------------------
    def _ask(self) -> list[Order]:
        self._proposals = []
        for c in range(self.chains):
            current = self.current[c]
            if current is None:
                if self.options["x0"] == "sequential" and c == 0:
                    start = tuple(range(1, self.n + 1))
                elif self.options["x0"] == "sequential":
                    start = self._neighbour(tuple(range(1, self.n + 1)))
                else:
                    start = random_order(self.rng, self.n)
                self._proposals.append((start, "init"))
                continue
            for _ in range(int(self.options["max_free"])):
                proposal = self._neighbour(current)
                if proposal in self.memo:
                    self._step(c, proposal, self.memo[proposal], free=True)
                    current = self.current[c]
                    continue
                self._proposals.append((proposal, "move"))
                break
            else:
                kicked = current
                for _ in range(int(self.options["kick"])):
                    kicked = self._neighbour(kicked)
                self.kicks += 1
                self._proposals.append((kicked, "kick"))
        return [p for p, _ in self._proposals]

    def _tell(self, orders: list[Order], values: list[float]) -> None:
        for c, ((order, kind), value) in enumerate(zip(self._proposals, values)):
            if kind == "move":
                self._step(c, order, value, free=False)
            else:  # "init" or "kick": the chain moves there unconditionally
                self.current[c], self.current_value[c] = order, value

    def _stop(self) -> bool:
        return self.total_orders is not None and len(self.memo) >= self.total_orders

    def _state(self) -> dict[str, Any]:
        low, high = float(self.options["poor_low"]), float(self.options["poor_high"])
        window = self.window_uphill
        initial = float(np.mean(window)) if window else None
        at_t0 = (float(np.mean(np.exp(-np.asarray(self.window_deltas) / self.t0)))
                 if self.window_deltas and self.t0 else None)
        poor = None
        if at_t0 is not None and len(window) >= min(10, int(self.options["window"])):
            met = (f"the first {len(window)} worsening moves would be accepted at T0 with mean probability "
                   f"{at_t0:.2g} ({initial:.0%} were, as it cooled)")
            if at_t0 <= low:
                poor = (f"poor temperature: too low (T0={self.t0:.4g}, {self.t0_source}); {met}: "
                        "annealing degenerates into greedy descent")
            elif at_t0 >= high:
                poor = (f"poor temperature: too high (T0={self.t0:.4g}, {self.t0_source}); {met}: "
                        "annealing degenerates into a random walk")
        temperature = self.temperature
        return {
            "chains": self.chains, "budget": self.budget, "budget_assumed": self.budget_assumed,
            "anneal_budget": self.anneal_budget,
            "t0": self.t0, "t0_source": self.t0_source,
            "t_final": None if self.t0 is None else self.t0 * float(self.options["t_final_ratio"]),
            "temperature": temperature,
            "calibration_deltas": len(self.deltas),
            "steps": self.steps, "free_steps": self.free_steps, "kicks": self.kicks,
            "acceptance_rate": self.accepted / self.steps if self.steps else None,
            "uphill_acceptance_rate": self.uphill_accepted / self.uphill if self.uphill else None,
            "recent_acceptance_rate": float(np.mean(self.recent)) if self.recent else None,
            "initial_uphill_acceptance": initial,
            "initial_acceptance_at_t0": at_t0,
            "poor_temperature": poor,
            "chain_values": [None if v == FAILURE else v for v in self.current_value],
        }
