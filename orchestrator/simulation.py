"""Run the lattice FMU through fmpy's low-level API: extract once, instantiate once, reset between runs.

This is the only place the orchestrator touches FMI. A failed FMI call becomes a SimulationError that
carries the FMU's own log message (the parameter it refused, the reason a solution diverged), never a
number.
"""

from __future__ import annotations

import functools
import itertools
import math
import numbers
import os
import re
import shutil
import tempfile
import zipfile
from ctypes import POINTER, byref, c_double, c_int, c_size_t, c_uint, c_void_p
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any, Mapping
from xml.etree import ElementTree

import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi1 import printLogMessage
from fmpy.fmi2 import (
    FMU2Slave,
    calloc,
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
    fmi2Discard,
    fmi2LastSuccessfulTime,
    fmi2Terminated,
    fmi2Warning,
    free,
)

from .types import NamedOutputs

PEAK_OUTPUTS = ("peak_backplate_force", "peak_backplate_force_continuous", "peak_time")
ENERGY_OUTPUTS = (
    "kinetic_energy",
    "potential_energy",
    "external_work",
    "dissipated_energy",
    "nonreciprocal_work",
    "energy_balance_error",
)
COUNTER_OUTPUTS = ("rhs_evaluations", "steps_accepted", "steps_rejected")


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


@functools.lru_cache(maxsize=16)
def _read_description(path: str, modified_ns: int, size: int):
    return read_model_description(path)


def model_description(fmu_path: str | Path):
    """The FMU's model description, read once per file version (the CLI's checks, the study, every
    instance in a process read the same file)."""
    status = os.stat(fmu_path)
    return _read_description(str(fmu_path), status.st_mtime_ns, status.st_size)


def enumeration_items(description, name: str) -> dict[str, int]:
    """The item names and codes the FMU declares for the enumeration parameter ``name`` ({} when it has none):
    the one place names such as ``mean`` or ``rkn5`` are turned into the codes the FMU takes. FMI 3 declares the
    parameter an Enumeration; FMI 2 declares it an Integer (which every importer sets) and names the items in the
    declared type of the Enumeration alias that shares its value reference."""
    variables = description.modelVariables
    variable = next((v for v in variables if v.name == name), None)
    if variable is not None and variable.type != "Enumeration":
        variable = next(
            (v for v in variables if v.type == "Enumeration" and v.valueReference == variable.valueReference), None
        )
    declared = getattr(variable, "declaredType", None)
    return {item.name: int(item.value) for item in (getattr(declared, "items", None) or [])}


def declared_outputs(description) -> tuple[str, ...]:
    """The names of the outputs the model description declares, in its order."""
    return tuple(v.name for v in description.modelVariables if v.causality == "output")


def material_columns(description) -> int:
    """How many columns (material[j] parameters; FMI 3: the length of the array material) the FMU's lattice has."""
    lengths = array_lengths(description)
    if "material" in lengths:
        return lengths["material"]
    return sum(1 for v in description.modelVariables if v.name.startswith("material["))


def array_lengths(description) -> dict[str, int]:
    """The FMI 3 arrays the model description declares (the parameter arrays material, k, ..., mass), by name,
    with their lengths; {} for FMI 2, which declares each element a scalar `name[i]`."""
    return {
        v.name: int(np.prod(v.shape))
        for v in description.modelVariables
        if getattr(v, "dimensions", None) and getattr(v, "shape", None)
    }


def start_values(description, parameters: Mapping[str, Any]) -> dict[str, Any]:
    """``parameters`` by FMI 2's names (``material[3]``, ``k[2]``: what answers[i].parameters and the console
    give) as the start values of the FMU of ``description``, for fmpy.simulate_fmu or any importer: for FMI 2
    the same; for FMI 3 each array's elements gathered into the array (``{"material": [3, 1, 2]}``), the elements
    not given keeping the array's start. A whole array may be given by its name too, but not with its
    elements."""
    lengths = array_lengths(description)
    if not lengths:
        return dict(parameters)
    declared = declared_parameters(description)
    values: dict[str, Any] = {}
    elements: dict[str, list] = {}
    for name, value in parameters.items():
        base, bracket, rest = name.partition("[")
        if not bracket or base not in lengths:
            values[name] = value
            continue
        if name not in declared:
            raise ValueError(f"{name} is no element of the array {base}: allowed {base}[1] ... {base}[{lengths[base]}]")
        if base not in elements:
            elements[base] = [declared[f"{base}[{i}]"].start for i in range(1, lengths[base] + 1)]
        elements[base][int(rest[:-1]) - 1] = value
    for base, array in elements.items():
        if base in values:
            raise ValueError(f"{base} is given both as an array and by its elements: give one")
        values[base] = array
    return values


