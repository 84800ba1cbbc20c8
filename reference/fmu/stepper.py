"""Co-simulation stepping of a :class:`reference.lattice.Scene`, for the reference FMU.

:func:`reference.simulate.simulate` integrates a whole horizon in one call; an FMU is advanced
communication point by communication point instead.  :class:`Stepper` keeps one scipy ``DOP853``
solver alive across communication points (it steps on its own grid and the outputs at a communication
point come from the last step's dense output), so advancing to 8 s in one ``doStep`` or in 800 of
0.01 s takes exactly the same solver steps and gives the same numbers, as the C FMU promises too.

What it computes, as the C FMU does (``fmu_src/variables.py`` names):

* ``peak_backplate_force``: max of the backplate force at the samples ``k * sample_interval``;
* ``peak_backplate_force_continuous`` and ``peak_time``: the max over the continuous solution, found
  per step on the dense output (a grid, then a bounded scalar refinement);
* ``last_contact_time``: the latest time a column-C mass touched the plate (located on the dense output);
* the work integrals of docs/model.md section 7, integrated with the state, and the energies at the communication point.

The load is switched off exactly at ``t_active`` (the solver of the loaded phase ends there).  There is
no event location at the backplate's switches: the adaptive error control takes care of them, which makes
this an independent check of the C FMU's event handling.  Pure numpy/scipy.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.integrate import DOP853
from scipy.optimize import brentq, minimize_scalar

from ..lattice import Scene, energies

#: samples within this fraction of an interval past a target count as reached (8 / 0.01 gives 801)
SAMPLE_SLACK = 1e-9
#: grid per step for the continuous peak and the contact search
FINE_POINTS = 16
#: kinetic energy beyond this many times the work put in means the solution diverged (as the C FMU)
ENERGY_LIMIT_FACTOR = 1e3
#: DOP853 evaluations: 12 per attempted step, 3 more for a dense output, 2 to start (f(t0) and the first
#: step's estimate)
STAGES, DENSE_STAGES = 12, 3
#: an accepted step shorter than this (times max(1, t)), not cut by a phase end, means the step size collapsed;
#: scipy itself gives up only at 10 ulp, after minutes of numpy evaluations
MIN_STEP = 1e-12


class SimulationDiverged(RuntimeError):
    """The solution left the physics (non-finite, energy far beyond the work put in, step size collapsed)."""


class Stepper:
    """Advance one scene from rest at ``start_time`` to successive communication points."""

    def __init__(
        self,
        scene: Scene,
        rtol: float,
        atol: float,
        sample_interval: float = 0.01,
        start_time: float = 0.0,
        stop_time: float | None = None,
    ):
        if not isinstance(scene, Scene):
            raise ValueError(f"Stepper: scene must be a reference.Scene, got {type(scene).__name__}")
        for name, value in (("rtol", rtol), ("atol", atol), ("sample_interval", sample_interval)):
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"Stepper: {name} must be a positive finite number, got {value!r}")
        if not (math.isfinite(start_time) and start_time >= 0):
            raise ValueError(f"Stepper: start_time must be >= 0 (the load starts at t = 0), got {start_time!r}")
        self.scene = scene
        self.model = scene.model
        self.N = self.model.N
        self.n = 4 * self.N
        self.rtol, self.atol = float(rtol), float(atol)
        self.sample_interval = float(sample_interval)
        self.stop_time = math.inf if stop_time is None else float(stop_time)
        wall = self.model.wall_idx
        self._ux_rows, self._vx_rows = wall, 2 * self.N + wall

        self.time = float(start_time)  # the last communication point
        self.load_on = self.time < scene.t_active
        self.solver = None
        self.dense = None  # dense output of the last accepted step
        self.t_old = self.t_new = self.time
        self.z = np.zeros(self.n + 3)  # state and (W_ext, D, W_nr) at t_new
        # the start state's potential energy counts as energy put in (a negative gap presses from t = 0)
        self.initial_energy = energies(scene, self.z[: self.n])[1]
        self.h_last = None
        self.rhs_evaluations = 0
        self.steps_accepted = 0
        self.steps_rejected = 0
        self._solver_nfev = 0
        self._solver_attempts = 0

        self.next_sample = int(math.ceil(self.time / self.sample_interval - SAMPLE_SLACK))
        self.peak_sampled = -math.inf
        self.max_compression = -math.inf
        self.peak_continuous, self.peak_time = -math.inf, math.nan
        self._step_peak = None  # (value, time) of the last step, once computed
        self._step_committed = True
        self.last_contact_time = 0.0
        self._process_samples(self.time)
        self._new_solver()

    # ------------------------------------------------------------------ physics of one evaluation
    def _fun(self, load_on: bool):
        model, n = self.model, self.n

        def fun(t, zz):
            dydt, (pe, pd, pn) = model.evaluate(zz[:n], load_on, True)
            out = np.empty(n + 3)
            out[:n] = dydt
            out[n], out[n + 1], out[n + 2] = pe, pd, pn
            return out

        return fun

    def backplate_force(self, z: np.ndarray) -> np.ndarray | float:
        """Backplate force of state(s) z: shape (>= 4N,) or (>= 4N, M)."""
        if not self.scene.wall:
            return np.zeros(z.shape[1:]) if z.ndim > 1 else 0.0
        sc = self.scene
        p = z[self._ux_rows] - sc.backplate_gap
        f = np.where(p > 0, sc.k_wall * p + sc.c_wall * np.maximum(z[self._vx_rows], 0.0), 0.0)
        return f.sum(axis=0)

    def compression(self, z: np.ndarray) -> float:
        """Mean ux of column 1 minus mean ux of column C (docs/model.md section 9)."""
        first = np.arange(self.scene.rows) * self.scene.cols
        return float(z[first].mean() - z[first + self.scene.cols - 1].mean())

    def _penetration(self, z: np.ndarray):
        """Largest penetration of the column-C masses (positive: in contact)."""
        return (z[self._ux_rows] - self.scene.backplate_gap).max(axis=0)

    # ------------------------------------------------------------------ solver bookkeeping
    def _count_solver(self) -> None:
        """Fold the live solver's evaluation count into the totals (called before it is replaced)."""
        if self.solver is None:
            return
        self.rhs_evaluations += self.solver.nfev - self._solver_nfev
        self._solver_nfev = self.solver.nfev

    def _new_solver(self) -> None:
        self._count_solver()
        t_bound = self.scene.t_active if self.load_on else self.stop_time
        t_bound = min(t_bound, self.stop_time)
        if not t_bound > self.t_new:
            self.solver = None
            return
        first = None
        if self.h_last is not None:
            first = min(self.h_last, t_bound - self.t_new)
        self.solver = DOP853(
            self._fun(self.load_on),
            self.t_new,
            self.z.copy(),
            t_bound,
            rtol=self.rtol,
            atol=self.atol,
            first_step=first,
        )
        self._solver_nfev = 0
        self._solver_start_evals = 1 + (first is None)
        self._solver_dense = 0
        self._solver_attempts = 0

    def _take_step(self) -> None:
        s = self.solver
        if s is None or s.status != "running":
            raise SimulationDiverged(
                f"cannot step past t = {self.t_new:.17g}: beyond the stop time {self.stop_time:.17g} given at setup"
            )
        nfev_before = s.nfev
        message = s.step()
        if s.status == "failed":
            raise SimulationDiverged(
                f"the solution diverged at t = {s.t:.9g} s: scipy DOP853 failed ({message}; rtol = {self.rtol:g})"
            )
        step = s.t - s.t_old
        if step < MIN_STEP * max(1.0, abs(s.t)) and s.t < s.t_bound:
            raise SimulationDiverged(
                f"the solution diverged at t = {s.t:.9g} s: step size collapsed to {step:g} s "
                f"(the solution is diverging or too stiff for rtol = {self.rtol:g}, "
                f"atol = {self.atol:g})"
            )
        attempts = (s.nfev - nfev_before) // STAGES
        self.steps_accepted += 1
        self.steps_rejected += max(0, attempts - 1)
        self.t_old, self.t_new = s.t_old, s.t
        self.h_last = s.t - s.t_old
        self.z = s.y.copy()
        self.dense = s.dense_output()
        self._count_solver()
        self._step_peak = None
        self._step_committed = False
        if not np.all(np.isfinite(self.z)):
            raise SimulationDiverged(
                f"the solution diverged at t = {self.t_new:.9g} s: the state is not finite (rtol = {self.rtol:g})"
            )
        self._check_energy()
        self._track_contact()
        if self.load_on and s.status == "finished" and self.t_new >= self.scene.t_active:
            self.load_on = False
            self._new_solver()

    def _check_energy(self) -> None:
        n = self.n
        v = self.z[2 * self.N : n]
        kinetic = 0.5 * self.scene.mass * float(v @ v)
        injected = self.initial_energy + abs(self.z[n]) + abs(self.z[n + 2])
        impulse = abs(self.scene.F_total) * max(self.scene.t_active, self.sample_interval)
        floor = 1e-9 + 1e-6 * impulse * impulse / self.scene.mass
        if not (math.isfinite(kinetic) and kinetic <= ENERGY_LIMIT_FACTOR * injected + floor):
            raise SimulationDiverged(
                f"the solution diverged at t = {self.t_new:.9g} s: kinetic energy "
                f"{kinetic:g} J against {injected:g} J of energy put in (rtol = {self.rtol:g})"
            )

    def _track_contact(self) -> None:
        if not self.scene.wall:
            return
        if self._penetration(self.z) > 0:
            self.last_contact_time = self.t_new
            return
        grid = np.linspace(self.t_old, self.t_new, FINE_POINTS + 1)
        pen = self._penetration(self.dense(grid))
        inside = np.flatnonzero(pen[:-1] > 0)
        if inside.size == 0:
            return
        k = int(inside[-1])  # contact at grid[k], none at grid[k + 1]: the contact ends in between
        f = lambda t: float(self._penetration(self.dense(t)))  # noqa: E731
        try:
            end = brentq(f, grid[k], grid[k + 1], xtol=1e-14, rtol=4 * np.finfo(float).eps)
        except ValueError:
            end = grid[k]
        self.last_contact_time = max(self.last_contact_time, end)

    # ------------------------------------------------------------------ peaks
    def _max_on(self, a: float, b: float) -> tuple[float, float]:
        """Max of the backplate force on [a, b] within the last step (grid, then bounded refinement)."""
        if not b > a:
            t = np.array(b)
            return float(self.backplate_force(self.dense(t))), float(b)
        grid = np.linspace(a, b, FINE_POINTS + 1)
        values = self.backplate_force(self.dense(grid))
        i = int(np.argmax(values))
        best, best_t = float(values[i]), float(grid[i])
        if best > 0:
            lo, hi = grid[max(i - 1, 0)], grid[min(i + 1, FINE_POINTS)]
            res = minimize_scalar(
                lambda t: -float(self.backplate_force(self.dense(t))),
                bounds=(lo, hi),
                method="bounded",
                options={"xatol": 1e-13 * max(1.0, hi)},
            )
            if -res.fun > best:
                best, best_t = float(-res.fun), float(res.x)
        return best, best_t

    def _commit(self, value: float, time: float) -> None:
        if value > self.peak_continuous:
            self.peak_continuous, self.peak_time = value, time

    def _process_samples(self, t_target: float) -> None:
        """Samples up to min(t_target, t_new) (the state at a sample comes from the step's dense output)."""
        limit = min(self.t_new, t_target + SAMPLE_SLACK * self.sample_interval)
        while True:
            ts = self.next_sample * self.sample_interval
            if ts > limit:
                break
            if self.dense is None:
                z = self.z
            else:
                z = self.dense(min(max(ts, self.t_old), self.t_new))
            force = float(self.backplate_force(z))
            self.peak_sampled = max(self.peak_sampled, force)
            self.max_compression = max(self.max_compression, self.compression(z))
            self._commit(force, ts)
            self.next_sample += 1

    def _process_step(self, t_target: float) -> None:
        self._process_samples(t_target)
        if self.dense is None or self._step_committed:
            return
        if self._step_peak is None:
            self._step_peak = self._max_on(self.t_old, self.t_new)
        if self.t_new <= t_target:
            self._commit(*self._step_peak)
            self._step_committed = True

    # ------------------------------------------------------------------ the communication step
    def advance(self, t_target: float) -> None:
        """Advance the outputs to ``t_target`` (the solver may step past it, as it pleases)."""
        if not (t_target >= self.time):
            raise ValueError(f"cannot step back from t = {self.time:.17g} to t = {t_target:.17g}")
        if t_target > self.stop_time:
            raise ValueError(f"t = {t_target:.17g} is beyond the stop time {self.stop_time:.17g} given at setup")
        self._process_step(t_target)
        while self.t_new < t_target:
            self._take_step()
            self._process_step(t_target)
        self.time = float(t_target)

    # ------------------------------------------------------------------ outputs at the communication point
    def state_at(self, t: float) -> np.ndarray:
        if self.dense is None or t >= self.t_new:
            return self.z.copy()
        return np.asarray(self.dense(max(t, self.t_old)), dtype=float)

    def outputs(self) -> dict:
        """Every output of the FMU at the last communication point."""
        t = self.time
        z = self.state_at(t)
        n, N = self.n, self.N
        peak, peak_time = self.peak_continuous, self.peak_time
        if self.dense is not None and not self._step_committed:
            partial, partial_time = self._step_peak if self._step_peak is not None else (-math.inf, math.nan)
            if not partial_time <= t:
                partial, partial_time = self._max_on(self.t_old, min(max(t, self.t_old), self.t_new))
            if partial > peak:
                peak, peak_time = partial, partial_time
        kinetic, potential = energies(self.scene, z[:n])
        w_ext, diss, w_nr = (float(x) for x in z[n:])
        sc = self.scene
        mid_row, mid_col = (sc.rows + 1) // 2, (sc.cols + 1) // 2
        places = {
            "corner": (1, 1),
            "left_edge": (mid_row, 1),
            "centre": (mid_row, mid_col),
            "right_edge": (mid_row, sc.cols),
        }
        out = {
            "backplate_force": float(self.backplate_force(z)),
            "peak_backplate_force": self.peak_sampled if math.isfinite(self.peak_sampled) else 0.0,
            "max_compression": self.max_compression if math.isfinite(self.max_compression) else 0.0,
            "peak_backplate_force_continuous": peak if math.isfinite(peak) else 0.0,
            "peak_time": peak_time if math.isfinite(peak_time) else 0.0,
            "last_contact_time": min(self.last_contact_time, t),
            "kinetic_energy": kinetic,
            "potential_energy": potential,
            "external_work": w_ext,
            "dissipated_energy": diss,
            "nonreciprocal_work": w_nr,
            "energy_balance_error": w_ext + w_nr - kinetic - potential - diss,
            "rhs_evaluations": int(self.rhs_evaluations),
            "steps_accepted": int(self.steps_accepted),
            "steps_rejected": int(self.steps_rejected),
        }
        for place, (row, col) in places.items():
            m = sc.index(row, col)
            out[f"ux_{place}"] = float(z[m])
            out[f"uy_{place}"] = float(z[N + m])
        return out
