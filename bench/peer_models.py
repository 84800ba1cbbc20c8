"""docs/model.md's right-hand side as the strongest pip-installable peers would write it: numba and JAX.

Used by bench.peers (scipy's odeint/LSODA and solve_ivp/DOP853 over the numba right-hand side, diffrax's
Tsit5 over the JAX one). Both are written once here from docs/model.md sections 2-5, on the grid (every spring
visited once, no index arrays), and :func:`check_against_reference`, which bench.peers runs before it times
anything, compares them with reference/lattice.py's right-hand side to 1e-12 on random states: a peer is timed
only while it computes the same model.

The scene's numbers come from a reference.Scene (it validates the order and the material table); what a
kernel needs is packed by :func:`pack` into four small arrays, so one compiled kernel serves every order:

- ``columns`` (3, C): vertical spring k, alpha and damping c of each column's material;
- ``diagonals`` (4, C-1): for the diagonals between columns j and j+1, (k, alpha) seen by the end in column
  j, then (k, alpha) seen by the end in column j+1. The receiver rule (docs/model.md §2, as computed) gives each end
  its own column's k_diag, alpha_diag; the mean rule gives both ends the mean of the two;
- ``scalars``: k0, alpha0, c0, k_wall, c_wall, gap, 1/mass, wall (1 or 0);
- ``load`` (2, R): the load's x and y force on each row's column-1 mass while it acts.

State layout as in reference/lattice.py: ``y = [ux(N), uy(N), vx(N), vy(N)]``, mass (i, j) at i*C + j.

The plate of docs/model.md section 10 (R x C x D) has its own kernels, written once the same way and checked by
:func:`check_plate_against_reference` against reference/lattice3d.py: :func:`pack_plate` adds to the arrays above
``column_diagonals`` (2, C) (k_diag, alpha_diag of each column's material: a yz diagonal stays in its column) and
spreads the load over the face as ``load`` (2, D, R). State layout as in reference/lattice3d.py: ``y = [ux, uy,
uz, vx, vy, vz]``, mass (i, j, k) at (k*R + i)*C + j. They are not a generalisation of the 2-D kernels: a plate of
depth 1 carries uz and its velocity, so the 2-D kernels would do more work, and their figures would mean another
code.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

R_EPS = 1e-12  # below this spring length the force is zero (docs/model.md section 2)


@dataclass(frozen=True)
class Packed:
    rows: int
    cols: int
    columns: np.ndarray
    diagonals: np.ndarray
    scalars: np.ndarray
    load: np.ndarray
    t_active: float

    @property
    def state_size(self) -> int:
        return 4 * self.rows * self.cols

    def kernel_args(self):
        return self.columns, self.diagonals, self.scalars, self.load

    @property
    def equal_diagonal_alphas(self) -> bool:
        """Both ends of every diagonal see the same alpha: one exp serves both (true for docs/model.md §3's table)."""
        return bool(np.array_equal(self.diagonals[1], self.diagonals[3]))

    def backplate_force(self, states: np.ndarray) -> np.ndarray:
        return backplate_force(self, states)


def pack(scene) -> Packed:
    """The kernel's arrays for a reference.Scene (exponential springs only: the armour scene's law)."""
    if scene.spring_law != "exponential":
        raise ValueError(f"pack: spring_law must be 'exponential', got {scene.spring_law!r}")
    material = np.asarray(scene.order) - 1
    columns = np.array([scene.k[material], scene.alpha[material], scene.c[material]], dtype=float)
    kd, ad = scene.k_diag[material], scene.alpha_diag[material]
    left = np.array([kd[:-1], ad[:-1]])
    right = np.array([kd[1:], ad[1:]])
    if scene.diagonal_rule == "mean":
        left = right = 0.5 * (left + right)
    elif scene.diagonal_rule != "receiver":
        raise ValueError(f"pack: diagonal_rule must be 'receiver' or 'mean', got {scene.diagonal_rule!r}")
    diagonals = np.ascontiguousarray(np.vstack([left, right]), dtype=float).reshape(4, scene.cols - 1)
    scalars = np.array(
        [
            scene.k0,
            scene.alpha0,
            scene.c0,
            scene.k_wall,
            scene.c_wall,
            scene.backplate_gap,
            1.0 / scene.mass,
            1.0 if scene.wall else 0.0,
        ]
    )
    weights = np.ones(scene.rows)
    if scene.rows > 1:
        weights[0] = weights[-1] = 0.5
    weights /= weights.sum()
    angle = math.radians(scene.load_angle)
    load = np.array([scene.F_total * math.cos(angle) * weights, scene.F_total * math.sin(angle) * weights])
    return Packed(
        scene.rows,
        scene.cols,
        np.ascontiguousarray(columns),
        diagonals,
        scalars,
        np.ascontiguousarray(load),
        float(scene.t_active),
    )


def backplate_force(packed: Packed, states: np.ndarray) -> np.ndarray:
    """docs/model.md section 5's backplate force of states stacked as rows, shape (M, 4N) -> (M,)."""
    R, C = packed.rows, packed.cols
    N = R * C
    k_w, c_w, gap = packed.scalars[3], packed.scalars[4], packed.scalars[5]
    wall = np.arange(R) * C + (C - 1)
    p = states[:, wall] - gap
    vx = states[:, 2 * N + wall]
    return np.where(p > 0, k_w * p + c_w * np.maximum(vx, 0.0), 0.0).sum(axis=1)


# ---------------------------------------------------------------------------------------------- numba
_NUMBA = {}


def numba_kernels():
    """(rhs_odeint, rhs_solve_ivp, rhs_into), compiled on first use (numba is a bench-only dependency).

    rhs_odeint(y, t, load_on, columns, diagonals, scalars, load) and rhs_solve_ivp(t, y, ...) return a new
    array, in the argument orders odeint and solve_ivp call them with; rhs_into(y, out, load_on, ...)
    writes into out. load_on is 1.0 or 0.0.
    """
    if _NUMBA:
        return _NUMBA["odeint"], _NUMBA["solve_ivp"], _NUMBA["into"]
    import numba

    @numba.njit(inline="always")
    def spring(ux, uy, fx, fy, a, b, ka, aa, kb, ab):
        rx = ux[b] - ux[a]
        ry = uy[b] - uy[a]
        d = math.sqrt(rx * rx + ry * ry)
        if d >= R_EPS:
            e = math.exp(aa * d) - 1.0
            inverse = 1.0 / d
            sa = ka * e * inverse
            sb = kb * (e if ab == aa else math.exp(ab * d) - 1.0) * inverse
            fx[a] += sa * rx
            fy[a] += sa * ry
            fx[b] -= sb * rx
            fy[b] -= sb * ry

    @numba.njit(inline="always")
    def damper(vx, vy, fx, fy, a, b, c):
        dx = c * (vx[b] - vx[a])
        dy = c * (vy[b] - vy[a])
        fx[a] += dx
        fy[a] += dy
        fx[b] -= dx
        fy[b] -= dy

    @numba.njit(cache=False, boundscheck=False)
    def rhs_into(y, out, load_on, columns, diagonals, scalars, load):
        R = load.shape[1]
        C = columns.shape[1]
        N = R * C
        ux, uy, vx, vy = y[:N], y[N : 2 * N], y[2 * N : 3 * N], y[3 * N :]
        out[: 2 * N] = y[2 * N :]
        fx, fy = out[2 * N : 3 * N], out[3 * N :]
        fx[:] = 0.0
        fy[:] = 0.0
        k0, a0, c0 = scalars[0], scalars[1], scalars[2]
        # one branch-free loop per spring family (faster than one loop over the masses with four tests)
        for i in range(R):  # horizontal (i, j)-(i, j+1): k0, alpha0, c0
            for j in range(C - 1):
                a = i * C + j
                spring(ux, uy, fx, fy, a, a + 1, k0, a0, k0, a0)
                damper(vx, vy, fx, fy, a, a + 1, c0)
        for i in range(R - 1):
            for j in range(C):  # vertical (i, j)-(i+1, j): column j's material
                a = i * C + j
                kv, av = columns[0, j], columns[1, j]
                spring(ux, uy, fx, fy, a, a + C, kv, av, kv, av)
                damper(vx, vy, fx, fy, a, a + C, columns[2, j])
            for j in range(C - 1):  # the two diagonals of the cell between columns j and j+1
                a = i * C + j
                # (i, j)-(i+1, j+1): this end in column j, the other in column j+1
                spring(ux, uy, fx, fy, a, a + C + 1, diagonals[0, j], diagonals[1, j], diagonals[2, j], diagonals[3, j])
                # (i, j+1)-(i+1, j): this end in column j+1, the other in column j
                spring(ux, uy, fx, fy, a + 1, a + C, diagonals[2, j], diagonals[3, j], diagonals[0, j], diagonals[1, j])
        if scalars[7] != 0.0:  # backplate behind column C
            k_w, c_w, gap = scalars[3], scalars[4], scalars[5]
            for i in range(R):
                a = i * C + C - 1
                p = ux[a] - gap
                if p > 0.0:
                    v = vx[a]
                    fx[a] -= k_w * p + (c_w * v if v > 0.0 else 0.0)
        if load_on != 0.0:
            for i in range(R):
                fx[i * C] += load[0, i]
                fy[i * C] += load[1, i]
        inverse_mass = scalars[6]
        if inverse_mass != 1.0:
            for n in range(2 * N, 4 * N):
                out[n] *= inverse_mass

    @numba.njit(cache=False)
    def rhs_odeint(y, t, load_on, columns, diagonals, scalars, load):
        out = np.empty_like(y)
        rhs_into(y, out, load_on, columns, diagonals, scalars, load)
        return out

    @numba.njit(cache=False)
    def rhs_solve_ivp(t, y, load_on, columns, diagonals, scalars, load):
        out = np.empty_like(y)
        rhs_into(y, out, load_on, columns, diagonals, scalars, load)
        return out

    _NUMBA.update(odeint=rhs_odeint, solve_ivp=rhs_solve_ivp, into=rhs_into)
    return rhs_odeint, rhs_solve_ivp, rhs_into


# ------------------------------------------------------------------------------------------------ JAX
def jax_rhs(rows: int, cols: int, equal_diagonal_alphas: bool = True):
    """f(y, load_on, columns, diagonals, scalars, load) -> dy/dt in jax.numpy, on (R, C) grids, no scatter.

    rows, cols and equal_diagonal_alphas are fixed when traced (one exp per diagonal when its two ends see
    the same alpha); the arrays are traced, so one compilation serves every order and material table.
    """
    import jax.numpy as jnp

    R, C = rows, cols
    N = R * C

    def scale(d, k, alpha):
        ok = d >= R_EPS
        return jnp.where(ok, k * jnp.expm1(alpha * d) / jnp.where(ok, d, 1.0), 0.0)

    def spread(fa, fb, a_slice, b_slice):
        """Forces fa on the a-ends (at a_slice of the grid) and fb on the b-ends, as one (R, C) grid
        (static slices: XLA adds into a slice, no index arrays; faster here than padding)."""
        return jnp.zeros((R, C), fa.dtype).at[a_slice].add(fa).at[b_slice].add(fb)

    def rhs(y, load_on, columns, diagonals, scalars, load):
        ux, uy, vx, vy = (y[k * N : (k + 1) * N].reshape(R, C) for k in range(4))
        k0, a0, c0 = scalars[0], scalars[1], scalars[2]
        fx = jnp.zeros((R, C), y.dtype)
        fy = jnp.zeros((R, C), y.dtype)
        if C > 1:  # horizontal (i, j)-(i, j+1)
            a, b = (slice(None), slice(None, -1)), (slice(None), slice(1, None))
            rx, ry = ux[b] - ux[a], uy[b] - uy[a]
            s = scale(jnp.sqrt(rx * rx + ry * ry), k0, a0)
            gx, gy = s * rx + c0 * (vx[b] - vx[a]), s * ry + c0 * (vy[b] - vy[a])
            fx += spread(gx, -gx, a, b)
            fy += spread(gy, -gy, a, b)
        if R > 1:  # vertical (i, j)-(i+1, j), column j's material
            a, b = (slice(None, -1), slice(None)), (slice(1, None), slice(None))
            rx, ry = ux[b] - ux[a], uy[b] - uy[a]
            s = scale(jnp.sqrt(rx * rx + ry * ry), columns[0], columns[1])
            gx, gy = s * rx + columns[2] * (vx[b] - vx[a]), s * ry + columns[2] * (vy[b] - vy[a])
            fx += spread(gx, -gx, a, b)
            fy += spread(gy, -gy, a, b)
        if R > 1 and C > 1:
            k_left, a_left, k_right, a_right = diagonals[0], diagonals[1], diagonals[2], diagonals[3]
            for a, b, (ka, aa), (kb, ab) in (
                # (i, j)-(i+1, j+1): a in column j (left), b in column j+1 (right)
                (
                    (slice(None, -1), slice(None, -1)),
                    (slice(1, None), slice(1, None)),
                    (k_left, a_left),
                    (k_right, a_right),
                ),
                # (i, j+1)-(i+1, j): a in column j+1 (right), b in column j (left)
                (
                    (slice(None, -1), slice(1, None)),
                    (slice(1, None), slice(None, -1)),
                    (k_right, a_right),
                    (k_left, a_left),
                ),
            ):
                rx, ry = ux[b] - ux[a], uy[b] - uy[a]
                d = jnp.sqrt(rx * rx + ry * ry)
                ok = d >= R_EPS
                inv_d = jnp.where(ok, 1.0 / jnp.where(ok, d, 1.0), 0.0)
                ea = jnp.expm1(aa * d)
                eb = ea if equal_diagonal_alphas else jnp.expm1(ab * d)
                sa, sb = ka * ea * inv_d, kb * eb * inv_d
                fx += spread(sa * rx, -sb * rx, a, b)
                fy += spread(sa * ry, -sb * ry, a, b)
        # backplate behind column C
        p = ux[:, -1] - scalars[5]
        wall = jnp.where(p > 0.0, scalars[3] * p + scalars[4] * jnp.maximum(vx[:, -1], 0.0), 0.0) * scalars[7]
        fx = fx.at[:, -1].add(-wall)
        fx = fx.at[:, 0].add(load_on * load[0])
        fy = fy.at[:, 0].add(load_on * load[1])
        return jnp.concatenate([y[2 * N :], fx.ravel() * scalars[6], fy.ravel() * scalars[6]])

    return rhs


# ------------------------------------------------------------------------------------- the check
KERNEL_TOLERANCE = 1e-12  # max |kernel - reference| / max |reference|


def check_scenes():
    """Scenes that reach every branch of the kernels: the published orders, the mean rule, another lattice, load
    angle and mass, a table whose two diagonal ends see different alphas, a lattice without a wall."""
    from fmu_src.published import STUDY_BEST_ORDER
    from reference import Scene

    return [
        ("published sequential", Scene()),
        ("study's best", Scene(order=STUDY_BEST_ORDER)),
        ("mean rule", Scene(order=(3, 1, 11, 2, 10, 4, 9, 5, 8, 6, 7), diagonal_rule="mean")),
        ("7 x 5, angled load, mass 2", Scene(rows=7, cols=5, order=(2, 5, 1, 4, 3), load_angle=30.0, mass=2.0)),
        (
            "4 x 6, own table",
            Scene(
                rows=4,
                cols=6,
                order=(6, 1, 5, 2, 4, 3),
                k=np.linspace(50, 150, 6),
                k_diag=np.linspace(10, 60, 6),
                c=np.linspace(1, 6, 6),
                alpha=np.linspace(5, 12, 6),
                alpha_diag=np.linspace(4, 14, 6),
            ),
        ),
        ("no wall", Scene(rows=5, cols=5, wall=False)),
    ]


def random_states(scene, count: int = 4, seed: int = 7):
    """Displacements up to 0.1 m (exp(alpha |r|) well away from 1) with the last column pushed past the wall in
    about half the rows, velocities of both signs, and one spring of zero length (its force must be 0, not nan)."""
    rng = np.random.default_rng(seed)
    N = scene.n_masses
    states = []
    for _ in range(count):
        y = np.concatenate([rng.uniform(-0.1, 0.1, 2 * N), rng.uniform(-3.0, 3.0, 2 * N)])
        wall = np.arange(scene.rows) * scene.cols + scene.cols - 1
        y[wall] += rng.choice([0.0, 0.05], scene.rows)
        y[0], y[N] = y[1], y[N + 1]
        states.append(y)
    return states


def check_against_reference() -> dict[str, float]:
    """The worst relative difference of each kernel (numba as odeint and solve_ivp call it, JAX, the backplate
    force) from reference/lattice.py over the check scenes; raises ValueError past KERNEL_TOLERANCE."""
    import jax

    jax.config.update("jax_enable_x64", True)
    from reference import backplate_force as reference_backplate_force, rhs as reference_rhs

    rhs_odeint, rhs_solve_ivp, _ = numba_kernels()
    compiled, worst = {}, {"numba": 0.0, "jax": 0.0, "backplate force": 0.0}
    for label, scene in check_scenes():
        packed = pack(scene)
        key = (scene.rows, scene.cols, packed.equal_diagonal_alphas)
        if key not in compiled:
            compiled[key] = jax.jit(jax_rhs(*key))
        states = random_states(scene)
        for y in states:
            for load_on in (True, False):
                want = reference_rhs(scene, 0.0, y, load_on=load_on)
                scale = np.max(np.abs(want))
                flag = 1.0 if load_on else 0.0
                for name, got in (
                    ("numba", rhs_odeint(y, 0.0, flag, *packed.kernel_args())),
                    ("numba", rhs_solve_ivp(0.0, y, flag, *packed.kernel_args())),
                    ("jax", np.asarray(compiled[key](y, flag, *packed.kernel_args()))),
                ):
                    difference = np.max(np.abs(got - want)) / scale if np.all(np.isfinite(got)) else np.inf
                    worst[name] = max(worst[name], float(difference))
                    if not difference <= KERNEL_TOLERANCE:
                        raise ValueError(
                            f"the {name} right-hand side differs from reference/ by {difference:.1e} "
                            f"(relative) on the scene {label!r}"
                        )
        if scene.wall:
            stacked = np.array(states)
            want = reference_backplate_force(scene, stacked.T)
            got = backplate_force(packed, stacked)
            difference = float(np.max(np.abs(got - want)) / max(np.max(np.abs(want)), 1e-300))
            worst["backplate force"] = max(worst["backplate force"], difference)
            if not difference <= KERNEL_TOLERANCE:
                raise ValueError(f"the backplate force differs from reference/ by {difference:.1e} on {label!r}")
    return worst


# ------------------------------------------------------------------------ the plate (docs/model.md §10)
@dataclass(frozen=True)
class PlatePacked:
    rows: int
    cols: int
    depth: int
    columns: np.ndarray
    column_diagonals: np.ndarray
    diagonals: np.ndarray
    scalars: np.ndarray
    load: np.ndarray
    t_active: float

    @property
    def state_size(self) -> int:
        return 6 * self.rows * self.cols * self.depth

    def kernel_args(self):
        return self.columns, self.column_diagonals, self.diagonals, self.scalars, self.load

    @property
    def equal_diagonal_alphas(self) -> bool:
        return bool(np.array_equal(self.diagonals[1], self.diagonals[3]))

    def backplate_force(self, states: np.ndarray) -> np.ndarray:
        """Section 5's backplate force over column C's R x D masses, states stacked as rows (M, 6N) -> (M,)."""
        R, C, D = self.rows, self.cols, self.depth
        N = R * C * D
        k_w, c_w, gap = self.scalars[3], self.scalars[4], self.scalars[5]
        wall = np.arange(R * D) * C + (C - 1)
        p = states[:, wall] - gap
        vx = states[:, 3 * N + wall]
        return np.where(p > 0, k_w * p + c_w * np.maximum(vx, 0.0), 0.0).sum(axis=1)


def face_weights(rows: int, depth: int, patch: int) -> np.ndarray:
    """Each loaded-face mass's share of the load, (D, R), summing to 1 (docs/model.md §4 and §10): the whole face
    (patch 0) the product of the row weight in y and in z (1/2 at an edge), a centred odd patch P x P equal."""
    if patch:
        weights = np.zeros((depth, rows))
        k0, i0 = (depth - patch) // 2, (rows - patch) // 2
        weights[k0 : k0 + patch, i0 : i0 + patch] = 1.0
    else:

        def edge(n):
            w = np.ones(n)
            if n > 1:
                w[0] = w[-1] = 0.5
            return w

        weights = np.outer(edge(depth), edge(rows))
    return weights / weights.sum()


def pack_plate(scene) -> PlatePacked:
    """The plate kernels' arrays for a reference.lattice3d.PlateScene (which validates it; exponential springs
    and a backplate, the plate scene's law)."""
    if scene.spring_law != "exponential":
        raise ValueError(f"pack_plate: spring_law must be 'exponential', got {scene.spring_law!r}")
    material = np.asarray(scene.order) - 1
    k, k_diag, c, alpha, alpha_diag = (
        np.asarray(getattr(scene, f), dtype=float)[material] for f in ("k", "k_diag", "c", "alpha", "alpha_diag")
    )
    columns = np.ascontiguousarray([k, alpha, c])
    column_diagonals = np.ascontiguousarray([k_diag, alpha_diag])
    left, right = np.array([k_diag[:-1], alpha_diag[:-1]]), np.array([k_diag[1:], alpha_diag[1:]])
    if scene.diagonal_rule == "mean":
        left = right = 0.5 * (left + right)
    elif scene.diagonal_rule != "receiver":
        raise ValueError(f"pack_plate: diagonal_rule must be 'receiver' or 'mean', got {scene.diagonal_rule!r}")
    diagonals = np.ascontiguousarray(np.vstack([left, right]), dtype=float).reshape(4, scene.cols - 1)
    scalars = np.array(
        [
            scene.k0,
            scene.alpha0,
            scene.c0,
            scene.k_wall,
            scene.c_wall,
            scene.backplate_gap,
            1.0 / scene.mass,
            1.0 if scene.has_backplate else 0.0,
        ]
    )
    weights = face_weights(scene.rows, scene.depth, scene.load_patch)
    angle = math.radians(scene.load_angle)
    load = np.ascontiguousarray([scene.F_total * math.cos(angle) * weights, scene.F_total * math.sin(angle) * weights])
    return PlatePacked(
        scene.rows, scene.cols, scene.depth, columns, column_diagonals, diagonals, scalars, load, float(scene.t_active)
    )


_PLATE_NUMBA = {}


def plate_numba_kernels():
    """(rhs_odeint, rhs_solve_ivp, rhs_into) of the plate, compiled on first use, called as the 2-D ones are with
    the plate's arrays: rhs_odeint(y, t, load_on, columns, column_diagonals, diagonals, scalars, load)."""
    if _PLATE_NUMBA:
        return _PLATE_NUMBA["odeint"], _PLATE_NUMBA["solve_ivp"], _PLATE_NUMBA["into"]
    import numba

    @numba.njit(inline="always")
    def spring(ux, uy, uz, fx, fy, fz, a, b, ka, aa, kb, ab):
        rx = ux[b] - ux[a]
        ry = uy[b] - uy[a]
        rz = uz[b] - uz[a]
        d = math.sqrt(rx * rx + ry * ry + rz * rz)
        if d >= R_EPS:
            e = math.exp(aa * d) - 1.0
            inverse = 1.0 / d
            sa = ka * e * inverse
            sb = kb * (e if ab == aa else math.exp(ab * d) - 1.0) * inverse
            fx[a] += sa * rx
            fy[a] += sa * ry
            fz[a] += sa * rz
            fx[b] -= sb * rx
            fy[b] -= sb * ry
            fz[b] -= sb * rz

    @numba.njit(inline="always")
    def damper(vx, vy, vz, fx, fy, fz, a, b, c):
        dx = c * (vx[b] - vx[a])
        dy = c * (vy[b] - vy[a])
        dz = c * (vz[b] - vz[a])
        fx[a] += dx
        fy[a] += dy
        fz[a] += dz
        fx[b] -= dx
        fy[b] -= dy
        fz[b] -= dz

    @numba.njit(cache=False, boundscheck=False)
    def rhs_into(y, out, load_on, columns, column_diagonals, diagonals, scalars, load):
        D, R = load.shape[1], load.shape[2]
        C = columns.shape[1]
        N = R * C * D
        plane = R * C  # from slice k to slice k+1
        ux, uy, uz = y[:N], y[N : 2 * N], y[2 * N : 3 * N]
        vx, vy, vz = y[3 * N : 4 * N], y[4 * N : 5 * N], y[5 * N :]
        out[: 3 * N] = y[3 * N :]
        fx, fy, fz = out[3 * N : 4 * N], out[4 * N : 5 * N], out[5 * N :]
        fx[:] = 0.0
        fy[:] = 0.0
        fz[:] = 0.0
        k0, a0, c0 = scalars[0], scalars[1], scalars[2]
        for k in range(D):
            for i in range(R):
                row = (k * R + i) * C
                for j in range(C - 1):  # along x (i, j, k)-(i, j+1, k): k0, alpha0, c0
                    a = row + j
                    spring(ux, uy, uz, fx, fy, fz, a, a + 1, k0, a0, k0, a0)
                    damper(vx, vy, vz, fx, fy, fz, a, a + 1, c0)
                if i < R - 1:
                    for j in range(C):  # along y (i, j, k)-(i+1, j, k): column j's material
                        a = row + j
                        kv, av = columns[0, j], columns[1, j]
                        spring(ux, uy, uz, fx, fy, fz, a, a + C, kv, av, kv, av)
                        damper(vx, vy, vz, fx, fy, fz, a, a + C, columns[2, j])
                    for j in range(C - 1):  # xy diagonals of the cell between columns j and j+1
                        a = row + j
                        spring(
                            ux,
                            uy,
                            uz,
                            fx,
                            fy,
                            fz,
                            a,
                            a + C + 1,
                            diagonals[0, j],
                            diagonals[1, j],
                            diagonals[2, j],
                            diagonals[3, j],
                        )
                        spring(
                            ux,
                            uy,
                            uz,
                            fx,
                            fy,
                            fz,
                            a + 1,
                            a + C,
                            diagonals[2, j],
                            diagonals[3, j],
                            diagonals[0, j],
                            diagonals[1, j],
                        )
                if k < D - 1:
                    for j in range(C):  # along z (i, j, k)-(i, j, k+1): column j's material
                        a = row + j
                        kv, av = columns[0, j], columns[1, j]
                        spring(ux, uy, uz, fx, fy, fz, a, a + plane, kv, av, kv, av)
                        damper(vx, vy, vz, fx, fy, fz, a, a + plane, columns[2, j])
                    for j in range(C - 1):  # xz diagonals of the cell between columns j and j+1
                        a = row + j
                        spring(
                            ux,
                            uy,
                            uz,
                            fx,
                            fy,
                            fz,
                            a,
                            a + plane + 1,
                            diagonals[0, j],
                            diagonals[1, j],
                            diagonals[2, j],
                            diagonals[3, j],
                        )
                        spring(
                            ux,
                            uy,
                            uz,
                            fx,
                            fy,
                            fz,
                            a + 1,
                            a + plane,
                            diagonals[2, j],
                            diagonals[3, j],
                            diagonals[0, j],
                            diagonals[1, j],
                        )
                    if i < R - 1:
                        for j in range(C):  # yz diagonals, inside column j: its own k_diag, alpha_diag
                            a = row + j
                            kd, ad = column_diagonals[0, j], column_diagonals[1, j]
                            spring(ux, uy, uz, fx, fy, fz, a, a + plane + C, kd, ad, kd, ad)
                            spring(ux, uy, uz, fx, fy, fz, a + C, a + plane, kd, ad, kd, ad)
        if scalars[7] != 0.0:  # backplate behind column C, each of its R x D masses
            k_w, c_w, gap = scalars[3], scalars[4], scalars[5]
            for f in range(R * D):
                a = f * C + C - 1
                p = ux[a] - gap
                if p > 0.0:
                    v = vx[a]
                    fx[a] -= k_w * p + (c_w * v if v > 0.0 else 0.0)
        if load_on != 0.0:
            for k in range(D):
                for i in range(R):
                    a = (k * R + i) * C
                    fx[a] += load[0, k, i]
                    fy[a] += load[1, k, i]
        inverse_mass = scalars[6]
        if inverse_mass != 1.0:
            for n in range(3 * N, 6 * N):
                out[n] *= inverse_mass

    @numba.njit(cache=False)
    def rhs_odeint(y, t, load_on, columns, column_diagonals, diagonals, scalars, load):
        out = np.empty_like(y)
        rhs_into(y, out, load_on, columns, column_diagonals, diagonals, scalars, load)
        return out

    @numba.njit(cache=False)
    def rhs_solve_ivp(t, y, load_on, columns, column_diagonals, diagonals, scalars, load):
        out = np.empty_like(y)
        rhs_into(y, out, load_on, columns, column_diagonals, diagonals, scalars, load)
        return out

    _PLATE_NUMBA.update(odeint=rhs_odeint, solve_ivp=rhs_solve_ivp, into=rhs_into)
    return rhs_odeint, rhs_solve_ivp, rhs_into


def jax_plate_rhs(rows: int, cols: int, depth: int, equal_diagonal_alphas: bool = True):
    """f(y, load_on, columns, column_diagonals, diagonals, scalars, load) -> dy/dt of the plate in jax.numpy, on
    (D, R, C) grids with static slices, as :func:`jax_rhs` is on (R, C) grids."""
    import jax.numpy as jnp

    R, C, D = rows, cols, depth
    N = R * C * D
    every = slice(None)
    head, tail = slice(None, -1), slice(1, None)

    def rhs(y, load_on, columns, column_diagonals, diagonals, scalars, load):
        u = [y[q * N : (q + 1) * N].reshape(D, R, C) for q in range(3)]
        v = [y[(3 + q) * N : (4 + q) * N].reshape(D, R, C) for q in range(3)]
        force = [jnp.zeros((D, R, C), y.dtype) for _ in range(3)]

        def add(a, b, ka, aa, kb, ab, c=None):
            """The springs (and dampers, c) from the masses at slice a to those at slice b."""
            r = [u[q][b] - u[q][a] for q in range(3)]
            d = jnp.sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2])
            ok = d >= R_EPS
            inv_d = jnp.where(ok, 1.0 / jnp.where(ok, d, 1.0), 0.0)
            ea = jnp.expm1(aa * d)
            eb = ea if ab is aa else jnp.expm1(ab * d)  # one exp where both ends see one alpha
            sa = ka * ea * inv_d
            sb = sa if kb is ka and ab is aa else kb * eb * inv_d
            for q in range(3):
                on_a, on_b = sa * r[q], sb * r[q]
                if c is not None:
                    damping = c * (v[q][b] - v[q][a])
                    on_a, on_b = on_a + damping, on_b + damping
                force[q] = force[q].at[a].add(on_a).at[b].add(-on_b)

        k0, a0, c0 = scalars[0], scalars[1], scalars[2]
        kv, av, cv = columns[0], columns[1], columns[2]
        kd, ad = column_diagonals[0], column_diagonals[1]
        k_left, a_left, k_right = diagonals[0], diagonals[1], diagonals[2]
        a_right = a_left if equal_diagonal_alphas else diagonals[3]
        if C > 1:  # along x: the base constants
            add((every, every, head), (every, every, tail), k0, a0, k0, a0, c0)
        if R > 1:  # along y: the column's material
            add((every, head, every), (every, tail, every), kv, av, kv, av, cv)
        if D > 1:  # along z: the column's material
            add((head, every, every), (tail, every, every), kv, av, kv, av, cv)
        if R > 1 and C > 1:  # xy diagonals: (i, j)-(i+1, j+1) and (i, j+1)-(i+1, j)
            add((every, head, head), (every, tail, tail), k_left, a_left, k_right, a_right)
            add((every, head, tail), (every, tail, head), k_right, a_right, k_left, a_left)
        if D > 1 and C > 1:  # xz diagonals: (k, j)-(k+1, j+1) and (k, j+1)-(k+1, j)
            add((head, every, head), (tail, every, tail), k_left, a_left, k_right, a_right)
            add((head, every, tail), (tail, every, head), k_right, a_right, k_left, a_left)
        if D > 1 and R > 1:  # yz diagonals, inside a column: (k, i)-(k+1, i+1) and (k, i+1)-(k+1, i)
            add((head, head, every), (tail, tail, every), kd, ad, kd, ad)
            add((head, tail, every), (tail, head, every), kd, ad, kd, ad)
        # backplate behind column C
        p = u[0][:, :, -1] - scalars[5]
        wall = jnp.where(p > 0.0, scalars[3] * p + scalars[4] * jnp.maximum(v[0][:, :, -1], 0.0), 0.0) * scalars[7]
        fx = force[0].at[:, :, -1].add(-wall).at[:, :, 0].add(load_on * load[0])
        fy = force[1].at[:, :, 0].add(load_on * load[1])
        return jnp.concatenate(
            [y[3 * N :], fx.ravel() * scalars[6], fy.ravel() * scalars[6], force[2].ravel() * scalars[6]]
        )

    return rhs


