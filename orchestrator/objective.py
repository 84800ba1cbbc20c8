"""What is minimised: one object, the way pymoo's ``Problem`` is the model handed to ``minimize``.

An objective says which FMU outputs it minimises (one, or two or three for a Pareto front), under which
parameters (the diagonal rule, the load...), over which load cases and how they combine, over which design
space, and at which fidelity:

- ``SEARCH``, what the searches rank by: a short horizon (``SEARCH_HORIZON``) at a looser tolerance with the
  cheapest solver at that accuracy (``SEARCH_SOLVER`` at ``SEARCH_RTOL``; python -m bench.work_precision and
  python -m bench.horizon_study measure their error against the gaps between good designs), extended to the full
  horizon for a design whose lattice still touches the backplate near its end;
- ``FULL``, what is reported: the whole scene at the FMU's default accuracy.

An objective turns a design into tasks (one FMU run per load case) that the one evaluator runs, caches and
journals, and combines their results. The outputs that can be minimised are the FMU's maxima over the run
(``RUN_MAXIMA``).
"""

from __future__ import annotations

import atexit
import os
import itertools
import math
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Callable, ClassVar, Mapping, Sequence

from .design import DesignSpace, as_design
from .tasks import EvaluateDesign, function_key
from .simulation import LatticeFMU, SimulationError, SimulationResult, declared_outputs, model_description
from .types import (
    OK,
    CaseValue,
    Evaluation,
    LimitedObjective,
    Order,
    RunOutputs,
    UnknownOutput,
    censored,
    failed,
)

SEARCH = "search"
FULL = "full"
FIDELITIES = (SEARCH, FULL)

SEARCH_HORIZON = 1.0  # s: every design has left the backplate by then (python -m bench.horizon_study)
SEARCH_RTOL = 8e-6  # its error stays far below the gaps between good designs (python -m bench.work_precision)
SEARCH_SOLVER = "rkn5"  # the cheapest pair at that accuracy (python -m bench.work_precision)
CONTACT_GUARD = 0.1  # a short horizon is trusted only when the lattice left the backplate before its last tenth
AGGREGATES = ("worst", "mean")


@dataclass(frozen=True)
class Quantity:
    """An FMU output that is a maximum over the run, and what it measures."""

    output: str
    label: str
    unit: str
    limits: bool  # a force limit on the sampled peak bounds it from below (the FMU may stop early)
    short: str = ""  # a few words for a table's row or a chart's axis


RUN_MAXIMA = {
    q.output: q
    for q in (
        Quantity(
            "peak_backplate_force",
            "peak backplate force over the samples every peak_sample_interval (the study's sampled peak)",
            "N",
            True,
            "peak backplate force (sampled)",
        ),
        Quantity(
            "peak_backplate_force_continuous",
            "peak backplate force over the continuous solution",
            "N",
            True,
            "peak backplate force (continuous)",
        ),
        Quantity(
            "stack_mass",
            "the stack's total mass (docs/model.md section 12; with --vary, its front against the peak)",
            "kg",
            False,
            "stack mass",
        ),
        Quantity(
            "max_compression",
            "largest compression of the stack along the load (mean x-displacement of column 1 minus that of column C)",
            "m",
            False,
            "largest compression",
        ),
    )
}
ALIASES = {"sampled": "peak_backplate_force", "continuous": "peak_backplate_force_continuous", "mass": "stack_mass"}

_INSTANCES: dict[str, LatticeFMU] = {}  # one open FMU per file and process
_SHIPPED: dict[str, str] = {}  # on a Dask worker: the FMU's SHA-256 -> this worker's copy of it
_SHIP_ERRORS: dict[str, str] = {}  # on a Dask worker: the FMU's SHA-256 -> why this worker cannot run it


def register_shipped_fmu(sha256: str, path: str | None, error: str | None = None) -> None:
    """Where this process keeps the FMU of that hash (a Dask worker's copy of the bytes the client sent), or why
    it cannot run it: a task naming the hash runs this copy, never a file at the client's path."""
    if error is None:
        _SHIPPED[sha256] = str(path)
        _SHIP_ERRORS.pop(sha256, None)
    else:
        _SHIP_ERRORS[sha256] = error


