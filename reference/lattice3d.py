"""Independent numpy/scipy reference of the three-dimensional lattice (docs/model.md section 10).

Written from docs/model.md alone (sections 2-7 and 10), sharing no code with the C model nor with the
two-dimensional reference (:mod:`reference.lattice`), so that each can check the other: with ``depth = 1`` this
module is the two-dimensional lattice of sections 1 to 7. The only thing it takes from the package is the study's
material table (:func:`fmu_src.materials.study_materials`, the one place the table is computed, as the
two-dimensional reference does).

Layout
------
``N = rows * cols * depth`` masses. Row ``i`` (y), column ``j`` (x, the load's direction) and slice ``k`` (z, depth),
all 1-based, is mass ``n = ((k-1) * rows + (i-1)) * cols + (j-1)``, so that ``depth = 1`` is the
two-dimensional numbering. The state is ``[ux, uy, uz, vx, vy, vz]``, each of length N.

Integration
-----------
scipy's DOP853, stepped here one step at a time so that every switch of the backplate is an event: while a
column-C mass is in contact (``p = ux - gap > 0``) and while its damper acts (in contact and ``vx > 0``) are
*modes*, frozen over a step. A step whose end disagrees with its modes is cut back to the earliest switch
(located on the step's dense output with Brent's method) and the solver restarts there with the switched modes,
so no step integrates across a discontinuity of the right-hand side. The load's end at ``t_active`` is a phase
boundary. The work integrals of section 7 are integrated with the state. The sampled peak is read from the
dense output at ``k * sample_interval``; the continuous peak is searched on every step's dense output (a grid,
then a bounded scalar refinement of the best candidates).

    python -m reference.lattice3d --write reference/plate_5x5x5_reference.json

writes the reference results the C model's three-dimensional lattice is checked against (see
:func:`reference_cases`).
"""

from __future__ import annotations

import argparse
import heapq
import json
import math
import sys
import time
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Optional

import numpy as np
import scipy
from scipy.integrate import DOP853
from scipy.optimize import brentq, minimize_scalar

from fmu_src.materials import study_materials

DIAGONAL_RULES = ("receiver", "mean")
SPRING_LAWS = ("exponential", "linear")
#: docs/model.md section 2: below this spring length the exponential law's force is zero
ZERO_LENGTH = 1e-12
MATERIAL_FIELDS = ("k", "k_diag", "c", "alpha", "alpha_diag")
#: switches located within this fraction of a step after the earliest one are switched together (mirror-image
#: masses of a symmetric load reach the plate at the same instant up to rounding)
SIMULTANEOUS_FRACTION = 1e-9
#: this many switches in a row at one instant mean the modes chatter: the reference refuses to go on
MAX_SWITCHES_AT_ONE_INSTANT = 1000
#: continuous peak: grid points per step, and candidates refined
FINE_POINTS = 16
CANDIDATES = 4


def _positive_int(name, value):
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
        raise ValueError(f"PlateScene.{name} must be a positive integer, got {value!r}")
    return int(value)


def _finite(name, value, minimum=None, strict=False):
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ValueError(f"PlateScene.{name} must be a number, got {value!r}")
    value = float(value)
    if not math.isfinite(value) or (minimum is not None and (value <= minimum if strict else value < minimum)):
        bound = "" if minimum is None else f" {'>' if strict else '>='} {minimum:g}"
        raise ValueError(f"PlateScene.{name} must be a finite number{bound}, got {value!r}")
    return value