def plate_check_scenes():
    """Small plates that reach every branch of the plate kernels and tell rows from slices (R != D): a centred
    patch and the whole face under both diagonal rules, an angled load and mass, a table whose two diagonal
    ends see different alphas, a plate without a backplate."""
    from reference.lattice3d import PlateScene

    own_table = dict(
        k=tuple(np.linspace(50, 150, 4)),
        k_diag=tuple(np.linspace(10, 60, 4)),
        c=tuple(np.linspace(1, 6, 4)),
        alpha=tuple(np.linspace(5, 12, 4)),
        alpha_diag=tuple(np.linspace(4, 14, 4)),
    )
    return [
        ("5x5x5, patch 3, receiver", PlateScene(order=(3, 1, 5, 2, 4), load_patch=3)),
        ("5x5x5, whole face, receiver", PlateScene(order=(3, 1, 5, 2, 4))),
        ("5x5x5, patch 3, mean", PlateScene(order=(3, 1, 5, 2, 4), load_patch=3, diagonal_rule="mean")),
        ("5x5x5, whole face, mean", PlateScene(order=(2, 5, 1, 4, 3), diagonal_rule="mean")),
        (
            "5x4x3, patch 3, angled load, mass 2",
            PlateScene(rows=5, cols=4, depth=3, order=(4, 1, 3, 2), load_patch=3, load_angle=30.0, mass=2.0),
        ),
        ("3x4x5, whole face, own table", PlateScene(rows=3, cols=4, depth=5, order=(4, 1, 3, 2), **own_table)),
        (
            "3x4x5, patch 1, mean, own table",
            PlateScene(rows=3, cols=4, depth=5, order=(2, 4, 1, 3), load_patch=1, diagonal_rule="mean", **own_table),
        ),
        ("4x3x2, no backplate", PlateScene(rows=4, cols=3, depth=2, has_backplate=False)),
    ]


