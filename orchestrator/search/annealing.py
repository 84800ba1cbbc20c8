"""Simulated annealing over a design space, with several chains in parallel.

Why several chains: a batch is one proposal per chain, so ``chains`` evaluations run in parallel, and
independent chains hedge against one chain freezing in a poor basin.

Why an automatic initial temperature: too low a temperature makes annealing a greedy descent from its start,
too high a random walk. So T0 is measured: the chains first take ``calibration`` greedy steps, and T0 is
chosen so that the mean Metropolis acceptance ``exp(-delta/T0)`` of the *worsening* moves seen equals
``initial_acceptance``. A forced ``t0`` skips this. Either way T0 is checked against the worsening moves the
chains meet once annealing has begun: if the first ``window`` of them would be accepted at T0 with a mean
probability ``exp(-delta/T0)`` of about 0 or 1, ``state()["poor_temperature"]`` says so. The check uses T0,
not the moves' own falling temperatures: with a short budget the temperature drops a hundredfold within the
window, so the share actually accepted (reported too) measures the schedule more than T0. The calibration
can misfire when few of its steps worsen (two small deltas put T0 far below the deltas met next); the check
flags that.

Why cooling by budget: the temperature falls geometrically from T0 to ``t_final_ratio * T0`` as the number
of *distinct* designs evaluated goes from the end of calibration to the annealing's share of the budget (the
part before the polishing phase, see ``polish.py``), so the schedule ends when that share does, whatever the
cache-hit rate.

Why free steps: the search remembers every value it was told. A proposal whose value is already known is
accepted or rejected on the spot (exactly what would happen if it were asked and answered from the loop's
cache), and the chain proposes again; so nearly every asked design is new and costs budget. A chain that
finds no unknown neighbour within ``max_free`` tries (it sits in a fully explored local optimum) is kicked:
a few random moves from its current design, accepted unconditionally.

Why the Metropolis uniform is drawn before the evaluation (the force limit): a proposal v from the chain's
current value c at temperature T is accepted iff v <= c or u < exp(-(v - c)/T), i.e. iff v <= c or
v < c - T ln u. With u drawn when the proposal is made (kept with it) and T taken for the number of designs
known once the batch is told, that threshold is known before the evaluation, so ``limits()`` hands it to the
loop: the FMU may stop once the peak passes it, and the censored evaluation ("above L") is a rejection. Only
accept/reject uses the threshold; no limit is given where the value itself is used: calibration steps (their
deltas set T0), an ``init`` or a kick (taken whatever the value), a chain whose current value failed. While
the temperature check's window is open (its first ``window`` worsening moves after T0) the limit is raised
to at least c + T0 ln(2/poor_low): a move censored there would be accepted at T0 with probability below
poor_low/2, so the check still tells a too-low T0 (it bounds a censored move's acceptance, never guesses
it; see ``_state``).

The search keeps of a told value only what its limit asked for: the number if it is at most the limit, else
"above the limit" (``self.above``), whether the evaluation stopped there or ran on. So it makes the same
decisions and asks whether or not the evaluator honours the limits (tests/test_annealing_limits.py); limits
change the cost only. A known "above b" is a free rejection when b is at or above the new threshold; below
it (another chain, a higher current value) it decides nothing, so the design is asked again with the new
limit, and the loop evaluates it again without charging the budget (``reevaluations``).
``use_limits=False`` gives no limits and keeps every value.

Why the defaults (python -m bench.search_convergence, on the study's lattice at the study's budget):
- ``x0="sequential"``: chain 0 starts at the baseline a designer already has (``DesignSpace.baseline``), the
  others one random move from it: good designs are nearer the baseline than a random design is.
- ``chains=4``: enough to fill a batch for a couple of workers, few enough that each chain takes many steps.
- ``initial_acceptance=0.2``: T0 is calibrated on deltas near the start, large where the start is far from
  good designs, so a higher target makes the first part of a short run a random walk.
- ``polish=0.3``: the last 30 % of the budget goes to the descent (``local.py``), which checks neighbours
  systematically where the cold end of the annealing samples them at random.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..design import Design, DesignSpace
from .base import FAILURE, Search


def metropolis_threshold(current: float, temperature: float | None, u: float | None) -> float:
    """The value below which a proposal from ``current`` is accepted: ``current - T ln u``.

    A proposal v is accepted iff v <= current or v < threshold, which for u in (0, 1) is the Metropolis rule
    u < exp(-(v - current)/T). No temperature yet (calibration) or T = 0: greedy (threshold = current);
    u = 0 (-ln 0 = inf) or a failed current value: every real value is accepted (threshold +inf)."""
    if temperature is None or not temperature > 0 or u is None:
        return current
    if not u > 0:
        return math.inf
    return current - temperature * math.log(u)


@dataclass(frozen=True)
class Proposal:
    """One chain's asked design (``order``): ``kind`` "init", "kick" (taken whatever its value) or "move" (a
    Metropolis step, with the uniform ``u`` and temperature drawn when it was proposed, its threshold and its
    limit)."""

    order: Design
    kind: str
    u: float | None = None
    temperature: float | None = None
    threshold: float = math.inf
    limit: float | None = None


class Annealing(Search):
    """Options (defaults):
    chains=4               chains; batch size.
    budget=None            distinct evaluations the loop will allow; scales the
                           cooling.  Pass the loop's budget (1000 assumed if None).
    t0=None                force the initial temperature (skips calibration).
    initial_acceptance=0.2 target acceptance of worsening moves at T0.
    t_final_ratio=1e-3     final temperature / T0.
    swap_prob=0.5          probability of a swap (else an insertion) for a move that is not a
                           replacement (``DesignSpace.random_move``).
    calibration=None       worsening/improving deltas sampled before T0 is set
                           (default max(10, 2 * chains)).
    window=30              worsening moves after T0 used to check the temperature.
    poor_low=0.02, poor_high=0.98   bounds of their mean acceptance at T0.
    max_free=500           proposals tried per chain and batch before a kick.
    kick=3                 random moves in a kick.
    x0="sequential"        chain c starts at starting design c (default: the space's baseline), the
                           chains beyond the starting designs one random move
                           from it; "random": every chain at a random design.
    use_limits=True        give the loop each proposal's Metropolis threshold as its limit.
    polish=0.3             fraction of ``budget`` left to the final descent (0 = none).
    polish_batch=4         batch size of that descent.
    """

    name = "sa"
    POLISH = 0.3  # the default share of the budget polished (polish.Polished)
    OPTIONS = {
        "chains": 4,
        "budget": None,
        "t0": None,
        "initial_acceptance": 0.2,
        "t_final_ratio": 1e-3,
        "swap_prob": 0.5,
        "calibration": None,
        "window": 30,
        "poor_low": 0.02,
        "poor_high": 0.98,
        "max_free": 500,
        "kick": 3,
        "x0": "sequential",
        "use_limits": True,
    }

    def __init__(self, space: DesignSpace | int, seed: int, **options: Any) -> None:
        super().__init__(space, seed, **options)
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
        if not isinstance(o["use_limits"], bool):
            raise ValueError(f"sa: use_limits must be True or False, got {o['use_limits']!r}")
        self.calibration = int(o["calibration"] or max(10, 2 * self.chains))
        self.current: list[Design | None] = [None] * self.chains
        self.current_value = [FAILURE] * self.chains
        self._proposals: list[Proposal] = []
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
        self.window_deltas: list[float] = []  # the delta, or for a censored move the lower bound it is above
        self.window_exact: list[bool] = []  # False: a censored move, its delta only known to exceed the bound
        # what this search knows of a design beyond its memo: only that it is above this bound (censored,
        # or told a value above the limit it was asked with: see "Why the Metropolis uniform ...")
        self.above: dict[Design, float] = {}
        self._limits: list[float | None] = []
        self.reevaluations = 0  # designs asked again: known only above a bound below a threshold that matters
        self.undecided = 0  # told censored below their own threshold (a limit lower than asked): rejected
        self.recent: deque[bool] = deque(maxlen=200)

    # -- temperature ------------------------------------------------------
    @property
    def temperature(self) -> float | None:
        return self._temperature_at(len(self.memo))

    def _temperature_at(self, evaluated: int) -> float | None:
        """The temperature once ``evaluated`` distinct designs are known."""
        if self.t0 is None:
            return None
        span = max(1, self.anneal_budget - self.memo_at_t0)
        progress = min(1.0, max(0.0, (evaluated - self.memo_at_t0) / span))
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
    def _neighbour(self, design: Design) -> Design:
        return self.space.random_move(self.rng, design, float(self.options["swap_prob"]))

    def _step(self, c: int, order: Design, value: float, threshold: float, *, free: bool, calibrating: bool) -> bool:
        """One Metropolis step of chain c (greedy while calibrating): accept iff value <= current or
        value < threshold. A design known only to be above a bound (``self.above``) is rejected when the
        bound is at or above the threshold; below it the step is not decided: returns False, changes
        nothing."""
        current = self.current_value[c]
        bound = self.above.get(order)
        if bound is not None:
            if not bound >= threshold:
                return False
            accept, exact = False, False
            delta: float | None = bound - current  # a lower bound: the value is above ``bound``
        else:
            accept = value <= current or value < threshold
            exact = True
            delta = value - current if value != FAILURE and current != FAILURE else None
        self.steps += 1
        self.free_steps += free
        if calibrating:
            if self.t0 is None and exact and delta is not None:
                self.deltas.append(delta)  # exact values only: a censored one was never asked while calibrating
        elif delta is not None and (delta > 0 or not exact):
            self.uphill += 1
            self.uphill_accepted += accept
            if len(self.window_uphill) < int(self.options["window"]):
                self.window_uphill.append(accept)
                self.window_deltas.append(delta)
                self.window_exact.append(exact)
        self.accepted += accept
        self.recent.append(accept)
        if accept:
            self.current[c], self.current_value[c] = order, value
        if self.t0 is None and len(self.deltas) >= self.calibration:
            self._calibrate()
        return True

    def _limit(self, c: int, threshold: float) -> float | None:
        """The limit to evaluate a move with: its threshold, raised while the temperature check's window is
        open so that a censored move's acceptance at T0 is known to be below half of ``poor_low`` (half: so
        that a window of censored moves is flagged as too low, rounding whatever)."""
        if not self.options["use_limits"] or not math.isfinite(threshold):
            return None
        if self.t0 is not None and len(self.window_uphill) < int(self.options["window"]):
            poor_low = float(self.options["poor_low"])
            if not poor_low > 0:
                return None
            threshold = max(threshold, self.current_value[c] + self.t0 * math.log(2.0 / poor_low))
        return threshold if math.isfinite(threshold) else None

    def _started_design(self, c: int) -> Design:
        """Chain c's current design, once it has started; ValueError before."""
        design = self.current[c]
        if design is None:
            raise ValueError(f"sa: chain {c} has no current design before its start is told")
        return design

    # -- protocol ---------------------------------------------------------
    def _ask(self) -> list[Design]:
        self._proposals = []
        for c in range(self.chains):
            current = self.current[c]
            if current is None:
                starts = self.start_designs()
                if self.options["x0"] == "sequential" and c < len(starts):
                    start = starts[c]
                elif self.options["x0"] == "sequential":
                    start = self._neighbour(starts[c % len(starts)])
                else:
                    start = self.space.random(self.rng)
                self._proposals.append(Proposal(start, "init"))
                continue
            for _ in range(int(self.options["max_free"])):
                order = self._neighbour(current)
                temperature = self.temperature
                u = None if temperature is None else float(self.rng.random())  # drawn before the evaluation
                if order in self.memo and self._step(
                    c,
                    order,
                    self.memo[order],
                    metropolis_threshold(self.current_value[c], temperature, u),
                    free=True,
                    calibrating=temperature is None,
                ):
                    current = self._started_design(c)  # the move if _step accepted it
                    continue
                self.reevaluations += order in self.memo  # known only above a bound below the threshold
                self._proposals.append(Proposal(order, "move", u))
                break
            else:
                kicked = current
                for _ in range(int(self.options["kick"])):
                    kicked = self._neighbour(kicked)
                self.kicks += 1
                self.reevaluations += kicked in self.above
                self._proposals.append(Proposal(kicked, "kick"))
        # a move is judged at the temperature of when it is told, once this batch's new designs are counted
        told_at = self._temperature_at(len(self.memo) + len({p.order for p in self._proposals} - self.memo.keys()))
        for c, p in enumerate(self._proposals):
            if p.kind == "move" and p.u is not None:
                threshold = metropolis_threshold(self.current_value[c], told_at, p.u)
                self._proposals[c] = Proposal(p.order, "move", p.u, told_at, threshold, self._limit(c, threshold))
            elif p.kind == "move":  # a calibration step: greedy, on the exact value
                self._proposals[c] = Proposal(p.order, "move", None, None, self.current_value[c])
        # a design asked by several chains is evaluated once: each gets the highest of their limits (None
        # if one needs the exact value)
        merged: dict[Design, float | None] = {}
        for p in self._proposals:
            if p.order not in merged:
                merged[p.order] = p.limit
            elif (known := merged[p.order]) is not None:
                merged[p.order] = None if p.limit is None else max(known, p.limit)
        self._limits = [merged[p.order] for p in self._proposals]
        return [p.order for p in self._proposals]

    def limits(self) -> list[float | None]:
        """Each asked design's limit (see ``_limit``); None for an init, a kick or a calibration step."""
        return list(self._limits)

    def _learn(self, order: Design, value: float, limit: float | None) -> None:
        """What the search keeps of a told value: the number if it is at most the limit asked (or none
        was), else only that it is above the limit, whether the evaluation stopped there (censored) or
        ran on. So its decisions and asks are the same whether or not the evaluator honours limits."""
        censored_at = self.censored_above.get(order) if value == FAILURE else None
        if censored_at is not None:
            self.above[order] = max(censored_at, self.above.get(order, -math.inf))
        elif value != FAILURE and limit is not None and value > limit:
            self.above[order] = max(limit, self.above.get(order, -math.inf))
        else:
            self.above.pop(order, None)

    def _tell(self, designs: list[Design], values: list[float]) -> None:
        for proposal, value, limit in zip(self._proposals, values, self._limits):
            self._learn(proposal.order, value, limit)
        for c, (proposal, value) in enumerate(zip(self._proposals, values)):
            if proposal.order in self.above:
                value = FAILURE  # known only to be above a bound: never a number
            if proposal.kind == "move" and proposal.temperature is None and self.t0 is not None:
                # asked while calibrating (no limit, an exact value), told once an earlier chain of this batch
                # set T0: a Metropolis step at the temperature of now, its u drawn now
                temperature = self.temperature
                u = float(self.rng.random())
                proposal = Proposal(
                    proposal.order, "move", u, temperature, metropolis_threshold(self.current_value[c], temperature, u)
                )
            if proposal.kind == "move":
                if not self._step(
                    c, proposal.order, value, proposal.threshold, free=False, calibrating=proposal.temperature is None
                ):
                    self.undecided += 1  # censored below the limit asked: rejected, as a failure would be
                    self.steps += 1
                    self.recent.append(False)
            else:  # "init" or "kick": the chain moves there unconditionally (a censored value: as a failure)
                self.current[c], self.current_value[c] = proposal.order, value

    def _stop(self) -> bool:
        return len(self.memo) >= self.space.size

    def _state(self) -> dict[str, Any]:
        low, high = float(self.options["poor_low"]), float(self.options["poor_high"])
        window = self.window_uphill
        initial = float(np.mean(window)) if window else None
        # mean acceptance at T0 of the window's worsening moves; a censored one is known only to be
        # accepted with a probability in [0, exp(-bound/T0)], so the mean is bounded, never guessed
        bounds = None
        if self.window_deltas and self.t0:
            at_t0_each = np.exp(-np.asarray(self.window_deltas) / self.t0)
            bounds = (float(np.mean(np.where(self.window_exact, at_t0_each, 0.0))), float(np.mean(at_t0_each)))
        censored = len(self.window_exact) - sum(self.window_exact)
        at_t0 = bounds[1] if bounds is not None and not censored else None
        poor = None
        if bounds is not None and len(window) >= min(10, int(self.options["window"])):
            mean = (
                f"{bounds[1]:.2g}"
                if not censored
                else f"between {bounds[0]:.2g} and {bounds[1]:.2g} ({censored} censored)"
            )
            met = (
                f"the first {len(window)} worsening moves would be accepted at T0 with mean probability "
                f"{mean} ({initial:.0%} were, as it cooled)"
            )
            if bounds[1] <= low:
                poor = (
                    f"poor temperature: too low (T0={self.t0:.4g}, {self.t0_source}); {met}: "
                    "annealing degenerates into greedy descent"
                )
            elif bounds[0] >= high:
                poor = (
                    f"poor temperature: too high (T0={self.t0:.4g}, {self.t0_source}); {met}: "
                    "annealing degenerates into a random walk"
                )
        temperature = self.temperature
        return {
            "chains": self.chains,
            "budget": self.budget,
            "budget_assumed": self.budget_assumed,
            "anneal_budget": self.anneal_budget,
            "t0": self.t0,
            "t0_source": self.t0_source,
            "t_final": None if self.t0 is None else self.t0 * float(self.options["t_final_ratio"]),
            "temperature": temperature,
            "calibration_deltas": len(self.deltas),
            "steps": self.steps,
            "free_steps": self.free_steps,
            "kicks": self.kicks,
            "acceptance_rate": self.accepted / self.steps if self.steps else None,
            "uphill_acceptance_rate": self.uphill_accepted / self.uphill if self.uphill else None,
            "recent_acceptance_rate": float(np.mean(self.recent)) if self.recent else None,
            "initial_uphill_acceptance": initial,
            "initial_acceptance_at_t0": at_t0,
            "initial_acceptance_at_t0_bounds": None if bounds is None else list(bounds),
            "window_censored": censored,
            "reevaluations": self.reevaluations,
            "undecided": self.undecided,
            "poor_temperature": poor,
            "chain_values": [None if v == FAILURE else v for v in self.current_value],
        }
