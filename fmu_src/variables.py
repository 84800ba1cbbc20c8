"""The one description of the FMU's variables: names, types, defaults, ranges and value references.

`build_fmu.py` turns it into both `modelDescription.xml` and the C header `model_variables.h`, so the two
cannot drift. A scene (see `scenes/`) decides which parameters a particular FMU exposes; a parameter it
does not expose is compiled in as a constant with the scene's value ("model no more than a scene needs").
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

from fmu_src.materials import FIELDS as MATERIAL_FIELDS
from fmu_src.materials import STUDY_MATERIAL_COUNT, MaterialTable, study_materials

REAL = "Real"
INTEGER = "Integer"

# Every unit a variable may carry, declared in both model descriptions' <UnitDefinitions>.
UNITS = ("N", "N.s", "N.s/m", "N/m", "1/m", "kg", "m", "s", "J", "deg", "m/s", "m/s2", "W", "s/m")
# The categories the FMI glue logs under (fmi2/, fmi3/), declared in both model descriptions.
LOG_CATEGORIES = (
    ("logStatusError", "Why a call failed"),
    ("logStatusWarning", "Model Exchange: a backplate switch the importer did not handle as an event"),
    ("logStatusDiscard", "Why a step stopped early (peak_force_limit)"),
)

# Roles in the continuous-time contract (fmu_src/lattice/model.h), what Model Exchange declares as its
# states, their derivatives and its event indicators.
STATE, DERIVATIVE, INDICATOR = "state", "derivative", "indicator"
# The continuous state vector in lattice.h's layout: displacements, velocities, the three energy integrals (a
# lattice of depth 1 has no uz and vz).
# projectile mode's rigid body last (docs/model.md section 11).
STATE_ORDER = (
    "ux",
    "uy",
    "uz",
    "vx",
    "vy",
    "vz",
    "external_work",
    "dissipated_energy",
    "nonreciprocal_work",
    "projectile_position",
    "projectile_velocity",
)


@dataclass(frozen=True)
class Variable:
    """One scalar variable, or an array flattened into `name[1]` ... `name[size]` for FMI 2."""

    name: str
    type: str  # REAL or INTEGER
    causality: str  # "parameter", "input", "output" or "local"
    description: str
    start: float | int | tuple | None = None  # a tuple gives one start value per element of an array
    unit: str | None = None
    minimum: float | int | None = None
    maximum: float | int | None = None
    minimum_exclusive: bool = False  # the C check refuses the minimum itself (rtol > 0, alpha > 0)
    size: int | None = None  # None: a scalar
    allowed: str | None = None  # how the C error message states the allowed values, when not a plain range
    shape: tuple[int, ...] | None = None  # an array's dimensions when it has more than one (rows, columns)
    role: str | None = None  # STATE, DERIVATIVE or INDICATOR: the continuous-time contract (model.h)
    derivative_of: str | None = None  # a DERIVATIVE's state
    enumeration: str | None = None  # an Integer declared as this FMI enumeration type, with these items
    items: tuple[tuple[str, str], ...] = ()  # (name, description) of the values 0, 1, ...
    # an output's direct dependencies on inputs (<ModelStructure>): the inputs it changes with at the same time,
    # without integrating (an output without the list would be taken to depend on every input)
    depends_on: tuple[str, ...] = ()

    @property
    def c_name(self) -> str:
        return self.name.replace("der(", "der_").rstrip(")").upper()

    @property
    def count(self) -> int:
        return 1 if self.size is None else self.size

    def element_names(self) -> list[str]:
        if self.size is None:
            return [self.name]
        if self.shape and len(self.shape) == 2:  # row-major, as lattice.h lays out the masses
            subscripts = [
                f"[{row},{col}]" for row in range(1, self.shape[0] + 1) for col in range(1, self.shape[1] + 1)
            ]
        elif self.shape and len(self.shape) == 3:  # (slice, row, column), row-major as lattice.h lays out a plate
            subscripts = [
                f"[{k},{row},{col}]"
                for k in range(1, self.shape[0] + 1)
                for row in range(1, self.shape[1] + 1)
                for col in range(1, self.shape[2] + 1)
            ]
        else:
            subscripts = [f"[{index}]" for index in range(1, self.size + 1)]
        if self.derivative_of:  # der(ux[1,1]), as FMI's structured naming convention writes a derivative
            return [f"der({self.derivative_of}{subscript})" for subscript in subscripts]
        return [f"{self.name}{subscript}" for subscript in subscripts]

    def element_starts(self) -> list:
        if self.start is None:
            return [None] * self.count
        if isinstance(self.start, tuple):
            return list(self.start)
        return [self.start] * self.count

    def allowed_text(self) -> str:
        if self.allowed:
            return self.allowed
        low = "-inf" if self.minimum is None else f"{self.minimum:g}"
        high = "inf" if self.maximum is None else f"{self.maximum:g}"
        left = "(" if self.minimum_exclusive or self.minimum is None else "["
        right = ")" if self.maximum is None else "]"
        if self.type == REAL and self.minimum is None and self.maximum is None:
            return "a finite number"
        if self.type == REAL:
            return f"a finite number in {left}{low}, {high}{right}"
        return f"an integer in [{low}, {high}]"


def enumeration_values(name: str) -> dict[str, int]:
    """The items of the enumeration parameter `name` by label, with their values ({"receiver": 0, "mean": 1} for
    diagonal_rule): the one label-to-value inverse of the table's items."""
    variable = next((v for v in all_variables(1, 1) if v.name == name and v.enumeration), None)
    if variable is None:
        raise KeyError(f"{name} is no enumeration parameter of the variable table")
    return {label: value for value, (label, _) in enumerate(variable.items)}