def declared_lattice_size(fmu_path: str | Path) -> tuple[int, int, int] | None:
    """(rows, columns, depth) as the FMU's model description declares them (the builder writes them under the
    tool or annotation ``scenes.SIZE_ANNOTATION``; None when it declares none): what an FMU given on its own says
    of its lattice, whatever scene it is used with."""
    status = os.stat(fmu_path)
    return _declared_size(str(fmu_path), status.st_mtime_ns, status.st_size)


@functools.lru_cache(maxsize=64)
def _declared_size(fmu_path: str, mtime_ns: int, size: int) -> tuple[int, int, int] | None:
    from scenes import SIZE_ANNOTATION

    with zipfile.ZipFile(fmu_path) as archive:
        root = ElementTree.fromstring(archive.read("modelDescription.xml"))
    for holder in (
        *root.findall(f"VendorAnnotations/Tool[@name='{SIZE_ANNOTATION}']"),
        *root.findall(f"Annotations/Annotation[@type='{SIZE_ANNOTATION}']"),
    ):
        lattice = holder.find("Lattice")
        if lattice is not None:
            try:
                return int(lattice.get("rows", "")), int(lattice.get("columns", "")), int(lattice.get("depth", ""))
            except ValueError:
                return None
        text = re.fullmatch(r"\s*rows=(\d+) columns=(\d+) depth=(\d+)\s*", holder.text or "")
        if text:  # FMI 3 declares it as the annotation's text
            return int(text[1]), int(text[2]), int(text[3])
    return None


REAL_TYPES = ("Real", "Float64", "Float32")
WHOLE_NUMBER_TYPES = (
    "Integer",
    "Enumeration",
    "Boolean",
    "Int8",
    "UInt8",
    "Int16",
    "UInt16",
    "Int32",
    "UInt32",
    "Int64",
    "UInt64",
)


@dataclass(frozen=True)
class Parameter:
    """One scalar parameter (or array element) as the model description declares it: its type, range and an
    enumeration's items. ``value`` is the one check of a value for it, wherever the value comes from (the
    command line, a scene or study file, a design file, Python)."""

    name: str
    type: str  # the model description's: Real, Integer, Enumeration, Boolean (FMI 3: Float64, Int32 ...)
    start: Any
    minimum: float | None
    maximum: float | None
    unit: str | None
    description: str
    items: dict[str, int] = field(default_factory=dict)  # an enumeration's names and codes

    @property
    def whole(self) -> bool:
        return self.type in WHOLE_NUMBER_TYPES

    def allowed(self) -> str:
        if self.items:
            return ", ".join(self.items)
        low = "-inf" if self.minimum is None else f"{self.minimum:g}"
        high = "inf" if self.maximum is None else f"{self.maximum:g}"
        kind = "an integer" if self.whole else "a finite number"
        return f"{kind} in [{low}, {high}]"

    def value(self, given: Any, where: str = "") -> float | int:
        """``given`` as the FMU takes it (a number; an enumeration's code, given by its item name or code), or a
        one-line ValueError naming the parameter (after ``where``: the option, the file) and what it allows."""
        name = f"{where}{self.name}"
        if self.whole:
            if isinstance(given, str) and given.strip() in self.items:
                return self.items[given.strip()]
            number: float | None = _whole_number(given)
            if number is None:
                if self.items:
                    raise ValueError(f"{name} = {given!r} is not allowed: allowed values are {sorted(self.items)}")
                raise ValueError(f"{name} = {given!r} is not an integer: allowed values are {self.allowed()}")
            if self.items and number not in self.items.values():
                codes = ", ".join(f"{code} ({item})" for item, code in sorted(self.items.items(), key=lambda e: e[1]))
                raise ValueError(f"{name} = {number} is not allowed: allowed values are {codes}")
            low: float | None = None if self.minimum is None else int(self.minimum)
            high: float | None = None if self.maximum is None else int(self.maximum)
            if (low is not None and number < low) or (high is not None and number > high):
                raise ValueError(
                    f"{name} = {number} is outside its range [{'-inf' if low is None else low}, "
                    f"{'inf' if high is None else high}]"
                )
            return number
        number = _real_number(given)
        if number is None:
            raise ValueError(f"{name} = {given!r} is not a number: allowed values are {self.allowed()}")
        if not math.isfinite(number):
            raise ValueError(f"{name} = {given!r} is not allowed: give {self.allowed()}")
        low, high = self.minimum, self.maximum
        if (low is not None and number < low) or (high is not None and number > high):
            raise ValueError(
                f"{name} = {number!r} is outside its range [{'-inf' if low is None else repr(low)}, "
                f"{'inf' if high is None else repr(high)}]"
            )
        return number

    def convert(self, text: Any, option: str) -> Any:
        """``text`` of ``option`` (the command line, a scene or study file) as this parameter's value: an
        enumeration by its item name, a number otherwise."""
        value = self.value(text, f"{option} ")
        if self.items:
            return next(item for item, code in self.items.items() if code == value)
        return value


