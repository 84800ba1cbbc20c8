"""Co-design (docs/model.md section 12): the material order and each column's properties, searched together.

A co-design point is an order (a design of the order space) and, for each column, a factor per varied property
(``--vary k,c,mass``): column j holds material ``p_j`` and its property ``name`` takes ``factor * name[p_j]`` of
the table. Each material fills at most one column (a permutation or an arrangement), so a column's factor is the
factor of the material it holds and the FMU's own parameters ``name[p_j]`` carry it: every run is an ordinary
FMU run with a few more parameters, through the one Evaluator (its cache key holds them). Materials no column
holds keep their table values.

The searches see the point in [0, 1]-scaled coordinates: the order's random keys (``DesignSpace.from_keys``),
then each column's factors on a log scale between the range's ends (factor 1 sits in the middle of a range
symmetric about it, as 0.5..2 is); a table's ``<name>_min`` and ``<name>_max`` give a material's own ends, so a
column's range is that of the material it holds. The stack's total mass (section 12: R D times the sum of each
column's mass) may not exceed the budget: a design above it is infeasible, a constraint of the searches (pycma's
augmented Lagrangian, SLSQP's inequality), never clipped into the budget.
"""

from __future__ import annotations

import contextlib
import io
import math
import warnings
from dataclasses import dataclass
from typing import Any, Callable, Sequence

import cma
import numpy as np
from scipy.optimize import minimize, nnls

from fmu_src.materials import FIELD_NAMES, MaterialTable

from .design import Design, DesignSpace, REPETITION, as_design
from .objective import FULL, SEARCH, LatticeObjective, RecordRun, missing_output
from .simulation import declared_parameters, model_description
from .tasks import EvaluateDesign
from .types import Evaluation

DEFAULT_RANGE = (0.5, 2.0)
MASS = "mass"
MASS_TOLERANCE = 1e-9  # relative: a stack this close above its budget is within it (the sum's rounding)


def parse_vary(text: str) -> tuple[str, ...]:
    """``"k,c,mass"`` as the varied properties (section 12's names, each once); refuses the rest in one line."""
    names = tuple(name.strip() for name in text.split(","))
    for name in names:
        if name not in FIELD_NAMES:
            raise ValueError(f"--vary {name!r}: allowed values are {', '.join(FIELD_NAMES)} (separated by commas)")
    if len(set(names)) != len(names):
        raise ValueError(f"--vary {text}: each property once; allowed values are {', '.join(FIELD_NAMES)}")
    return names


def parse_vary_range(text: str) -> tuple[float, float]:
    """``"0.5,2"`` as the factor range (0 < low <= 1 <= high, low < high: the table's value lies in it)."""
    parts = text.split(",")
    try:
        low, high = (float(part) for part in parts)
    except ValueError:
        raise ValueError(
            f"--vary-range {text!r}: expected LOW,HIGH, two numbers with 0 < LOW <= 1 <= HIGH and LOW < HIGH"
        ) from None
    if not (math.isfinite(low) and math.isfinite(high) and 0 < low <= 1 <= high and low < high):
        raise ValueError(
            f"--vary-range {text!r}: allowed values are 0 < LOW <= 1 <= HIGH with LOW < HIGH (the table's value, "
            "factor 1, inside the range)"
        )
    return low, high


@dataclass(frozen=True)
class CoDesignPoint:
    """An order and each column's factors (``factors[j][i]``: column j + 1's factor of ``names[i]``)."""

    order: Design
    factors: tuple[tuple[float, ...], ...]


@dataclass(frozen=True)
class ColumnProperties:
    """One column of a co-design answer: its material, each section-12 property's value and each varied one's
    factor."""

    column: int
    material: str
    values: dict[str, float]
    factors: dict[str, float]


def table_columns(table: MaterialTable, order: Sequence[int]) -> tuple[ColumnProperties, ...]:
    """Each column of ``order`` at the table's values (no factors)."""
    return tuple(
        ColumnProperties(
            column,
            table.name_of(material),
            {name: float(getattr(table.materials[material - 1], name)) for name in FIELD_NAMES},
            {},
        )
        for column, material in enumerate(as_design(order), start=1)
    )


