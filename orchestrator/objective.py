"""What is minimised: one object, the way pymoo's ``Problem`` is the model handed to ``minimize``.

An objective says what it measures and in which unit, and evaluates orders at two fidelities:
``SEARCH`` (what the searches rank by: a short horizon at a looser tolerance) and ``FULL`` (what is
reported: the whole scene at the FMU's default accuracy). The searches, the verification of finalists,
the local-optimality check and the report all call it, always through the one guarded evaluation path
(``orchestrator.loop.Evaluator``): an objective turns an order into *tasks* (one FMU run per load case),
the evaluator runs, caches, journals and guards the tasks, and the objective combines their results.

The sampled and the continuous peak are classes; the diagonal rule, the scene parameters and the load
cases are values of an instance. A new objective is one class and one line in ``OBJECTIVES``.
"""
from __future__ import annotations

import itertools
import math
import time
from dataclasses import dataclass, replace
from typing import Any, Callable, ClassVar, Sequence

from .simulation import COUNTER_OUTPUTS, ENERGY_OUTPUTS, PEAK_OUTPUTS, LatticeFMU, SimulationError, model_description
from .types import OK, Evaluation, Order, as_order, censored, failed

SEARCH = "search"
FULL = "full"
FIDELITIES = (SEARCH, FULL)

# The searches' cheaper fidelity. bench/horizon_study.py over 257 orders: every order leaves the plate for good
# before 0.74 s, so 1 s gives the 8 s peak; an error of 3e-5 is a fourteenth of the smallest gap between the best
# ten orders (4.3e-4) and keeps their ranking. bench/solver_work_precision.py over 43 orders against DOP853 at
# rtol 1e-12: Fine's Runge-Kutta-Nystrom 5(4) pair (bench/method_study.py found it the cheapest of eight
# methods) at rtol 8e-6 errs by at most 2.3e-5 with 836 right-hand sides, where Tsitouras' 5(4) pair needs 1018
# at rtol 1e-5 (2.7e-5) and DOP853 1394 (2.3e-5); CPU 1.24 against 1.44 and 1.81 ms per order. At rtol 1e-5
# the Nystrom pair errs by 3.03e-5, just past the bound. Full fidelity keeps the FMU's default, DOP853.
SEARCH_HORIZON = 1.0
SEARCH_RTOL = 8e-6
SEARCH_SOLVER = "rkn5"
# A short horizon is trusted only when the lattice left the plate before its last CONTACT_GUARD fraction.
CONTACT_GUARD = 0.1
AGGREGATES = ("worst", "mean")

_INSTANCES: dict[str, LatticeFMU] = {}  # one open FMU per file and process


def fmu_instance(fmu_path: str) -> LatticeFMU:
    """This process's instance of the FMU (opened on first use, then reused with fmi2Reset)."""
    instance = _INSTANCES.get(fmu_path)
    if instance is None:
        instance = _INSTANCES[fmu_path] = LatticeFMU(fmu_path, instance_name="objective")
    return instance


def close_instances() -> None:
    """Frees this process's FMU instances and their extracted folders (a worker or a run ends)."""
    while _INSTANCES:
        _, instance = _INSTANCES.popitem()
        instance.close()


def search_tolerances(rtol: float) -> dict:
    """The FMU's settings for a search at rtol: the search solver, atol two decades below rtol (as the
    horizon study ran them)."""
    return {"solver": SEARCH_SOLVER, "rtol": rtol, "atol": rtol * 1e-2}