def _whole_number(given: Any) -> int | None:
    if isinstance(given, bool):
        return None
    if isinstance(given, numbers.Integral):
        return int(given)
    if isinstance(given, str):
        text = given.strip()
        try:
            return int(text, 10)
        except ValueError:
            given = _real_number(text)
    if isinstance(given, numbers.Real) and math.isfinite(given) and float(given).is_integer():
        return int(float(given))
    return None


def _real_number(given: Any) -> float | None:
    if isinstance(given, bool) or not isinstance(given, (str, numbers.Real)):
        return None
    try:
        return float(given)
    except ValueError:
        return None


def _bound(variable, attribute: str) -> float | None:
    text = getattr(variable, attribute, None)
    if text in (None, "") and getattr(variable, "declaredType", None) is not None:
        text = getattr(variable.declaredType, attribute, None)
    return None if text in (None, "") else float(text)


@functools.lru_cache(maxsize=16)
def declared_parameters(description) -> Mapping[str, Parameter]:
    """Every parameter the model description declares (array elements too), as the one typed Parameter; read
    once per model description."""
    parameters = {}
    lengths = array_lengths(description)
    for variable in description.modelVariables:
        if variable.causality != "parameter":
            continue
        items = enumeration_items(description, variable.name)
        if variable.name in lengths:  # an FMI 3 array: its elements by FMI 2's names, each with its start
            texts = str(variable.start).split() if variable.start is not None else [None] * lengths[variable.name]
            elements = [(f"{variable.name}[{i}]", text) for i, text in enumerate(texts, start=1)]
        else:
            elements = [(variable.name, variable.start)]
        for name, text in elements:
            start: str | float | int | None = text
            if items:
                start = next((n for n, c in items.items() if str(c) == str(text)), text)
            elif variable.type in REAL_TYPES and text is not None:
                start = float(text)
            elif variable.type in WHOLE_NUMBER_TYPES and variable.type != "Boolean" and text is not None:
                start = int(text)
            elif variable.type == "Boolean" and text is not None:
                start = int(str(text).lower() in ("1", "true"))
            parameters[name] = Parameter(
                name,
                variable.type,
                start,
                _bound(variable, "min"),
                _bound(variable, "max"),
                getattr(variable, "unit", None),
                variable.description or "",
                items,
            )
    return MappingProxyType(parameters)


class SimulationError(RuntimeError):
    """An FMI call failed; the message holds what the FMU logged."""


@dataclass(frozen=True)
class RecordedSamples:
    """Outputs at every communication point of one run, as the FMU returned them (``objective.Trajectory`` is
    the study's record of them)."""

    time: np.ndarray
    values: dict[str, np.ndarray]


@dataclass(frozen=True)
class SimulationResult(NamedOutputs):
    """One run: its outputs at the end by the names the FMU's model description declares (``result[name]``,
    as FMPy's simulation result is indexed), the time it ended, and the trajectory when one was recorded.

    ``stopped_early``: a peak_force_limit stopped the run at ``stop_time`` (fmi2Discard, fmi2Terminated), so
    its outputs are the FMU's at that time and peak_backplate_force only the peak so far (above the limit).
    """

    values: dict[str, float | int]
    stop_time: float
    stopped_early: bool = False
    trajectory: RecordedSamples | None = None


