"""A Model Exchange importer that loses events the way some do, to test the FMU's defences against it.

It integrates with SciPy's DOP853 stepper, checks the event indicators after every step, locates a sign change
on the step's dense output (Brent's method) and handles it in event mode, stops on an output grid as fmpy
does, and restarts the integrator after every event and grid point. Optionally it loses events as OMSimulator
3 was seen to (issue mechanism: mirror-image rows reach the plate within rounding of each other):

- `zero_restart`: at an event, every other indicator within `snap` of zero is made exactly zero (as a root
  finder that stops on it does), and at the restart an indicator that is exactly zero is inactive until it
  moves away from zero, and that move is never reported as a root;
- `honour_enter_event_mode` False: `enterEventMode` from fmi2CompletedIntegratorStep is ignored.

`drop_root` makes it lose one located root entirely (the sign change is seen and ignored), the harshest case.
"""

from __future__ import annotations

import ctypes
import shutil
from dataclasses import dataclass, field

import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Model
from scipy.integrate import DOP853
from scipy.optimize import brentq

from orchestrator.simulation import _CALLBACKS, _MESSAGES


@dataclass(frozen=True)
class LossyRun:
    """What the importer saw: the backplate force on its output grid and the FMU's outputs at the end."""

    time: np.ndarray
    backplate_force: np.ndarray
    outputs: dict
    events: int
    zeroed: int  # indicators the importer restarted on exactly zero (and so never saw leave zero)
    requests: int  # completed steps that answered enterEventMode = true
    ignored_requests: int  # ... and those of them the importer ignored
    messages: tuple[str, ...] = field(default=())

    @property
    def grid_peak(self) -> float:
        return float(self.backplate_force.max())


def _pointer(array):
    return array.ctypes.data_as(ctypes.POINTER(ctypes.c_double))


class _Instance:
    def __init__(self, fmu_path, name):
        self.description = read_model_description(str(fmu_path))
        self.variables = {v.name: v for v in self.description.modelVariables}
        self.unzip_dir = extract(str(fmu_path))
        self.name, self.messages = name, []
        _MESSAGES[name] = self.messages
        self.fmu = FMU2Model(
            guid=self.description.guid,
            unzipDirectory=self.unzip_dir,
            modelIdentifier=self.description.modelExchange.modelIdentifier,
            instanceName=name,
        )
        self.fmu.instantiate(callbacks=_CALLBACKS, loggingOn=True)
        self.nx = self.description.numberOfContinuousStates
        self.nz = self.description.numberOfEventIndicators
        self.x, self.dx, self.z = np.zeros(self.nx), np.zeros(self.nx), np.zeros(self.nz)

    def vr(self, name):
        return self.variables[name].valueReference

    def set(self, t, x):
        self.fmu.setTime(t)
        self.x[:] = x
        self.fmu.setContinuousStates(_pointer(self.x), self.nx)

    def derivatives(self, t, x):
        self.set(t, x)
        self.fmu.getDerivatives(_pointer(self.dx), self.nx)
        return self.dx.copy()

    def indicators(self, t, x):
        self.set(t, x)
        self.fmu.getEventIndicators(_pointer(self.z), self.nz)
        return self.z.copy()

    def close(self):
        self.fmu.freeInstance()
        _MESSAGES.pop(self.name, None)
        shutil.rmtree(self.unzip_dir, ignore_errors=True)


