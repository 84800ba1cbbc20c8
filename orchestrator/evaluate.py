"""The FMU as an objective for the searches: order in, Evaluation out, one FMU instance per process.

`FMUObjective` is a small frozen dataclass, so it pickles to any executor (a process pool, a Dask
worker); each process opens the FMU once (extract, instantiate) and resets it between orders.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

from .simulation import COUNTER_OUTPUTS, ENERGY_OUTPUTS, PEAK_OUTPUTS, LatticeFMU, SimulationError
from .types import OK, Evaluation, Order, failed

OBJECTIVES = {
    "sampled": "peak_backplate_force",  # the study's 0.01 s samples: reproduces its numbers
    "continuous": "peak_backplate_force_continuous",  # the true maximum of the continuous solution
}

CONTACT_GUARD = 0.1  # fraction of the horizon at its end that must be free of contact
_INSTANCES: dict[str, LatticeFMU] = {}  # one per FMU file and process


def fmu_instance(fmu_path: str) -> LatticeFMU:
    """This process's instance of the FMU (opened on first use, then reused with fmi2Reset)."""
    instance = _INSTANCES.get(fmu_path)
    if instance is None:
        instance = _INSTANCES[fmu_path] = LatticeFMU(fmu_path, instance_name="objective")
    return instance


def objective_output(objective: str) -> str:
    try:
        return OBJECTIVES[objective]
    except KeyError:
        raise ValueError(f"objective {objective!r}: allowed values are {sorted(OBJECTIVES)}") from None


@dataclass(frozen=True)
class FMUObjective:
    """Peak backplate force of an order, simulated by the FMU over `horizon` seconds.

    `parameters` are FMU parameters as (name, value) pairs (hashable, so the objective can be a cache
    key). Both peaks are kept in `details` whichever is optimised, so a report can show both.

    A short horizon is only trusted when the lattice left the plate well before it: if a column-C mass
    touched the plate in the last CONTACT_GUARD of the horizon, the order is simulated again over
    `fallback_horizon` (details["horizon"] says which was used).
    """

    fmu_path: str
    horizon: float = 8.0
    objective: str = "sampled"
    parameters: tuple = field(default=())
    fallback_horizon: float | None = None  # when the lattice still touches the plate near the horizon

    def __post_init__(self):
        objective_output(self.objective)
        if not self.horizon > 0:
            raise ValueError(f"horizon must be > 0 s, got {self.horizon}")

    def with_horizon(self, horizon: float, **parameters) -> "FMUObjective":
        merged = dict(self.parameters)
        merged.update(parameters)
        return FMUObjective(self.fmu_path, horizon, self.objective, tuple(sorted(merged.items())))

    def simulate(self, order: Order, horizon: float | None = None) -> dict:
        return fmu_instance(self.fmu_path).simulate(
            order, horizon=horizon or self.horizon, parameters=dict(self.parameters),
            outputs=PEAK_OUTPUTS + ENERGY_OUTPUTS + COUNTER_OUTPUTS + ("last_contact_time",))

    def __call__(self, order: Order) -> Evaluation:
        start = time.perf_counter()
        horizon = self.horizon
        try:
            result = self.simulate(order)
            if self.fallback_horizon and result["last_contact_time"] >= (1.0 - CONTACT_GUARD) * horizon:
                horizon = max(self.fallback_horizon, horizon)
                result = self.simulate(order, horizon)
        except (SimulationError, ValueError) as exc:
            return failed(order, str(exc), time.perf_counter() - start)
        seconds = time.perf_counter() - start
        details = {
            "peak_sampled": result["peak_backplate_force"],
            "peak_continuous": result["peak_backplate_force_continuous"],
            "peak_time": result["peak_time"],
            "last_contact_time": result["last_contact_time"],
            "energy_balance_error": result["energy_balance_error"],
            "external_work": result["external_work"],
            "rhs_evaluations": result["rhs_evaluations"],
            "horizon": horizon,
        }
        return Evaluation(tuple(order), float(result[objective_output(self.objective)]), OK, "", seconds, details)