@dataclass(frozen=True)
class CoDesignSpace:
    """The order space, the varied properties and their factor range, the stack's mass budget (kg; None: none).

    ``masses_per_column`` is R D, the masses of one column (section 12's total mass)."""

    space: DesignSpace
    table: MaterialTable
    names: tuple[str, ...]
    low: float = DEFAULT_RANGE[0]
    high: float = DEFAULT_RANGE[1]
    masses_per_column: int = 1
    mass_budget: float | None = None

    def __post_init__(self):
        if self.space.kind == REPETITION:
            raise ValueError(
                "--vary: not with --repeat (a material in several columns has one value of each property); "
                "allowed: a permutation or an arrangement of the table's materials"
            )
        if not self.names:
            raise ValueError(f"--vary: name at least one property; allowed values are {', '.join(FIELD_NAMES)}")
        parse_vary(",".join(self.names))
        parse_vary_range(f"{self.low!r},{self.high!r}")
        if self.mass_budget is not None and not (math.isfinite(self.mass_budget) and self.mass_budget > 0):
            raise ValueError(f"--mass-budget must be a finite number of kg > 0, got {self.mass_budget!r}")

    # ------------------------------------------------------------------------------------- coordinates
    @property
    def columns(self) -> int:
        return self.space.columns

    @property
    def dimension(self) -> int:
        """Length of a scaled point: the order's keys, then C times the varied properties' factors."""
        return self.space.key_dimension + self.columns * len(self.names)

    def factor_range(self, material: int, name: str) -> tuple[float, float]:
        """The factors material ``material``'s property ``name`` may take: the table's bounds (``name_min``,
        ``name_max``) over its value where its row gives them, else the range's ends."""
        base = float(getattr(self.table.materials[material - 1], name))
        low, high = self.table.bound(material, name)
        return (self.low if low is None else low / base), (self.high if high is None else high / base)

    def factor_of(self, scaled: float, material: int, name: str) -> float:
        """A scaled coordinate in [0, 1] as a factor in the material's range for ``name``, on a log scale."""
        low, high = self.factor_range(material, name)
        return float(low * (high / low) ** min(1.0, max(0.0, float(scaled))))

    def scaled_of(self, factor: float, material: int, name: str) -> float:
        low, high = self.factor_range(material, name)
        return float(math.log(factor / low) / math.log(high / low))

    def log_span(self, material: int, name: str) -> float:
        """d ln(factor) / d scaled coordinate for the material's property."""
        low, high = self.factor_range(material, name)
        return math.log(high / low)

    def decode(self, coordinates: Sequence[float]) -> CoDesignPoint:
        x = np.asarray(coordinates, dtype=float)
        keys = self.space.key_dimension
        order = self.space.from_keys(x[:keys])
        per = len(self.names)
        factors = tuple(
            tuple(self.factor_of(x[keys + j * per + i], order[j], name) for i, name in enumerate(self.names))
            for j in range(self.columns)
        )
        return CoDesignPoint(order, factors)

    def encode(self, point: CoDesignPoint) -> np.ndarray:
        keys = self.space.to_keys(point.order)
        scaled = [
            self.scaled_of(f, point.order[j], name)
            for j, column in enumerate(point.factors)
            for f, name in zip(column, self.names)
        ]
        return np.concatenate([keys, scaled])

    def unit_point(self, order: Sequence[int]) -> CoDesignPoint:
        """``order`` with every property at its table value (factor 1)."""
        return CoDesignPoint(as_design(order), tuple((1.0,) * len(self.names) for _ in range(self.columns)))

    def with_factors(self, order: Sequence[int], flat: Sequence[float]) -> CoDesignPoint:
        """``order`` with the factors given column by column, property by property (a flat list)."""
        per = len(self.names)
        return CoDesignPoint(
            as_design(order), tuple(tuple(float(flat[j * per + i]) for i in range(per)) for j in range(self.columns))
        )

    # ------------------------------------------------------------------------------------- properties
    def value(self, point: CoDesignPoint, column: int, name: str) -> float:
        """Column ``column``'s (1-based) value of property ``name``."""
        material = point.order[column - 1]
        base = getattr(self.table.materials[material - 1], name)
        if name not in self.names:
            return float(base)
        value = float(base * point.factors[column - 1][self.names.index(name)])
        low, high = self.table.bound(material, name)  # a bound's own value, not one rounded past it
        return min(max(value, low if low is not None else value), high if high is not None else value)

    def parameters(self, point: CoDesignPoint) -> dict[str, float]:
        """The FMU parameters that set the point's properties: ``name[m]`` of every varied name and material
        (a material no column holds at its table value), so every point sets the same names."""
        values = {
            f"{name}[{m}]": float(getattr(material, name))
            for name in self.names
            for m, material in enumerate(self.table.materials, start=1)
        }
        for column, material in enumerate(point.order, start=1):
            for name in self.names:
                values[f"{name}[{material}]"] = self.value(point, column, name)
        return values

    def total_mass(self, point: CoDesignPoint) -> float:
        """Section 12's stack mass, R D times the sum of each column's mass, in kg."""
        return self.masses_per_column * math.fsum(
            self.value(point, column, MASS) for column in range(1, self.columns + 1)
        )

    def budget_for(self, order: Sequence[int]) -> float:
        """The mass budget: the one given, else ``order``'s own mass at the table's values."""
        if self.mass_budget is not None:
            return float(self.mass_budget)
        return self.table.stack_mass(as_design(order), self.masses_per_column)

    def mass_excess(self, point: CoDesignPoint, budget: float) -> float:
        """How far (kg) the point's mass lies above ``budget``; 0 within it."""
        excess = self.total_mass(point) - budget
        return excess if excess > MASS_TOLERANCE * budget else 0.0

    def columns_of(self, point: CoDesignPoint) -> tuple[ColumnProperties, ...]:
        return tuple(
            ColumnProperties(
                column,
                self.table.name_of(material),
                {name: self.value(point, column, name) for name in FIELD_NAMES},
                {name: point.factors[column - 1][i] for i, name in enumerate(self.names)},
            )
            for column, material in enumerate(point.order, start=1)
        )


@dataclass(frozen=True)
class CoDesignObjective:
    """The objective of a co-design point: the lattice objective's runs with the point's parameters set."""

    base: LatticeObjective
    space: CoDesignSpace

    def evaluate(self, points: Sequence[CoDesignPoint], evaluator, fidelity: str = SEARCH) -> list[Evaluation]:
        """Each point's evaluation through ``evaluator`` (cached by its runs' parameters, the factors
        included)."""
        tasks = self.base.tasks(fidelity)
        items = [
            EvaluateDesign(task.with_parameters(**self.space.parameters(point)), point.order)
            for point in points
            for task in tasks
        ]
        results = evaluator.run(items)
        per = len(tasks)
        return [self.base.combine(p.order, results[i * per : (i + 1) * per]) for i, p in enumerate(points)]


@dataclass(frozen=True)
class Scored:
    """A point the search evaluated: its value (None: failed), its mass and whether it is within the budget."""

    point: CoDesignPoint
    value: float | None
    mass: float
    feasible: bool


@dataclass(frozen=True)
class SearchOutcome:
    """What the co-design search found: the best feasible point at the search fidelity and every point it scored."""

    best: Scored | None
    scored: tuple[Scored, ...]
    evaluations: int
    stop: str