@dataclass(frozen=True)
class FMURun:
    """One FMU run of one order: the unit the evaluator schedules, caches and journals.

    Frozen and made of plain values, so it pickles to any executor and is a cache key. ``output`` is the
    FMU output that becomes ``Evaluation.peak``; both peaks, the energies and the counters go to
    ``details`` whichever is optimised. A short horizon is simulated again over ``fallback_horizon`` when a
    column-C mass still touched the plate in the horizon's last CONTACT_GUARD (details["horizon"] says
    which was used).
    """

    fmu_path: str
    horizon: float
    parameters: tuple = ()
    output: str = "peak_backplate_force"
    fallback_horizon: float | None = None
    force_limit: float | None = None  # N: stop once the sampled peak passes it (a censored evaluation)

    def __post_init__(self):
        if not (math.isfinite(self.horizon) and self.horizon > 0):
            raise ValueError(f"horizon must be a finite number of seconds > 0, got {self.horizon}")

    @property
    def key(self) -> str:
        """A stable text key for the journal (the FMU file is fingerprinted by the run, not here)."""
        return (f"{self.output}|{self.horizon!r}|{self.fallback_horizon!r}|"
                + ",".join(f"{k}={v!r}" for k, v in self.parameters)
                + ("" if self.force_limit is None else f"|limit={self.force_limit!r}"))

    def with_limit(self, limit: float | None) -> "FMURun":
        return replace(self, force_limit=None if limit is None else float(limit))

    def simulate(self, order: Order, horizon: float) -> dict:
        parameters = dict(self.parameters)
        if self.force_limit is not None:
            parameters["peak_force_limit"] = self.force_limit
        return fmu_instance(self.fmu_path).simulate(
            order, horizon=horizon, parameters=parameters,
            outputs=PEAK_OUTPUTS + ENERGY_OUTPUTS + COUNTER_OUTPUTS + ("last_contact_time",))

    def __call__(self, order: Order) -> Evaluation:
        start = time.perf_counter()
        horizon = self.horizon
        try:
            result = self.simulate(order, horizon)
            if result.get("censored"):
                return censored(order, self.force_limit, result.get("censored_at"), time.perf_counter() - start,
                                {"rhs_evaluations": result.get("rhs_evaluations"), "horizon": horizon})
            if self.fallback_horizon and result["last_contact_time"] >= (1.0 - CONTACT_GUARD) * horizon:
                horizon = max(self.fallback_horizon, horizon)
                result = self.simulate(order, horizon)
        except (SimulationError, ValueError) as exc:
            return failed(order, str(exc), time.perf_counter() - start)
        details = {
            "peak_sampled": result["peak_backplate_force"],
            "peak_continuous": result["peak_backplate_force_continuous"],
            "peak_time": result["peak_time"],
            "last_contact_time": result["last_contact_time"],
            "energy_balance_error": result["energy_balance_error"],
            "external_work": result["external_work"],
            "dissipated_energy": result["dissipated_energy"],
            "nonreciprocal_work": result["nonreciprocal_work"],
            "rhs_evaluations": result["rhs_evaluations"],
            "horizon": horizon,
        }
        return Evaluation(as_order(order), float(result[self.output]), OK, "", time.perf_counter() - start,
                          details)


class Objective:
    """The interface every objective offers (pymoo's Problem: the model, not the algorithm).

    ``tasks(fidelity)`` are picklable callables ``order -> Evaluation``, one per load case;
    ``combine(order, evaluations)`` makes the order's value from them. ``evaluate`` is the convenience
    that runs both through an evaluator.
    """

    name: ClassVar[str] = "objective"
    quantity: ClassVar[str] = "value"
    unit: ClassVar[str] = ""
    n_var: int
    supports_limits = False  # can an evaluation stop early once its value passes a limit?

    def tasks(self, fidelity: str) -> list[Callable[[Order], Evaluation]]:
        raise NotImplementedError

    def combine(self, order: Order, evaluations: Sequence[Evaluation]) -> Evaluation:
        return evaluations[0]

    def describe(self) -> dict:
        return {"name": self.name, "quantity": self.quantity, "unit": self.unit}

    def evaluate(self, orders: Sequence[Sequence[int]], evaluator, fidelity: str = SEARCH,
                 progress: Callable[[int], Any] | None = None,
                 limits: Sequence[float | None] | None = None) -> list[Evaluation]:
        """Every order's value at ``fidelity``, through ``evaluator`` (failures stay failures).

        ``limits``: per order, a value above which only "above" matters (a search fidelity only, and only
        where ``supports_limits``): such an evaluation may come back censored. An exact value already in
        the evaluator's cache is always preferred to a censored one."""
        if fidelity not in FIDELITIES:
            raise ValueError(f"fidelity {fidelity!r}: allowed values are {', '.join(FIDELITIES)}")
        orders = [as_order(o) for o in orders]
        tasks = self.tasks(fidelity)
        per_order = len(tasks)
        use_limits = limits is not None and self.supports_limits and fidelity == SEARCH
        items = []
        for index, order in enumerate(orders):
            limit = limits[index] if use_limits else None
            for task in tasks:
                if limit is not None and math.isfinite(limit) and evaluator.cached(task, order) is None:
                    items.append((task.with_limit(limit), order))
                else:
                    items.append((task, order))
        reported = [0]

        def ticks(done_tasks: int) -> None:  # progress in orders, not in FMU runs
            if done_tasks // per_order > reported[0]:
                reported[0] = done_tasks // per_order
                progress(reported[0])
        results = evaluator.run(items, progress=ticks if progress is not None else None)
        return [self.combine(order, results[i * per_order:(i + 1) * per_order]) for i, order in enumerate(orders)]