def random_plate_states(scene, count: int = 3, seed: int = 11):
    """As :func:`random_states` in three dimensions: uz too, column C past the backplate in about half its masses,
    one spring (masses 0 and 1) of zero length."""
    rng = np.random.default_rng(seed)
    N = scene.n_masses
    wall = np.arange(scene.rows * scene.depth) * scene.cols + scene.cols - 1
    states = []
    for _ in range(count):
        y = np.concatenate([rng.uniform(-0.1, 0.1, 3 * N), rng.uniform(-3.0, 3.0, 3 * N)])
        y[wall] += rng.choice([0.0, 0.05], wall.size)
        for component in range(3):
            y[component * N] = y[component * N + 1]
        states.append(y)
    return states


def check_plate_against_reference(scenes=None, with_jax: bool = True) -> dict[str, float]:
    """The worst relative difference of the plate's kernels (numba as odeint and solve_ivp call it, JAX unless
    with_jax is false) and backplate force from reference/lattice3d.py over the check scenes (the backplate's
    modes read from each state, as a peer without events sees them); raises ValueError past KERNEL_TOLERANCE."""
    from reference.lattice3d import PlateModel

    rhs_odeint, rhs_solve_ivp, _ = plate_numba_kernels()
    worst = {"numba": 0.0, "backplate force": 0.0}
    if with_jax:
        import jax

        jax.config.update("jax_enable_x64", True)
        worst["jax"] = 0.0
    for label, scene in plate_check_scenes() if scenes is None else scenes:
        packed = pack_plate(scene)
        jax_kernel = (
            jax.jit(jax_plate_rhs(scene.rows, scene.cols, scene.depth, packed.equal_diagonal_alphas))
            if with_jax
            else None
        )
        model = PlateModel(scene)
        N = scene.n_masses
        states = random_plate_states(scene)
        for y in states:
            contact = y[model.wall_index] - scene.backplate_gap > 0
            damper_on = contact & (y[3 * N + model.wall_index] > 0)
            augmented = np.concatenate([y, np.zeros(3)])
            for load_on in (True, False):
                want = model.derivative(augmented, load_on, contact, damper_on)[: 6 * N]
                scale = np.max(np.abs(want))
                flag = 1.0 if load_on else 0.0
                kernels = [
                    ("numba", rhs_odeint(y, 0.0, flag, *packed.kernel_args())),
                    ("numba", rhs_solve_ivp(0.0, y, flag, *packed.kernel_args())),
                ]
                if jax_kernel is not None:
                    kernels.append(("jax", np.asarray(jax_kernel(y, flag, *packed.kernel_args()))))
                for name, got in kernels:
                    difference = np.max(np.abs(got - want)) / scale if np.all(np.isfinite(got)) else np.inf
                    worst[name] = max(worst[name], float(difference))
                    if not difference <= KERNEL_TOLERANCE:
                        raise ValueError(
                            f"the plate's {name} right-hand side differs from reference/lattice3d.py by "
                            f"{difference:.1e} (relative) on the scene {label!r}"
                        )
            if scene.has_backplate:
                want = float(model.backplate_force(y, contact, damper_on))
                got = float(packed.backplate_force(y[None, :])[0])
                difference = abs(got - want) / max(abs(want), 1e-300)
                worst["backplate force"] = max(worst["backplate force"], difference)
                if not difference <= KERNEL_TOLERANCE:
                    raise ValueError(
                        f"the plate's backplate force differs from reference/lattice3d.py by "
                        f"{difference:.1e} on {label!r}"
                    )
    return worst