class LatticeFMU:
    """One instance of the lattice FMU, reused for many runs (fmi2Reset between them).

    A run costs a fixed number of FMI calls whatever it sets and reads: the order and the integer parameters
    in one fmi2SetInteger, the real parameters in one fmi2SetReal, the outputs in one fmi2GetReal and one
    fmi2GetInteger. Value references are resolved once per set of names and the ctypes arrays kept; the calls
    FMPy has no such form of are made through ctypes (``_DirectCalls``), every other one through FMPy.
    """

    def __init__(self, fmu_path: str | Path, instance_name: str = "lattice"):
        self.fmu_path = Path(fmu_path)
        if not self.fmu_path.is_file():
            raise FileNotFoundError(f"FMU not found: {self.fmu_path} (build it with `python build_fmu.py`)")
        self.model_description = model_description(self.fmu_path)
        if self.model_description.coSimulation is None:
            raise ValueError(f"{self.fmu_path} has no co-simulation interface")
        self.variables = {v.name: v for v in self.model_description.modelVariables}
        self.columns = material_columns(self.model_description)
        self.outputs = declared_outputs(self.model_description)
        self._material_references = [self.value_reference(f"material[{j}]") for j in range(1, self.columns + 1)]
        self._unzip_dir = extract(str(self.fmu_path), tempfile.mkdtemp(prefix="lattice_fmu_"))
        self._messages: list[str] = []
        self._name = f"{instance_name}-{next(_INSTANCE_NUMBERS)}"  # unique: the log is routed by name
        _MESSAGES[self._name] = self._messages
        self._slave = None
        try:
            self._slave = FMU2Slave(
                guid=self.model_description.guid,
                unzipDirectory=self._unzip_dir,
                modelIdentifier=self.model_description.coSimulation.modelIdentifier,
                instanceName=self._name,
            )
            self._slave.instantiate(callbacks=_CALLBACKS, loggingOn=True)  # pythonfmu logs nothing without it
        except Exception as exc:  # noqa: BLE001 - the FMU's own reason, in one line
            reason = "; ".join(self._messages) or str(exc) or type(exc).__name__
            _MESSAGES.pop(self._name, None)
            shutil.rmtree(self._unzip_dir, ignore_errors=True)
            raise SimulationError(f"{self.fmu_path.name} cannot be instantiated: {reason}") from None
        self._declared = declared_parameters(self.model_description)
        self._api = _DirectCalls(self._slave)
        self._setters: dict[tuple, _Setter] = {}
        self._readers: dict[tuple, _Reader] = {}

    def value_reference(self, name: str) -> int:
        try:
            return self.variables[name].valueReference
        except KeyError:
            raise ValueError(f"{self.fmu_path.name} has no variable {name!r}") from None

    def _parameter(self, name: str):
        variable = self.variables.get(name)
        if variable is None or variable.causality != "parameter":
            known = sorted(n for n, v in self.variables.items() if v.causality == "parameter" and "[" not in n)
            raise ValueError(
                f"unknown parameter {name!r}; the FMU's parameters are {known} "
                f"and the arrays material[j], k[m], k_diag[m], c[m], alpha[m], alpha_diag[m], mass[m], "
                f"damping_exponent[m]"
            )
        return variable

    def _setter(self, with_order: bool, names: tuple) -> "_Setter":
        """The value-reference arrays for setting the order (if given) and these parameters, made once."""
        key = (with_order, names)
        setter = self._setters.get(key)
        if setter is None:
            integers: list[tuple[int, int]] = []
            reals: list[tuple[int, int]] = []
            for index, name in enumerate(names):
                variable = self._parameter(name)
                (integers if variable.type in INTEGER_TYPES else reals).append((index, variable.valueReference))
            named_integers = [(index, vr, names[index]) for index, vr in integers]
            setter = self._setters[key] = _Setter(
                self._material_references if with_order else [], named_integers, reals
            )
        return setter

    def _reader(self, names: tuple) -> "_Reader":
        """The value-reference arrays and value buffers for reading these outputs, made once."""
        reader = self._readers.get(names)
        if reader is None:
            integers: list[tuple[str, int]] = []
            reals: list[tuple[str, int]] = []
            for name in names:
                variable = self.variables.get(name)
                if variable is None:
                    raise ValueError(f"{self.fmu_path.name} has no output {name!r}")
                (integers if variable.type in INTEGER_TYPES else reals).append((name, variable.valueReference))
            reader = self._readers[names] = _Reader(integers, reals, names)
        return reader

    def _read(self, names) -> dict:
        return self._reader(tuple(names)).read(self._api)

    def simulate(
        self,
        order=None,
        horizon: float = 8.0,
        parameters: dict | None = None,
        communication_step: float | None = None,
        outputs=None,
        record=None,
        peak_force_limit: float | None = None,
    ) -> SimulationResult:
        """One run from t = 0 to the horizon: the outputs at its end (``outputs``: these names; None: every
        output the model description declares), and the trajectory of the ``record`` outputs if asked.

        With communication_step None the FMU is advanced by a single doStep: it samples the peak itself.

        With peak_force_limit (N, > 0; as the argument or among the parameters) the FMU stops the run as soon
        as its sampled peak exceeds the limit: the result is then ``stopped_early`` at its ``stop_time``. A run
        that stays below the limit gives the same result bit for bit as one without it.
        """
        self._messages.clear()
        api = self._api
        parameters = dict(parameters or {})
        if peak_force_limit is not None:
            parameters["peak_force_limit"] = peak_force_limit
        limited = "peak_force_limit" in parameters
        if order is not None:
            order = [_int32("order", m) for m in order]
            if len(order) != self.columns:
                raise ValueError(f"order: expected one material per column ({self.columns}), got {len(order)}")
        for name, value in parameters.items():
            if isinstance(value, str):  # an enumeration's item by name (or a number as text): its type reads it
                self._parameter(name)
                parameters[name] = self._declared[name].value(value)
        setter = self._setter(order is not None, tuple(parameters))
        reader = self._reader(self.outputs if outputs is None else tuple(outputs))
        stopped_at = None
        try:
            api.slave.reset()
            api.slave.setupExperiment(startTime=0.0, stopTime=float(horizon))
            api.slave.enterInitializationMode()
            setter.apply(api, order, list(parameters.values()))
            api.slave.exitInitializationMode()
            trajectory = None
            if communication_step is None and record is None:
                stopped_at = api.do_step(0.0, horizon, limited)
            else:
                step = communication_step or horizon
                count = max(1, int(round(horizon / step)))
                times = [0.0] + [min(horizon, (i + 1) * step) for i in range(count)]
                recorder = self._reader(tuple(record)) if record else None
                series: dict[str, list[float]] = {name: [] for name in (record or ())}
                reached = [0.0]
                if recorder:
                    for name, value in recorder.read(api).items():
                        series[name].append(value)
                for start, stop in zip(times[:-1], times[1:]):
                    stopped_at = api.do_step(start, stop - start, limited)
                    reached.append(stop if stopped_at is None else stopped_at)
                    if recorder:
                        for name, value in recorder.read(api).items():
                            series[name].append(value)
                    if stopped_at is not None:
                        break
                if record:
                    trajectory = RecordedSamples(np.array(reached), {k: np.array(v) for k, v in series.items()})
            values = reader.read(api)
        except FMICallException as exc:
            detail = "; ".join(self._messages) or "the FMU logged no reason"
            raise SimulationError(f"{exc.function} failed: {detail}") from None
        return SimulationResult(
            values, float(horizon) if stopped_at is None else stopped_at, stopped_at is not None, trajectory
        )

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