@dataclass(frozen=True, eq=False)
class PlateScene:
    """One ``rows x cols x depth`` lattice (docs/model.md section 10). Defaults: the study's materials and load
    (sections 3 to 5) on a 5 x 5 x 5 plate, the load over the whole face.

    ``load_patch`` 0 spreads the load over the whole face of column 1; an odd ``P`` puts it on the centred
    ``P x P`` patch of that face (rows and slices ``(n - P)/2 + 1 .. (n + P)/2``), equal weights.
    """

    rows: int = 5
    cols: int = 5
    depth: int = 5
    #: material number (1-based row of the table) of each column; default 1..cols
    order: Optional[tuple] = None
    #: the material table, one entry per material (default: the study's first ``cols`` materials)
    k: Optional[tuple] = None
    k_diag: Optional[tuple] = None
    c: Optional[tuple] = None
    alpha: Optional[tuple] = None
    alpha_diag: Optional[tuple] = None
    k0: float = 100.0
    alpha0: float = 10.0
    c0: float = 5.0
    mass: float = 1.0
    F_total: float = 1200.0
    #: degrees in the xy plane, 0 along +x
    load_angle: float = 0.0
    t_active: float = 0.15
    load_patch: int = 0
    has_backplate: bool = True
    k_wall: float = 1e4
    c_wall: float = 10.0
    backplate_gap: float = 1e-3
    diagonal_rule: str = "receiver"
    spring_law: str = "exponential"

    def __post_init__(self):
        put = lambda name, value: object.__setattr__(self, name, value)  # noqa: E731
        for name in ("rows", "cols", "depth"):
            put(name, _positive_int(name, getattr(self, name)))
        if self.diagonal_rule not in DIAGONAL_RULES:
            raise ValueError(f"PlateScene.diagonal_rule must be one of {DIAGONAL_RULES}, got {self.diagonal_rule!r}")
        if self.spring_law not in SPRING_LAWS:
            raise ValueError(f"PlateScene.spring_law must be one of {SPRING_LAWS}, got {self.spring_law!r}")
        if not isinstance(self.has_backplate, (bool, np.bool_)):
            raise ValueError(f"PlateScene.has_backplate must be True or False, got {self.has_backplate!r}")
        put("has_backplate", bool(self.has_backplate))

        given = [getattr(self, f) is not None for f in MATERIAL_FIELDS]
        if any(given) and not all(given):
            missing = [f for f, g in zip(MATERIAL_FIELDS, given) if not g]
            raise ValueError(
                f"PlateScene material table: give all of {', '.join(MATERIAL_FIELDS)} or none; missing {missing}"
            )
        if not any(given):
            table = study_materials(min(self.cols, 11))
            values = {f: table.column(f) for f in MATERIAL_FIELDS}
        else:
            values = {f: getattr(self, f) for f in MATERIAL_FIELDS}
        count = None
        for f in MATERIAL_FIELDS:
            try:
                column = tuple(float(v) for v in values[f])
            except (TypeError, ValueError):
                raise ValueError(f"PlateScene.{f} must be a sequence of numbers, got {values[f]!r}") from None
            if not column or (count is not None and len(column) != count):
                raise ValueError(
                    f"PlateScene.{f} must have one entry per material, as many as the other fields "
                    f"({count}); got {len(column)}"
                )
            positive = f.startswith("alpha") and self.spring_law == "exponential"
            if not all(math.isfinite(v) and (v > 0 if positive else v >= 0) for v in column):
                raise ValueError(
                    f"PlateScene.{f} must be finite and {'> 0' if positive else '>= 0'}, got {list(column)}"
                )
            count = len(column)
            put(f, column)

        order = tuple(range(1, self.cols + 1)) if self.order is None else self.order
        try:
            order = tuple(order)
        except TypeError:
            order = None
        if (
            order is None
            or len(order) != self.cols
            or not all(isinstance(p, (int, np.integer)) and not isinstance(p, bool) and 1 <= p <= count for p in order)
        ):
            raise ValueError(
                f"PlateScene.order must be {self.cols} material numbers (one per column), each in "
                f"1..{count}, got {self.order!r}"
            )
        put("order", tuple(int(p) for p in order))

        put("k0", _finite("k0", self.k0, 0.0))
        put("alpha0", _finite("alpha0", self.alpha0, 0.0, strict=self.spring_law == "exponential"))
        put("c0", _finite("c0", self.c0, 0.0))
        put("mass", _finite("mass", self.mass, 0.0, strict=True))
        put("F_total", _finite("F_total", self.F_total))
        put("load_angle", _finite("load_angle", self.load_angle))
        put("t_active", _finite("t_active", self.t_active, 0.0))
        put("k_wall", _finite("k_wall", self.k_wall, 0.0))
        put("c_wall", _finite("c_wall", self.c_wall, 0.0))
        put("backplate_gap", _finite("backplate_gap", self.backplate_gap))

        patch = self.load_patch
        if isinstance(patch, bool) or not isinstance(patch, (int, np.integer)) or patch < 0:
            raise ValueError(
                f"PlateScene.load_patch must be 0 (the whole face) or an odd P <= min(rows, depth) = "
                f"{min(self.rows, self.depth)}, got {patch!r}"
            )
        if patch:
            if patch % 2 == 0 or patch > min(self.rows, self.depth):
                raise ValueError(
                    f"PlateScene.load_patch must be 0 (the whole face) or an odd P <= min(rows, depth) "
                    f"= {min(self.rows, self.depth)}, got {patch!r}"
                )
            if self.rows % 2 == 0 or self.depth % 2 == 0:
                raise ValueError(
                    f"PlateScene.load_patch: a centred odd patch needs an odd number of rows and of "
                    f"slices, got rows = {self.rows}, depth = {self.depth}"
                )
        put("load_patch", int(patch))

    @property
    def n_masses(self) -> int:
        return self.rows * self.cols * self.depth

    @property
    def state_size(self) -> int:
        return 6 * self.n_masses

    def index(self, i: int, j: int, k: int = 1) -> int:
        """State index of the mass in row ``i``, column ``j``, slice ``k`` (all 1-based)."""
        if not (1 <= i <= self.rows and 1 <= j <= self.cols and 1 <= k <= self.depth):
            raise ValueError(f"(i, j, k) = ({i}, {j}, {k}) outside 1..{self.rows} x 1..{self.cols} x 1..{self.depth}")
        return ((k - 1) * self.rows + (i - 1)) * self.cols + (j - 1)

    def describe(self) -> dict:
        """Every field by name, JSON-ready."""
        return {f.name: (list(v) if isinstance(v := getattr(self, f.name), tuple) else v) for f in fields(self)}