def cmaes_search(
    objective: CoDesignObjective,
    evaluator,
    start_order: Sequence[int],
    budget: float,
    evaluations: int,
    seed: int = 0,
    sigma0: float = 0.2,
    fidelity: str = SEARCH,
) -> SearchOutcome:
    """CMA-ES (pycma) over the order's keys and the factors together, in [0, 1]-scaled coordinates, from
    ``start_order`` at the table's values; the mass budget is pycma's augmented-Lagrangian constraint
    (``cma.ConstrainedFitnessAL``). Stops when pycma does or before a population would pass ``evaluations``
    points (the cache's repeats count too)."""
    space = objective.space
    x0 = space.encode(space.unit_point(start_order))
    values: dict[tuple[float, ...], float] = {}
    scored: list[Scored] = []
    worst = [0.0]

    def constraint(x) -> list[float]:
        return [(space.total_mass(space.decode(x)) - budget) / budget]

    with _quiet():
        fitness = cma.ConstrainedFitnessAL(lambda x: values[tuple(x)], constraint, logging=0)
    options = {"bounds": [0.0, 1.0], "seed": seed + 1, "verbose": -9, "verb_log": 0, "maxfevals": evaluations}
    caller_state = np.random.get_state()  # pycma draws from numpy's global generator: the caller's is kept
    with _quiet():
        strategy = cma.CMAEvolutionStrategy(x0, sigma0, options)
    used = 0
    while used < evaluations:
        with _quiet():
            if strategy.stop():
                break
            xs = strategy.ask()
        if used + len(xs) > evaluations:  # pycma is told whole populations only
            break
        points = [space.decode(x) for x in xs]
        results = objective.evaluate(points, evaluator, fidelity)
        used += len(xs)
        for x, point, result in zip(xs, points, results):
            mass = space.total_mass(point)
            peak = result.value if result.ok else None
            if peak is not None:
                worst[0] = max(worst[0], float(peak))
            values[tuple(x)] = float(peak) if peak is not None else 2.0 * worst[0] + 1.0
            scored.append(
                Scored(point, None if peak is None else float(peak), mass, space.mass_excess(point, budget) == 0)
            )
        with _quiet():
            strategy.tell(xs, [fitness(x) for x in xs])
            fitness.update(strategy)
    feasible = [s for s in scored if s.feasible and s.value is not None]
    best = min(feasible, key=lambda s: s.value or 0.0) if feasible else None
    with _quiet():
        reasons = strategy.stop()
    np.random.set_state(caller_state)
    stop = ", ".join(sorted(reasons)) if reasons else f"{evaluations} evaluations"
    return SearchOutcome(best, tuple(scored), used, stop)


def repaired_order(choices: Sequence[int], materials: int) -> Design:
    """Column by column, each column's chosen material (1-based); a material an earlier column holds is replaced by
    the lowest-numbered one no column chose or holds, so the result is an arrangement of ``materials``."""
    taken: set[int] = set()
    chosen = set(int(c) for c in choices)
    spare = [m for m in range(1, materials + 1) if m not in chosen]
    order = []
    for choice in (int(c) for c in choices):
        if choice in taken:
            choice = spare.pop(0)
        taken.add(choice)
        order.append(choice)
    return as_design(order)


def mixed_ga_search(
    objective: CoDesignObjective,
    evaluator,
    start_order: Sequence[int],
    budget: float,
    evaluations: int,
    seed: int = 0,
    population: int = 40,
    fidelity: str = SEARCH,
) -> SearchOutcome:
    """pymoo's mixed-variable GA (``MixedVariableGA``): each column's material a ``Choice`` (a repeated one repaired
    by ``repaired_order``), each column's factors ``Real`` scaled coordinates in [0, 1] (as CMA-ES's), the mass
    budget an inequality constraint. Its first population holds ``start_order`` at the table's values, the rest
    random; stops before a batch would pass ``evaluations`` designs."""
    from pymoo.core.evaluator import Evaluator as PymooEvaluator
    from pymoo.core.mixed import MixedVariableGA, MixedVariableSampling
    from pymoo.core.population import Population
    from pymoo.core.problem import Problem
    from pymoo.core.variable import Choice, Real
    from pymoo.problems.static import StaticProblem

    space = objective.space
    materials = space.space.materials
    per = len(space.names)
    variables: dict[str, Choice | Real] = {}
    for j in range(space.columns):
        variables[f"material{j}"] = Choice(options=list(range(1, materials + 1)))
        for name in space.names:
            variables[f"{name}{j}"] = Real(bounds=(0.0, 1.0))
    problem = Problem(vars=variables, n_obj=1, n_ieq_constr=1)

    def point_of(x: dict) -> CoDesignPoint:
        order = repaired_order([x[f"material{j}"] for j in range(space.columns)], materials)
        return space.with_factors(
            order,
            [
                space.factor_of(float(x[f"{name}{j}"]), order[j], name)
                for j in range(space.columns)
                for name in space.names
            ],
        )

    first = MixedVariableSampling().do(problem, population, random_state=np.random.default_rng(seed)).get("X")
    start = space.encode(space.unit_point(start_order))[space.space.key_dimension :]
    first[0] = {
        **{f"material{j}": int(m) for j, m in enumerate(as_design(start_order))},
        **{f"{name}{j}": float(start[j * per + i]) for j in range(space.columns) for i, name in enumerate(space.names)},
    }
    algorithm = MixedVariableGA(pop_size=population, sampling=Population.new(X=first))
    algorithm.setup(problem, termination=("n_eval", evaluations), seed=seed, verbose=False)
    scored: list[Scored] = []
    used = 0
    worst = 0.0
    while algorithm.has_next():
        asked = algorithm.ask()
        xs = list(asked.get("X"))
        if not xs or used + len(xs) > evaluations:
            break
        points = [point_of(x) for x in xs]
        results = objective.evaluate(points, evaluator, fidelity)
        used += len(xs)
        values = []
        for point, result in zip(points, results):
            peak = float(result.value) if result.ok and result.value is not None else None
            worst = max(worst, peak or 0.0)
            values.append(peak)
            scored.append(Scored(point, peak, space.total_mass(point), space.mass_excess(point, budget) == 0))
        told = np.array([[v if v is not None else 2.0 * worst + 1.0] for v in values])
        excess = np.array([[space.mass_excess(p, budget) / budget] for p in points])
        PymooEvaluator().eval(StaticProblem(problem, F=told, G=excess), asked)
        algorithm.tell(infills=asked)
    feasible = [s for s in scored if s.feasible and s.value is not None]
    best = min(feasible, key=lambda s: s.value or 0.0) if feasible else None
    return SearchOutcome(best, tuple(scored), used, f"{evaluations} evaluations" if used else "no batch")


TRACE_OUTPUT = "backplate_force"
SAMPLE_INTERVAL = "peak_sample_interval"
SAMPLED_PEAK = "peak_backplate_force"
# a parameter's forward difference, relative to its value: between the truncation error of a larger step and the
# solver's noise divided by a smaller one at full fidelity (python -m bench.codesign_polish)
RELATIVE_STEP = 1e-4
# relative: the samples this close below the peak are the epigraph's constraints. A band, not the top K: how many
# samples compete for the peak follows the pulse's shape; wide, so that one outside rarely reaches the peak within a
# round of SLSQP (one that does starts another round, up to POLISH_ROUNDS), while the samples far below, which
# cannot decide the maximum, stay out of the QP
CANDIDATE_BAND = 0.2
ACTIVE_TOLERANCE = 1e-3  # relative: the samples this close below the peak are active in the first-order measure
POLISH_ROUNDS = 4  # SLSQP runs at most: another from the best point when a sample outside the constraints peaks
STOP_FRACTION = 0.1  # SLSQP stops at an iterate whose first-order measure is this fraction of the tolerance
BOUND_TOLERANCE = 1e-9  # a scaled coordinate this close to 0 or 1 sits on its bound