def simulate_lossy(
    fmu_path,
    order,
    horizon=1.0,
    rtol=1e-9,
    atol=1e-11,
    output_interval=0.01,
    zero_restart=True,
    honour_enter_event_mode=False,
    snap=1e-12,
    drop_root=None,
    name="lossy-importer",
) -> LossyRun:
    """Model Exchange of the FMU at `fmu_path` with `order` (FMI 2), through this importer; `drop_root` is the
    number (1-based) of a located root to ignore."""
    me = _Instance(fmu_path, name)
    rows = me.nz // 2
    cols = sum(1 for v in me.description.modelVariables if v.name.startswith("material["))
    masses = (me.nx - 3) // 4
    gap = float(me.variables["backplate_gap"].start)
    force_vr = [me.vr("backplate_force")]
    try:
        me.fmu.setupExperiment(startTime=0.0, stopTime=horizon)
        me.fmu.enterInitializationMode()
        me.fmu.setInteger([me.vr(f"material[{j}]") for j in range(1, cols + 1)], list(order))
        me.fmu.exitInitializationMode()
        _, _, _, _, next_defined, next_time = me.fmu.newDiscreteStates()
        next_event = next_time if next_defined else np.inf
        me.fmu.enterContinuousTimeMode()
        x = np.zeros(me.nx)
        me.fmu.getContinuousStates(_pointer(x), me.nx)
        t, events, roots, zeroed, requests, ignored = 0.0, 0, 0, 0, 0, 0
        grid = [k * output_interval for k in range(int(round(horizon / output_interval)) + 1)]
        times, forces = [0.0], [me.fmu.getReal(force_vr)[0]]

        def component(k, z):
            """The state component indicator k is made of: ux of the row's column-C mass, or its vx."""
            row = k % rows
            mass = row * cols + cols - 1
            free = k < rows or z[k] == z[k - rows]  # off the plate the damping indicator repeats the contact one
            return (mass, gap) if free else (2 * masses + mass, 0.0)

        def event_mode(t_event, x_event):
            nonlocal next_event, events
            me.set(t_event, x_event)
            me.fmu.enterEventMode()
            _, _, _, _, defined, when = me.fmu.newDiscreteStates()
            next_event = when if defined else np.inf
            me.fmu.enterContinuousTimeMode()
            events += 1

        for t_out in grid[1:]:
            while t < t_out:
                t_bound = min(t_out, next_event)
                z_old = me.indicators(t, x)
                active = z_old != 0.0 if zero_restart else np.ones(me.nz, bool)
                solver = DOP853(me.derivatives, t, x, t_bound, rtol=rtol, atol=atol)
                while True:
                    solver.step()
                    if solver.status == "failed":
                        raise RuntimeError(f"DOP853 failed at t = {solver.t}")
                    z_new = me.indicators(solver.t, solver.y)
                    changed = active & ((z_old > 0) != (z_new > 0))
                    newly_active = ~active & (z_new != 0.0)  # moved away from zero: no root reported
                    active |= newly_active
                    z_old = np.where(newly_active, z_new, z_old)
                    event = None
                    if changed.any():
                        dense = solver.dense_output()
                        crossings = []
                        for k in np.flatnonzero(changed):

                            def g(s, k=k):
                                return me.indicators(s, dense(s))[k]

                            low, high = solver.t_old, solver.t
                            if (g(low) > 0) == (z_new[k] > 0):
                                continue  # not a crossing inside this step (the mode it depends on switched)
                            root = brentq(g, low, high, xtol=1e-15, rtol=4 * np.finfo(float).eps)
                            while (g(root) > 0) != (z_new[k] > 0) and root < high:  # the new sign, as CVODE
                                root = np.nextafter(root, high)
                            crossings.append((root, k))
                        if crossings:
                            roots += 1
                            if drop_root != roots:  # else seen and ignored
                                event = min(crossings)
                    if event is not None:
                        root, k = event
                        x_event = dense(root)
                        if zero_restart:
                            z_event = me.indicators(root, x_event)
                            for j in np.flatnonzero(np.abs(z_event) <= snap):
                                if j != k:
                                    index, threshold = component(j, z_event)
                                    x_event[index] = threshold  # exactly on the threshold: the indicator is 0
                                    zeroed += 1
                        t, x = root, x_event
                        me.set(t, x)
                        me.fmu.completedIntegratorStep()
                        event_mode(t, x)
                        break
                    z_old = z_new
                    me.set(solver.t, solver.y)
                    enter, _ = me.fmu.completedIntegratorStep()
                    t, x = solver.t, solver.y.copy()
                    requests += bool(enter)
                    if enter and honour_enter_event_mode:
                        event_mode(t, x)
                        break
                    ignored += bool(enter)
                    if solver.status == "finished":
                        if t >= next_event:
                            event_mode(t, x)
                        break
            times.append(t)
            forces.append(me.fmu.getReal(force_vr)[0])
        outputs = [v for v in me.description.modelVariables if v.causality == "output"]
        reals = [v for v in outputs if v.type == "Real"]
        values = dict(zip((v.name for v in reals), me.fmu.getReal([v.valueReference for v in reals])))
        return LossyRun(
            np.array(times), np.array(forces), values, events, zeroed, requests, ignored, tuple(me.messages)
        )
    finally:
        me.close()