def load_weights(rows: int, depth: int, patch: int) -> np.ndarray:
    """docs/model.md sections 4 and 10: the share of the total load of each mass of the loaded face, ``(depth,
    rows)``, summing to 1. The whole face: the product of the row weight in y and the same weight in z (1/2 at an
    edge); a centred ``patch x patch`` square: equal weights."""
    if patch:
        w = np.zeros((depth, rows))
        first_row, first_slice = (rows - patch) // 2, (depth - patch) // 2
        w[first_slice : first_slice + patch, first_row : first_row + patch] = 1.0
    else:
        edge = lambda n: np.array([0.5 if q in (0, n - 1) else 1.0 for q in range(n)])  # noqa: E731
        w = np.outer(edge(depth), edge(rows))
    return w / w.sum()


class PlateModel:
    """The scene's springs as index arrays, and the right-hand side under given backplate modes."""

    def __init__(self, scene: PlateScene):
        self.scene = sc = scene
        R, C, D = sc.rows, sc.cols, sc.depth
        self.N = N = R * C * D
        grid = np.arange(N).reshape(D, R, C)  # grid[k, i, j]
        material = np.array(sc.order) - 1
        k_, kd, c_, al, ald = (np.array(getattr(sc, f)) for f in ("k", "k_diag", "c", "alpha", "alpha_diag"))

        ends_a, ends_b, kinds = [], [], []

        def pairs(a, b, kind):
            ends_a.append(a.ravel())
            ends_b.append(b.ravel())
            kinds.append(np.full(a.size, kind))

        # nearest neighbours: along x (between columns), along y and along z (inside a column)
        pairs(grid[:, :, :-1], grid[:, :, 1:], "x")
        pairs(grid[:, :-1, :], grid[:, 1:, :], "y")
        pairs(grid[:-1, :, :], grid[1:, :, :], "z")
        # face diagonals of the xy, xz and yz planes, both directions of each square
        pairs(grid[:, :-1, :-1], grid[:, 1:, 1:], "xy")
        pairs(grid[:, :-1, 1:], grid[:, 1:, :-1], "xy")
        pairs(grid[:-1, :, :-1], grid[1:, :, 1:], "xz")
        pairs(grid[:-1, :, 1:], grid[1:, :, :-1], "xz")
        pairs(grid[:-1, :-1, :], grid[1:, 1:, :], "yz")
        pairs(grid[:-1, 1:, :], grid[1:, :-1, :], "yz")
        a, b, kind = np.concatenate(ends_a), np.concatenate(ends_b), np.concatenate(kinds)
        self.a, self.b, self.kind = a, b, kind
        self.n_springs = a.size
        ma, mb = material[a % C], material[b % C]  # the material of each end's column
        along_x, inside = kind == "x", (kind == "y") | (kind == "z")
        diagonal = ~(along_x | inside)

        ka, kb, aa, ab, damping = (np.zeros(a.size) for _ in range(5))
        ka[along_x] = kb[along_x] = sc.k0
        aa[along_x] = ab[along_x] = sc.alpha0
        damping[along_x] = sc.c0
        ka[inside] = kb[inside] = k_[ma[inside]]  # both ends in one column
        aa[inside] = ab[inside] = al[ma[inside]]
        damping[inside] = c_[ma[inside]]
        if sc.diagonal_rule == "receiver":  # each end takes the constants of its own column
            ka[diagonal], kb[diagonal] = kd[ma[diagonal]], kd[mb[diagonal]]
            aa[diagonal], ab[diagonal] = ald[ma[diagonal]], ald[mb[diagonal]]
        else:  # both ends the mean of the two columns'
            ka[diagonal] = kb[diagonal] = 0.5 * (kd[ma[diagonal]] + kd[mb[diagonal]])
            aa[diagonal] = ab[diagonal] = 0.5 * (ald[ma[diagonal]] + ald[mb[diagonal]])
        self.ka, self.kb, self.aa, self.ab = ka, kb, aa, ab
        self.damping = damping
        self.damped = np.flatnonzero(damping > 0)

        # flat gathers from the state and one scatter into the force array [Fx, Fy, Fz] (3N): spring
        # quantities are laid out (3, E) -> [x of every spring, y ..., z ...]
        comp = np.arange(3)[:, None] * N
        self.u_a, self.u_b = (comp + a).ravel(), (comp + b).ravel()
        self.v_a, self.v_b = self.u_a + 3 * N, self.u_b + 3 * N
        da, db = a[self.damped], b[self.damped]
        self.dv_a, self.dv_b = (comp + da).ravel() + 3 * N, (comp + db).ravel() + 3 * N
        self.damping3 = np.tile(damping[self.damped], 3)
        self.scatter = np.concatenate([self.u_a, self.u_b, self.dv_a - 3 * N, self.dv_b - 3 * N])

        # load on column 1 (sections 4 and 10), backplate behind column C (section 5)
        weights = load_weights(R, D, sc.load_patch)
        loaded = weights.ravel() > 0
        self.load_index = grid[:, :, 0].ravel()[loaded]
        theta = math.radians(sc.load_angle)
        share = sc.F_total * weights.ravel()[loaded]
        self.load_fx, self.load_fy = share * math.cos(theta), share * math.sin(theta)
        self.wall_index = grid[:, :, -1].ravel()
        self.first_column, self.last_column = grid[:, :, 0].ravel(), grid[:, :, -1].ravel()

    # ------------------------------------------------------------------ the force law (section 2)
    def _law(self, d, k, alpha):
        """Scale s of the force ``f = s r`` of springs of length d."""
        if self.scene.spring_law == "linear":
            return k.copy()
        long_enough = d >= ZERO_LENGTH
        return np.where(long_enough, k * np.expm1(alpha * d) / np.where(long_enough, d, 1.0), 0.0)

    def _potential(self, d, k, alpha):
        if self.scene.spring_law == "linear":
            return 0.5 * k * d * d
        x = alpha * d
        # exp(x) - x - 1 by its series where the difference would cancel
        series = x * x * (1 / 2 + x * (1 / 6 + x * (1 / 24 + x * (1 / 120 + x * (1 / 720 + x / 5040)))))
        return (k / alpha) * np.where(x < 1e-2, series, np.expm1(x) - x)

    def spring_state(self, y):
        """``r = u_b - u_a`` (3, E), its length, and the scale of the force on end a and on end b."""
        r = (y[self.u_b] - y[self.u_a]).reshape(3, -1)
        d = np.sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2])
        return r, d, self._law(d, self.ka, self.aa), self._law(d, self.kb, self.ab)

    def derivative(self, z, load_on: bool, contact: np.ndarray, damper_on: np.ndarray) -> np.ndarray:
        """d/dt of the state augmented with ``[external work, dissipated energy, non-reciprocal work]``, under
        the backplate modes ``contact`` and ``damper_on`` (one flag per column-C mass)."""
        sc, N = self.scene, self.N
        y = z[: 6 * N]
        r, d, sa, sb = self.spring_state(y)
        dv = y[self.dv_b] - y[self.dv_a]
        cdv = self.damping3 * dv
        on_a, on_b = (r * sa).ravel(), (r * sb).ravel()
        force = np.bincount(self.scatter, np.concatenate([on_a, -on_b, cdv, -cdv]), minlength=3 * N)

        wall_power = 0.0
        if sc.has_backplate:
            w = self.wall_index
            p = y[w] - sc.backplate_gap
            vx = y[3 * N + w]
            damper = sc.c_wall * vx * damper_on
            force[w] -= contact * sc.k_wall * p + damper
            wall_power = float(damper @ vx)
        external_power = 0.0
        if load_on:
            li = self.load_index
            force[li] += self.load_fx
            force[N + li] += self.load_fy
            external_power = float(self.load_fx @ y[3 * N + li] + self.load_fy @ y[4 * N + li])

        out = np.empty(6 * N + 3)
        out[: 3 * N] = y[3 * N :]
        out[3 * N : 6 * N] = force / sc.mass
        out[6 * N] = external_power
        out[6 * N + 1] = float(cdv @ dv) + wall_power
        # section 7: g = (f(r; k_a) - f(r; k_b)) / 2 on each pair, its power g . (v_a + v_b)
        out[6 * N + 2] = 0.5 * float((on_a - on_b) @ (y[self.v_a] + y[self.v_b]))
        return out

    def energies(self, y, contact) -> tuple[float, float]:
        """``(kinetic, potential)``: the potential sums U over the springs (a non-reciprocal pair the mean of its
        two ends' U) and ½ k_w p² over the masses in contact."""
        sc, N = self.scene, self.N
        v = y[3 * N : 6 * N]
        kinetic = 0.5 * sc.mass * float(v @ v)
        _, d, _, _ = self.spring_state(y)
        potential = float(np.sum(0.5 * (self._potential(d, self.ka, self.aa) + self._potential(d, self.kb, self.ab))))
        if sc.has_backplate:
            p = y[self.wall_index] - sc.backplate_gap
            potential += float(np.sum(contact * 0.5 * sc.k_wall * p * p))
        return kinetic, potential

    def backplate_force(self, y, contact, damper_on):
        """Section 5's ``F_bp`` of the state(s) y ((6N,) or (6N, M)) under the given modes."""
        if not self.scene.has_backplate:
            return np.zeros(y.shape[1:]) if y.ndim > 1 else 0.0
        N, sc = self.N, self.scene
        p = y[self.wall_index] - sc.backplate_gap
        vx = y[3 * N + self.wall_index]
        if y.ndim > 1:
            contact, damper_on = contact[:, None], damper_on[:, None]
        return np.sum(contact * sc.k_wall * p + damper_on * sc.c_wall * vx, axis=0)

    def compression(self, y):
        """Section 9: mean ux of column 1 minus mean ux of column C."""
        return y[self.first_column].mean(axis=0) - y[self.last_column].mean(axis=0)