INTEGER_TYPES = ("Integer", "Enumeration")  # set and read with fmi2SetInteger / fmi2GetInteger


class _DirectCalls:
    """The FMI 2 calls FMPy has no form of that a run needs, called through ctypes on the instance FMPy loaded
    and instantiated (every other call is FMPy's):

    - setting and reading values into arrays made once per set of names (FMPy's ``setReal`` / ``getReal`` build
      new ctypes arrays from Python lists on every call, thousands of times per search);
    - a ``fmi2DoStep`` that returns fmi2Discard rather than raising: it is how the FMU says that it stopped the
      run early at its peak_force_limit (FMPy's ``doStep`` raises on any status above fmi2Warning).
    """

    SIGNATURES = {
        "fmi2SetReal": [c_void_p, POINTER(c_uint), c_size_t, POINTER(c_double)],
        "fmi2SetInteger": [c_void_p, POINTER(c_uint), c_size_t, POINTER(c_int)],
        "fmi2GetReal": [c_void_p, POINTER(c_uint), c_size_t, POINTER(c_double)],
        "fmi2GetInteger": [c_void_p, POINTER(c_uint), c_size_t, POINTER(c_int)],
        "fmi2DoStep": [c_void_p, c_double, c_double, c_int],
    }

    def __init__(self, slave: FMU2Slave):
        self.slave = slave
        self.component = slave.component
        self.functions = {}
        for name, argtypes in self.SIGNATURES.items():
            function = slave.dll[name]  # a function object of our own: fmpy's keep their own argtypes
            function.argtypes = argtypes
            function.restype = c_int
            self.functions[name] = function

    def call(self, name: str, *args) -> int:
        status = self.functions[name](self.component, *args)
        if status > fmi2Warning:
            raise FMICallException(function=name, status=status)
        return status

    def do_step(self, start: float, size: float, limited: bool) -> float | None:
        """fmi2DoStep; None when the step was completed, or, in a run with a peak_force_limit (limited), the
        time reached when the FMU stopped early and terminated (fmi2Discard with fmi2Terminated, FMI 2.0
        section 4.2.3). Any other failure raises, as fmpy's call would."""
        status = self.functions["fmi2DoStep"](self.component, start, size, 1)
        if status <= fmi2Warning:
            return None
        if status == fmi2Discard and limited and self.slave.getBooleanStatus(fmi2Terminated):
            return self.slave.getRealStatus(fmi2LastSuccessfulTime)
        raise FMICallException(function="fmi2DoStep", status=status)


