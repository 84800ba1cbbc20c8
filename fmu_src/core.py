"""ctypes binding to the C physics core (lattice.c) without the FMI glue, for tests and benchmarks.

`LatticeParams` mirrors the C struct in fmu_src/lattice/lattice.h field for field: change both together.
"""

from __future__ import annotations

import ctypes
from pathlib import Path

import numpy as np

from fmu_src.materials import FIELD_NAMES, FIELDS
from fmu_src.variables import WHOLE_FACE, enumeration_values

MAX_COLS = 64  # LATTICE_MAX_COLS
DIAGONAL_RULES = enumeration_values("diagonal_rule")
SPRING_LAWS = {"exponential": 0, "linear": 1}


class ColumnConstants(ctypes.Structure):
    """One material's fields, as the generated C struct lays them out (builder/build.py, model_table.h)."""

    _fields_ = [(name, ctypes.c_double) for name in FIELD_NAMES]


class LatticeParams(ctypes.Structure):
    _fields_ = [
        ("rows", ctypes.c_int),
        ("cols", ctypes.c_int),
        ("k_horizontal", ctypes.c_double),
        ("alpha_horizontal", ctypes.c_double),
        ("c_horizontal", ctypes.c_double),
        ("column", ColumnConstants * MAX_COLS),
        ("diagonal_rule", ctypes.c_int),
        ("spring_law", ctypes.c_int),
        ("load_total", ctypes.c_double),
        ("load_angle_deg", ctypes.c_double),
        ("load_duration", ctypes.c_double),
        ("has_backplate", ctypes.c_int),
        ("k_wall", ctypes.c_double),
        ("c_wall", ctypes.c_double),
        ("backplate_gap", ctypes.c_double),
        ("depth", ctypes.c_int),
        ("load_patch", ctypes.c_int),
        # the ports (docs/model.md section 11); zero: the pulse and the rigid wall
        ("load_mode", ctypes.c_int),
        ("front_force", ctypes.c_double),
        ("back_position", ctypes.c_double),
        ("back_velocity", ctypes.c_double),
    ]


def components(params: LatticeParams) -> int:
    """Components of a displacement in the state (lattice.h: LATTICE_COMPONENTS): x, y, and z in a plate."""
    return 3 if params.depth > 1 else 2


def masses(params: LatticeParams) -> int:
    return params.rows * params.cols * params.depth


def params_from_scene(scene, depth: int = 1, load_patch: int = WHOLE_FACE) -> LatticeParams:
    """The C parameters of a `reference.Scene` (the numpy oracle's description of a scene), as a plate of
    `depth` slices pushed over the whole face or a centred `load_patch` x `load_patch` patch (docs/model.md
    section 10; the two-dimensional oracle's scene has neither)."""
    return _params(scene, scene.wall, depth, load_patch)


def params_from_plate(plate) -> LatticeParams:
    """The C parameters of a `reference.lattice3d.PlateScene` (the three-dimensional oracle's scene)."""
    return _params(plate, plate.has_backplate, plate.depth, plate.load_patch)


def _params(scene, has_backplate: bool, depth: int, load_patch: int) -> LatticeParams:
    if scene.cols > MAX_COLS:
        raise ValueError(f"cols: at most {MAX_COLS} columns, got {scene.cols}")
    p = LatticeParams()
    p.rows, p.cols = scene.rows, scene.cols
    p.k_horizontal, p.alpha_horizontal, p.c_horizontal = scene.k0, scene.alpha0, scene.c0
    for j, material in enumerate(scene.order):
        p.column[j] = ColumnConstants(**{field.name: _material_value(scene, field, material - 1) for field in FIELDS})
    p.diagonal_rule = DIAGONAL_RULES[scene.diagonal_rule]
    p.spring_law = SPRING_LAWS[scene.spring_law]
    p.load_total, p.load_angle_deg, p.load_duration = scene.F_total, scene.load_angle, scene.t_active
    p.has_backplate = int(has_backplate)
    p.k_wall, p.c_wall, p.backplate_gap = scene.k_wall, scene.c_wall, scene.backplate_gap
    p.depth, p.load_patch = depth, load_patch
    return p


