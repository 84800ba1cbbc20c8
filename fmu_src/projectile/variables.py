"""The projectile's variable table (fmu_src/projectile/): a rigid body striking the lattice's loaded face with
Hunt-Crossley contact (docs/model.md section 11).

The parameters are the lattice's projectile-mode parameters (fmu_src/variables.py: names, units, defaults, ranges),
so that the armour system (`python build_fmu.py --system`) and the lattice's one-model projectile mode are the
same physics. The builder
generates the projectile's C header and both model descriptions from this table (`python build_fmu.py --model
projectile`).
"""

from __future__ import annotations

from dataclasses import replace

from fmu_src.component_table import ComponentTable
from fmu_src.variables import DERIVATIVE, REAL, STATE, Variable, all_variables

INPUTS = ("x_front", "v_front")
# The lattice's projectile-mode parameters, taken from its table with their names, units, defaults and ranges, so
# the three-FMU system and the one-model projectile mode strike with the same body.
SHARED_PARAMETERS = ("projectile_mass", "projectile_speed", "contact_stiffness", "contact_exponent", "contact_damping")
LATTICE_PREFIX = "Projectile mode: "


def shared_parameter(name: str) -> Variable:
    """The lattice's parameter `name`, described for the projectile FMU."""
    variable = next(v for v in all_variables(1, 1) if v.name == name)
    return replace(variable, description=variable.description.removeprefix(LATTICE_PREFIX))


TABLE = ComponentTable(
    identifier="Projectile",
    description="A rigid projectile striking the armour's loaded face: Hunt-Crossley contact, its force "
    "averaged over each communication step",
    variables=(
        *(shared_parameter(name) for name in SHARED_PARAMETERS),
        Variable(
            "x_front",
            REAL,
            "input",
            "Displacement of the lattice's loaded face along +x (its output x_front). Co-Simulation: "
            "extrapolated over a step as x_front + v_front (t - t0)",
            start=0.0,
            unit="m",
        ),
        Variable(
            "v_front",
            REAL,
            "input",
            "Velocity of the lattice's loaded face along +x (its output v_front). Co-Simulation: held over a "
            "step, or extrapolated with its first derivative where the master sets one",
            start=0.0,
            unit="m/s",
        ),
        Variable(
            "contact_force",
            REAL,
            "output",
            "Contact force on the face along +x (the lattice's F_front), the projectile gets its opposite. "
            "Co-Simulation: the impulse over the last communication step divided by the step (the "
            "instantaneous force before the first step), so momentum crosses the interface exactly; Model "
            "Exchange: the instantaneous force",
            unit="N",
            depends_on=INPUTS,
        ),
        Variable(
            "projectile_position",
            REAL,
            "output",
            "Position of the projectile along +x (0 at t = 0)",
            unit="m",
            role=STATE,
        ),
        Variable("projectile_velocity", REAL, "output", "Velocity of the projectile along +x", unit="m/s", role=STATE),
        Variable(
            "face_work",
            REAL,
            "output",
            "Work the contact force did on the face so far, the integral of F_c v_front with the face's motion "
            "as the projectile sees it (Co-Simulation: extrapolated over each step; a continuous state). Less "
            "the face's received work (the lattice's external_work at the front port), it is the energy the "
            "coupling created or lost",
            unit="J",
            role=STATE,
        ),
        Variable(
            "der(projectile_position)",
            REAL,
            "local",
            "Velocity of the projectile",
            unit="m/s",
            role=DERIVATIVE,
            derivative_of="projectile_position",
        ),
        Variable(
            "der(projectile_velocity)",
            REAL,
            "local",
            "Acceleration of the projectile: -F_c / mass",
            unit="m/s2",
            role=DERIVATIVE,
            derivative_of="projectile_velocity",
        ),
        Variable(
            "der(face_work)",
            REAL,
            "local",
            "Power of the contact force on the face: F_c v_front",
            unit="W",
            role=DERIVATIVE,
            derivative_of="face_work",
        ),
    ),
    horizon=1.0,
    communication_step=1e-4,
)