@dataclass(frozen=True, eq=False)
class PlateResult:
    """One run of :func:`simulate_plate`: the objective of section 6, section 9's compression and section 7's
    energy terms at the horizon."""

    scene: PlateScene
    rtol: float
    atol: float
    horizon: float
    sample_interval: float
    times: np.ndarray
    backplate_force: np.ndarray
    peak_backplate_force: float
    peak_sample_time: float
    max_compression: float
    peak_backplate_force_continuous: float
    peak_time: float
    kinetic_energy: float
    potential_energy: float
    external_work: float
    dissipated_energy: float
    nonreciprocal_work: float
    energy_balance_error: float
    final_state: np.ndarray
    #: right-hand sides evaluated, steps taken (one cut back at a switch counts), backplate switches located
    n_rhs: int
    n_steps: int
    n_switches: int
    wall_time: float = field(default=0.0)


def sample_times(horizon: float, sample_interval: float) -> np.ndarray:
    """``q * sample_interval`` for q = 0, 1, ... up to the horizon (801 samples for 8 s at 0.01 s)."""
    count = int(math.floor(horizon / sample_interval * (1 + 1e-12) + 1e-9))
    return np.minimum(np.arange(count + 1) * sample_interval, horizon)


class _PeakSearch:
    """The continuous maximum of ``F_bp`` over the pieces of the solution: a grid per piece, then a bounded
    scalar refinement of the best few grid points."""

    def __init__(self, model: PlateModel):
        self.model = model
        self.best = (-math.inf, math.nan)
        self.candidates: list = []
        self.counter = 0

    def add(self, t0, t1, interpolant, contact, damper_on):
        grid = t0 + (t1 - t0) * np.linspace(0.0, 1.0, FINE_POINTS + 1)
        values = self.model.backplate_force(interpolant(grid), contact, damper_on)
        q = int(np.argmax(values))
        value = float(values[q])
        if value > self.best[0]:
            self.best = (value, float(grid[q]))
        item = (
            value,
            self.counter,
            float(grid[max(q - 1, 0)]),
            float(grid[min(q + 1, FINE_POINTS)]),
            interpolant,
            contact.copy(),
            damper_on.copy(),
        )
        self.counter += 1
        if len(self.candidates) < CANDIDATES:
            heapq.heappush(self.candidates, item)
        elif value > self.candidates[0][0]:
            heapq.heapreplace(self.candidates, item)

    def result(self):
        value, at = self.best
        for _, _, lo, hi, interpolant, contact, damper_on in self.candidates:
            if hi <= lo:
                continue
            found = minimize_scalar(
                lambda t: -float(self.model.backplate_force(interpolant(t), contact, damper_on)),
                bounds=(lo, hi),
                method="bounded",
                options={"xatol": 1e-13 * max(1.0, hi)},
            )
            if -found.fun > value:
                value, at = float(-found.fun), float(found.x)
        return value, at


