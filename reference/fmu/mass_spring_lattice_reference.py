"""The reference FMU's slave: the numpy/scipy model of reference/ behind pythonfmu's FMI 2.0 co-simulation.

Built by ``python build_fmu.py --reference`` (see :mod:`reference.fmu`) into
``models/MassSpringLatticeReference.fmu``, which bundles this file, the ``reference`` package and
pythonfmu's Python side.  Its variables have the names of the C FMU (``fmu_src/variables.py``): the
``material[j]`` integers, the material table, the scene's scalars, ``rtol``/``atol``,
``peak_sample_interval``, ``diagonal_rule``, and the same outputs, so one importer code path drives both.

It integrates with scipy's DOP853 only: ``solver`` accepts 0 alone, and there is no ``fixed_step``.
A failure (a refused parameter, a diverging solution) ends the next ``fmi2DoStep`` with ``fmi2Discard``
and a logged reason (pythonfmu's only non-fatal failure status; the C FMU says ``fmi2Error``); pythonfmu
passes log messages on only to an importer that instantiates with ``loggingOn``.
An importer needs a Python 3 interpreter with numpy and scipy (the FMU runs inside it); the C FMU is the
one to ship, this one is the independent oracle.
"""

from __future__ import annotations

import math
import traceback

from pythonfmu import Fmi2Causality, Fmi2Initial, Fmi2Slave, Fmi2Variability, Integer, Real
from pythonfmu.enums import Fmi2Status

from reference.fmu.stepper import SimulationDiverged, Stepper
from reference.lattice import Scene, default_material_table

ROWS, COLS = 11, 11
MATERIAL_ARRAYS = ("k", "k_diag", "c", "alpha", "alpha_diag")

# name -> (start, check, allowed text); checks are done at exitInitializationMode, as in the C FMU
_finite = math.isfinite
REAL_PARAMETERS = {
    "k_horizontal": (100.0, lambda v: _finite(v) and v >= 0, "a finite number in [0, inf)"),
    "alpha_horizontal": (10.0, lambda v: _finite(v) and v > 0, "a finite number in (0, inf)"),
    "c_horizontal": (5.0, lambda v: _finite(v) and v >= 0, "a finite number in [0, inf)"),
    "F_total": (1200.0, _finite, "a finite number"),
    "load_angle": (0.0, lambda v: _finite(v) and -360 <= v <= 360, "a finite number in [-360, 360]"),
    "t_active": (0.15, lambda v: _finite(v) and v >= 0, "a finite number in [0, inf)"),
    "k_wall": (1e4, lambda v: _finite(v) and v >= 0, "a finite number in [0, inf)"),
    "c_wall": (10.0, lambda v: _finite(v) and v >= 0, "a finite number in [0, inf)"),
    "backplate_gap": (1e-3, _finite, "a finite number"),
    "peak_sample_interval": (0.01, lambda v: _finite(v) and v > 0, "a finite number in (0, inf)"),
    "rtol": (5e-8, lambda v: _finite(v) and 1e-14 <= v <= 0.1, "a finite number in [1e-14, 0.1]"),
    "atol": (1e-9, lambda v: _finite(v) and 0 < v <= 1, "a finite number in (0, 1]"),
}
INTEGER_PARAMETERS = {
    "repeat_materials": (0, (0, 1), "0 (each material at most once) or 1 (any)"),
    "diagonal_rule": (0, (0, 1), "0 (receiver) or 1 (mean)"),
    "solver": (0, (0,), "0 (scipy DOP853; the reference FMU has no fixed-step solvers)"),
}
# like the C FMU of the armour scene (scenes/armour_11x11.json), spring_law and has_backplate are not exposed:
# exponential springs and the backplate are fixed
REAL_OUTPUTS = (
    "backplate_force",
    "peak_backplate_force",
    "max_compression",
    "peak_backplate_force_continuous",
    "peak_time",
    "last_contact_time",
    "kinetic_energy",
    "potential_energy",
    "external_work",
    "dissipated_energy",
    "nonreciprocal_work",
    "energy_balance_error",
    "ux_corner",
    "uy_corner",
    "ux_left_edge",
    "uy_left_edge",
    "ux_centre",
    "uy_centre",
    "ux_right_edge",
    "uy_right_edge",
)
INTEGER_OUTPUTS = ("rhs_evaluations", "steps_accepted", "steps_rejected")