@dataclass(frozen=True)
class TraceJacobian:
    """The sampled backplate-force trace of one point and its derivatives with respect to FMU parameters."""

    times: tuple[float, ...]  # s, the sample times
    values: np.ndarray  # (S,) N, backplate force at each sample
    jacobian: np.ndarray  # (S, P) N per unit of each parameter, columns in `names` order
    names: tuple[str, ...]  # FMU parameter names, e.g. ("k[3]", "c[3]", "mass[3]", ...)
    evaluations: int  # FMU runs it took


TraceJacobianSource = Callable[[CoDesignObjective, Any, CoDesignPoint, tuple[str, ...], str, float], TraceJacobian]
"""``(objective, evaluator, point, names, fidelity, relative_step) -> TraceJacobian``: where the polish's
gradients come from."""


def minimax_refusal(objective: CoDesignObjective) -> str | None:
    """Why the objective's value is not a maximum over the samples of the backplate-force trace (so the epigraph
    polish does not apply), or None: the sampled peak of one load case, or the worst over several."""
    base = objective.base
    if base.outputs[0] != SAMPLED_PEAK:
        return f"the objective {base.outputs[0]} is not the sampled peak ({SAMPLED_PEAK})"
    if len(base.cases) > 1 and base.aggregate != "worst":
        return f"the {base.aggregate} over load cases is not a maximum over samples (the worst over them is)"
    return missing_output(base.fmu_path, (TRACE_OUTPUT,))


def trace_runs(
    objective: CoDesignObjective, order: Sequence[int], parameters: dict[str, float], fidelity: str
) -> list[RecordRun]:
    """The runs recording the backplate force at each sample of the peak, one per load case, with ``fidelity``'s
    settings and ``parameters`` set, over the whole horizon the value is a maximum over."""
    refusal = minimax_refusal(objective)
    if refusal is not None:
        raise ValueError(f"the polish's trace: {refusal}")
    runs = []
    for task in objective.base.tasks(fidelity):
        settings = {**dict(task.parameters), **parameters}
        interval = settings.get(SAMPLE_INTERVAL)
        if interval is None:
            interval = declared_parameters(model_description(task.fmu_path))[SAMPLE_INTERVAL].start
        runs.append(
            RecordRun(
                task.fmu_path,
                as_design(order),
                task.fallback_horizon or task.horizon,
                float(interval),
                tuple(sorted(settings.items())),
                (TRACE_OUTPUT,),
                task.fmu_sha256,
            )
        )
    return runs


def sampled_traces(
    objective: CoDesignObjective,
    evaluator,
    order: Sequence[int],
    parameter_sets: Sequence[dict[str, float]],
    fidelity: str,
) -> list[tuple[tuple[float, ...], np.ndarray]]:
    """Each parameter set's sample times and backplate force at them (the load cases' traces one after the
    other), through ``evaluator`` (cached and journalled like every run)."""
    runs = [trace_runs(objective, order, parameters, fidelity) for parameters in parameter_sets]
    results = evaluator.run([run for per_set in runs for run in per_set])
    traces = []
    index = 0
    for per_set in runs:
        recorded = results[index : index + len(per_set)]
        index += len(per_set)
        for trajectory in recorded:
            if not trajectory.ok:
                raise RuntimeError(f"the polish's recorded run of {list(order)} failed: {trajectory.message}")
        times = tuple(t for trajectory in recorded for t in trajectory.time)
        values = np.concatenate([np.asarray(trajectory.values[TRACE_OUTPUT], dtype=float) for trajectory in recorded])
        traces.append((times, values))
    return traces


def _at_upper_end(space: CoDesignSpace, point: CoDesignPoint, name: str, relative_step: float) -> bool:
    """Would a forward step of ``relative_step`` take the FMU parameter ``name`` (``property[material]``) past
    its column's factor range (the range the CoDesign step checks against the FMU's declared ones)?"""
    prop, _, rest = name.partition("[")
    material = int(rest.rstrip("]")) if rest.rstrip("]").isdigit() else 0
    if prop not in space.names or material not in point.order:
        return False
    factor = point.factors[point.order.index(material)][space.names.index(prop)]
    return factor * (1.0 + relative_step) > space.factor_range(material, prop)[1]


def finite_difference_jacobian(
    objective: CoDesignObjective,
    evaluator,
    point: CoDesignPoint,
    names: tuple[str, ...],
    fidelity: str,
    relative_step: float = RELATIVE_STEP,
) -> TraceJacobian:
    """Forward differences of the point's sampled trace per FMU parameter of ``names``, each moved by
    ``relative_step`` of its value (backwards where that would leave its factor range): one recorded run per
    parameter and load case beyond the point's own."""
    if not (math.isfinite(relative_step) and 0 < relative_step < 1):
        raise ValueError(f"relative_step must be a number in (0, 1), got {relative_step!r}")
    space = objective.space
    base = space.parameters(point)
    unknown = next((name for name in names if name not in base), None)
    if unknown is not None:
        raise ValueError(f"finite_difference_jacobian: {unknown!r} is not set by the point; allowed: {', '.join(base)}")
    moved = []
    steps = []
    for name in names:
        sign = -1.0 if _at_upper_end(space, point, name, relative_step) else 1.0
        shifted = base[name] + sign * relative_step * (abs(base[name]) or 1.0)
        moved.append({**base, name: shifted})
        steps.append(shifted - base[name])  # the step the run took, after rounding
    (times, values), *others = sampled_traces(objective, evaluator, point.order, [base, *moved], fidelity)
    jacobian = (
        np.column_stack([(other - values) / step for (_, other), step in zip(others, steps)])
        if names
        else np.zeros((len(values), 0))
    )
    runs = len(objective.base.tasks(fidelity)) * (1 + len(names))
    return TraceJacobian(times, values, jacobian, tuple(names), runs)