def _switches(y_old, y_new, interpolant, t_old, t_new, ux_wall, vx_wall, gap, contact, damper_on):
    """The backplate switches inside the step [t_old, t_new], as ``(time, wall mass, "contact" or "damper")``:
    every indicator (``p`` for the contact, ``vx`` for the damper of a mass in contact) whose sign at the step's
    end disagrees with its mode, located on the step's dense output. One already on the far side at the
    step's start (a mirror-image twin of a switch just made, within rounding) switches at ``t_old``."""
    indicators = (
        ((y_new[ux_wall] - gap > 0) != contact, ux_wall, gap, "contact"),
        (contact & ((y_new[vx_wall] > 0) != damper_on), vx_wall, 0.0, "damper"),
    )
    roots = []
    for wrong, rows, shift, kind in indicators:
        for w in np.flatnonzero(wrong):
            q = rows[w]
            start, end = y_old[q] - shift, y_new[q] - shift
            if start == 0.0 or np.sign(start) == np.sign(end):
                roots.append((t_old, w, kind))
            else:
                roots.append(
                    (
                        brentq(
                            lambda s: interpolant(s)[q] - shift, t_old, t_new, xtol=1e-16, rtol=4 * np.finfo(float).eps
                        ),
                        w,
                        kind,
                    )
                )
    return roots