def fmu_instance(fmu_path: str, fmu_sha256: str = "") -> LatticeFMU:
    """This process's instance of the FMU (opened on first use, then reused with fmi2Reset): the copy shipped
    to this worker when there is one for the hash, else the file at ``fmu_path``."""
    if fmu_sha256 in _SHIP_ERRORS:
        raise SimulationError(_SHIP_ERRORS[fmu_sha256])
    path = _SHIPPED.get(fmu_sha256, fmu_path) if fmu_sha256 else fmu_path
    instance = _INSTANCES.get(path)
    if instance is None:
        instance = _INSTANCES[path] = LatticeFMU(path, instance_name="objective")
    return instance


def close_instances() -> None:
    """Frees this process's FMU instances and their extracted folders (a worker or a run ends)."""
    while _INSTANCES:
        _, instance = _INSTANCES.popitem()
        instance.close()


atexit.register(close_instances)  # a process that used FMU runs directly leaves no extracted FMU behind


def _forget_parents_instances() -> None:
    """In a forked child (a Dask worker, a pool worker): the parent's instances are the parent's; closing one here
    would remove the folder the parent's instance runs from, so the child opens its own."""
    _INSTANCES.clear()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_forget_parents_instances)


def missing_output(fmu_path: str | Path, names: Sequence[str]) -> str | None:
    """``"NAME: FMU has no such output (...)"`` for the first of ``names`` the FMU's model description does not
    declare, or None."""
    declared = declared_outputs(model_description(fmu_path))
    missing = next((name for name in names if name not in declared), None)
    if missing is None:
        return None
    return (
        f"{missing}: {Path(fmu_path).name} has no such output (its outputs: {', '.join(declared)}; rebuild it "
        "from these sources)"
    )


def output_names(text: str | Sequence[str]) -> tuple[str, ...]:
    """``"sampled"``, ``"peak_backplate_force,max_compression"`` ... as FMU output names; refuses the rest."""
    names = [t.strip() for t in (text.split(",") if isinstance(text, str) else text)]
    result = []
    for name in names:
        name = ALIASES.get(name, name)
        if name not in RUN_MAXIMA:
            raise ValueError(
                f"objective {name!r}: allowed values are {', '.join(list(ALIASES) + list(RUN_MAXIMA))} "
                "(one, or two or three separated by commas)"
            )
        result.append(name)
    if not 1 <= len(result) <= 3 or len(set(result)) != len(result):
        raise ValueError(f"objective {','.join(names)}: give one output, or two or three different ones")
    return tuple(result)