@dataclass(frozen=True)
class Stationarity:
    """First-order optimality of min over z of max_s F_s(z) at a point: the residual of least length of the
    projected ``sum_s lambda_s grad F_s + mu grad mass`` and the multipliers giving it."""

    residual: float  # its largest component
    sample_multipliers: tuple[float, ...]  # lambda_s >= 0, summing to 1, one per sample given
    mass_multiplier: float  # mu >= 0 (0 without the constraint)


def minimax_stationarity(
    gradients: np.ndarray, z: np.ndarray, constraint_gradient: np.ndarray | None = None
) -> Stationarity:
    """The KKT conditions of the epigraph problem (Clarke stationarity of the maximum) at ``z`` in [0, 1]^n:
    min over lambda >= 0 with sum 1 and mu >= 0 of the length of the projected ``gradients.T @ lambda + mu *
    constraint_gradient`` (``gradients``: one row per active sample; the constraint's gradient where it binds,
    pointing out of the feasible side); a component at a bound counts only when it points into the box (the
    bound's own multiplier takes the rest). scipy's NNLS, the sum of lambda a heavily weighted row."""
    gradients = np.atleast_2d(np.asarray(gradients, dtype=float))
    z = np.asarray(z, dtype=float)
    samples, n = gradients.shape
    lower = z <= BOUND_TOLERANCE
    upper = z >= 1.0 - BOUND_TOLERANCE
    blocks = [gradients.T]
    if constraint_gradient is not None:
        blocks.append(np.asarray(constraint_gradient, dtype=float).reshape(n, 1))
    identity = np.eye(n)
    blocks += [-identity[:, lower], identity[:, upper]]
    matrix = np.hstack(blocks)
    weight = 1e3 * max(1.0, float(np.max(np.abs(matrix))) if matrix.size else 1.0)
    row = np.zeros(matrix.shape[1])
    row[:samples] = weight
    solution, _ = nnls(np.vstack([matrix, row]), np.append(np.zeros(n), weight), maxiter=50 * matrix.shape[1])
    weights = solution[:samples] / np.sum(solution[:samples])
    mass_multiplier = float(solution[samples]) if constraint_gradient is not None else 0.0
    combined = gradients.T @ weights
    if constraint_gradient is not None:
        combined = combined + mass_multiplier * np.asarray(constraint_gradient, dtype=float)
    projected = np.where(lower, np.minimum(combined, 0.0), np.where(upper, np.maximum(combined, 0.0), combined))
    return Stationarity(
        float(np.max(np.abs(projected))) if n else 0.0, tuple(float(w) for w in weights), mass_multiplier
    )


def scaled_parameter_names(space: CoDesignSpace, order: Sequence[int]) -> tuple[str, ...]:
    """The FMU parameter each scaled factor coordinate of ``order`` sets, in the coordinates' order (column by
    column, property by property): ``("k[3]", "c[3]", "mass[3]", ...)``."""
    return tuple(f"{name}[{material}]" for material in as_design(order) for name in space.names)


def scaled_gradients(space: CoDesignSpace, point: CoDesignPoint, found: TraceJacobian) -> np.ndarray:
    """``found``'s derivatives per FMU parameter as d F_s / d z per scaled factor coordinate (one row per sample):
    each parameter is its table value times exp(z log_span) of its range, so d parameter / d z = parameter *
    log_span."""
    names = scaled_parameter_names(space, point.order)
    if tuple(found.names) != names:
        raise ValueError(f"the trace's jacobian has columns {found.names}; the polish needs {names}")
    parameters = space.parameters(point)
    spans = [space.log_span(material, name) for material in point.order for name in space.names]
    chain = np.array([parameters[name] * span for name, span in zip(names, spans)])
    return np.asarray(found.jacobian, dtype=float) * chain[None, :]


@dataclass(frozen=True)
class FirstOrder:
    """The minimax problem's first-order measure at a point: over its active samples, and the peak's alone."""

    stationarity: Stationarity  # over the active samples
    smooth: Stationarity  # the peak's sample alone: the smooth measure, which a tie of samples keeps large
    active: tuple[int, ...]  # the active samples' indices, highest value first


def first_order_measure(
    values: np.ndarray,
    gradients: np.ndarray,
    z: np.ndarray,
    constraint_gradient: np.ndarray | None = None,
    active_tolerance: float = ACTIVE_TOLERANCE,
) -> FirstOrder:
    """``minimax_stationarity`` of max_s F_s at ``z`` over the samples within ``active_tolerance`` of the peak
    (relative), the gradients (d F_s / d z, one row per sample) relative to the peak's value."""
    values = np.asarray(values, dtype=float)
    peak = float(np.max(values))
    ranked = np.argsort(-values, kind="stable")
    active = tuple(int(s) for s in ranked if values[s] >= peak - active_tolerance * abs(peak))
    relative = np.asarray(gradients, dtype=float) / (abs(peak) or 1.0)
    return FirstOrder(
        minimax_stationarity(relative[list(active)], z, constraint_gradient),
        minimax_stationarity(relative[list(active[:1])], z, constraint_gradient),
        active,
    )


@dataclass(frozen=True)
class Polish:
    """The polish of the continuous part at a fixed order: SLSQP on the epigraph of the sampled peak (min t with
    every sample near the peak at most t) from ``start`` to ``end`` (values at the fidelity it ran at), the
    first-order optimality of that minimax problem at the end and the tolerance it was asked to meet."""

    start: CoDesignPoint
    end: CoDesignPoint
    start_value: float
    end_value: float
    # the minimax problem's first-order measure (``minimax_stationarity``) over the active samples: the largest
    # component of the projected sum_s lambda_s grad F_s + mu grad mass, relative to the value, per unit of scaled x
    kkt_residual: float
    # the same with the peak's sample alone: the smooth measure, which a tie of samples keeps large
    smooth_residual: float
    tolerance: float
    active_tolerance: float  # relative: a sample this close below the peak is active
    active_times: tuple[float, ...]  # s: the active samples' times, highest force first
    sample_multipliers: tuple[float, ...]  # each active sample's lambda_s (summing to 1)
    multiplier: float  # the mass constraint's mu at the end (N per unit of the constraint relative to the budget)
    active: bool  # the mass constraint binds at the end
    iterations: int  # SLSQP's, over its rounds
    rounds: int  # SLSQP runs: another when a sample outside the constraints became the peak
    evaluations: int  # FMU runs it simulated (the evaluator's cache hits not counted)
    message: str
    # at the end, d value / d ln(factor) per column and varied property: the multiplier-weighted gradient of the
    # active samples (the subgradient the first-order conditions pick), how much a relative change of each
    # layer's property moves the value
    sensitivities: tuple[tuple[float, ...], ...] = ()

    @property
    def converged(self) -> bool:
        """The first-order conditions of the minimax problem hold within the tolerance."""
        return self.kkt_residual <= self.tolerance