def enumerations() -> list[Variable]:
    """The enumeration parameters of the table (their items do not depend on the lattice's size)."""
    return [v for v in all_variables(1, 1) if v.enumeration]


def plotted_masses(rows: int, cols: int) -> dict[str, tuple[int, int]]:
    """The masses whose displacements the study plots, as (row, column), 1-based (in a plate, of its
    middle slice in depth: plotted_slice)."""
    middle_row, middle_col = (rows + 1) // 2, (cols + 1) // 2
    return {
        "corner": (1, 1),
        "left_edge": (middle_row, 1),
        "centre": (middle_row, middle_col),
        "right_edge": (middle_row, cols),
    }


def plotted_slice(depth: int) -> int:
    """The slice (1-based) of a plate whose masses the plotted displacements are: the middle one."""
    return (depth + 1) // 2


def plotted_mass_index(rows: int, cols: int, depth: int, row: int, col: int) -> int:
    """lattice.h's number of plotted mass (row, col) (1-based) of the plotted slice: (k R + i) C + j, 0-based."""
    return ((plotted_slice(depth) - 1) * rows + row - 1) * cols + col - 1


# The event indicator of projectile mode's contact (the last indicator; an FMU without a backplate has only it).
IMPACT_INDICATOR = "impact_indicator"
# Projectile mode's default contact stiffness (N/m^1.5): with the default 50 kg at 3.6 m/s on the study's lattice
# the contact force is about the pulse's in size and duration (docs/model.md section 11 says how it was chosen).
PROJECTILE_CONTACT_STIFFNESS = 3e4

# The back port's inputs: what the backplate force and the penetration at the current time depend on directly.
BACK_PORT = ("x_back", "v_back")

WHOLE_FACE = 0  # load_patch of a load over column 1's whole face (lattice.h: LATTICE_WHOLE_FACE)


@dataclass(frozen=True)
class LoadedFace:
    """The masses of column 1's rows x depth face the load pushes (docs/model.md section 10): rows i in
    ``row_range`` and positions k along z in ``depth_range``, 0-based as lattice.c numbers them."""

    row_range: range
    depth_range: range
    whole_face: bool  # load_patch 0: every mass of the face, with the edge weights of section 4

    def masses(self) -> frozenset[tuple[int, int]]:
        """The loaded masses as (i, k), 0-based."""
        return frozenset((i, k) for i in self.row_range for k in self.depth_range)


def load_patch_allowed(rows: int, depth: int, load_patch) -> bool:
    """The core's rule (lattice.c, lattice_params_error): 0, or an odd P <= min(rows, depth) on a face with an
    odd number of rows and an odd depth, so that the patch leaves as many on either side."""
    if load_patch == WHOLE_FACE and not isinstance(load_patch, bool):
        return True
    return (
        isinstance(load_patch, int)
        and not isinstance(load_patch, bool)
        and load_patch > 0
        and load_patch % 2 == 1
        and load_patch <= min(rows, depth)
        and rows % 2 == 1
        and depth % 2 == 1
    )


def load_patch_refusal(rows: int, depth: int, load_patch) -> str:
    return (
        f"load_patch = {load_patch!r} is not allowed for {rows} rows and depth {depth}: allowed 0 (the whole "
        f"face) or an odd P <= min(rows, depth) = {min(rows, depth)}, with an odd number of rows and an odd depth"
    )


def loaded_face(rows: int, depth: int, load_patch: int) -> LoadedFace:
    """Which masses of column 1's face the load pushes: all of them (load_patch 0) or the centred load_patch x
    load_patch square, as lattice.c's load_fraction places it; any other load_patch is refused."""
    if not load_patch_allowed(rows, depth, load_patch):
        raise ValueError(load_patch_refusal(rows, depth, load_patch))
    if load_patch == WHOLE_FACE:
        return LoadedFace(range(rows), range(depth), True)
    first_row, first_depth = (rows - load_patch) // 2, (depth - load_patch) // 2
    return LoadedFace(range(first_row, first_row + load_patch), range(first_depth, first_depth + load_patch), False)


