"""The hull's variable table (fmu_src/hull/): the body the armour is mounted on (docs/model.md section 11).

A mass m on a spring k and a damper c to the ground, pushed by the force the lattice puts on its backplate:
m x'' = F - k x - c x'. Its x and v are the lattice's x_back and v_back in the armour system
(`python build_fmu.py --system`). The builder generates the hull's C header and both model descriptions from
this table (`python build_fmu.py --model hull`).
"""

from __future__ import annotations

from fmu_src.component_table import ComponentTable
from fmu_src.variables import DERIVATIVE, REAL, STATE, Variable

TABLE = ComponentTable(
    identifier="Hull",
    description="The body the armour is mounted on: a mass on a spring and a damper to the ground, pushed by the "
    "backplate force",
    variables=(
        Variable(
            "m", REAL, "parameter", "Mass of the hull", start=20.0, unit="kg", minimum=0.0, minimum_exclusive=True
        ),
        Variable(
            "k", REAL, "parameter", "Stiffness of the mounting to the ground", start=2.0e4, unit="N/m", minimum=0.0
        ),
        Variable(
            "c", REAL, "parameter", "Damping of the mounting to the ground", start=200.0, unit="N.s/m", minimum=0.0
        ),
        Variable(
            "F",
            REAL,
            "input",
            "Force on the hull along +x (the lattice's backplate_force). Co-Simulation: held over a step, or "
            "extrapolated with its first derivative where the master sets one",
            start=0.0,
            unit="N",
        ),
        Variable("x", REAL, "output", "Displacement of the hull along +x (the lattice's x_back)", unit="m", role=STATE),
        Variable("v", REAL, "output", "Velocity of the hull along +x (the lattice's v_back)", unit="m/s", role=STATE),
        Variable(
            "dissipated_energy",
            REAL,
            "output",
            "Energy the damper took out so far, the integral of c v^2 (a continuous state): with the kinetic "
            "energy m v^2 / 2 and the spring's k x^2 / 2 it closes the hull's energy balance against the "
            "work of F",
            unit="J",
            role=STATE,
        ),
        Variable("der(x)", REAL, "local", "Velocity of the hull", unit="m/s", role=DERIVATIVE, derivative_of="x"),
        Variable(
            "der(v)",
            REAL,
            "local",
            "Acceleration of the hull: (F - k x - c v) / m",
            unit="m/s2",
            role=DERIVATIVE,
            derivative_of="v",
        ),
        Variable(
            "der(dissipated_energy)",
            REAL,
            "local",
            "Power of the damper: c v^2",
            unit="W",
            role=DERIVATIVE,
            derivative_of="dissipated_energy",
        ),
    ),
    horizon=8.0,
    communication_step=1e-3,
)
