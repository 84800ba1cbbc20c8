"""The variable table of a small model folder (fmu_src/projectile/, fmu_src/hull/): the one source of its names,
causalities, units, defaults, ranges, value references and outputs' input dependencies, for its C header and both
model descriptions, as fmu_src/variables.py is the lattice's.

A table answers what builder/fmi2_description.py and builder/fmi3_description.py ask of the lattice's Interface
(exposed, fixed, value_references, state_offsets, event_indicator_count) and what they ask of a scene
(description, horizon, communication_step), so the lattice's generators write its model descriptions too. The
lattice's table is sized by a scene; a component's is fixed, so it is one module-level ComponentTable.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass

from fmu_src.variables import INDICATOR, STATE, Variable

# The model folders of fmu_src/ that carry a ComponentTable (as TABLE in their variables.py).
COMPONENT_MODELS = ("projectile", "hull")


@dataclass(frozen=True)
class ComponentTable:
    """A component's variables in value-reference order (its continuous states in the order they appear)."""

    identifier: str  # the FMU's model identifier
    description: str  # one line: modelDescription.xml's description
    variables: tuple[Variable, ...]
    horizon: float  # <DefaultExperiment> stopTime (s)
    communication_step: float  # <DefaultExperiment> stepSize (s)

    def __post_init__(self):
        names = [v.name for v in self.variables]
        repeated = sorted({n for n in names if names.count(n) > 1})
        if repeated:
            raise ValueError(f"{self.identifier}: variables {repeated} are declared twice")
        if any(v.size is not None for v in self.variables):
            raise ValueError(f"{self.identifier}: a component's variables are scalars")
        for variable in self.variables:
            inputs = {v.name for v in self.variables if v.causality == "input"}
            unknown = set(variable.depends_on) - inputs
            if unknown:
                raise ValueError(
                    f"{self.identifier}: {variable.name} depends on {sorted(unknown)}, which are not inputs"
                )

    @property
    def exposed(self) -> list[Variable]:
        return list(self.variables)

    @property
    def fixed(self) -> list[Variable]:
        return []  # a component compiles no parameter in: every one is settable

    @property
    def value_references(self) -> dict[str, int]:
        return {variable.name: index for index, variable in enumerate(self.variables)}

    def state_offsets(self) -> dict[str, int]:
        states = [v.name for v in self.variables if v.role == STATE]
        return {name: offset for offset, name in enumerate(states)}

    def event_indicator_count(self) -> int:
        return sum(1 for v in self.variables if v.role == INDICATOR)

    def state_count(self) -> int:
        return sum(1 for v in self.variables if v.role == STATE)

    def variable(self, name: str) -> Variable:
        for variable in self.variables:
            if variable.name == name:
                return variable
        raise KeyError(
            f"{self.identifier} has no variable {name!r}; its variables: {', '.join(v.name for v in self.variables)}"
        )


def component_table(model: str) -> ComponentTable:
    """The table of the model folder fmu_src/<model>/ (its variables.py's TABLE)."""
    if model not in COMPONENT_MODELS:
        raise ValueError(f"model {model!r} has no component table: allowed {', '.join(COMPONENT_MODELS)}")
    return importlib.import_module(f"fmu_src.{model}.variables").TABLE