# ---------------------------------------------------------------------------------------------- one FMU run
@dataclass(frozen=True)
class FMURun:
    """One FMU run of a design: the evaluation function the evaluator schedules.

    Frozen and made of plain values, so it pickles to any executor and its ``key`` names what it computes
    (the FMU file is identified by its hash in the run's settings, not by where it lies). ``outputs`` are the
    objective's: the first is ``Evaluation.value``, and all of them ``Evaluation.values`` when there are
    several. A short horizon is simulated again over ``fallback_horizon`` when a column-C mass still touched
    the backplate in the horizon's last CONTACT_GUARD.
    """

    fmu_path: str
    horizon: float
    parameters: tuple[tuple[str, Any], ...] = ()
    outputs: tuple[str, ...] = ("peak_backplate_force",)
    fallback_horizon: float | None = None
    force_limit: float | None = None  # stop once the sampled peak passes it (a censored evaluation)
    fmu_sha256: str = ""  # the FMU's content: a Dask worker runs its own copy of it, wherever the client keeps it
    NEEDS: ClassVar[tuple[str, ...]] = ("last_contact_time", "rhs_evaluations")  # read besides ``outputs``

    def __post_init__(self):
        if not (math.isfinite(self.horizon) and self.horizon > 0):
            raise ValueError(f"horizon must be a finite number of seconds > 0, got {self.horizon}")

    @property
    def key(self) -> str:
        return (
            f"{','.join(self.outputs)}|{self.horizon!r}|{self.fallback_horizon!r}|"
            + ",".join(f"{k}={v!r}" for k, v in self.parameters)
            + ("" if self.force_limit is None else f"|limit={self.force_limit!r}")
        )

    def with_limit(self, limit: float | None) -> "FMURun":
        return replace(self, force_limit=None if limit is None else float(limit))

    def with_parameters(self, **changes) -> "FMURun":
        """The same run with some FMU parameters set otherwise (a tighter tolerance, another solver)."""
        return replace(self, parameters=tuple(sorted({**dict(self.parameters), **changes}.items())))

    def _simulate(self, order: Order, horizon: float) -> SimulationResult:
        parameters = dict(self.parameters)
        if self.force_limit is not None:
            parameters["peak_force_limit"] = self.force_limit
        return fmu_instance(self.fmu_path, self.fmu_sha256).simulate(order, horizon=horizon, parameters=parameters)

    def __call__(self, order: Order) -> Evaluation:
        start = time.perf_counter()
        horizon = self.horizon
        try:
            result = self._simulate(order, horizon)
            if result.stopped_early:
                if self.force_limit is None:
                    raise ValueError("the FMU stopped the run early, and this run asked for no force limit")
                return censored(
                    order,
                    self.force_limit,
                    result.stop_time,
                    time.perf_counter() - start,
                    work=int(result["rhs_evaluations"]),
                )
            work = 0
            if self.fallback_horizon and result["last_contact_time"] >= (1.0 - CONTACT_GUARD) * horizon:
                horizon = max(self.fallback_horizon, horizon)
                work = int(result["rhs_evaluations"])
                result = self._simulate(order, horizon)
            values = tuple(float(result[name]) for name in self.outputs)
        except (SimulationError, ValueError, UnknownOutput) as exc:
            return failed(order, str(exc), time.perf_counter() - start)
        outputs = RunOutputs(result.values, horizon)
        return Evaluation(
            as_design(order),
            values[0],
            OK,
            "",
            time.perf_counter() - start,
            outputs,
            values if len(values) > 1 else (),
            work=work + int(result["rhs_evaluations"]),
        )


@dataclass(frozen=True)
class Trajectory:
    """Outputs of one run at every communication point (a chart's data)."""

    kind: ClassVar[str] = "trajectory"
    order: Order
    status: str
    message: str
    time: tuple[float, ...]
    values: dict[str, tuple[float, ...]]
    seconds: float

    @property
    def ok(self) -> bool:
        return self.status == OK


@dataclass(frozen=True)
class RecordRun:
    """One FMU run that records ``outputs`` every ``step`` seconds: a task of the evaluator."""

    fmu_path: str
    order: Order
    horizon: float
    step: float
    parameters: tuple[tuple[str, Any], ...]
    outputs: tuple[str, ...]
    fmu_sha256: str = ""  # as FMURun's

    @property
    def key(self) -> str:
        return (
            f"record|{','.join(self.outputs)}|{self.horizon!r}|{self.step!r}|"
            + ",".join(f"{k}={v!r}" for k, v in self.parameters)
            + "#"
            + ",".join(map(str, self.order))
        )

    def __call__(self) -> Trajectory:
        start = time.perf_counter()
        try:
            result = fmu_instance(self.fmu_path, self.fmu_sha256).simulate(
                self.order,
                horizon=self.horizon,
                parameters=dict(self.parameters),
                communication_step=self.step,
                record=self.outputs,
            )
        except (SimulationError, ValueError) as exc:
            return self.failure(str(exc), time.perf_counter() - start)
        trajectory = result.trajectory
        if trajectory is None:
            return self.failure("the FMU recorded no trajectory", time.perf_counter() - start)
        return Trajectory(
            self.order,
            OK,
            "",
            tuple(float(t) for t in trajectory.time),
            {name: tuple(float(v) for v in trajectory.values[name]) for name in self.outputs},
            time.perf_counter() - start,
        )

    def failure(self, message: str, seconds: float) -> Trajectory:
        return Trajectory(self.order, "failed", message, (), {}, seconds)

    def keep(self, result: Trajectory) -> bool:
        return True