class CallableObjective(Objective):
    """Any ``order -> Evaluation | float`` callable as an objective, the same at both fidelities.

    Why: the cheap problems with known optima (``search/problems.py``) test the searches and the loop in
    milliseconds through the same path as the FMU.
    """

    name = "callable"

    def __init__(self, function: Callable[[Order], Any], n_var: int | None = None):
        self.function = function
        self.n_var = n_var if n_var is not None else getattr(function, "n", 0)

    def tasks(self, fidelity: str) -> list[Callable[[Order], Evaluation]]:
        return [self.function]

    def describe(self) -> dict:
        return {"name": self.name, "function": type(self.function).__name__}


def as_objective(objective: Any) -> Objective:
    return objective if isinstance(objective, Objective) else CallableObjective(objective)


class PeakObjective(Objective):
    """A peak backplate force of the lattice FMU over one or more load cases.

    ``parameters``: FMU parameters of every run (F_total, diagonal_rule, ...). ``cases``: a list of
    parameter dicts, each one FMU run per order on top of ``parameters``; the order's value is their
    ``aggregate`` (``worst``: the largest peak; ``mean``). ``horizon``: the full scene's; the search
    fidelity runs ``search_horizon`` at ``search_rtol`` (None: the full horizon, the FMU's tolerance).
    """

    output: ClassVar[str] = "peak_backplate_force"
    unit = "N"

    def __init__(self, fmu_path, n_var: int, horizon: float, parameters: dict | None = None,
                 cases: Sequence[dict] | None = None, aggregate: str = "worst",
                 search_horizon: float | None = SEARCH_HORIZON, search_rtol: float | None = SEARCH_RTOL,
                 use_limits: bool = True):
        if aggregate not in AGGREGATES:
            raise ValueError(f"aggregate {aggregate!r}: allowed values are {', '.join(AGGREGATES)}")
        if not (math.isfinite(horizon) and horizon > 0):
            raise ValueError(f"horizon must be a finite number of seconds > 0, got {horizon}")
        self.fmu_path = str(fmu_path)
        self.n_var = int(n_var)
        self.horizon = float(horizon)
        self.parameters = {k: v for k, v in (parameters or {}).items() if v is not None}
        self.cases = [dict(case) for case in (cases or [{}])] or [{}]
        self.aggregate = aggregate
        self.search_horizon = min(search_horizon or self.horizon, self.horizon)
        self.search_rtol = search_rtol
        self.use_limits = use_limits  # False: every evaluation runs to the end (bench/force_limit_search.py)

    @property
    def supports_limits(self) -> bool:
        """A limit on the sampled peak bounds this objective (the continuous peak is at least the sampled
        one; the worst case is at least each case) when the FMU has ``peak_force_limit``."""
        if not self.use_limits or (self.aggregate != "worst" and len(self.cases) > 1):
            return False
        if not hasattr(self, "_fmu_has_limit"):
            names = {v.name for v in model_description(self.fmu_path).modelVariables}
            self._fmu_has_limit = "peak_force_limit" in names
        return self._fmu_has_limit

    def with_parameters(self, **parameters) -> "PeakObjective":
        """The same objective with some FMU parameters changed (the other diagonal rule, another load)."""
        return type(self)(self.fmu_path, self.n_var, self.horizon, {**self.parameters, **parameters},
                          self.cases, self.aggregate, self.search_horizon, self.search_rtol, self.use_limits)

    def with_cases(self, cases: Sequence[dict] | None, aggregate: str = "worst") -> "PeakObjective":
        return type(self)(self.fmu_path, self.n_var, self.horizon, self.parameters, cases, aggregate,
                          self.search_horizon, self.search_rtol, self.use_limits)

    def case_parameters(self, case: dict) -> dict:
        return {**self.parameters, **case}

    def tasks(self, fidelity: str) -> list[FMURun]:
        runs = []
        for case in self.cases:
            parameters = self.case_parameters(case)
            if fidelity == SEARCH:
                if self.search_rtol is not None:  # what the user set (a solver, a tolerance) stays theirs
                    parameters = {**search_tolerances(self.search_rtol), **parameters}
                runs.append(FMURun(self.fmu_path, self.search_horizon, tuple(sorted(parameters.items())),
                                   self.output, fallback_horizon=self.horizon))
            else:
                runs.append(FMURun(self.fmu_path, self.horizon, tuple(sorted(parameters.items())), self.output))
        return runs

    def combine(self, order: Order, evaluations: Sequence[Evaluation]) -> Evaluation:
        if len(self.cases) == 1:
            return evaluations[0]
        seconds = sum(e.seconds for e in evaluations)
        cases = [{"parameters": case, "peak": e.peak, "status": e.status, **({"message": e.message} if not e.ok else {})}
                 for case, e in zip(self.cases, evaluations)]
        bad = next((e for e in evaluations if not e.ok and not e.censored), None)
        if bad is not None:
            case = self.cases[evaluations.index(bad)]
            return replace(failed(order, f"case {case}: {bad.message}", seconds), details={"cases": cases})
        above = next((e for e in evaluations if e.censored), None)
        if above is not None:  # one case above the limit: the worst of the cases is above it too
            return censored(order, above.lower_bound, above.details.get("censored_at"), seconds, {"cases": cases})
        peaks = [e.peak for e in evaluations]
        value = max(peaks) if self.aggregate == "worst" else sum(peaks) / len(peaks)
        worst = evaluations[peaks.index(max(peaks))]
        details = {**worst.details, "cases": cases, "aggregate": self.aggregate}
        return Evaluation(as_order(order), float(value), OK, "", seconds, details)

    def describe(self) -> dict:
        return {"name": self.name, "quantity": self.quantity, "unit": self.unit, "output": self.output,
                "diagonal_rule": self.parameters.get("diagonal_rule", "receiver"),
                "parameters": dict(self.parameters), "cases": self.cases if self.cases != [{}] else [],
                "aggregate": self.aggregate if self.cases != [{}] else None, "horizon": self.horizon,
                "search_horizon": self.search_horizon, "search_rtol": self.search_rtol}


class SampledPeak(PeakObjective):
    """The study's objective: the largest of the backplate force's samples every peak_sample_interval."""

    name = "sampled"
    quantity = "peak backplate force over 0.01 s samples (reproduces the study)"
    output = "peak_backplate_force"


class ContinuousPeak(PeakObjective):
    """The true maximum of the backplate force over the continuous solution."""

    name = "continuous"
    quantity = "peak backplate force over the continuous solution"
    output = "peak_backplate_force_continuous"


OBJECTIVES: dict[str, type[PeakObjective]] = {
    "sampled": SampledPeak,
    "continuous": ContinuousPeak,
}


def make_objective(name: str, *args, **kwargs) -> PeakObjective:
    try:
        cls = OBJECTIVES[name]
    except KeyError:
        raise ValueError(f"objective {name!r}: allowed values are {', '.join(OBJECTIVES)}") from None
    return cls(*args, **kwargs)


def expand_cases(case_lists: dict[str, Sequence[Any]]) -> list[dict]:
    """The product of ``{"F_total": [600, 1200], ...}``: every combination, one dict each."""
    if not case_lists:
        return [{}]
    names = list(case_lists)
    return [dict(zip(names, values)) for values in itertools.product(*(case_lists[n] for n in names))]

