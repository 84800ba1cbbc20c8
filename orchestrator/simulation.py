"""Run the lattice FMU through fmpy's low-level API: extract once, instantiate once, reset between runs.

This is the only place the orchestrator touches FMI. A failed FMI call becomes a SimulationError that
carries the FMU's own log message (the parameter it refused, the reason a solution diverged), never a
number.
"""
from __future__ import annotations

import itertools
import shutil
import tempfile
from ctypes import byref
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi1 import printLogMessage
from fmpy.fmi2 import (FMU2Slave, calloc, fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE,
                       fmi2CallbackFunctions, fmi2CallbackLoggerTYPE, free)

PEAK_OUTPUTS = ("peak_backplate_force", "peak_backplate_force_continuous", "peak_time")
ENERGY_OUTPUTS = ("kinetic_energy", "potential_energy", "external_work", "dissipated_energy",
                  "nonreciprocal_work", "energy_balance_error")
COUNTER_OUTPUTS = ("rhs_evaluations", "steps_accepted", "steps_rejected")
DIAGONAL_RULES = {"receiver": 0, "mean": 1}
SOLVERS = {"dop853": 0, "rk4": 1, "semi_implicit_euler": 2}


# FMU log messages, routed by instance name to the LatticeFMU that owns the instance. fmpy's logger proxy
# (which formats the FMU's printf-style message) keeps ONE process-wide pointer to the Python logger, so
# the callbacks must be registered once and live as long as the process: a per-instance callback would
# leave the proxy pointing at freed memory once that instance is gone (a segmentation fault later).
_MESSAGES: dict[str, list[str]] = {}
_INSTANCE_NUMBERS = itertools.count(1)


def _route_log(component, instance_name, status, category, message):
    sink = _MESSAGES.get(instance_name.decode("utf-8", errors="replace"))
    if sink is None:  # an FMU instantiated elsewhere with fmpy's default callbacks: print as fmpy would
        printLogMessage(component, instance_name, status, category, message)
    else:
        sink.append(message.decode("utf-8", errors="replace"))


_CALLBACKS = fmi2CallbackFunctions()
_CALLBACKS.logger = fmi2CallbackLoggerTYPE(_route_log)
_CALLBACKS.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
_CALLBACKS.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
try:
    from fmpy.logging import addLoggerProxy

    addLoggerProxy(byref(_CALLBACKS))
except Exception:  # pragma: no cover - without the proxy the raw format string arrives instead
    pass


class SimulationError(RuntimeError):
    """An FMI call failed; the message holds what the FMU logged."""


@dataclass
class Trajectory:
    """Outputs at every communication point of one run."""

    time: np.ndarray
    values: dict[str, np.ndarray]