# ---------------------------------------------------------------------------------------------- objectives
class Objective:
    """The interface every objective offers (pymoo's Problem: the model, not the algorithm).

    ``tasks(fidelity)`` are picklable functions ``design -> Evaluation``, one per load case;
    ``combine(design, evaluations)`` makes the design's value from them; ``evaluate`` runs both through an
    evaluator.
    """

    space: DesignSpace

    @property
    def n_objectives(self) -> int:
        return 1

    @property
    def supports_limits(self) -> bool:
        """Can an evaluation stop early once its value passes a limit?"""
        return False

    @property
    def n_var(self) -> int:
        return self.space.columns

    def tasks(self, fidelity: str) -> Sequence[Callable[[Order], Evaluation]]:
        raise NotImplementedError

    def combine(self, order: Order, evaluations: Sequence[Evaluation]) -> Evaluation:
        return evaluations[0]

    def evaluate(
        self,
        orders: Sequence[Sequence[int]],
        evaluator,
        fidelity: str = SEARCH,
        progress: Callable[[int], Any] | None = None,
        limits: Sequence[float | None] | None = None,
    ) -> list[Evaluation]:
        """Every design's evaluation at ``fidelity`` through ``evaluator`` (failures stay failures).

        ``limits``: per design, a value above which only "above" matters (the search fidelity, and only where
        ``supports_limits``): such an evaluation may come back censored. An exact value already in the
        evaluator's cache is always preferred to a censored one."""
        if fidelity not in FIDELITIES:
            raise ValueError(f"fidelity {fidelity!r}: allowed values are {', '.join(FIDELITIES)}")
        designs = [as_design(o) for o in orders]
        tasks = self.tasks(fidelity)
        per_design = len(tasks)
        used_limits = limits if self.supports_limits and fidelity == SEARCH else None
        items = []
        for index, order in enumerate(designs):
            limit = used_limits[index] if used_limits is not None else None
            for task in tasks:
                exact = EvaluateDesign(task, order)
                if (
                    limit is not None
                    and math.isfinite(limit)
                    and isinstance(task, LimitedObjective)  # the tasks of an objective that supports limits
                    and evaluator.cached(exact) is None
                ):
                    items.append(EvaluateDesign(task.with_limit(limit), order))
                else:
                    items.append(exact)
        reported = [0]

        def ticks(done_tasks: int) -> None:  # progress in designs, not in FMU runs
            if progress is not None and done_tasks // per_design > reported[0]:
                reported[0] = done_tasks // per_design
                progress(reported[0])

        results = evaluator.run(items, progress=ticks if progress is not None else None)
        return [self.combine(order, results[i * per_design : (i + 1) * per_design]) for i, order in enumerate(designs)]


class CallableObjective(Objective):
    """Any ``design -> Evaluation | float`` function as an objective, the same at both fidelities: cheap
    problems with known optima test the searches and the loop through the same path as the FMU."""

    def __init__(self, function: Callable[[Order], Any], n_var: int | None = None, space: DesignSpace | None = None):
        self.function = function
        self.space = (
            space
            or getattr(function, "space", None)
            or DesignSpace.permutations(n_var if n_var is not None else getattr(function, "n", 1))
        )
        self._n_objectives = int(getattr(function, "n_objectives", 1))

    @property
    def n_objectives(self) -> int:
        return self._n_objectives

    def tasks(self, fidelity: str) -> Sequence[Callable[[Order], Evaluation]]:
        return [self.function]

    @property
    def key(self) -> str:
        return function_key(self.function)


def as_objective(objective: Any) -> Objective:
    return objective if isinstance(objective, Objective) else CallableObjective(objective)


@dataclass(frozen=True)
class ObjectiveDescription:
    """What an objective minimises, for results.json and the report."""

    outputs: tuple[str, ...]
    labels: tuple[str, ...]
    short_labels: tuple[str, ...]
    units: tuple[str, ...]
    diagonal_rule: str
    parameters: dict[str, Any]
    cases: tuple[dict[str, Any], ...]
    aggregate: str | None
    horizon: float
    search_horizon: float
    search_rtol: float | None
    search_solver: str