def simulate_plate(
    scene: PlateScene, horizon: float = 8.0, sample_interval: float = 0.01, rtol: float = 1e-12, atol: float = 1e-14
) -> PlateResult:
    """Integrate ``scene`` from rest to ``horizon`` (module docstring: DOP853, every backplate switch an event)."""
    if not isinstance(scene, PlateScene):
        raise ValueError(f"simulate_plate: scene must be a PlateScene, got {type(scene).__name__}")
    for name, value in (("horizon", horizon), ("sample_interval", sample_interval), ("rtol", rtol), ("atol", atol)):
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not (math.isfinite(value) and value > 0):
            raise ValueError(f"simulate_plate: {name} must be a positive finite number, got {value!r}")
    started = time.perf_counter()
    model = PlateModel(scene)
    N = model.N
    size = 6 * N + 3
    gap = scene.backplate_gap
    ux_wall, vx_wall = model.wall_index, 3 * N + model.wall_index

    z = np.zeros(size)
    contact = (z[ux_wall] - gap > 0) & scene.has_backplate  # a negative gap starts in contact
    damper_on = np.zeros_like(contact)

    times = sample_times(horizon, sample_interval)
    force_samples = np.full(times.size, np.nan)
    compression_samples = np.full(times.size, np.nan)
    force_samples[0] = model.backplate_force(z[: 6 * N], contact, damper_on)
    compression_samples[0] = model.compression(z[: 6 * N])
    peaks = _PeakSearch(model)
    n_rhs = n_steps = n_switches = 0

    def record(t0, t1, interpolant):
        """Samples in (t0, t1] and the continuous peak over [t0, t1], under the current modes."""
        chosen = np.flatnonzero((times > t0) & (times <= t1))
        if chosen.size:
            states = interpolant(times[chosen])[: 6 * N]
            force_samples[chosen] = model.backplate_force(states, contact, damper_on)
            compression_samples[chosen] = model.compression(states)
        peaks.add(t0, t1, lambda t: interpolant(t)[: 6 * N], contact, damper_on)

    phases = [(0.0, min(scene.t_active, horizon), True)] if scene.t_active > 0 else []
    if scene.t_active < horizon:
        phases.append((scene.t_active, horizon, False))
    first_step = None
    for t_start, t_end, load_on in phases:
        t = t_start
        at_one_instant = 0
        while t < t_end:
            solver = DOP853(
                lambda _t, zz, _on=load_on, _c=contact.copy(), _d=damper_on.copy(): model.derivative(zz, _on, _c, _d),
                t,
                z,
                t_end,
                rtol=rtol,
                atol=atol,
                first_step=None if first_step is None else min(first_step, t_end - t),
            )
            switched = False
            while solver.status == "running":
                message = solver.step()
                if solver.status == "failed":
                    raise RuntimeError(f"simulate_plate: DOP853 failed at t = {solver.t!r}: {message}")
                n_steps += 1
                t_old, t_new = solver.t_old, solver.t
                interpolant = solver.dense_output()
                roots = (
                    _switches(
                        solver.y_old, solver.y, interpolant, t_old, t_new, ux_wall, vx_wall, gap, contact, damper_on
                    )
                    if scene.has_backplate
                    else []
                )
                if not roots:
                    record(t_old, t_new, interpolant)
                    first_step = solver.h_abs
                    continue
                t_switch = min(r[0] for r in roots)
                if t_switch > t_old:
                    record(t_old, t_switch, interpolant)
                z = interpolant(t_switch)
                together = [r for r in roots if r[0] <= t_switch + SIMULTANEOUS_FRACTION * (t_new - t_old)]
                vx_now = z[vx_wall]
                for _, w, kind in together:
                    if kind == "contact":
                        contact[w] = not contact[w]
                        damper_on[w] = contact[w] and vx_now[w] > 0
                    else:
                        damper_on[w] = not damper_on[w]
                n_switches += len(together)
                at_one_instant = at_one_instant + 1 if t_switch == t else 0
                if at_one_instant > MAX_SWITCHES_AT_ONE_INSTANT:
                    raise RuntimeError(f"simulate_plate: the backplate's modes chatter at t = {t_switch!r}")
                t = t_switch
                first_step = max(solver.h_abs, 1e-12)
                switched = True
                break
            n_rhs += solver.nfev
            if not switched:
                z = solver.y.copy()
                t = t_end

    if not np.all(np.isfinite(force_samples)):
        raise RuntimeError("simulate_plate: a sample time was not reached")
    peak_index = int(np.argmax(force_samples))
    peak = float(force_samples[peak_index])
    continuous, peak_time = peaks.result()
    if peak > continuous:
        continuous, peak_time = peak, float(times[peak_index])
    y_end = z[: 6 * N].copy()
    kinetic, potential = model.energies(y_end, contact)
    external, dissipated, nonreciprocal = (float(x) for x in z[6 * N :])
    return PlateResult(
        scene=scene,
        rtol=rtol,
        atol=atol,
        horizon=horizon,
        sample_interval=sample_interval,
        times=times,
        backplate_force=force_samples,
        peak_backplate_force=peak,
        peak_sample_time=float(times[peak_index]),
        max_compression=float(np.max(compression_samples)),
        peak_backplate_force_continuous=continuous,
        peak_time=peak_time,
        kinetic_energy=kinetic,
        potential_energy=potential,
        external_work=external,
        dissipated_energy=dissipated,
        nonreciprocal_work=nonreciprocal,
        energy_balance_error=external + nonreciprocal - kinetic - potential - dissipated,
        final_state=y_end,
        n_rhs=n_rhs,
        n_steps=n_steps,
        n_switches=n_switches,
        wall_time=time.perf_counter() - started,
    )