def _material_value(scene, field, index: int) -> float:
    """Material ``index``'s (0-based) value of a table column in a reference scene: a value per material, one
    value for every material (a scene's single ``mass``), or the column's default when the scene has none."""
    value = getattr(scene, field.name, None)
    if value is None:
        if field.default is None:
            raise ValueError(f"scene: no {field.name} (a value per material)")
        return field.default
    if isinstance(value, (int, float)):
        return float(value)
    return float(value[index])


class Core:
    """The compiled core (build_fmu.build_core_library) behind numpy-friendly calls."""

    def __init__(self, library_path: str | Path):
        self.library = ctypes.CDLL(str(library_path))
        double_p = ctypes.POINTER(ctypes.c_double)
        self.library.lattice_rhs.argtypes = [
            ctypes.POINTER(LatticeParams),
            ctypes.c_int,
            ctypes.c_char_p,
            double_p,
            double_p,
        ]
        self.library.lattice_backplate_force.argtypes = [ctypes.POINTER(LatticeParams), double_p]
        self.library.lattice_backplate_force.restype = ctypes.c_double
        self.library.lattice_energies.argtypes = [ctypes.POINTER(LatticeParams), double_p, double_p, double_p]
        self.library.lattice_rhs_along_x.argtypes = [
            ctypes.POINTER(LatticeParams),
            ctypes.c_int,
            ctypes.c_int,
            ctypes.c_char_p,
            double_p,
            double_p,
        ]
        self.library.lattice_along_x.argtypes = [ctypes.POINTER(LatticeParams)]
        self.library.lattice_along_x.restype = ctypes.c_int
        self.library.lattice_mirror_rows.argtypes = [ctypes.POINTER(LatticeParams)]
        self.library.lattice_mirror_rows.restype = ctypes.c_int
        self.library.lattice_mirror_slices.argtypes = [ctypes.POINTER(LatticeParams)]
        self.library.lattice_mirror_slices.restype = ctypes.c_int
        self.library.lattice_params_error.argtypes = [ctypes.POINTER(LatticeParams), ctypes.c_char_p, ctypes.c_int]
        self.library.lattice_params_error.restype = ctypes.c_char_p
        self.library.lattice_backplate_force_mirrored.argtypes = [
            ctypes.POINTER(LatticeParams),
            double_p,
            double_p,
            ctypes.c_int,
        ]
        self.library.lattice_backplate_force_mirrored.restype = ctypes.c_double

    def params_error(self, params: LatticeParams) -> str | None:
        """None when the core computes this lattice, else its one-line reason."""
        message = ctypes.create_string_buffer(256)
        error = self.library.lattice_params_error(ctypes.byref(params), message, len(message))
        return None if error is None else error.decode()

    @staticmethod
    def _augmented(params: LatticeParams, y) -> np.ndarray:
        n = 2 * components(params) * masses(params)
        y = np.ascontiguousarray(y, dtype=float)
        if y.shape == (n,):
            y = np.concatenate([y, np.zeros(3)])
        if y.shape != (n + 3,):
            raise ValueError(f"state: expected {n} or {n + 3} values, got {y.shape}")
        return y

    @staticmethod
    def _modes(wall_mode):
        return None if wall_mode is None else bytes(np.asarray(wall_mode, dtype=np.int8).tobytes())

    def rhs(self, params: LatticeParams, y, load_on: bool, wall_mode=None) -> tuple[np.ndarray, np.ndarray]:
        """(dydt over the mechanical states, (P_ext, P_diss, P_nr)), with the wall switches from the state or
        from wall_mode (one per column-C mass, f = k*R + i)."""
        y = self._augmented(params, y)
        dydt = np.empty_like(y)
        self.library.lattice_rhs(
            ctypes.byref(params),
            int(load_on),
            self._modes(wall_mode),
            y.ctypes.data_as(ctypes.POINTER(ctypes.c_double)),
            dydt.ctypes.data_as(ctypes.POINTER(ctypes.c_double)),
        )
        return dydt[:-3], dydt[-3:]

    def mirror_rows(self, params: LatticeParams) -> int:
        """Rows of the part that carries a mirror-symmetric lattice's solution, 0 if it is not symmetric about
        its middle row."""
        return self.library.lattice_mirror_rows(ctypes.byref(params))

    def mirror_slices(self, params: LatticeParams) -> int:
        """Slices of that part, 0 if the lattice is not symmetric about its middle slice."""
        return self.library.lattice_mirror_slices(ctypes.byref(params))

    def mirrored_extent(self, params: LatticeParams) -> tuple[int, int]:
        """(rows, slices) the mirrored along-x state holds (lattice.h: lattice_rhs_along_x)."""
        rows, slices = self.mirror_rows(params), self.mirror_slices(params)
        return rows or params.rows, slices or params.depth

    def along_x(self, params: LatticeParams) -> bool:
        """Whether the lattice moves along x alone (lattice.h: its state without uy and vy carries it)."""
        return bool(self.library.lattice_along_x(ctypes.byref(params)))

    def rhs_along_x(
        self, params: LatticeParams, y_x, load_on: bool, mirrored: bool = False, wall_mode=None
    ) -> tuple[np.ndarray, np.ndarray]:
        """As rhs over the layout [ux, vx, W_ext, D, W_nr] of all masses or (mirrored) of the part that carries
        a mirror-symmetric lattice's solution (mirrored_extent)."""
        symmetric = self.mirror_rows(params) or self.mirror_slices(params)
        if not self.along_x(params) or (mirrored and not symmetric):
            raise ValueError(
                "params: the lattice does not move along x alone (load_angle 0), or is not "
                "mirror-symmetric (odd rows >= 3 or odd depth >= 3, a centred load)"
            )
        rows, slices = self.mirrored_extent(params) if mirrored else (params.rows, params.depth)
        n = 2 * rows * params.cols * slices
        y = np.ascontiguousarray(y_x, dtype=float)
        if y.shape != (n + 3,):
            raise ValueError(f"state: expected {n + 3} values, got {y.shape}")
        dydt = np.empty_like(y)
        self.library.lattice_rhs_along_x(
            ctypes.byref(params),
            int(mirrored),
            int(load_on),
            self._modes(wall_mode),
            y.ctypes.data_as(ctypes.POINTER(ctypes.c_double)),
            dydt.ctypes.data_as(ctypes.POINTER(ctypes.c_double)),
        )
        return dydt[:-3], dydt[-3:]

    def backplate_force_mirrored(self, params: LatticeParams, y_half) -> float:
        """The backplate force from the mirrored part's along-x layout [ux, vx, ...] (lattice.h)."""
        rows, slices = self.mirrored_extent(params)
        cols = params.cols
        y = np.ascontiguousarray(y_half, dtype=float)
        n = rows * cols * slices
        return self.library.lattice_backplate_force_mirrored(
            ctypes.byref(params),
            y[cols - 1 :].ctypes.data_as(ctypes.POINTER(ctypes.c_double)),
            y[n + cols - 1 :].ctypes.data_as(ctypes.POINTER(ctypes.c_double)),
            cols,
        )

    def backplate_force(self, params: LatticeParams, y) -> float:
        y = self._augmented(params, y)
        return self.library.lattice_backplate_force(
            ctypes.byref(params), y.ctypes.data_as(ctypes.POINTER(ctypes.c_double))
        )

    def energies(self, params: LatticeParams, y) -> tuple[float, float]:
        y = self._augmented(params, y)
        kinetic, potential = ctypes.c_double(), ctypes.c_double()
        self.library.lattice_energies(
            ctypes.byref(params),
            y.ctypes.data_as(ctypes.POINTER(ctypes.c_double)),
            ctypes.byref(kinetic),
            ctypes.byref(potential),
        )
        return kinetic.value, potential.value