class MassSpringLatticeReference(Fmi2Slave):
    """11 x 11 lattice of docs/model.md, integrated by reference/ (numpy + scipy DOP853)."""

    author = "mass-spring-lattice project"
    description = (
        "Reference FMU: the numpy/scipy model of reference/ (docs/model.md), scipy DOP853; "
        "needs a Python interpreter with numpy and scipy"
    )

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.modelName = "MassSpringLatticeReference"
        table = default_material_table(COLS)
        self.values = {}
        self.outputs = {name: 0.0 for name in REAL_OUTPUTS}
        self.outputs.update({name: 0 for name in INTEGER_OUTPUTS})
        self.stepper: Stepper | None = None
        self.failure: str | None = None
        self.start_time, self.stop_time = 0.0, None

        for j in range(1, COLS + 1):
            self._parameter(f"material[{j}]", Integer, j, "Material number of column j (a row of the table)")
        for array in MATERIAL_ARRAYS:
            for m in range(1, COLS + 1):
                self._parameter(f"{array}[{m}]", Real, float(table[array][m - 1]), f"{array} of material m")
        for m in range(1, COLS + 1):  # the C FMU's mass[m]; this oracle has one mass for every node
            self._parameter(f"mass[{m}]", Real, 1.0, "mass of each node of a column of material m")
        for name, (start, _, _) in REAL_PARAMETERS.items():
            self._parameter(name, Real, start, name)
        for name, (start, _, _) in INTEGER_PARAMETERS.items():
            self._parameter(name, Integer, start, name)
        for name in REAL_OUTPUTS:
            self._output(name, Real, Fmi2Variability.continuous)
        for name in INTEGER_OUTPUTS:
            self._output(name, Integer, Fmi2Variability.discrete)

    # ------------------------------------------------------------------ variables
    def _parameter(self, name, kind, start, description):
        self.values[name] = start
        self.register_variable(
            kind(
                name,
                causality=Fmi2Causality.parameter,
                variability=Fmi2Variability.fixed,
                description=description,
                getter=lambda n=name: self.values[n],
                setter=lambda v, n=name: self.values.__setitem__(n, v),
            ),
            nested=False,
        )

    def _output(self, name, kind, variability):
        # initial="exact" (the lattice starts at rest, every output is 0): pythonfmu writes no InitialUnknowns
        self.register_variable(
            kind(
                name,
                causality=Fmi2Causality.output,
                variability=variability,
                initial=Fmi2Initial.exact,
                getter=lambda n=name: self.outputs[n],
            ),
            nested=False,
        )

    # ------------------------------------------------------------------ FMI
    def setup_experiment(self, start_time, stop_time, tolerance):
        self.start_time = float(start_time)
        self.stop_time = None if stop_time is None else float(stop_time)

    def _fail(self, message: str) -> None:
        self.failure = message
        self.log(message, Fmi2Status.error)

    def scene(self) -> Scene:
        """The scene of the parameters set; ValueError naming the parameter and its allowed values."""
        v = self.values
        order = [int(v[f"material[{j}]"]) for j in range(1, COLS + 1)]
        distinct = int(v["repeat_materials"]) == 0
        if not all(1 <= p <= COLS for p in order) or (distinct and len(set(order)) != COLS):
            raise ValueError(
                f"material[1..{COLS}] = {order} is not allowed: allowed values are "
                + (f"a permutation of 1..{COLS}" if distinct else f"each in 1..{COLS}")
            )
        for name, (_, check, allowed) in REAL_PARAMETERS.items():
            if not check(float(v[name])):
                raise ValueError(f"{name} = {v[name]!r} is not allowed: allowed values are {allowed}")
        for name, (_, allowed, text) in INTEGER_PARAMETERS.items():
            if int(v[name]) not in allowed:
                raise ValueError(f"{name} = {v[name]!r} is not allowed: allowed values are {text}")
        for array in MATERIAL_ARRAYS:
            for m in range(1, COLS + 1):
                value = float(v[f"{array}[{m}]"])
                ok = _finite(value) and (value > 0 if array.startswith("alpha") else value >= 0)
                if not ok:
                    raise ValueError(
                        f"{array}[{m}] = {value!r} is not allowed: allowed values are "
                        f"a finite number in {'(0' if array.startswith('alpha') else '[0'}, inf)"
                    )
        masses = {float(v[f"mass[{m}]"]) for m in range(1, COLS + 1)}
        if len(masses) != 1 or not all(_finite(mass) and mass > 0 for mass in masses):
            raise ValueError(
                f"mass[1..{COLS}] = {sorted(masses)} is not allowed: allowed values are one finite number "
                f"in (0, inf) for every material (this reference has one mass for every node)"
            )
        table = {a: [float(v[f"{a}[{m}]"]) for m in range(1, COLS + 1)] for a in MATERIAL_ARRAYS}
        return Scene(
            rows=ROWS,
            cols=COLS,
            order=tuple(order),
            **table,
            k0=float(v["k_horizontal"]),
            alpha0=float(v["alpha_horizontal"]),
            c0=float(v["c_horizontal"]),
            mass=masses.pop(),
            F_total=float(v["F_total"]),
            load_angle=float(v["load_angle"]),
            t_active=float(v["t_active"]),
            wall=True,
            k_wall=float(v["k_wall"]),
            c_wall=float(v["c_wall"]),
            backplate_gap=float(v["backplate_gap"]),
            diagonal_rule=("receiver", "mean")[int(v["diagonal_rule"])],
            spring_law="exponential",
        )

    def exit_initialization_mode(self):
        # A refused parameter is reported at the first doStep (fmi2Error), not here: pythonfmu turns an
        # exception in exitInitializationMode into fmi2Fatal, after which its fmi2Terminate can crash the
        # importer's process (seen: a segmentation fault). The instance stays usable after fmi2Reset.
        try:
            scene = self.scene()
            if self.stop_time is not None and not self.stop_time >= self.start_time:
                raise ValueError(f"stop time {self.stop_time} is before the start time {self.start_time}")
            self.stepper = Stepper(
                scene,
                float(self.values["rtol"]),
                float(self.values["atol"]),
                float(self.values["peak_sample_interval"]),
                self.start_time,
                self.stop_time,
            )
            self.outputs.update(self.stepper.outputs())
        except ValueError as exc:
            self.failure = f"parameters refused at exitInitializationMode: {exc}"

    def do_step(self, current_time, step_size):
        if self.failure is not None:
            self.log(f"{self.failure}; reset the FMU to start again", Fmi2Status.error)
            return False
        if self.stepper is None:
            self._fail("the model is not initialised")
            return False
        try:
            self.stepper.advance(current_time + step_size)
            self.outputs.update(self.stepper.outputs())
        except (SimulationDiverged, ValueError) as exc:
            self._fail(str(exc))
            return False
        except Exception as exc:  # noqa: BLE001 - never a silent number
            self._fail(f"{type(exc).__name__}: {exc}\n{traceback.format_exc()}")
            return False
        return True