class LatticeFMU:
    """One instance of the lattice FMU, reused for many runs (fmi2Reset between them)."""

    def __init__(self, fmu_path: str | Path, instance_name: str = "lattice"):
        self.fmu_path = Path(fmu_path)
        if not self.fmu_path.is_file():
            raise FileNotFoundError(f"FMU not found: {self.fmu_path} (build it with `python build_fmu.py`)")
        self.model_description = read_model_description(str(self.fmu_path))
        if self.model_description.coSimulation is None:
            raise ValueError(f"{self.fmu_path} has no co-simulation interface")
        self.variables = {v.name: v for v in self.model_description.modelVariables}
        self.columns = sum(1 for name in self.variables if name.startswith("material["))
        self._unzip_dir = extract(str(self.fmu_path), tempfile.mkdtemp(prefix="lattice_fmu_"))
        self._messages: list[str] = []
        self._name = f"{instance_name}-{next(_INSTANCE_NUMBERS)}"  # unique: the log is routed by name
        _MESSAGES[self._name] = self._messages
        self._slave = FMU2Slave(guid=self.model_description.guid, unzipDirectory=self._unzip_dir,
                                modelIdentifier=self.model_description.coSimulation.modelIdentifier,
                                instanceName=self._name)
        self._slave.instantiate(callbacks=_CALLBACKS, loggingOn=True)  # pythonfmu logs nothing without it

    def value_reference(self, name: str) -> int:
        try:
            return self.variables[name].valueReference
        except KeyError:
            raise ValueError(f"{self.fmu_path.name} has no variable {name!r}") from None

    def _set(self, name: str, value) -> None:
        variable = self.variables.get(name)
        if variable is None or variable.causality != "parameter":
            known = sorted(n for n, v in self.variables.items() if v.causality == "parameter" and "[" not in n)
            raise ValueError(f"unknown parameter {name!r}; the FMU's parameters are {known} "
                             f"and the arrays material[j], k[m], k_diag[m], c[m], alpha[m], alpha_diag[m]")
        if variable.type == "Integer":
            self._slave.setInteger([variable.valueReference], [_int32(name, value)])
        else:
            self._slave.setReal([variable.valueReference], [float(value)])

    def _read(self, names) -> dict:
        values = {}
        for name in names:
            variable = self.variables.get(name)
            if variable is None:
                raise ValueError(f"{self.fmu_path.name} has no output {name!r}")
            if variable.type == "Integer":
                values[name] = self._slave.getInteger([variable.valueReference])[0]
            else:
                values[name] = self._slave.getReal([variable.valueReference])[0]
        return values

    def simulate(self, order=None, horizon: float = 8.0, parameters: dict | None = None,
                 communication_step: float | None = None, outputs=PEAK_OUTPUTS + ENERGY_OUTPUTS,
                 record=None) -> dict:
        """One run from t = 0 to the horizon; returns the outputs at the end (and a Trajectory if asked).

        With communication_step None the FMU is advanced by a single doStep: it samples the peak itself.
        """
        self._messages.clear()
        try:
            self._slave.reset()
            self._slave.setupExperiment(startTime=0.0, stopTime=horizon)
            self._slave.enterInitializationMode()
            if order is not None:
                order = [_int32("order", m) for m in order]
                if len(order) != self.columns:
                    raise ValueError(f"order: expected {self.columns} materials (a permutation of "
                                     f"1..{self.columns}), got {len(order)}")
                self._slave.setInteger([self.value_reference(f"material[{j}]") for j in range(1, self.columns + 1)],
                                       order)
            for name, value in (parameters or {}).items():
                if name == "diagonal_rule" and isinstance(value, str):
                    value = _choice("diagonal_rule", value, DIAGONAL_RULES)
                if name == "solver" and isinstance(value, str):
                    value = _choice("solver", value, SOLVERS)
                self._set(name, value)
            self._slave.exitInitializationMode()
            trajectory = None
            if communication_step is None and record is None:
                self._slave.doStep(currentCommunicationPoint=0.0, communicationStepSize=horizon)
            else:
                step = communication_step or horizon
                count = max(1, int(round(horizon / step)))
                times = [0.0] + [min(horizon, (i + 1) * step) for i in range(count)]
                series = {name: [] for name in (record or ())}
                if record:
                    for name, value in self._read(record).items():
                        series[name].append(value)
                for start, stop in zip(times[:-1], times[1:]):
                    self._slave.doStep(currentCommunicationPoint=start, communicationStepSize=stop - start)
                    if record:
                        for name, value in self._read(record).items():
                            series[name].append(value)
                if record:
                    trajectory = Trajectory(np.array(times), {k: np.array(v) for k, v in series.items()})
            result = self._read(outputs)
        except FMICallException as exc:
            detail = "; ".join(self._messages) or "the FMU logged no reason"
            raise SimulationError(f"{exc.function} failed: {detail}") from None
        if trajectory is not None:
            result["trajectory"] = trajectory
        return result

    def close(self) -> None:
        if self._slave is not None:
            try:
                self._slave.terminate()
            except Exception:
                pass
            self._slave.freeInstance()
            self._slave = None
            _MESSAGES.pop(self._name, None)
            shutil.rmtree(self._unzip_dir, ignore_errors=True)

    def __enter__(self):
        return self

    def __exit__(self, *exc_info):
        self.close()


def _int32(name: str, value) -> int:
    """An FMI Integer: a whole number that fits in 32 bits (ctypes would wrap a wider one silently)."""
    number = int(value)
    if number != value or not -2 ** 31 <= number < 2 ** 31:
        raise ValueError(f"{name} = {value!r} is not allowed: FMI integers are whole numbers in [-2**31, 2**31 - 1]")
    return number


def _choice(name: str, value: str, allowed: dict) -> int:
    try:
        return allowed[value]
    except KeyError:
        raise ValueError(f"{name}={value!r}: allowed values are {sorted(allowed)}") from None