def default_order(cols: int, materials: int) -> tuple[int, ...]:
    """The order an FMU starts with: material j in column j, the table's materials again from 1 when it has
    fewer than columns."""
    return tuple((j % materials) + 1 for j in range(cols))


def all_variables(rows: int, cols: int, materials: MaterialTable | None = None, depth: int = 1) -> list[Variable]:
    """Every variable the model knows, in value-reference order, with docs/model.md's published defaults and
    the material table's values (default: the study's, its first C materials, all eleven for a wider lattice,
    whose default then repeats them) as the table's start values; `depth` slices (docs/model.md section 10)."""
    table = materials or study_materials(min(cols, STUDY_MATERIAL_COUNT))
    count = len(table)
    values = table.parameters()
    variables = [
        Variable(
            "material",
            INTEGER,
            "parameter",
            "Material number of each column: a row of the material table (1..M); each material in at most "
            "one column unless repeat_materials = 1",
            start=default_order(cols, count),
            minimum=1,
            maximum=count,
            size=cols,
            allowed=f"each an integer in [1, {count}]",
        ),
        Variable(
            "repeat_materials",
            INTEGER,
            "parameter",
            "0 = each material in at most one column (an arrangement; with M = C a permutation, the study's "
            "design space), 1 = any material in any number of columns",
            start=0 if count >= cols else 1,
            minimum=0,
            maximum=1,
            allowed="0 (each material at most once) or 1 (any)",
        ),
        # the material table's columns, one array each (fmu_src/materials.py spells them)
        *(
            Variable(
                column.name,
                REAL,
                "parameter",
                f"{column.description.capitalize()} of each material",
                start=values[column.name],
                unit=column.unit,
                minimum=0.0,
                minimum_exclusive=column.positive,
                size=count,
            )
            for column in MATERIAL_FIELDS
        ),
        Variable(
            "k_horizontal", REAL, "parameter", "Horizontal spring constant k0", start=100.0, unit="N", minimum=0.0
        ),
        Variable(
            "alpha_horizontal",
            REAL,
            "parameter",
            "Horizontal spring exponent alpha0",
            start=10.0,
            unit="1/m",
            minimum=0.0,
            minimum_exclusive=True,
        ),
        Variable("c_horizontal", REAL, "parameter", "Horizontal damping c0", start=5.0, unit="N.s/m", minimum=0.0),
        # a magnitude (load_angle gives the direction); the maximum is far beyond any armour load, where the
        # exponential springs stiffen until the adaptive solver's step collapses (tests/test_stability.py)
        Variable(
            "F_total",
            REAL,
            "parameter",
            "Total load on column 1 (its direction is load_angle)",
            start=1200.0,
            unit="N",
            minimum=0.0,
            maximum=1e7,
        ),
        Variable(
            "load_angle",
            REAL,
            "parameter",
            "Direction of the load (0 = +x)",
            start=0.0,
            unit="deg",
            minimum=-360.0,
            maximum=360.0,
        ),
        Variable(
            "t_active", REAL, "parameter", "The load acts for 0 <= t <= t_active", start=0.15, unit="s", minimum=0.0
        ),
        Variable("k_wall", REAL, "parameter", "Backplate stiffness", start=1e4, unit="N/m", minimum=0.0),
        Variable(
            "c_wall", REAL, "parameter", "Backplate damping (while approaching)", start=10.0, unit="N.s/m", minimum=0.0
        ),
        Variable("backplate_gap", REAL, "parameter", "Gap between column C and the backplate", start=1e-3, unit="m"),
        Variable(
            "peak_sample_interval",
            REAL,
            "parameter",
            "Interval of the samples peak_backplate_force is taken over (0.01 s reproduces the study)",
            start=0.01,
            unit="s",
            minimum=0.0,
            minimum_exclusive=True,
        ),
        Variable(
            "peak_force_limit",
            REAL,
            "parameter",
            "Co-Simulation: stop the run (fmi2Discard, terminated) as soon as peak_backplate_force exceeds "
            "this; 0 = no limit. Model Exchange does not stop at it",
            start=0.0,
            unit="N",
            minimum=0.0,
            allowed="a finite number >= 0 (0: no limit)",
        ),
        # 5e-8: the energy balance closes to 1e-6 of the work input with a margin (tests/test_fmu.py, every 0.01 s)
        Variable(
            "rtol",
            REAL,
            "parameter",
            "Relative tolerance of the adaptive solver",
            start=5e-8,
            minimum=1e-14,
            maximum=0.1,
        ),
        Variable(
            "atol",
            REAL,
            "parameter",
            "Absolute tolerance of the adaptive solver",
            start=1e-9,
            minimum=0.0,
            minimum_exclusive=True,
            maximum=1.0,
        ),
        Variable(
            "fixed_step",
            REAL,
            "parameter",
            "Step of the fixed-step solvers",
            start=1e-4,
            unit="s",
            minimum=0.0,
            minimum_exclusive=True,
            maximum=1.0,
        ),
        Variable(
            "diagonal_rule",
            INTEGER,
            "parameter",
            "Where a diagonal spring takes its constants from: receiver (0, the receiving mass's column, as "
            "the study computed its published numbers; the two ends' forces differ) or mean (1, both ends "
            "the mean of the two columns: reciprocal)",
            start=0,
            minimum=0,
            maximum=1,
            allowed="0 (receiver) or 1 (mean)",
            enumeration="DiagonalRule",
            items=(
                ("receiver", "The receiving mass's column (as the study computed; not reciprocal)"),
                ("mean", "The mean of the two columns (reciprocal)"),
            ),
        ),
        Variable(
            "solver",
            INTEGER,
            "parameter",
            "Co-Simulation's solver: DOP853 (0, adaptive), RK4 (1, fixed step), semi-implicit Euler (2, "
            "fixed step), Tsit5 (3, adaptive), DOPRI5 (4, adaptive) or Fine's Runge-Kutta-Nystrom 5(4) (5, "
            "adaptive); Model Exchange uses the importer's",
            start=0,
            minimum=0,
            maximum=5,
            allowed="0 (adaptive DOP853), 1 (RK4), 2 (semi-implicit Euler), 3 (adaptive Tsit5), 4 (adaptive "
            "DOPRI5) or 5 (adaptive Fine RKN 5(4))",
            enumeration="Solver",
            items=(
                ("dop853", "DOP853: adaptive Dormand-Prince 8(5,3) with 7th-order dense output (rtol, atol)"),
                ("rk4", "RK4: fixed-step classical Runge-Kutta (fixed_step)"),
                (
                    "semi_implicit_euler",
                    "Semi-implicit Euler: fixed-step semi-implicit (symplectic) Euler (fixed_step)",
                ),
                ("tsit5", "Tsit5: adaptive Tsitouras 5(4) pair (rtol, atol)"),
                ("dopri5", "DOPRI5: adaptive Dormand-Prince 5(4) pair (rtol, atol)"),
                (
                    "rkn5",
                    "Fine RKN 5(4): adaptive general Runge-Kutta-Nystrom 5(4) pair of Fine (rtol, "
                    "atol): cheapest at the searches' accuracy",
                ),
            ),
        ),
        Variable(
            "spring_law",
            INTEGER,
            "parameter",
            "0 = exponential springs (the study's law), 1 = linear springs F = k r",
            start=0,
            minimum=0,
            maximum=1,
            allowed="0 (exponential) or 1 (linear)",
        ),
        Variable(
            "has_backplate",
            INTEGER,
            "parameter",
            "1 = the backplate is there, 0 = a free lattice",
            start=1,
            minimum=0,
            maximum=1,
            allowed="0 or 1",
        ),
        Variable(
            "use_symmetry",
            INTEGER,
            "parameter",
            "Co-Simulation: 1 = when the lattice is mirror-symmetric about its middle row (an odd number of "
            "rows, load_angle 0) integrate only its upper half, the same solution at about half the cost, "
            "and of a plate also about its middle slice in depth (a quarter); 0 = always the whole lattice. Model "
            "Exchange always hands the importer the whole lattice",
            start=1,
            minimum=0,
            maximum=1,
            allowed="0 or 1",
        ),
        # odd and centred: the core refuses the rest at initialisation (lattice_params_error), in one line
        Variable(
            "load_patch",
            INTEGER,
            "parameter",
            "Where column 1 is loaded: 0 = over its whole face (each mass's share the product of its row's "
            "and its depth slice's weights, half at an edge), or an odd P = the centred P x P patch of its "
            "rows x depth masses, each of those masses an equal share",
            start=0,
            minimum=0,
            maximum=min(rows, depth),
            allowed=f"0 (the whole face) or an odd P, 1 <= P <= min(rows, depth) = {min(rows, depth)}, with "
            f"an odd number of rows and an odd depth",
        ),
        Variable(
            "load_mode",
            INTEGER,
            "parameter",
            "What pushes column 1: pulse (0, F_total for 0 <= t <= t_active, the "
            "study's load), input (1, the input F_front, spread over the face as the pulse is) or projectile "
            "(2, a rigid body striking the face through a Hunt-Crossley contact, integrated with the lattice)",
            start=0,
            minimum=0,
            maximum=2,
            allowed="0 (pulse), 1 (input) or 2 (projectile)",
            enumeration="LoadMode",
            items=(
                ("pulse", "F_total at load_angle for 0 <= t <= t_active (the study's load)"),
                ("input", "The input F_front along +x, spread over the face with the pulse's weights"),
                (
                    "projectile",
                    (
                        "A rigid body of projectile_mass striking the face at projectile_speed: "
                        "its contact force pushes the face as F_front would"
                    ),
                ),
            ),
        ),
        # projectile mode (docs/model.md section 11): the default body carries the pulse's momentum, F_total x
        # t_active (tests/test_ports.py checks it), as a blunt impactor
        Variable(
            "projectile_mass",
            REAL,
            "parameter",
            "Projectile mode: the striking body's mass (with projectile_speed, by default the pulse's "
            "momentum F_total x t_active, as a blunt impactor)",
            start=50.0,
            unit="kg",
            minimum=0.0,
            minimum_exclusive=True,
        ),
        Variable(
            "projectile_speed",
            REAL,
            "parameter",
            "Projectile mode: the body's speed along +x at t = 0, when it touches the face",
            start=3.6,
            unit="m/s",
            minimum=0.0,
        ),
        Variable(
            "contact_stiffness",
            REAL,
            "parameter",
            "Projectile mode: k_c of the Hunt-Crossley contact F_c = k_c d^n (1 + lambda d'), in "
            "N/m^contact_exponent (d the overlap of body and face); the default makes the default body's "
            "contact force about the pulse's in size and duration",
            start=PROJECTILE_CONTACT_STIFFNESS,
            minimum=0.0,
            minimum_exclusive=True,
        ),
        Variable(
            "contact_exponent",
            REAL,
            "parameter",
            "Projectile mode: n of the contact (1.5: Hertz's, a blunt body's curved nose on a flat face)",
            start=1.5,
            minimum=1.0,
            maximum=3.0,
        ),
        Variable(
            "contact_damping",
            REAL,
            "parameter",
            "Projectile mode: lambda of the Hunt-Crossley contact (the contact's coefficient of "
            "restitution is about 1 - 2 lambda v / 3 at impact speed v: the default gives about 0.76 at "
            "3.6 m/s)",
            start=0.1,
            unit="s/m",
            minimum=0.0,
        ),
        # inputs: the ports (docs/model.md section 11)
        Variable(
            "F_front",
            REAL,
            "input",
            "Front port: the force along +x on column 1's face in load_mode input, each loaded mass its "
            "share of it (the pulse's weights, normalised to 1); F_front v_front is the power the port takes "
            "in. Co-Simulation holds it over a step, or extrapolates it with the derivative a master gives "
            "(fmi2SetRealInputDerivatives)",
            start=0.0,
            unit="N",
        ),
        Variable(
            "x_back",
            REAL,
            "input",
            "Back port: the backplate's displacement along +x (0: the rigid wall of section 5). "
            "Co-Simulation moves the backplate from it with v_back over a step",
            start=0.0,
            unit="m",
        ),
        Variable(
            "v_back",
            REAL,
            "input",
            "Back port: the backplate's velocity along +x; the backplate's damper acts on vx - v_back",
            start=0.0,
            unit="m/s",
        ),
        # outputs
        Variable("backplate_force", REAL, "output", "Force on the backplate", unit="N", depends_on=BACK_PORT),
        Variable(
            "stack_mass",
            REAL,
            "output",
            "Total mass of the lattice: rows x depth x the sum over the columns of their materials' mass",
            unit="kg",
        ),
        Variable(
            "peak_backplate_force",
            REAL,
            "output",
            "Maximum backplate force over the samples every peak_sample_interval so far. Model Exchange: "
            "over the sample times at which the importer completed a step or handled an event (the FMU "
            "sees no other points; an importer that stops on the sample grid, as fmpy does on its output "
            "grid, gives the study's sampled peak to its own accuracy)",
            unit="N",
            depends_on=BACK_PORT,
        ),
        Variable(
            "peak_backplate_force_continuous",
            REAL,
            "output",
            "Maximum backplate force over the continuous solution so far. Model Exchange: over every point "
            "at which the importer completed a step or handled an event, which can miss the maximum "
            "between them",
            unit="N",
            depends_on=BACK_PORT,
        ),
        Variable(
            "peak_time", REAL, "output", "Time of peak_backplate_force_continuous", unit="s", depends_on=BACK_PORT
        ),
        Variable(
            "last_contact_time",
            REAL,
            "output",
            "Latest time any column-C mass touched the backplate (0 if none has): a search over a short "
            "horizon is safe only if this is well before the horizon. Model Exchange: over the points the "
            "importer completed, contact ends located as events",
            unit="s",
            depends_on=BACK_PORT,
        ),
        Variable(
            "max_compression",
            REAL,
            "output",
            "Largest shortening of the lattice along the load so far: the mean x displacement of column 1 "
            "minus that of column C, over the same samples as peak_backplate_force",
            unit="m",
        ),
        Variable(
            "transmitted_impulse",
            REAL,
            "output",
            "Impulse transmitted to the backplate so far: the time integral of the backplate force, by the "
            "trapezoidal rule over the same samples as peak_backplate_force",
            unit="N.s",
            depends_on=BACK_PORT,
        ),
        Variable("kinetic_energy", REAL, "output", "Kinetic energy (projectile mode: with the body's)", unit="J"),
        Variable(
            "potential_energy",
            REAL,
            "output",
            "Potential energy of the springs and the backplate (projectile mode: and of the contact, "
            "k_c d^(n+1) / (n+1))",
            unit="J",
            depends_on=BACK_PORT,
        ),
        Variable(
            "external_work",
            REAL,
            "output",
            "Work done on the lattice from outside: by the load (pulse) or the front port, minus the work "
            "it does on a moving backplate (projectile mode: the contact's work stays inside the model, "
            "whose energy holds the body's; a continuous state: Model Exchange integrates it with the "
            "lattice)",
            unit="J",
            role=STATE,
        ),
        Variable(
            "dissipated_energy",
            REAL,
            "output",
            "Energy taken out by the dampers (projectile mode: and by the contact; a continuous state)",
            unit="J",
            role=STATE,
        ),
        Variable(
            "nonreciprocal_work",
            REAL,
            "output",
            "Work of the unequal part of diagonal pairs (receiver rule; a continuous state)",
            unit="J",
            role=STATE,
        ),
        Variable(
            "energy_balance_error",
            REAL,
            "output",
            "external_work + nonreciprocal_work - kinetic - potential - dissipated (+ the start state's "
            "energy: the projectile's kinetic energy)",
            unit="J",
            depends_on=BACK_PORT,
        ),
        Variable(
            "x_front",
            REAL,
            "output",
            "Front port: the loaded face's displacement along +x, sum of w_a ux_a over its loaded masses "
            "with the load's weights w_a (summing to 1)",
            unit="m",
        ),
        Variable(
            "v_front",
            REAL,
            "output",
            "Front port: the loaded face's velocity along +x, sum of w_a vx_a (F_front v_front is the power "
            "the port takes in)",
            unit="m/s",
        ),
        Variable(
            "contact_force",
            REAL,
            "output",
            "Projectile mode: the contact force between the body and the face, max(k_c d^n (1 + lambda d'), "
            "0) while d = projectile_position - x_front > 0, else 0; 0 in the other modes",
            unit="N",
        ),
        Variable(
            "projectile_position",
            REAL,
            "output",
            "Projectile mode: the body's displacement along +x from where it touches the face at t = 0 (a "
            "continuous state)",
            unit="m",
            role=STATE,
        ),
        Variable(
            "projectile_velocity",
            REAL,
            "output",
            "Projectile mode: the body's velocity along +x (a continuous state)",
            unit="m/s",
            role=STATE,
        ),
    ]
    where = f" of slice {plotted_slice(depth)}" if depth > 1 else ""
    for place, (row, col) in plotted_masses(rows, cols).items():
        for axis in ("x", "y"):
            variables.append(
                Variable(
                    f"u{axis}_{place}",
                    REAL,
                    "output",
                    f"Displacement {axis} of the mass at row {row}, column {col}{where}",
                    unit="m",
                )
            )
    variables += [
        Variable(
            "rhs_evaluations",
            INTEGER,
            "output",
            "Right-hand-side evaluations so far (Model Exchange: derivative evaluations the importer asked for)",
        ),
        Variable(
            "steps_accepted",
            INTEGER,
            "output",
            "Accepted solver steps so far (Model Exchange: the importer's completed steps and events)",
        ),
        Variable(
            "steps_rejected",
            INTEGER,
            "output",
            "Rejected solver steps so far (Model Exchange: the importer does not tell the FMU, stays 0)",
        ),
    ]
    return variables + continuous_time_variables(rows, cols, depth) + sensitivity_variables(count)


