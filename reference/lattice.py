"""Vectorised numpy reference implementation of the mass-spring lattice (docs/model.md).

Written from ``docs/model.md`` only; it is the oracle the C model is tested
against.  Everything here is plain numpy; the integrator lives in
:mod:`reference.simulate`.

State layout (shared with the C model)
--------------------------------------
``N = rows * cols`` masses.  Row ``i`` (1-based, at y = (i-1)*spacing) and column
``j`` (1-based, at x = (j-1)*spacing) is mass ``n = (i-1)*cols + (j-1)``.  The
state vector is ``y = [ux(0..N-1), uy(0..N-1), vx(0..N-1), vy(0..N-1)]`` (length
4N); ``u`` is the displacement of each mass from its grid point.

Springs (docs/model.md section 2)
----------------
Every spring joins two masses ``a`` and ``b`` (stored once per pair).  With
``r = u_b - u_a`` the force on ``a`` is ``f(r; k_a, alpha_a)`` and the force on
``b`` is ``-f(r; k_b, alpha_b)``, where ``(k_a, alpha_a)`` are the constants
seen by end ``a``:

* horizontal neighbours: ``k0, alpha0`` and damping ``c0`` at both ends;
* vertical neighbours: ``k, alpha, c`` of the column's material (both ends are
  in the same column);
* diagonal neighbours, no damping:
  - ``diagonal_rule="receiver"`` (default, reproduces the published numbers):
    each end uses ``k_diag, alpha_diag`` of *its own* column's material, so a
    diagonal between two different materials is not reciprocal;
  - ``diagonal_rule="mean"``: both ends use the arithmetic mean of the two
    columns' ``k_diag`` and the mean of their ``alpha_diag`` (reciprocal).

Spring laws: ``"exponential"`` ``f = k (exp(alpha|r|) - 1) r/|r|`` (0 when
``|r| < 1e-12``), ``U = (k/alpha)(exp(alpha|r|) - alpha|r| - 1)``; ``"linear"``
``f = k r``, ``U = k |r|^2 / 2`` (alpha is ignored).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import Optional, Tuple

import numpy as np

from fmu_src.materials import study_materials

DIAGONAL_RULES = ("receiver", "mean")
SPRING_LAWS = ("exponential", "linear")

#: Below this spring length the exponential law's force is exactly zero (docs/model.md section 2).
R_EPS = 1e-12

MATERIAL_FIELDS = ("k", "k_diag", "c", "alpha", "alpha_diag")


def default_material_table(n: int = 11) -> dict:
    """docs/model.md section 3: material ``m = 1..n`` has scale ``s = (2/3)^(m-1)`` and
    ``k = 100 s``, ``k_diag = 50 s``, ``c = 5 s``, ``alpha = alpha_diag = 10``.

    Returns a dict of float arrays keyed by ``k, k_diag, c, alpha, alpha_diag``: the values of
    :func:`fmu_src.materials.study_materials`, the one place the study's table is computed (so the oracle and
    the FMU start from the same bits on every CPU).
    """
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise ValueError(f"default_material_table: n must be a positive integer, got {n!r}")
    table = study_materials(int(n))
    return {field: np.array(table.column(field), dtype=float) for field in MATERIAL_FIELDS}


def _frozen_array(x) -> np.ndarray:
    a = np.array(x, dtype=float, copy=True)
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class Scene:
    """One lattice scene.  Defaults are the published scene of docs/model.md.

    The scene is immutable (use :func:`dataclasses.replace` to vary it), so the
    index arrays built from it can be cached on it.
    """

    rows: int = 11
    cols: int = 11
    #: material number (1-based) of each column; default ``1..cols``.
    order: Optional[Tuple[int, ...]] = None
    #: material table, one entry per material (default: docs/model.md section 3 with ``cols`` materials).
    k: Optional[np.ndarray] = None
    k_diag: Optional[np.ndarray] = None
    c: Optional[np.ndarray] = None
    alpha: Optional[np.ndarray] = None
    alpha_diag: Optional[np.ndarray] = None
    #: horizontal spring constants (all columns).
    k0: float = 100.0
    alpha0: float = 10.0
    c0: float = 5.0
    mass: float = 1.0
    spacing: float = 1.0
    F_total: float = 1200.0
    #: load direction in degrees (0 = +x).
    load_angle: float = 0.0
    t_active: float = 0.15
    wall: bool = True
    k_wall: float = 1e4
    c_wall: float = 10.0
    backplate_gap: float = 1e-3
    diagonal_rule: str = "receiver"
    spring_law: str = "exponential"

    # ------------------------------------------------------------------ checks
    def __post_init__(self):
        set_ = lambda name, value: object.__setattr__(self, name, value)  # noqa: E731

        for name in ("rows", "cols"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
                raise ValueError(f"Scene.{name} must be a positive integer, got {v!r}")
            set_(name, int(v))

        if self.diagonal_rule not in DIAGONAL_RULES:
            raise ValueError(f"Scene.diagonal_rule must be one of {DIAGONAL_RULES}, got {self.diagonal_rule!r}")
        if self.spring_law not in SPRING_LAWS:
            raise ValueError(f"Scene.spring_law must be one of {SPRING_LAWS}, got {self.spring_law!r}")
        if not isinstance(self.wall, (bool, np.bool_)):
            raise ValueError(f"Scene.wall must be True or False, got {self.wall!r}")
        set_("wall", bool(self.wall))

        # material table (M materials; default: docs/model.md section 3 with ``cols`` materials)
        given = [getattr(self, f) is not None for f in MATERIAL_FIELDS]
        if any(given) and not all(given):
            missing = [f for f, g in zip(MATERIAL_FIELDS, given) if not g]
            raise ValueError(
                f"Scene material table: give all of k, k_diag, c, alpha, alpha_diag or none; missing {missing}"
            )
        table = default_material_table(self.cols) if not any(given) else {f: getattr(self, f) for f in MATERIAL_FIELDS}
        count = None
        for f in MATERIAL_FIELDS:
            try:
                a = np.array(table[f], dtype=float)
            except (TypeError, ValueError):
                raise ValueError(f"Scene.{f} must be an array of numbers, got {table[f]!r}") from None
            if a.ndim != 1 or a.shape[0] < 1 or (count is not None and a.shape[0] != count):
                raise ValueError(
                    f"Scene.{f} must have one entry per material, as many as the other fields of the table "
                    f"({count}); got shape {a.shape}"
                )
            count = a.shape[0]
            if not np.all(np.isfinite(a)) or np.any(a < 0):
                raise ValueError(f"Scene.{f} must be finite and >= 0, got {a.tolist()}")
            if f.startswith("alpha") and self.spring_law == "exponential" and np.any(a <= 0):
                raise ValueError(f"Scene.{f} must be > 0 for spring_law='exponential', got {a.tolist()}")
            set_(f, _frozen_array(a))

        # order: a material number (a row of the table, 1..M) per column; repeats are allowed here (the FMU's
        # repeat_materials decides whether a design may repeat one)
        if self.order is None:
            if count < self.cols:
                raise ValueError(f"Scene.order must be given: the table has {count} materials for {self.cols} columns")
            set_("order", tuple(range(1, self.cols + 1)))
        else:
            try:
                raw = list(self.order)
            except TypeError:
                raise ValueError(
                    f"Scene.order must be a sequence of {self.cols} material numbers in 1..{count}; got {self.order!r}"
                ) from None

            def _as_int(p):
                if isinstance(p, (bool, np.bool_)) or not isinstance(p, (int, np.integer, float, np.floating)):
                    return None
                if not math.isfinite(p) or float(p) != int(p):
                    return None
                return int(p)

            ints = [_as_int(p) for p in raw]
            if len(ints) != self.cols or None in ints or not all(1 <= p <= count for p in ints):
                raise ValueError(
                    f"Scene.order must be {self.cols} material numbers (one per column), each in 1..{count}, "
                    f"got {self.order!r}"
                )
            set_("order", tuple(int(p) for p in raw))

        # scalars
        def scalar(name, lo=None, strict=False):
            v = getattr(self, name)
            if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, float, np.integer, np.floating)):
                raise ValueError(f"Scene.{name} must be a number, got {v!r}")
            v = float(v)
            if not math.isfinite(v):
                raise ValueError(f"Scene.{name} must be finite, got {v!r}")
            if lo is not None and (v <= lo if strict else v < lo):
                raise ValueError(f"Scene.{name} must be {'>' if strict else '>='} {lo}, got {v!r}")
            set_(name, v)

        scalar("k0", 0.0)
        scalar("alpha0", 0.0, strict=self.spring_law == "exponential")
        scalar("c0", 0.0)
        scalar("mass", 0.0, strict=True)
        scalar("spacing", 0.0, strict=True)
        scalar("F_total")
        scalar("load_angle")
        scalar("t_active", 0.0)
        scalar("k_wall", 0.0)
        scalar("c_wall", 0.0)
        scalar("backplate_gap")

    # --------------------------------------------------------------- helpers
    @classmethod
    def from_description(cls, description, order=None) -> "Scene":
        """The oracle's scene for a scene description (a :class:`scenes.Scene`, or its name or .json path):
        the FMU's parameters of that scene, named as here; ``order`` replaces its material order.

        ``scenes`` is imported here, not at the top: the reference FMU bundles this package alone."""
        import scenes

        if not isinstance(description, scenes.Scene):
            description = scenes.Scene.load(description)
        v = description.parameter_values()
        masses = set(v["mass"])  # the FMU's mass[m] of each material (docs/model.md section 12)
        if len(masses) != 1:
            raise ValueError(
                f"scene {description.name}: its materials weigh {sorted(masses)} kg; this oracle has "
                f"one mass for every node"
            )
        return cls(
            rows=description.rows,
            cols=description.cols,
            order=tuple(order) if order is not None else v["material"],
            **{f: v[f] for f in MATERIAL_FIELDS},
            k0=v["k_horizontal"],
            alpha0=v["alpha_horizontal"],
            c0=v["c_horizontal"],
            mass=masses.pop(),
            F_total=v["F_total"],
            load_angle=v["load_angle"],
            t_active=v["t_active"],
            wall=bool(v["has_backplate"]),
            k_wall=v["k_wall"],
            c_wall=v["c_wall"],
            backplate_gap=v["backplate_gap"],
            diagonal_rule=DIAGONAL_RULES[int(v["diagonal_rule"])],
            spring_law=SPRING_LAWS[int(v["spring_law"])],
        )

    @classmethod
    def default_material_table(cls, n: int = 11) -> dict:
        return default_material_table(n)

    @property
    def n_masses(self) -> int:
        return self.rows * self.cols

    @property
    def state_size(self) -> int:
        return 4 * self.n_masses

    def index(self, i: int, j: int) -> int:
        """State index of the mass in row ``i``, column ``j`` (both 1-based)."""
        if not (1 <= i <= self.rows and 1 <= j <= self.cols):
            raise ValueError(f"(i, j) = ({i}, {j}) outside 1..{self.rows} x 1..{self.cols}")
        return (i - 1) * self.cols + (j - 1)

    def positions(self) -> np.ndarray:
        """Reference (grid) positions, shape (N, 2)."""
        i, j = np.divmod(np.arange(self.n_masses), self.cols)
        return np.column_stack([j * self.spacing, i * self.spacing]).astype(float)

    def zero_state(self) -> np.ndarray:
        return np.zeros(self.state_size)

    @cached_property
    def model(self) -> "_Model":
        """Precomputed index/constant arrays (built once per scene)."""
        return _Model(self)


# ---------------------------------------------------------------------------
# force law: the only place the spring law is written down
# ---------------------------------------------------------------------------
def spring_scale(d: np.ndarray, k: np.ndarray, alpha: np.ndarray, law: str) -> np.ndarray:
    """Return ``s`` such that the spring force is ``f(r) = s * r`` for ``|r| = d``."""
    if law == "linear":
        return np.broadcast_to(k, np.shape(d)).astype(float, copy=True)
    ok = d >= R_EPS
    s = k * np.expm1(alpha * d)
    s /= np.where(ok, d, 1.0)
    s *= ok
    return s


def spring_potential(d: np.ndarray, k: np.ndarray, alpha: np.ndarray, law: str) -> np.ndarray:
    """Spring potential ``U(|r| = d)``; the gradient of U w.r.t. r is the force above."""
    if law == "linear":
        return 0.5 * k * d * d
    x = alpha * d
    # (exp(x) - x - 1) with a Taylor series where the subtraction would cancel
    series = x * x * (1 / 2 + x * (1 / 6 + x * (1 / 24 + x * (1 / 120 + x * (1 / 720 + x / 5040)))))
    exact = np.expm1(x) - x
    return (k / alpha) * np.where(x < 1e-2, series, exact)


class _Model:
    """Per-scene constant arrays: spring ends, constants of both ends, damping."""

    def __init__(self, scene: Scene):
        self.scene = sc = scene
        R, C = sc.rows, sc.cols
        N = R * C
        self.N = N
        n = np.arange(N).reshape(R, C)
        mat = np.asarray(sc.order) - 1  # material index of each column (0-based)
        col = np.broadcast_to(np.arange(C), (R, C))

        ea, eb, ka, aa, kb, ab, ce = [], [], [], [], [], [], []

        def add(a, b, k_a, a_a, k_b, a_b, c):
            a = np.ravel(a)
            m = a.size
            ea.append(a)
            eb.append(np.ravel(b))
            for lst, v in ((ka, k_a), (aa, a_a), (kb, k_b), (ab, a_b), (ce, c)):
                lst.append(np.broadcast_to(np.ravel(v) if np.ndim(v) else v, (m,)).astype(float))

        # horizontal: (i, j) - (i, j+1)
        add(n[:, :-1], n[:, 1:], sc.k0, sc.alpha0, sc.k0, sc.alpha0, sc.c0)
        # vertical: (i, j) - (i+1, j); constants of column j's material
        mv = mat[col[:-1, :]]
        add(n[:-1, :], n[1:, :], sc.k[mv], sc.alpha[mv], sc.k[mv], sc.alpha[mv], sc.c[mv])
        # diagonals (i, j) - (i+1, j+1) and (i, j+1) - (i+1, j); no damping
        ml, mr = mat[col[:-1, :-1]], mat[col[:-1, 1:]]
        add(n[:-1, :-1], n[1:, 1:], sc.k_diag[ml], sc.alpha_diag[ml], sc.k_diag[mr], sc.alpha_diag[mr], 0.0)
        add(n[:-1, 1:], n[1:, :-1], sc.k_diag[mr], sc.alpha_diag[mr], sc.k_diag[ml], sc.alpha_diag[ml], 0.0)
        n_diag = ml.size * 2

        cat = lambda lst: np.concatenate(lst) if lst else np.zeros(0)  # noqa: E731
        self.ea = cat(ea).astype(np.intp)
        self.eb = cat(eb).astype(np.intp)
        ka, aa, kb, ab, ce = map(cat, (ka, aa, kb, ab, ce))
        E = self.ea.size
        self.n_springs = E
        self.is_diagonal = np.zeros(E, bool)
        self.is_diagonal[E - n_diag :] = True
        if sc.diagonal_rule == "mean":
            km, am = 0.5 * (ka + kb), 0.5 * (aa + ab)
            ka = kb = km
            aa = ab = am
        self.ka, self.aa, self.kb, self.ab = ka, aa, kb, ab

        # springs whose two ends see different constants (non-reciprocal)
        if sc.spring_law == "linear":
            nr = ka != kb
        else:
            nr = (ka != kb) | (aa != ab)
        self.nr = np.flatnonzero(nr)
        self.ea_nr, self.eb_nr = self.ea[self.nr], self.eb[self.nr]
        # flat gathers for the non-reciprocal power: r components and v_a + v_b
        self.g_rnr = np.concatenate([self.nr, self.nr + E])
        self.g_vnr_a = np.concatenate([self.ea_nr, self.ea_nr + N]) + 2 * N
        self.g_vnr_b = np.concatenate([self.eb_nr, self.eb_nr + N]) + 2 * N
        # one "spring end" entry per spring (end a) plus one per non-reciprocal
        # spring (end b); reciprocal springs share the a-end value.
        self.end_src = np.concatenate([np.arange(E), self.nr])
        self.k_end = np.concatenate([ka, kb[self.nr]])
        self.a_end = np.concatenate([aa, ab[self.nr]])
        self.b_map = np.arange(E)
        self.b_map[self.nr] = E + np.arange(self.nr.size)

        # damped springs (nearest neighbours with c > 0)
        d = np.flatnonzero(ce > 0)
        self.da, self.db, self.dc = self.ea[d], self.eb[d], ce[d]
        self.n_dampers = d.size

        # flat gather/scatter indices.  The state is [ux, uy, vx, vy]; with
        # x and y components stacked, spring quantities are laid out as
        # (2, E) -> flat [x of every spring, y of every spring].
        cat = np.concatenate
        self.g_ua, self.g_ub = cat([self.ea, self.ea + N]), cat([self.eb, self.eb + N])
        self.g_va, self.g_vb = cat([self.da, self.da + N]) + 2 * N, cat([self.db, self.db + N]) + 2 * N
        self.dc2 = cat([self.dc, self.dc])
        # scatter into the flat force array [Fx, Fy] (length 2N) of the weights
        # [spring a-ends (2E), spring b-ends (2E), damper a-ends, damper b-ends]
        self.scatter2 = cat([self.g_ua, self.g_ub, self.g_va - 2 * N, self.g_vb - 2 * N])

        # load on column 1 (docs/model.md section 4)
        w = np.ones(R)
        w[0] = 0.5
        w[-1] = 0.5
        w = w / w.sum()
        th = math.radians(sc.load_angle)
        self.load_idx = n[:, 0].copy()
        self.load_fx = sc.F_total * math.cos(th) * w
        self.load_fy = sc.F_total * math.sin(th) * w

        # wall on the last column (docs/model.md section 5)
        self.wall_idx = n[:, -1].copy()

    # ----------------------------------------------------------------- core
    def spring_terms(self, y):
        """From the state ``y``: ``r = u_b - u_a`` (2, E), ``|r|`` (E,), the
        force scale of end a (E,) and of end b (E,) of every spring (force on a
        ``s_a r``, on b ``-s_b r``), and the raw per-end scales."""
        E = self.n_springs
        r = (y[self.g_ub] - y[self.g_ua]).reshape(2, E)
        d = np.sqrt(r[0] * r[0] + r[1] * r[1])
        s = spring_scale(d[self.end_src], self.k_end, self.a_end, self.scene.spring_law)
        sb = s[self.b_map] if self.nr.size else s
        return r, d, s[:E], sb, s

    def _forces(self, r, sa, sb, cdv):
        """Scatter spring terms (r, s_a, s_b) and damper terms ``c (v_b - v_a)``
        (flat, length 2*n_dampers) into the flat force array [Fx, Fy]."""
        w = np.concatenate([(r * sa).ravel(), (r * (-sb)).ravel(), cdv, -cdv])
        return np.bincount(self.scatter2, w, minlength=2 * self.N)

    def internal_forces(self, y, springs=True, damping=True):
        """Spring + damper forces on every mass, flat [Fx, Fy] of length 2N."""
        r, d, sa, sb, _ = self.spring_terms(y)
        if not springs:
            sa = sb = np.zeros_like(sa)
        cdv = self.dc2 * (y[self.g_vb] - y[self.g_va])
        if not damping:
            cdv = np.zeros_like(cdv)
        return self._forces(r, sa, sb, cdv)

    def wall_terms(self, y):
        """(penetration p, contact mask, vx) of the last-column masses."""
        N = self.N
        p = y[self.wall_idx] - self.scene.backplate_gap
        return p, p > 0, y[2 * N + self.wall_idx]

    def evaluate(self, y, load_on: bool, with_powers: bool = False):
        """Derivative of the state (and optionally the three powers of docs/model.md section 7)."""
        sc = self.scene
        N = self.N
        y = np.asarray(y, dtype=float)

        r, d, sa, sb, s = self.spring_terms(y)
        dv = y[self.g_vb] - y[self.g_va]
        cdv = self.dc2 * dv
        f = self._forces(r, sa, sb, cdv)  # [Fx, Fy]

        p_wall = 0.0
        if sc.wall:
            p, contact, vxw = self.wall_terms(y)
            if contact.any():
                vpos = np.maximum(vxw, 0.0)
                f[self.wall_idx] -= np.where(contact, sc.k_wall * p + sc.c_wall * vpos, 0.0)
                if with_powers:
                    p_wall = float(np.sum(np.where(contact, sc.c_wall * vpos * vxw, 0.0)))

        p_ext = 0.0
        if load_on:
            li = self.load_idx
            f[li] += self.load_fx
            f[N + li] += self.load_fy
            if with_powers:
                p_ext = float(self.load_fx @ y[2 * N + li] + self.load_fy @ y[3 * N + li])

        dydt = np.empty(4 * N)
        dydt[: 2 * N] = y[2 * N : 4 * N]
        dydt[2 * N :] = f
        if sc.mass != 1.0:
            dydt[2 * N :] /= sc.mass
        if not with_powers:
            return dydt

        p_diss = float(cdv @ dv) + p_wall
        if self.nr.size:
            E = self.n_springs
            # g = (f(r; k_a, alpha_a) - f(r; k_b, alpha_b)) / 2 = (s_a - s_b) r / 2
            half_ds = 0.5 * (s[self.nr] - s[E:])
            rv = (r.ravel()[self.g_rnr] * (y[self.g_vnr_a] + y[self.g_vnr_b])).reshape(2, -1)
            p_nr = float(half_ds @ (rv[0] + rv[1]))
        else:
            p_nr = 0.0
        return dydt, (p_ext, p_diss, p_nr)


# ---------------------------------------------------------------------------
# public functional API
# ---------------------------------------------------------------------------
def _load_on(scene: Scene, t: float, load_on: Optional[bool]) -> bool:
    if load_on is None:
        return 0.0 <= t <= scene.t_active
    return bool(load_on)


def _check_state(scene: Scene, y) -> np.ndarray:
    y = np.asarray(y, dtype=float)
    if y.shape != (scene.state_size,):
        raise ValueError(f"state y must have shape ({scene.state_size},), got {y.shape}")
    return y


def rhs(scene: Scene, t: float, y, load_on: Optional[bool] = None) -> np.ndarray:
    """d y / d t.  ``load_on=None`` means the load acts iff ``0 <= t <= t_active``."""
    return scene.model.evaluate(_check_state(scene, y), _load_on(scene, t, load_on))


def powers(scene: Scene, t: float, y, load_on: Optional[bool] = None) -> Tuple[float, float, float]:
    """docs/model.md section 7 integrands ``(P_ext, P_diss, P_nonreciprocal)``:
    ``dW_ext/dt = F_ext . v``, ``dD/dt = sum c|v_a - v_b|^2 + sum_contact c_w max(vx,0) vx``,
    ``dW_nr/dt = sum g . (v_a + v_b)`` with ``g = (f(r; k_a, alpha_a) - f(r; k_b, alpha_b))/2``.
    """
    _, pw = scene.model.evaluate(_check_state(scene, y), _load_on(scene, t, load_on), True)
    return pw


def rhs_with_powers(scene: Scene, t: float, y, load_on: Optional[bool] = None):
    """``(dydt, (P_ext, P_diss, P_nr))`` from one evaluation."""
    return scene.model.evaluate(_check_state(scene, y), _load_on(scene, t, load_on), True)


def energies(scene: Scene, y) -> Tuple[float, float]:
    """``(kinetic, potential)``.  Potential: sum over springs of U (for a
    non-reciprocal spring the mean of its two ends' potentials) + sum over wall
    contacts of ``k_w p^2 / 2``."""
    m = scene.model
    y = _check_state(scene, y)
    v = y[2 * m.N :]
    ke = 0.5 * scene.mass * float(v @ v)
    r, d, _, _, _ = m.spring_terms(y)
    law = scene.spring_law
    pe = 0.5 * (spring_potential(d, m.ka, m.aa, law) + spring_potential(d, m.kb, m.ab, law))
    pe = float(np.sum(pe))
    if scene.wall:
        p, contact, _ = m.wall_terms(y)
        pe += float(np.sum(np.where(contact, 0.5 * scene.k_wall * p * p, 0.0)))
    return ke, pe


def backplate_force(scene: Scene, y) -> float | np.ndarray:
    """``F_bp = sum over last-column masses in contact of k_w p + c_w max(vx, 0)``.

    ``y`` may be one state (4N,) -> float, or states stacked as columns
    (4N, M) -> array of M values.  Zero when ``scene.wall`` is False.
    """
    y = np.asarray(y, dtype=float)
    if y.shape[0] != scene.state_size or y.ndim > 2:
        raise ValueError(f"state y must have shape ({scene.state_size},) or ({scene.state_size}, M)")
    if not scene.wall:
        return 0.0 if y.ndim == 1 else np.zeros(y.shape[1])
    N = scene.n_masses
    idx = scene.model.wall_idx
    p = y[idx] - scene.backplate_gap
    vx = y[2 * N + idx]
    f = np.where(p > 0, scene.k_wall * p + scene.c_wall * np.maximum(vx, 0.0), 0.0)
    out = f.sum(axis=0)
    return float(out) if y.ndim == 1 else out


def internal_forces(scene: Scene, y, springs: bool = True, damping: bool = True) -> np.ndarray:
    """Spring and damper forces on every mass, shape (N, 2) (no wall, no load)."""
    m = scene.model
    f = m.internal_forces(_check_state(scene, y), springs=springs, damping=damping)
    return f.reshape(2, m.N).T.copy()


def wall_forces(scene: Scene, y) -> np.ndarray:
    """Backplate forces on every mass, shape (N, 2) (nonzero only in the last column)."""
    m = scene.model
    y = _check_state(scene, y)
    out = np.zeros((m.N, 2))
    if scene.wall:
        p, contact, vxw = m.wall_terms(y)
        out[m.wall_idx, 0] = np.where(contact, -scene.k_wall * p - scene.c_wall * np.maximum(vxw, 0.0), 0.0)
    return out


def external_forces(scene: Scene, t: float, load_on: Optional[bool] = None) -> np.ndarray:
    """Applied load on every mass, shape (N, 2)."""
    m = scene.model
    out = np.zeros((m.N, 2))
    if _load_on(scene, t, load_on):
        out[m.load_idx, 0] = m.load_fx
        out[m.load_idx, 1] = m.load_fy
    return out


def forces(scene: Scene, t: float, y, load_on: Optional[bool] = None) -> np.ndarray:
    """Total force on every mass, shape (N, 2): springs + dampers + wall + load."""
    return internal_forces(scene, y) + wall_forces(scene, y) + external_forces(scene, t, load_on)