@dataclass(frozen=True)
class LatticeObjective(Objective):
    """FMU outputs of the lattice over one or more load cases.

    ``parameters``: FMU parameters of every run (diagonal_rule, F_total, ...). ``cases``: parameter dicts,
    each one FMU run per design on top of ``parameters``; a design's value is their ``aggregate`` (``worst``:
    the largest; ``mean``), output by output. ``horizon``: the full scene's; the search fidelity runs
    ``search_horizon`` at ``search_rtol`` (None: the full horizon at the FMU's tolerance). A record: the
    variants a study needs are made with ``dataclasses.replace`` (``with_parameters`` and its siblings).
    """

    fmu_path: str
    space: DesignSpace
    horizon: float
    outputs: tuple[str, ...] = ("peak_backplate_force",)
    parameters: dict[str, Any] = field(default_factory=dict)
    cases: tuple[dict[str, Any], ...] = ({},)
    aggregate: str = "worst"
    search_horizon: float | None = SEARCH_HORIZON
    search_rtol: float | None = SEARCH_RTOL
    use_limits: bool = True
    has_force_limit: bool = True
    default_rule: str = ""
    fmu_sha256: str = ""

    def __post_init__(self):
        if self.aggregate not in AGGREGATES:
            raise ValueError(f"aggregate {self.aggregate!r}: allowed values are {', '.join(AGGREGATES)}")
        if not (math.isfinite(self.horizon) and self.horizon > 0):
            raise ValueError(f"horizon must be a finite number of seconds > 0, got {self.horizon}")
        normal = object.__setattr__  # a frozen record normalises what it was given, once, here
        normal(self, "fmu_path", str(self.fmu_path))
        normal(self, "horizon", float(self.horizon))
        normal(self, "outputs", output_names(self.outputs))
        refusal = missing_output(self.fmu_path, self.outputs + FMURun.NEEDS)
        if refusal:
            raise ValueError(f"objective {refusal}")
        normal(self, "parameters", {k: v for k, v in (self.parameters or {}).items() if v is not None})
        normal(self, "cases", tuple(dict(case) for case in (self.cases or ({},))) or ({},))
        normal(self, "search_horizon", self.search_fidelity_horizon)

    @property
    def n_objectives(self) -> int:
        return len(self.outputs)

    @property
    def search_fidelity_horizon(self) -> float:
        """The search fidelity's horizon: ``search_horizon`` as __post_init__ made it (None: the full horizon; never
        past it)."""
        return min(self.search_horizon or self.horizon, self.horizon)

    @property
    def supports_limits(self) -> bool:
        """A limit on the sampled peak bounds a single peak objective from below (the continuous peak is at least
        the sampled one, the worst case at least each case) when the FMU has ``peak_force_limit``."""
        return (
            self.use_limits
            and self.has_force_limit
            and self.n_objectives == 1
            and RUN_MAXIMA[self.outputs[0]].limits
            and (self.aggregate == "worst" or len(self.cases) == 1)
        )

    @property
    def diagonal_rule(self) -> str:
        """The rule the runs use (the FMU's default unless set; "" for an FMU without diagonal rules)."""
        return str(self.parameters.get("diagonal_rule", self.default_rule))

    @property
    def unit(self) -> str:
        return RUN_MAXIMA[self.outputs[0]].unit

    def with_parameters(self, **parameters) -> "LatticeObjective":
        """The same objective with some FMU parameters changed (the other diagonal rule, another load)."""
        return replace(self, parameters={**self.parameters, **parameters})

    def with_cases(self, cases: Sequence[dict] | None, aggregate: str = "worst") -> "LatticeObjective":
        return replace(self, cases=tuple(cases or ({},)), aggregate=aggregate)

    def with_outputs(self, outputs: Sequence[str]) -> "LatticeObjective":
        return replace(self, outputs=tuple(outputs))

    def run_parameters(self, case: dict, fidelity: str) -> dict:
        """The FMU parameters of one case's run at ``fidelity``."""
        parameters = {**self.parameters, **case}
        if fidelity == SEARCH and self.search_rtol is not None:  # what the user set stays theirs
            parameters = {
                "solver": SEARCH_SOLVER,
                "rtol": self.search_rtol,
                "atol": self.search_rtol * 1e-2,
                **parameters,
            }
        return parameters

    def tasks(self, fidelity: str) -> list[FMURun]:
        runs = []
        for case in self.cases:
            parameters = tuple(sorted(self.run_parameters(case, fidelity).items()))
            if fidelity == SEARCH:
                runs.append(
                    FMURun(
                        self.fmu_path,
                        self.search_fidelity_horizon,
                        parameters,
                        self.outputs,
                        fallback_horizon=self.horizon,
                        fmu_sha256=self.fmu_sha256,
                    )
                )
            else:
                runs.append(FMURun(self.fmu_path, self.horizon, parameters, self.outputs, fmu_sha256=self.fmu_sha256))
        return runs

    def combine(self, order: Order, evaluations: Sequence[Evaluation]) -> Evaluation:
        if len(self.cases) == 1:
            return evaluations[0]
        seconds = sum(e.seconds for e in evaluations)
        cases = tuple(
            CaseValue(case, e.value, e.status, "" if e.ok else e.message) for case, e in zip(self.cases, evaluations)
        )
        bad = next((e for e in evaluations if not e.ok and not e.censored), None)
        if bad is not None:
            case = self.cases[evaluations.index(bad)]
            return failed(order, f"case {case}: {bad.message}", seconds, cases=cases)
        above = next((e for e in evaluations if e.censored), None)
        if above is not None:  # one case above the limit: the worst of the cases is above it too
            return censored(order, above.censored_limit, above.stopped_at, seconds, cases=cases)
        columns = [e.values or (e.ok_value,) for e in evaluations]
        if self.aggregate == "worst":
            values = tuple(max(column[i] for column in columns) for i in range(self.n_objectives))
        else:
            values = tuple(sum(column[i] for column in columns) / len(columns) for i in range(self.n_objectives))
        worst = max(evaluations, key=lambda e: e.ok_value)
        work = sum(e.work or 0 for e in evaluations)
        return Evaluation(
            as_design(order),
            values[0],
            OK,
            "",
            seconds,
            worst.outputs,
            values if self.n_objectives > 1 else (),
            cases=cases,
            work=work,
        )

    def describe(self) -> ObjectiveDescription:
        return ObjectiveDescription(
            outputs=self.outputs,
            labels=tuple(RUN_MAXIMA[o].label for o in self.outputs),
            short_labels=tuple(RUN_MAXIMA[o].short for o in self.outputs),
            units=tuple(RUN_MAXIMA[o].unit for o in self.outputs),
            diagonal_rule=self.diagonal_rule,
            parameters=dict(self.parameters),
            cases=self.cases if self.cases != ({},) else (),
            aggregate=self.aggregate if self.cases != ({},) else None,
            horizon=self.horizon,
            search_horizon=self.search_fidelity_horizon,
            search_rtol=self.search_rtol,
            search_solver=SEARCH_SOLVER,
        )


def expand_cases(case_lists: Mapping[str, Sequence[Any]]) -> list[dict]:
    """The product of ``{"F_total": [600, 1200], ...}``: every combination, one dict each."""
    if not case_lists:
        return [{}]
    names = list(case_lists)
    return [dict(zip(names, values)) for values in itertools.product(*(case_lists[n] for n in names))]


def count_cases(case_lists: dict[str, Sequence[Any]]) -> int:
    return math.prod(len(v) for v in case_lists.values()) if case_lists else 1


__all__ = [
    "AGGREGATES",
    "ALIASES",
    "CONTACT_GUARD",
    "CallableObjective",
    "FIDELITIES",
    "FMURun",
    "FULL",
    "LatticeObjective",
    "Objective",
    "ObjectiveDescription",
    "Quantity",
    "RUN_MAXIMA",
    "RecordRun",
    "SEARCH",
    "SEARCH_HORIZON",
    "SEARCH_RTOL",
    "SEARCH_SOLVER",
    "as_objective",
    "close_instances",
    "count_cases",
    "expand_cases",
    "fmu_instance",
    "missing_output",
    "output_names",
    "register_shipped_fmu",
    "Trajectory",
]