# The seeds' names: the sensitivity seed of material property ``name`` is ``d_<name>`` (d_k, d_mass, ...).
SEED_PREFIX = "d_"


def seed_name(field_name: str) -> str:
    """The sensitivity seed parameter of material table column ``field_name`` (``k`` -> ``d_k``)."""
    return SEED_PREFIX + field_name


def sensitivity_variables(materials: int) -> list[Variable]:
    """The forward sensitivity along a parameter direction (Co-Simulation): a seed per material property and
    material, and the derivatives of the backplate force and of its sampled peak along the seeded direction.

    Last in the table, so that they leave every other variable's value reference as it is. FMI's own
    fmi2/3GetDirectionalDerivative give partial derivatives of outputs with respect to states and inputs at one
    instant, not how a whole run answers a change of its parameters: the FMU offers that as these variables."""
    seeds = [
        Variable(
            seed_name(column.name),
            REAL,
            "parameter",
            f"Co-Simulation's forward sensitivity: the seed of {column.name} of each material, its part in the "
            f"direction d every parameter p moves along (p + epsilon d); all seeds 0 (the default) = no sensitivity",
            start=0.0,
            unit=column.unit,
            size=materials,
        )
        for column in MATERIAL_FIELDS
    ]
    return seeds + [
        Variable(
            "backplate_force_derivative",
            REAL,
            "output",
            "d backplate_force / d epsilon along the seeded direction (Co-Simulation; 0 without a seed and under "
            "Model Exchange)",
            unit="N",
            depends_on=BACK_PORT,
        ),
        Variable(
            "peak_backplate_force_derivative",
            REAL,
            "output",
            "d peak_backplate_force / d epsilon along the seeded direction: the derivative at the sample that "
            "holds the sampled peak (Co-Simulation; 0 without a seed and under Model Exchange)",
            unit="N",
            depends_on=BACK_PORT,
        ),
    ]