# ---------------------------------------------------------------------------------------------- reference data
#: what the C model's three-dimensional lattice is checked against (docs/model.md section 10): a 5 x 5 x 5 plate
#: of the study's first five materials, two orders, both diagonal rules, the whole face and the centred 3 x 3 patch
REFERENCE_ORDERS = ((1, 2, 3, 4, 5), (3, 1, 5, 2, 4))
REFERENCE_PATCHES = (0, 3)
REFERENCE_HORIZON, REFERENCE_SAMPLE_INTERVAL = 8.0, 0.01
REFERENCE_RTOL, REFERENCE_ATOL = 1e-12, 1e-14
REFERENCE_FILE = Path(__file__).resolve().parent / "plate_5x5x5_reference.json"
COMMAND = "python -m reference.lattice3d --write reference/plate_5x5x5_reference.json"
#: the figures of a case, by PlateResult field
CASE_FIGURES = (
    "peak_backplate_force",
    "peak_sample_time",
    "peak_backplate_force_continuous",
    "peak_time",
    "max_compression",
    "kinetic_energy",
    "potential_energy",
    "external_work",
    "dissipated_energy",
    "nonreciprocal_work",
    "energy_balance_error",
)


def reference_cases() -> tuple[tuple[str, PlateScene], ...]:
    """The eight scenes of the reference file, named ``<rule>-<whole|patchP>-<order>``."""
    cases = []
    for order in REFERENCE_ORDERS:
        for rule in DIAGONAL_RULES:
            for patch in REFERENCE_PATCHES:
                name = f"{rule}-{'whole' if patch == 0 else f'patch{patch}'}-{''.join(map(str, order))}"
                cases.append((name, PlateScene(order=order, diagonal_rule=rule, load_patch=patch)))
    return tuple(cases)