def polish(
    objective: CoDesignObjective,
    evaluator,
    start: CoDesignPoint,
    budget: float,
    fidelity: str,
    tolerance: float = 1e-2,
    iterations: int = 30,
    jacobian: TraceJacobianSource = finite_difference_jacobian,
    relative_step: float = RELATIVE_STEP,
) -> Polish:
    """SLSQP on ``(z, t)``, the factors of ``start``'s order in scaled coordinates z in [0, 1] and the epigraph's
    t: minimise t with F_s(z) <= t for each sample s of the backplate-force trace within ``CANDIDATE_BAND`` of the
    peak, the mass budget an inequality with its exact gradient. The samples' gradients come from ``jacobian``
    (d F_s / d parameter, chained to z: d parameter / d z = parameter * log_span). Each iterate, scaled onto the
    budget where SLSQP left it a hair above, is kept when it lowers the peak; SLSQP stops at an iterate whose
    first-order measure is ``STOP_FRACTION`` of ``tolerance``, or at its own end, and runs again from the best
    point with the samples chosen afresh when one outside them peaks there. At the end, the first-order optimality
    of the minimax problem (``first_order_measure``: the samples within ``ACTIVE_TOLERANCE`` of the peak) against
    ``tolerance``."""
    refusal = minimax_refusal(objective)
    if refusal is not None:
        raise ValueError(f"the polish: {refusal}")
    space = objective.space
    order = start.order
    per = len(space.names)
    z0 = space.encode(start)[space.space.key_dimension :]
    materials = [order[i // per] for i in range(len(z0))]
    properties = [space.names[i % per] for i in range(len(z0))]
    parameter_names = scaled_parameter_names(space, order)
    spans = np.array([space.log_span(m, name) for m, name in zip(materials, properties)])
    simulated = evaluator.state().simulated

    def point_of(z: np.ndarray) -> CoDesignPoint:
        return space.with_factors(order, [space.factor_of(v, m, name) for v, m, name in zip(z, materials, properties)])

    traces: dict[tuple[float, ...], np.ndarray] = {}
    gradients: dict[tuple[float, ...], np.ndarray] = {}

    def trace(z: np.ndarray) -> np.ndarray:
        key = tuple(float(v) for v in z)
        if key not in traces:
            ((_, values),) = sampled_traces(objective, evaluator, order, [space.parameters(point_of(z))], fidelity)
            traces[key] = values
        return traces[key]

    def gradient(z: np.ndarray) -> np.ndarray:
        """d F_s / d z, one row per sample."""
        key = tuple(float(v) for v in z)
        if key not in gradients:
            point = point_of(z)
            found = jacobian(objective, evaluator, point, parameter_names, fidelity, relative_step)
            gradients[key] = scaled_gradients(space, point, found)
        return gradients[key]

    mass_indices = [i for i, name in enumerate(properties) if name == MASS]

    def mass_slack(z: np.ndarray) -> float:  # >= 0 within the budget, relative to it
        return (budget - space.total_mass(point_of(np.asarray(z)))) / budget

    def mass_slack_gradient(z: np.ndarray) -> np.ndarray:
        gradient = np.zeros(len(z))
        for index in mass_indices:
            material = materials[index]
            base = getattr(space.table.materials[material - 1], MASS)
            factor = space.factor_of(z[index], material, MASS)
            gradient[index] = -space.masses_per_column * base * factor * spans[index] / budget
        return gradient

    def feasible(z: np.ndarray) -> bool:
        return not mass_indices or mass_slack(z) >= -MASS_TOLERANCE

    def within_budget(z: np.ndarray) -> np.ndarray:
        """``z`` with its mass factors scaled down together onto the budget where it lies above it (SLSQP meets a
        constraint to its own tolerance only): those strictly inside their range (a factor on a bound stays on it,
        as the first-order conditions see it), else every one above its lower end; the stack's mass is linear in
        them, so the scaling is exact but for a factor it takes to its lower end, which the next pass leaves out."""
        repaired = np.array(z, dtype=float)
        for _ in range(len(mass_indices)):
            excess = space.total_mass(point_of(repaired)) - budget
            if excess <= MASS_TOLERANCE * budget:
                break
            free = [i for i in mass_indices if BOUND_TOLERANCE < repaired[i] < 1.0 - BOUND_TOLERANCE] or [
                i for i in mass_indices if repaired[i] > 0.0
            ]
            if not free:
                break
            held = math.fsum(
                space.masses_per_column * space.value(point_of(repaired), i // per + 1, MASS) for i in free
            )
            ratio = max(held - excess, 0.0) / held
            for i in free:
                repaired[i] = max(0.0, repaired[i] + math.log(ratio) / spans[i]) if ratio > 0 else 0.0
        return repaired

    def measured(z: np.ndarray) -> FirstOrder:
        """The minimax measure at ``z`` (the budget's gradient where it binds)."""
        return first_order_measure(trace(z), gradient(z), z, -mass_slack_gradient(z) if binding(z) else None)

    def binding(z: np.ndarray) -> bool:
        return bool(mass_indices) and mass_slack(z) <= 1e-6

    start_value = float(np.max(trace(z0)))
    scale = abs(start_value) or 1.0
    best, best_value = z0, start_value

    def keep_if_better(z: np.ndarray) -> bool:
        """Keeps ``z`` (onto the budget) as the best point when it is within the budget and lowers the value."""
        nonlocal best, best_value
        repaired = within_budget(np.clip(np.asarray(z, dtype=float), 0.0, 1.0))
        value = float(np.max(trace(repaired)))
        if feasible(repaired) and value < best_value:
            best, best_value = repaired, value
            return True
        return False

    count = len(z0)
    last = np.append(np.zeros(count), 1.0)
    steps = 0
    rounds = 0
    met = measured(z0).stationarity.residual <= tolerance
    message = "its start meets the first-order conditions" if met else ""
    stopped = [False]
    while not met and rounds < POLISH_ROUNDS:
        rounds += 1
        values = trace(best)
        peak = float(np.max(values))
        chosen = np.flatnonzero(values >= peak - CANDIDATE_BAND * abs(peak))

        def below_peak(x: np.ndarray, chosen=chosen) -> np.ndarray:  # t - F_s(z) >= 0, relative to the start
            return x[-1] - trace(x[:-1])[chosen] / scale

        def below_peak_gradient(x: np.ndarray, chosen=chosen) -> np.ndarray:
            return np.hstack([-gradient(x[:-1])[chosen] / scale, np.ones((len(chosen), 1))])

        def stop_when_met(intermediate_result) -> None:
            """Each iterate, onto the budget, may be the best; SLSQP stops at a stationary one (measured where
            SLSQP's own gradients were taken)."""
            iterate = np.clip(np.asarray(intermediate_result.x[:-1], dtype=float), 0.0, 1.0)
            if keep_if_better(iterate) and measured(iterate).stationarity.residual <= STOP_FRACTION * tolerance:
                stopped[0] = True
                raise StopIteration

        constraints = [{"type": "ineq", "fun": below_peak, "jac": below_peak_gradient}]
        if mass_indices:
            constraints.append(
                {
                    "type": "ineq",
                    "fun": lambda x: mass_slack(x[:-1]),
                    "jac": lambda x: np.append(mass_slack_gradient(x[:-1]), 0.0),
                }
            )
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            result = minimize(
                lambda x: x[-1],
                np.append(best, peak / scale),
                jac=lambda x: last,
                method="SLSQP",
                bounds=[(0.0, 1.0)] * count + [(None, None)],
                constraints=constraints,
                callback=stop_when_met,
                options={"maxiter": iterations, "ftol": 1e-9},
            )
        steps += int(getattr(result, "nit", 0))
        message = "stopped where the first-order conditions hold" if stopped[0] else str(result.message)
        keep_if_better(result.x[:-1])
        ended = trace(best)
        met = measured(best).stationarity.residual <= tolerance
        outside = np.delete(ended, chosen)
        if not outside.size or float(np.max(outside)) <= float(np.max(ended[chosen])):
            break  # the peak is among the constraints: SLSQP saw the whole maximum

    z = best
    peak = float(np.max(trace(z)))
    final = measured(z)
    measure, active_samples = final.stationarity, list(final.active)
    times = sampled_traces(objective, evaluator, order, [space.parameters(point_of(z))], fidelity)[0][0]
    weighted = np.asarray(measure.sample_multipliers) @ gradient(z)[active_samples] / spans
    return Polish(
        start=start,
        end=point_of(z),
        start_value=start_value,
        end_value=peak,
        kkt_residual=measure.residual,
        smooth_residual=final.smooth.residual,
        tolerance=tolerance,
        active_tolerance=ACTIVE_TOLERANCE,
        active_times=tuple(float(times[s]) for s in active_samples),
        sample_multipliers=measure.sample_multipliers,
        multiplier=measure.mass_multiplier * (abs(peak) or 1.0),
        active=binding(z),
        iterations=steps,
        rounds=rounds,
        evaluations=evaluator.state().simulated - simulated,
        message=message,
        sensitivities=tuple(
            tuple(float(weighted[column * per + i]) for i in range(per)) for column in range(space.columns)
        ),
    )


@dataclass(frozen=True)
class FrontDesign:
    """A design on the co-design front: its values at the search fidelity (what the front is chosen by) and at
    full fidelity (what is reported), one per objective."""

    point: CoDesignPoint
    search_values: tuple[float, ...]
    full_values: tuple[float, ...] | None  # None: its full-fidelity run failed


@dataclass(frozen=True)
class CoDesignFront:
    """The front of the objectives (the peak against the stack's mass) over order and factors: the designs within
    the mass budget that no other design NSGA-II evaluated within it dominates at the search fidelity, by the
    first objective."""

    designs: tuple[FrontDesign, ...]
    evaluated: tuple[tuple[float, ...], ...]  # every evaluated design's values within the budget, search fidelity
    evaluations: int
    mass_range: tuple[float, float]  # kg: the lightest design the factors allow, and the front's upper end


MASS_PROFILES = ("even", "impact_side_first", "back_first")
"""How a mass ladder's designs share their mass among the columns: every column at one scaled coordinate, or the
columns filled to their heaviest one after the other from column 1 (the loaded face), or from the last column."""


def mass_range(space: CoDesignSpace, order: Sequence[int], budget: float | None) -> tuple[float, float]:
    """The stack masses ``order``'s designs span (kg): every mass factor at its range's lower end, and at its upper
    end or the budget, whichever is lighter (without a varied mass, the order's own mass at both ends)."""
    lightest = space.total_mass(_mass_at(space, order, 0.0, MASS_PROFILES[0]))
    heaviest = space.total_mass(_mass_at(space, order, 1.0, MASS_PROFILES[0]))
    return lightest, heaviest if budget is None else max(lightest, min(heaviest, float(budget)))


def mass_ladder(
    space: CoDesignSpace, order: Sequence[int], budget: float | None, count: int, profile: str = MASS_PROFILES[0]
) -> list[CoDesignPoint]:
    """``count`` designs of ``order`` whose stack masses are evenly spaced over its mass range (``mass_range``),
    the mass shared among the columns as ``profile`` (one of ``MASS_PROFILES``) says, found by bisection (the mass
    grows along the profile), every other property at the table's value: seeds that make NSGA-II's first
    population span the masses."""
    if profile not in MASS_PROFILES:
        raise ValueError(f"profile {profile!r}: allowed values are {', '.join(MASS_PROFILES)}")
    if MASS not in space.names or count < 1:
        return []
    low, high = mass_range(space, order, budget)
    targets = [low] if count == 1 else [low + (high - low) * i / (count - 1) for i in range(count)]
    ladder = []
    for target in targets:
        below, above = 0.0, 1.0
        for _ in range(60):
            middle = 0.5 * (below + above)
            if space.total_mass(_mass_at(space, order, middle, profile)) <= target:
                below = middle
            else:
                above = middle
        ladder.append(_mass_at(space, order, below, profile))
    return ladder


def _mass_at(space: CoDesignSpace, order: Sequence[int], along: float, profile: str) -> CoDesignPoint:
    """``order`` with its columns' masses at ``along`` (0: the lightest, 1: the heaviest) of ``profile`` and every
    other property at its table value."""
    order = as_design(order)
    count = len(order)

    def scaled(column: int) -> float:  # column counts from 0
        if profile == "even":
            return along
        filled = column if profile == "impact_side_first" else count - 1 - column
        return min(1.0, max(0.0, along * count - filled))

    return CoDesignPoint(
        order,
        tuple(
            tuple(space.factor_of(scaled(column), material, name) if name == MASS else 1.0 for name in space.names)
            for column, material in enumerate(order)
        ),
    )


def nsga2_front(
    objective: CoDesignObjective,
    evaluator,
    start_order: Sequence[int],
    evaluations: int,
    seed: int = 0,
    population: int = 40,
    mass_budget: float | None = None,
    seeds: Sequence[CoDesignPoint] = (),
) -> CoDesignFront:
    """pymoo's NSGA-II over the order's keys and the factors in [0, 1]-scaled coordinates, every objective of
    ``objective``'s lattice objective minimised, the stack's mass at most ``mass_budget`` (kg; None: the factors'
    whole range) as an inequality constraint. Its first population holds ``seeds`` (e.g. the co-design's answer),
    ``start_order`` at the table's values and, with the mass varied, about half a population of designs of
    ``start_order`` and of the space's baseline order at evenly spaced masses from the lightest to the front's
    upper end, the mass shared among the columns in each of ``MASS_PROFILES``'s ways (``mass_ladder``), the rest
    random; the front is the non-dominated set of every design it evaluated within the budget, then evaluated at
    full fidelity."""
    from pymoo.algorithms.moo.nsga2 import NSGA2
    from pymoo.core.evaluator import Evaluator as PymooEvaluator
    from pymoo.core.problem import Problem
    from pymoo.problems.static import StaticProblem

    from .search.pareto import non_dominated

    space = objective.space
    rng = np.random.default_rng(seed)
    first = rng.random((population, space.dimension))
    seeded: list[np.ndarray] = []  # distinct rows only: pymoo drops a repeated one, shrinking the population
    orders = list(dict.fromkeys([as_design(start_order), space.space.baseline()]))
    rungs = population // (2 * len(MASS_PROFILES) * len(orders)) + 1
    ladders = [
        point
        for order in orders
        for profile in MASS_PROFILES
        for point in mass_ladder(space, order, mass_budget, rungs, profile)
    ]
    for point in [*seeds, space.unit_point(start_order), *ladders]:
        x = space.encode(point)
        if len(seeded) < population and all(np.max(np.abs(x - other)) > 1e-9 for other in seeded):
            seeded.append(x)
    first[: len(seeded)] = seeded
    budget = math.inf if mass_budget is None else float(mass_budget)
    problem = Problem(n_var=space.dimension, n_obj=objective.base.n_objectives, n_ieq_constr=1, xl=0.0, xu=1.0)
    algorithm = NSGA2(pop_size=population, sampling=first)
    algorithm.setup(problem, termination=("n_eval", evaluations), seed=seed, verbose=False)
    points: list[CoDesignPoint] = []
    values: list[tuple[float, ...]] = []
    used = 0
    while algorithm.has_next() and used < evaluations:
        asked = algorithm.ask()
        xs = asked.get("X")
        batch = [space.decode(x) for x in xs]
        results = objective.evaluate(batch, evaluator, SEARCH)
        used += len(batch)
        told = []
        excess = []
        for point, result in zip(batch, results):
            over = space.mass_excess(point, budget) if math.isfinite(budget) else 0.0
            excess.append([over / budget if math.isfinite(budget) else 0.0])
            if result.ok and result.value is not None:
                own = tuple(float(v) for v in (result.values or (result.value,)))
                if over == 0.0:
                    points.append(point)
                    values.append(own)
                told.append(own)
            else:  # a failed design ranks behind every evaluated one
                told.append(tuple(math.inf for _ in range(problem.n_obj)))
        finite = [row for row in told if not any(math.isinf(v) for v in row)]
        worst = np.max(np.array(finite), axis=0) if finite else np.ones(problem.n_obj)
        told_matrix = np.array([[w * 2 + 1 if math.isinf(v) else v for v, w in zip(row, worst)] for row in told])
        PymooEvaluator().eval(StaticProblem(problem, F=told_matrix, G=np.array(excess)), asked)
        algorithm.tell(infills=asked)
    span = mass_range(space, start_order, mass_budget)
    if not values:
        return CoDesignFront((), (), used, span)
    mask = non_dominated(values)
    chosen = sorted((i for i in range(len(values)) if mask[i]), key=lambda i: values[i])
    unique = list({points[i]: i for i in chosen}.values())
    full = objective.evaluate([points[i] for i in unique], evaluator, FULL)
    designs = tuple(
        FrontDesign(
            points[i],
            values[i],
            tuple(float(v) for v in (e.values or (e.value,))) if e.ok and e.value is not None else None,
        )
        for i, e in zip(unique, full)
    )
    return CoDesignFront(designs, tuple(values), used, span)


@contextlib.contextmanager
def _quiet():
    """pycma's console notes and warnings stay out of the run's output, and its augmented Lagrangian makes no log
    folder in the working folder (pycma's own switch: its constraints handler's logger replaced by the dummy)."""
    handler = cma.constraints_handler
    logger = handler._Logger
    handler._Logger = cma.logger.LoggerDummy
    try:
        with warnings.catch_warnings(), contextlib.redirect_stdout(io.StringIO()):
            warnings.simplefilter("ignore")
            yield
    finally:
        handler._Logger = logger


__all__ = [
    "CoDesignFront",
    "CoDesignObjective",
    "CoDesignPoint",
    "CoDesignSpace",
    "ColumnProperties",
    "DEFAULT_RANGE",
    "FirstOrder",
    "FrontDesign",
    "MASS_PROFILES",
    "Polish",
    "Scored",
    "Stationarity",
    "TraceJacobian",
    "SearchOutcome",
    "cmaes_search",
    "finite_difference_jacobian",
    "first_order_measure",
    "mass_ladder",
    "mass_range",
    "minimax_refusal",
    "minimax_stationarity",
    "mixed_ga_search",
    "nsga2_front",
    "parse_vary",
    "parse_vary_range",
    "polish",
    "repaired_order",
    "sampled_traces",
    "scaled_gradients",
    "scaled_parameter_names",
    "table_columns",
    "trace_runs",
]