class _Setter:
    """Sets an order and parameters: one fmi2SetInteger and one fmi2SetReal, over arrays made once."""

    def __init__(
        self, material_references: list[int], integers: list[tuple[int, int, str]], reals: list[tuple[int, int]]
    ):
        self.materials = len(material_references)
        self.integer_positions = [(index, name) for index, _, name in integers]
        self.real_positions = [index for index, _ in reals]
        integer_references = material_references + [vr for _, vr, _ in integers]
        self.integer_references = (c_uint * len(integer_references))(*integer_references)
        self.integer_values = (c_int * len(integer_references))()
        self.real_references = (c_uint * len(reals))(*[vr for _, vr in reals])
        self.real_values = (c_double * len(reals))()

    def apply(self, api: _DirectCalls, order, values: list) -> None:
        if len(self.integer_references):
            integers = (list(order) if self.materials else []) + [
                _int32(name, values[i]) for i, name in self.integer_positions
            ]
            self.integer_values[:] = integers
            api.call("fmi2SetInteger", self.integer_references, len(self.integer_references), self.integer_values)
        if len(self.real_references):
            self.real_values[:] = [float(values[i]) for i in self.real_positions]
            api.call("fmi2SetReal", self.real_references, len(self.real_references), self.real_values)


class _Reader:
    """Reads outputs: one fmi2GetReal and one fmi2GetInteger, into buffers made once."""

    def __init__(self, integers: list[tuple[str, int]], reals: list[tuple[str, int]], names: tuple):
        self.names = names  # the order the caller asked for
        self.integer_names = [name for name, _ in integers]
        self.real_names = [name for name, _ in reals]
        self.integer_references = (c_uint * len(integers))(*[vr for _, vr in integers])
        self.integer_values = (c_int * len(integers))()
        self.real_references = (c_uint * len(reals))(*[vr for _, vr in reals])
        self.real_values = (c_double * len(reals))()

    def read(self, api: _DirectCalls) -> dict:
        values: dict[str, float | int] = {}
        if self.real_names:
            api.call("fmi2GetReal", self.real_references, len(self.real_names), self.real_values)
            values.update(zip(self.real_names, self.real_values))
        if self.integer_names:
            api.call("fmi2GetInteger", self.integer_references, len(self.integer_names), self.integer_values)
            values.update(zip(self.integer_names, self.integer_values))
        return {name: values[name] for name in self.names}


def _int32(name: str, value) -> int:
    """What fmi2SetInteger carries: a whole number that fits in 32 bits (ctypes would wrap a wider one silently).
    Whether the FMU allows it is the FMU's to say (its own message, as a SimulationError)."""
    number = int(value)
    if number != value or not -(2**31) <= number < 2**31:
        raise ValueError(f"{name} = {value!r} is not allowed: FMI integers are whole numbers in [-2**31, 2**31 - 1]")
    return number