def case_record(name: str, result: PlateResult) -> dict:
    """One case of the reference file: its scene, every field by name, and its figures."""
    return {
        "name": name,
        "scene": result.scene.describe(),
        **{figure: getattr(result, figure) for figure in CASE_FIGURES},
    }


def reference_document(records: list[dict]) -> dict:
    return {
        "description": "Reference results of the three-dimensional lattice, computed by the independent numpy/scipy "
        "reference (reference/lattice3d.py), for the C model to be checked against",
        "specification": "docs/model.md section 10 (with sections 2 to 7 and 9 it extends)",
        "command": COMMAND,
        "integration": {
            "method": "scipy DOP853, every backplate switch (contact, damper) located as an event, "
            "the load's end a phase boundary",
            "rtol": REFERENCE_RTOL,
            "atol": REFERENCE_ATOL,
        },
        "horizon": REFERENCE_HORIZON,
        "sample_interval": REFERENCE_SAMPLE_INTERVAL,
        "libraries": {"numpy": np.__version__, "scipy": scipy.__version__},
        "cases": records,
    }


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m reference.lattice3d",
        description="Compute the three-dimensional reference results (docs/model.md section 10): a 5 x 5 x 5 plate, "
        "two orders, both diagonal rules, the whole face and a centred 3 x 3 patch.",
    )
    parser.add_argument(
        "--write",
        metavar="PATH",
        type=Path,
        help=f"write the results as JSON to PATH (the repository's file: {COMMAND.split()[-1]})",
    )
    parser.add_argument("--debug", action="store_true", help="show tracebacks")
    args = parser.parse_args(argv)
    if args.write is not None and not args.write.parent.is_dir():
        print(f"error: --write: the folder {args.write.parent} does not exist", file=sys.stderr)
        return 2
    try:
        records = []
        for name, scene in reference_cases():
            result = simulate_plate(scene, REFERENCE_HORIZON, REFERENCE_SAMPLE_INTERVAL, REFERENCE_RTOL, REFERENCE_ATOL)
            records.append(case_record(name, result))
            print(
                f"{name:24s} peak {result.peak_backplate_force:.12g} N  continuous "
                f"{result.peak_backplate_force_continuous:.12g} N  external work {result.external_work:.12g} J  "
                f"balance {result.energy_balance_error / result.external_work:.1e}  ({result.wall_time:.1f} s)",
                flush=True,
            )
        if args.write is not None:
            partial = args.write.with_name(args.write.name + ".partial")
            partial.write_text(json.dumps(reference_document(records), indent=1) + "\n")
            partial.replace(args.write)  # never a half-written reference file
            print(f"wrote {args.write}")
    except Exception as error:  # noqa: BLE001 - one line unless --debug
        if args.debug:
            raise
        print(f"error: {error}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