def main(argv=None) -> int:
    """The checks alone (bench.peers runs them before timing): the worst differences, or one line and exit 1."""
    import argparse
    import sys

    parser = argparse.ArgumentParser(
        prog="python -m bench.peer_models",
        description="Check the peers' right-hand sides against reference/ to "
        f"{KERNEL_TOLERANCE:g}, as bench.peers does before it times them.",
    )
    parser.add_argument(
        "--models",
        nargs="+",
        choices=("lattice", "plate"),
        default=["lattice", "plate"],
        help="the 2-D lattice's kernels (against reference/lattice.py), the plate's (against "
        "reference/lattice3d.py); default both",
    )
    parser.add_argument(
        "--without-jax",
        action="store_true",
        help="the plate's numba kernel only, not its JAX one (the 2-D check always takes both)",
    )
    args = parser.parse_args(argv)
    try:
        if "lattice" in args.models:
            worst = check_against_reference()
            print("2-D lattice against reference/lattice.py: " + ", ".join(f"{k} {v:.1e}" for k, v in worst.items()))
        if "plate" in args.models:
            worst = check_plate_against_reference(with_jax=not args.without_jax)
            print("plate against reference/lattice3d.py: " + ", ".join(f"{k} {v:.1e}" for k, v in worst.items()))
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