def continuous_time_variables(rows: int, cols: int, depth: int = 1) -> list[Variable]:
    """The continuous states, their derivatives and the event indicators (model.h's contract), as variables.

    Model Exchange needs them declared; Co-Simulation answers them too (at the communication point). A plate
    (depth > 1) adds the z components and indexes its masses [slice, row, column]; its indicators are
    one per column-C mass, f = k R + i, as lattice.h numbers the face.
    """
    masses = rows * cols * depth
    shape, index = ((rows, cols), "[row, column]") if depth == 1 else ((depth, rows, cols), "[slice, row, column]")
    axes = ("x", "y") if depth == 1 else ("x", "y", "z")
    face = "row's" if depth == 1 else "face mass's (slice by slice)"
    variables = []
    for name, what, unit in [(f"u{a}", f"Displacement {a}", "m") for a in axes] + [
        (f"v{a}", f"Velocity {a}", "m/s") for a in axes
    ]:
        variables.append(
            Variable(
                name,
                REAL,
                "local",
                f"{what} of each mass {index} (a continuous state)",
                unit=unit,
                size=masses,
                shape=shape,
                role=STATE,
            )
        )
    for name, what, unit in [(f"u{a}", f"Velocity {a}", "m/s") for a in axes] + [
        (f"v{a}", f"Acceleration {a}", "m/s2") for a in axes
    ]:
        variables.append(
            Variable(
                f"der({name})",
                REAL,
                "local",
                f"{what} of each mass {index}",
                unit=unit,
                size=masses,
                shape=shape,
                role=DERIVATIVE,
                derivative_of=name,
            )
        )
    for name, what in (
        ("external_work", "Power of the load"),
        ("dissipated_energy", "Power of the dampers"),
        ("nonreciprocal_work", "Power of the unequal part of diagonal pairs"),
    ):
        variables.append(Variable(f"der({name})", REAL, "local", what, unit="W", role=DERIVATIVE, derivative_of=name))
    for name, what, unit in (
        ("projectile_position", "Velocity of the projectile", "m/s"),
        ("projectile_velocity", "Acceleration of the projectile", "m/s2"),
    ):
        variables.append(Variable(f"der({name})", REAL, "local", what, unit=unit, role=DERIVATIVE, derivative_of=name))
    variables += [
        Variable(
            "contact_indicator",
            REAL,
            "local",
            f"Event indicator of each {face} column-C mass touching the backplate: ux - backplate_gap - "
            "x_back (> 0 in contact)",
            unit="m",
            size=rows * depth,
            role=INDICATOR,
        ),
        Variable(
            "damping_indicator",
            REAL,
            "local",
            f"Event indicator of each {face} backplate damper: vx - v_back while in contact (> 0: "
            "approaching, the damper acts); off the plate the damper cannot switch and this repeats "
            "contact_indicator",
            size=rows * depth,
            role=INDICATOR,
        ),
        Variable(
            IMPACT_INDICATOR,
            REAL,
            "local",
            "Event indicator of the projectile's contact: projectile_position - x_front (> 0 in contact); "
            "1 outside projectile mode",
            unit="m",
            role=INDICATOR,
        ),
    ]
    return variables


