"""The co-design polish's gradient from the FMU's forward sensitivity, the other source beside finite differences.

The FMU integrates, with a run's state, its derivative along a direction of the materials' properties given by
the seeds ``d_<property>[m]`` (docs/fmu-reference.md), and records ``backplate_force_derivative`` with
``backplate_force``. A unit seed on one parameter gives that parameter's column of the trace's Jacobian: one
recorded run per parameter (and load case), where forward differences take one per parameter and one more for
the point itself. ``directional_jacobian`` has ``finite_difference_jacobian``'s signature
(``orchestrator.codesign.TraceJacobianSource``), so the polish takes either.
"""

from __future__ import annotations

import dataclasses
from typing import Sequence

import numpy as np

from fmu_src.materials import FIELD_NAMES
from fmu_src.variables import seed_name

from .codesign import TRACE_OUTPUT, CoDesignObjective, CoDesignPoint, TraceJacobian, trace_runs
from .objective import missing_output

DERIVATIVE_OUTPUT = "backplate_force_derivative"


def seed_of(name: str) -> str:
    """The seed of FMU parameter ``name`` (``k[3]`` -> ``d_k[3]``); refuses a name that is no material's
    property in one line."""
    prop, bracket, rest = name.partition("[")
    if prop not in FIELD_NAMES or not bracket or not rest.endswith("]") or not rest[:-1].isdigit():
        raise ValueError(
            f"directional_jacobian: {name!r} is not a material's property; allowed: property[m] with property one "
            f"of {', '.join(FIELD_NAMES)}"
        )
    return f"{seed_name(prop)}[{rest}"


def directional_jacobian(
    objective: CoDesignObjective,
    evaluator,
    point: CoDesignPoint,
    names: Sequence[str],
    fidelity: str,
    relative_step: float | None = None,
) -> TraceJacobian:
    """The point's sampled backplate-force trace and its derivative per FMU parameter of ``names`` (``k[3]``, ...),
    each from one recorded run per load case with that parameter's seed 1 (the trace itself is each of these runs'
    own: a seed leaves it as it is), through ``evaluator`` (cached and journalled like every run).
    ``relative_step`` is taken for the polish's sake and not used: the FMU chooses its own quotient's step."""
    del relative_step
    names = tuple(names)
    seeds = [seed_of(name) for name in names]
    refusal = missing_output(objective.base.fmu_path, (DERIVATIVE_OUTPUT,))
    if refusal is not None:
        raise ValueError(f"directional_jacobian: the FMU has no forward sensitivity ({refusal}): rebuild it")
    base = objective.space.parameters(point)
    unknown = next((name for name in names if name not in base), None)
    if unknown is not None:
        raise ValueError(f"directional_jacobian: {unknown!r} is not set by the point; allowed: {', '.join(base)}")
    seeded = [{**base, seed: 1.0} for seed in seeds] or [base]  # without a parameter: the trace alone
    runs = [
        [
            dataclasses.replace(run, outputs=(TRACE_OUTPUT, DERIVATIVE_OUTPUT))
            for run in trace_runs(objective, point.order, parameters, fidelity)
        ]
        for parameters in seeded
    ]
    results = evaluator.run([run for per_parameter in runs for run in per_parameter])
    for trajectory in results:
        if not trajectory.ok:
            raise RuntimeError(f"the sensitivity's recorded run of {list(point.order)} failed: {trajectory.message}")
    cases = len(runs[0])
    per_parameter = [results[i * cases : (i + 1) * cases] for i in range(len(seeded))]
    first = per_parameter[0]
    times = tuple(t for trajectory in first for t in trajectory.time)
    values = np.concatenate([np.asarray(trajectory.values[TRACE_OUTPUT], dtype=float) for trajectory in first])
    columns = [
        np.concatenate([np.asarray(trajectory.values[DERIVATIVE_OUTPUT], dtype=float) for trajectory in recorded])
        for recorded in per_parameter
    ]
    jacobian = np.column_stack(columns) if names else np.zeros((len(values), 0))
    return TraceJacobian(times, values, jacobian, names, len(results))


__all__ = ["DERIVATIVE_OUTPUT", "directional_jacobian", "seed_of"]