@dataclass(frozen=True)
class Interface:
    """The variables one FMU exposes, with value references, and the constants it compiles in instead."""

    rows: int
    cols: int
    exposed: list[Variable]
    fixed: list[Variable]  # parameters the scene does not expose; their start is compiled in
    value_references: dict[str, int] = field(default_factory=dict)  # first element's vr, by variable name
    material_count: int = 0  # M: the rows of the material table
    depth: int = 1  # D: masses along z, through the plate's depth (docs/model.md section 10)

    def state_offsets(self) -> dict[str, int]:
        """Where each state variable starts in the continuous state vector (STATE_ORDER, lattice.h's layout)."""
        sizes = {v.name: v.count for v in self.exposed if v.role == STATE}
        offsets, offset = {}, 0
        for name in (name for name in STATE_ORDER if name in sizes):
            offsets[name] = offset
            offset += sizes[name]
        return offsets

    def event_indicator_count(self) -> int:
        return sum(v.count for v in self.exposed if v.role == INDICATOR)


TABLE_PARAMETERS = tuple(column.name for column in MATERIAL_FIELDS)  # the material table's columns


def with_node_mass(
    parameters: dict | None, materials: MaterialTable | None, cols: int
) -> tuple[dict, MaterialTable | None]:
    """A scene's parameters and table with a scalar ``mass`` among the parameters (the one mass of every node,
    as scenes gave it before docs/model.md section 12 gave each material its own ``mass[m]``) read as every
    material's mass: the table with that mass column, the parameters without it. A table that sets masses of
    its own as well is refused, rather than one silently winning."""
    parameters = dict(parameters or {})
    if "mass" not in parameters or isinstance(parameters["mass"], (list, tuple)):
        return parameters, materials
    node_mass = parameters.pop("mass")
    table = materials or study_materials(min(cols, STUDY_MATERIAL_COUNT))
    if (
        isinstance(node_mass, bool)
        or not isinstance(node_mass, (int, float))
        or not (math.isfinite(node_mass) and node_mass > 0)
    ):
        raise ValueError(
            f"parameter mass = {node_mass!r} is not allowed: allowed a finite number > 0 (kg, every material's mass)"
        )
    if any(m.mass != 1.0 for m in table.materials):
        raise ValueError(
            f"parameter mass = {node_mass!r} and the material table's mass column both set the "
            f"masses: give the masses in the table only"
        )
    return parameters, MaterialTable(tuple(replace(m, mass=float(node_mass)) for m in table.materials))


def make_interface(
    rows: int,
    cols: int,
    parameters: dict | None = None,
    hidden: tuple[str, ...] = (),
    materials: MaterialTable | None = None,
    depth: int = 1,
) -> Interface:
    """Variables for a rows x cols x depth lattice with the material table `materials` (default: the study's, up
    to one material per column); `parameters` overrides starts, `hidden` compiles them in."""
    if rows < 1 or cols < 1 or cols > 64 or depth < 1 or rows * cols * depth > 100000:
        raise ValueError(
            f"rows, cols and depth: allowed 1 <= rows, 1 <= cols <= 64, 1 <= depth, at most 100000 "
            f"masses (got rows={rows}, cols={cols}, depth={depth})"
        )
    parameters, materials = with_node_mass(parameters, materials, cols)
    variables = all_variables(rows, cols, materials, depth)
    known = {v.name for v in variables}
    unknown = set(parameters or {}) - known | set(hidden) - known
    if unknown:
        raise ValueError(f"unknown parameter(s) {sorted(unknown)}; known: {sorted(known)}")
    in_table = sorted(set(parameters or {}) & set(TABLE_PARAMETERS))
    if in_table:
        raise ValueError(
            f"parameters {in_table} are the material table's: give the table itself (a scene's "
            f"materials, build_fmu.py --materials FILE)"
        )
    exposed: list[Variable] = []
    fixed: list[Variable] = []
    patch = (parameters or {}).get("load_patch", WHOLE_FACE)
    if not load_patch_allowed(rows, depth, patch):
        raise ValueError("parameter " + load_patch_refusal(rows, depth, patch))
    for variable in variables:
        if parameters and variable.name in parameters:
            value = parameters[variable.name]
            variable = replace(variable, start=tuple(value) if isinstance(value, (list, tuple)) else value)
            if variable.size is not None and len(variable.element_starts()) != variable.size:
                raise ValueError(f"parameter {variable.name}: expected {variable.size} values")
        (fixed if variable.name in hidden else exposed).append(variable)
    if not _has_backplate(exposed + fixed):  # no backplate: no backplate switches, only the projectile's contact
        exposed = [variable for variable in exposed if variable.role != INDICATOR or variable.name == IMPACT_INDICATOR]
    value_references, next_vr = {}, 0
    for variable in exposed:  # reals and integers share one numbering: unique across types, as FMI 3 needs
        value_references[variable.name] = next_vr
        next_vr += variable.count
    count = next(v.count for v in variables if v.name == "k")
    return Interface(rows, cols, exposed, fixed, value_references, count, depth)


def _has_backplate(variables: list[Variable]) -> bool:
    """False only when has_backplate is compiled in (or defaults) as 0; an exposed one may be switched on."""
    return next(v.start for v in variables if v.name == "has_backplate") != 0


def c_literal(variable: Variable, value) -> str:
    if variable.type == INTEGER:
        return str(int(value))
    if math.isinf(value):
        return "INFINITY" if value > 0 else "-INFINITY"
    return repr(float(value))
