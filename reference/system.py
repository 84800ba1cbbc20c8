"""Independent numpy/scipy reference of the lattice as a component (docs/model.md sections 11 and 12).

Written from docs/model.md alone, sharing no code with the C model: the lattice's springs come from the
three-dimensional reference (:class:`reference.lattice3d.PlateModel`, its index arrays and force law; ``depth = 1``
is the two-dimensional lattice), everything of sections 11 and 12 is written here:

* the **front port** (section 11): the loaded face's weights ``w_a`` of section 4 or 10 normalised to 1, the force
  ``F_front w_a`` along +x, ``x_front = Σ w_a ux_a``, ``v_front = Σ w_a vx_a``; ``load_mode`` ``pulse`` (section 4,
  the study's load), ``input`` (a given ``F_front(t)``) or ``projectile``;
* the **back port**: the wall of section 5 moved to ``x_back`` (penetration ``ux - g - x_back``, damper
  ``c_w max(vx - v_back, 0)``), with ``x_back, v_back`` zero (the fixed wall), given functions of time, or the
  state of a **hull** ``M x'' = F_bp - k x - c x'``;
* the **projectile**: a rigid body touching the face at t = 0 at ``projectile_speed``, Hunt-Crossley contact
  ``F_c = max(k_c δ^n (1 + λ δ'), 0)`` for ``δ = x_p - x_front > 0``;
* section 12: each material's ``mass`` and ``damping_exponent`` (a damper inside column j pushes with
  ``-c |dv|^(n-1) dv``; the dampers between columns keep ``c0`` and n = 1).

Projectile, lattice and hull are one ODE (:func:`simulate_system`), integrated with scipy's DOP853 stepped here
one step at a time. Every switch of the right-hand side is an event: a wall mass touching or leaving the wall, its
damper starting or stopping, the projectile touching or leaving the face, its contact force reaching zero while
the two separate. A step whose end disagrees with its modes is cut back to the earliest switch (located on the
step's dense output with Brent's method) and the solver restarts there, so no step integrates across a kink. The
load's end, and the breaks of given inputs, are phase boundaries. The work integrals of sections 7 and 11 are
integrated with the state.

    from reference.lattice3d import PlateScene
    from reference.system import Hull, Projectile, SystemScene, simulate_system
    scene = SystemScene(PlateScene(rows=5, cols=5, depth=1), load_mode="projectile",
                        projectile=Projectile(mass=50.0, speed=3.6, contact_stiffness=3e4, contact_exponent=1.5,
                                              contact_damping=0.1),
                        hull=Hull(mass=100.0, stiffness=1e4, damping=500.0))
    result = simulate_system(scene, horizon=1.0)
    result.peak_backplate_force, result.energy.system_error, result.contact_force
"""

from __future__ import annotations

import heapq
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import DOP853
from scipy.optimize import brentq, minimize_scalar

from .lattice3d import PlateModel, PlateScene, load_weights, sample_times

LOAD_MODES = ("pulse", "input", "projectile")
#: switches located within this fraction of a step after the earliest one are switched together (mirror-image
#: masses of a symmetric load reach the wall at the same instant up to rounding)
SIMULTANEOUS_FRACTION = 1e-9
#: this many switches in a row at one instant mean the modes chatter: the reference refuses to go on
MAX_SWITCHES_AT_ONE_INSTANT = 1000
#: continuous peaks: grid points per step, and candidates refined
FINE_POINTS = 16
CANDIDATES = 4


def _number(owner: str, name: str, value, minimum=None, strict=False) -> float:
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ValueError(f"{owner}.{name} must be a number, got {value!r}")
    value = float(value)
    if not math.isfinite(value) or (minimum is not None and (value <= minimum if strict else value < minimum)):
        bound = "" if minimum is None else f" {'>' if strict else '>='} {minimum:g}"
        raise ValueError(f"{owner}.{name} must be a finite number{bound}, got {value!r}")
    return value


# ------------------------------------------------------------------------------------------- given inputs
@dataclass(frozen=True)
class PiecewiseSignal:
    """A function of time given piece by piece: ``pieces[i]`` on ``[breaks[i], breaks[i+1]]`` (the last piece
    to the horizon). Each piece is smooth; the breaks are where the reference restarts its solver, so a jump at
    a break is integrated exactly (the piece of a phase is evaluated at the phase's own ends)."""

    breaks: tuple
    pieces: tuple

    def __post_init__(self):
        breaks = tuple(float(b) for b in self.breaks)
        if not breaks or breaks[0] != 0.0 or any(b >= c for b, c in zip(breaks, breaks[1:])):
            raise ValueError(f"PiecewiseSignal.breaks must start at 0 and increase, got {self.breaks!r}")
        if len(self.pieces) != len(breaks) or not all(callable(p) for p in self.pieces):
            raise ValueError(f"PiecewiseSignal.pieces must be {len(breaks)} functions of time, one per break")
        object.__setattr__(self, "breaks", breaks)
        object.__setattr__(self, "pieces", tuple(self.pieces))

    @classmethod
    def held(cls, times, values) -> PiecewiseSignal:
        """``values[i]`` held on ``[times[i], times[i+1])`` (a zero-order hold; ``times[0]`` must be 0)."""
        return cls(tuple(times), tuple((lambda _t, _v=float(v): _v) for v in values))

    @classmethod
    def constant(cls, value: float) -> PiecewiseSignal:
        return cls.held((0.0,), (value,))

    def piece_at(self, t: float) -> Callable[[float], float]:
        """The piece in force on the phase that contains ``t`` (t a phase's interior point)."""
        return self.pieces[int(np.searchsorted(self.breaks, t, side="right")) - 1]


@dataclass(frozen=True)
class Projectile:
    """Section 11's projectile: mass (kg), speed at first touch (m/s), Hunt-Crossley contact ``k_c`` (N/m^n),
    ``n`` and ``λ`` (s/m)."""

    mass: float
    speed: float
    contact_stiffness: float
    contact_exponent: float = 1.0
    contact_damping: float = 0.0

    def __post_init__(self):
        object.__setattr__(self, "mass", _number("Projectile", "mass", self.mass, 0.0, strict=True))
        object.__setattr__(self, "speed", _number("Projectile", "speed", self.speed, 0.0))
        object.__setattr__(
            self,
            "contact_stiffness",
            _number("Projectile", "contact_stiffness", self.contact_stiffness, 0.0, strict=True),
        )
        object.__setattr__(
            self, "contact_exponent", _number("Projectile", "contact_exponent", self.contact_exponent, 1.0)
        )
        object.__setattr__(self, "contact_damping", _number("Projectile", "contact_damping", self.contact_damping, 0.0))


@dataclass(frozen=True)
class Hull:
    """Section 11's hull: ``M x'' = F_bp - k x - c x'`` (kg, N/m, N s/m); its x, x' are the back port's."""

    mass: float
    stiffness: float
    damping: float

    def __post_init__(self):
        object.__setattr__(self, "mass", _number("Hull", "mass", self.mass, 0.0, strict=True))
        object.__setattr__(self, "stiffness", _number("Hull", "stiffness", self.stiffness, 0.0))
        object.__setattr__(self, "damping", _number("Hull", "damping", self.damping, 0.0))


@dataclass(frozen=True, eq=False)
class SystemScene:
    """A lattice (``lattice``: geometry, materials, load face, wall, diagonal rule) with section 11's ports and
    section 12's masses and damping exponents.

    ``load_mode``: ``pulse`` (section 4 on the face: ``lattice.F_total`` at ``lattice.load_angle`` until
    ``lattice.t_active``), ``input`` (``front_force``, along +x) or ``projectile`` (``projectile``).
    The back port: a fixed wall (default), given ``back_position`` and ``back_velocity``, or a ``hull``.
    ``material_mass`` and ``damping_exponent``: one entry per row of the lattice's material table (default: every
    mass ``lattice.mass``, every exponent 1).
    """

    lattice: PlateScene
    load_mode: str = "pulse"
    front_force: PiecewiseSignal | None = None
    projectile: Projectile | None = None
    back_position: PiecewiseSignal | None = None
    back_velocity: PiecewiseSignal | None = None
    hull: Hull | None = None
    material_mass: tuple | None = None
    damping_exponent: tuple | None = None

    def __post_init__(self):
        if not isinstance(self.lattice, PlateScene):
            raise ValueError(f"SystemScene.lattice must be a PlateScene, got {type(self.lattice).__name__}")
        if self.load_mode not in LOAD_MODES:
            raise ValueError(f"SystemScene.load_mode must be one of {LOAD_MODES}, got {self.load_mode!r}")
        if (self.load_mode == "input") != (self.front_force is not None):
            raise ValueError("SystemScene.front_force: give a PiecewiseSignal exactly when load_mode is 'input'")
        if (self.load_mode == "projectile") != (self.projectile is not None):
            raise ValueError("SystemScene.projectile: give a Projectile exactly when load_mode is 'projectile'")
        if (self.back_position is None) != (self.back_velocity is None):
            raise ValueError("SystemScene.back_position and back_velocity: give both or neither")
        if self.hull is not None and self.back_position is not None:
            raise ValueError("SystemScene: the back port is moved by a hull or by given functions, not both")
        if (self.hull is not None or self.back_position is not None) and not self.lattice.has_backplate:
            raise ValueError("SystemScene: a moving back port needs lattice.has_backplate = True")
        count = len(self.lattice.k)
        for name, default, minimum, strict in (
            ("material_mass", self.lattice.mass, 0.0, True),
            ("damping_exponent", 1.0, 0.0, True),
        ):
            value = getattr(self, name)
            if value is None:
                value = (default,) * count
            try:
                value = tuple(_number("SystemScene", name, v, minimum, strict) for v in value)
            except TypeError:
                raise ValueError(f"SystemScene.{name} must be {count} numbers, one per material") from None
            if len(value) != count:
                raise ValueError(f"SystemScene.{name} must be {count} numbers (one per material), got {len(value)}")
            object.__setattr__(self, name, value)

    @property
    def back_port(self) -> str:
        """``wall`` (fixed), ``given`` (functions of time) or ``hull``."""
        return "hull" if self.hull is not None else "given" if self.back_position is not None else "wall"

    @property
    def total_mass(self) -> float:
        """Section 12: ``R D Σ_j mass[p_j]``."""
        sc = self.lattice
        return sc.rows * sc.depth * sum(self.material_mass[p - 1] for p in sc.order)


# ------------------------------------------------------------------------------------------- the model
@dataclass(frozen=True)
class Phase:
    """What is constant between two breaks: the pulse on or off, and the pieces of the given inputs."""

    load_on: bool
    front_force: Callable[[float], float] | None
    back_position: Callable[[float], float] | None
    back_velocity: Callable[[float], float] | None


class SystemModel:
    """The right-hand side of projectile, lattice and hull under given modes.

    State ``z``: the lattice's ``[ux, uy, uz, vx, vy, vz]`` (6N), the projectile's ``x_p, v_p``, the hull's
    ``x, v``, then the integrals ``W_front = ∫ F_front v_front dt`` (the work the front port takes in; the pulse's
    work in ``pulse`` mode), ``W_back = ∫ F_bp v_back dt``, the lattice's dissipation, ``W_nr`` (section 7), the
    contact's dissipation, the hull's dissipation and the backplate's impulse ``∫ F_bp dt``.

    Modes, one flag each: every wall mass in contact, its damper acting, the projectile touching, its contact
    force positive. A damper's flag counts only while its mass touches; the contact force's only while the
    projectile touches.
    """

    INTEGRALS = (
        "front_work",
        "back_work",
        "lattice_dissipation",
        "nonreciprocal_work",
        "contact_dissipation",
        "hull_dissipation",
        "backplate_impulse",
    )

    def __init__(self, scene: SystemScene):
        self.scene = scene
        lat = scene.lattice
        self.plate = plate = PlateModel(lat)
        self.N = N = plate.N
        C = lat.cols
        material = np.array(lat.order) - 1
        column_mass = np.array(scene.material_mass)[material]
        self.node_mass = column_mass[np.arange(N) % C]
        self.mass3 = np.tile(self.node_mass, 3)
        # section 12: a damper inside a column (along y or z) takes its column's exponent; along x n = 1
        damped_kind = plate.kind[plate.damped]
        exponent = np.array(scene.damping_exponent)[material[plate.a[plate.damped] % C]]
        self.damper_exponent = np.where(damped_kind == "x", 1.0, exponent)
        self.linear_dampers = bool(np.all(self.damper_exponent == 1.0))
        self.damper_c = plate.damping[plate.damped]

        weights = load_weights(lat.rows, lat.depth, lat.load_patch).ravel()
        loaded = weights > 0
        self.front_index = plate.load_index
        self.front_weight = weights[loaded]
        self.wall_index = plate.wall_index
        self.W = W = self.wall_index.size
        self.P = 6 * N  # projectile x_p, v_p
        self.H = 6 * N + 2  # hull x, v
        self.I = 6 * N + 4  # the integrals
        self.size = self.I + len(self.INTEGRALS)
        self.n_modes = 2 * W + 2
        self.touch, self.push = 2 * W, 2 * W + 1

    # ------------------------------------------------------------------ pieces of the right-hand side
    def back_port(self, t, z, phase: Phase):
        """``(x_back, v_back)`` at t: 0, the given functions, or the hull's state."""
        kind = self.scene.back_port
        if kind == "hull":
            return z[self.H], z[self.H + 1]
        if kind == "given":
            if np.ndim(t):
                return (np.array([phase.back_position(s) for s in t]), np.array([phase.back_velocity(s) for s in t]))
            return phase.back_position(t), phase.back_velocity(t)
        return 0.0, 0.0

    def front(self, z):
        """``(x_front, v_front)``: the weighted mean displacement and velocity of the loaded face along x."""
        return self.front_weight @ z[self.front_index], self.front_weight @ z[3 * self.N + self.front_index]

    def contact(self, z, modes):
        """``(F_c, k_c δ^n, δ, δ')`` under the modes; δ^n is continued as ``sign(δ)|δ|^n`` past δ = 0 so that a
        step overshooting a touch integrates a smooth function until it is cut back."""
        pr = self.scene.projectile
        if pr is None:
            zero = np.zeros(np.shape(z)[1:]) if np.ndim(z) > 1 else 0.0
            return zero, zero, zero, zero
        x_front, v_front = self.front(z)
        delta, rate = z[self.P] - x_front, z[self.P + 1] - v_front
        elastic = pr.contact_stiffness * np.sign(delta) * np.abs(delta) ** pr.contact_exponent * modes[self.touch]
        force = elastic * (1.0 + pr.contact_damping * rate) * modes[self.push]
        return force, elastic, delta, rate

    def wall(self, t, z, modes, phase):
        """Per wall mass: the spring part ``k_w p`` and the damper part ``c_w (vx - v_back)`` of its force on the
        wall under the modes, and the relative velocity."""
        sc = self.scene.lattice
        x_back, v_back = self.back_port(t, z, phase)
        W = self.W
        p = z[self.wall_index] - sc.backplate_gap - x_back
        relative = z[3 * self.N + self.wall_index] - v_back
        on = modes[:W] if np.ndim(z) == 1 else modes[:W, None]
        damper = (modes[:W] & modes[W : 2 * W]) if np.ndim(z) == 1 else (modes[:W] & modes[W : 2 * W])[:, None]
        return on * sc.k_wall * p, damper * sc.c_wall * relative, relative, p

    def backplate_force(self, t, z, modes, phase):
        """Section 5's ``F_bp`` (state z (size,) or states (size, M) at times t)."""
        if not self.scene.lattice.has_backplate:
            return np.zeros(np.shape(z)[1:]) if np.ndim(z) > 1 else 0.0
        spring, damper, _, _ = self.wall(t, z, modes, phase)
        return np.sum(spring + damper, axis=0)

    def indicators(self, t, z, phase):
        """The switching functions, one per mode: ``p``, ``vx - v_back`` per wall mass, ``δ`` and ``1 + λ δ'``."""
        sc = self.scene.lattice
        x_back, v_back = self.back_port(t, z, phase)
        out = np.empty(self.n_modes)
        W = self.W
        out[:W] = z[self.wall_index] - sc.backplate_gap - x_back
        out[W : 2 * W] = z[3 * self.N + self.wall_index] - v_back
        pr = self.scene.projectile
        if pr is not None:
            x_front, v_front = self.front(z)
            out[self.touch] = z[self.P] - x_front
            out[self.push] = 1.0 + pr.contact_damping * (z[self.P + 1] - v_front)
        else:
            out[self.touch] = out[self.push] = -1.0
        return out

    def watched(self, modes):
        """Which indicators can switch the right-hand side under these modes."""
        W = self.W
        out = np.zeros(self.n_modes, bool)
        if self.scene.lattice.has_backplate:
            out[:W] = True
            out[W : 2 * W] = modes[:W]
        if self.scene.projectile is not None:
            out[self.touch] = True
            out[self.push] = modes[self.touch]
        return out

    def derivative(self, t, z, modes, phase: Phase) -> np.ndarray:
        """d/dt of the state (and of the integrals) under frozen modes: a smooth function, so that DOP853's error
        control means what it says between two switches."""
        sc, N, plate = self.scene.lattice, self.N, self.plate
        y = z[: 6 * N]
        r, _, sa, sb = plate.spring_state(y)
        dv = y[plate.dv_b] - y[plate.dv_a]
        if self.linear_dampers:
            cdv = plate.damping3 * dv
        else:
            rel = dv.reshape(3, -1)
            speed = np.sqrt(rel[0] * rel[0] + rel[1] * rel[1] + rel[2] * rel[2])
            n = self.damper_exponent
            powered = np.power(speed, n - 1.0, out=np.zeros_like(speed), where=speed > 0)
            cdv = np.tile(self.damper_c * np.where(n == 1.0, 1.0, powered), 3) * dv
        on_a, on_b = (r * sa).ravel(), (r * sb).ravel()
        force = np.asarray(
            np.bincount(plate.scatter, np.concatenate([on_a, -on_b, cdv, -cdv]), minlength=3 * N), dtype=float
        )  # a lattice without springs counts in integers

        out = np.zeros(self.size)
        wall_power = backplate = 0.0
        x_back_rate = 0.0
        if sc.has_backplate:
            spring, damper, relative, _ = self.wall(t, z, modes, phase)
            force[self.wall_index] -= spring + damper
            backplate = float(np.sum(spring + damper))
            wall_power = float(damper @ relative)
            _, x_back_rate = self.back_port(t, z, phase)

        mode = self.scene.load_mode
        li = self.front_index
        if mode == "pulse":
            front_power = 0.0
            if phase.load_on:
                theta = math.radians(sc.load_angle)
                fx = sc.F_total * math.cos(theta) * self.front_weight
                fy = sc.F_total * math.sin(theta) * self.front_weight
                force[li] += fx
                force[N + li] += fy
                front_power = float(fx @ y[3 * N + li] + fy @ y[4 * N + li])
        else:
            if mode == "input":
                front_force = float(phase.front_force(t))
            else:
                front_force, elastic, _, rate = self.contact(z, modes)
                pr = self.scene.projectile
                out[self.P] = z[self.P + 1]
                out[self.P + 1] = -front_force / pr.mass
                out[self.I + 4] = (front_force - elastic) * rate
            force[li] += front_force * self.front_weight
            front_power = front_force * float(self.front_weight @ y[3 * N + li])

        hull = self.scene.hull
        if hull is not None:
            x, v = z[self.H], z[self.H + 1]
            out[self.H] = v
            out[self.H + 1] = (backplate - hull.stiffness * x - hull.damping * v) / hull.mass
            out[self.I + 5] = hull.damping * v * v

        out[: 3 * N] = y[3 * N :]
        out[3 * N : 6 * N] = force / self.mass3
        out[self.I] = front_power
        out[self.I + 1] = backplate * x_back_rate
        out[self.I + 2] = float(cdv @ dv) + wall_power
        out[self.I + 3] = 0.5 * float((on_a - on_b) @ (y[plate.v_a] + y[plate.v_b]))
        out[self.I + 6] = backplate
        return out

    # ------------------------------------------------------------------ energies at a state
    def stored_energies(self, t, z, modes, phase) -> tuple:
        """``(lattice kinetic, lattice potential, projectile kinetic, contact potential, hull kinetic, hull
        potential)``."""
        sc, N = self.scene.lattice, self.N
        v = z[3 * N : 6 * N]
        kinetic = 0.5 * float(self.mass3 @ (v * v))
        _, potential = self.plate.energies(z[: 6 * N], np.zeros(self.W, bool))  # the springs only
        if sc.has_backplate:
            spring, _, _, p = self.wall(t, z, modes, phase)
            potential += float(0.5 * spring @ p)
        projectile_kinetic = contact_potential = hull_kinetic = hull_potential = 0.0
        pr = self.scene.projectile
        if pr is not None:
            projectile_kinetic = 0.5 * pr.mass * z[self.P + 1] ** 2
            _, _, delta, _ = self.contact(z, modes)
            if modes[self.touch] and delta > 0:
                contact_potential = (
                    pr.contact_stiffness * delta ** (pr.contact_exponent + 1) / (pr.contact_exponent + 1)
                )
        hull = self.scene.hull
        if hull is not None:
            hull_kinetic = 0.5 * hull.mass * z[self.H + 1] ** 2
            hull_potential = 0.5 * hull.stiffness * z[self.H] ** 2
        return kinetic, potential, projectile_kinetic, contact_potential, hull_kinetic, hull_potential


# ------------------------------------------------------------------------------------------- results
@dataclass(frozen=True)
class EnergyTerms:
    """Sections 7 and 11 at the horizon (J).

    The lattice alone: ``lattice_initial_potential + front_work - back_work + nonreciprocal_work =
    lattice_kinetic + lattice_potential + lattice_dissipation`` (the initial potential: a wall given at
    ``x_back(0) < -g`` starts pressed into the lattice). The whole system adds the projectile (its initial kinetic
    energy in; its kinetic energy, the contact potential ``k_c δ^(n+1)/(n+1)`` and the contact's dissipation out)
    and the hull (its kinetic and spring energy and its dissipation out; the back port's work then stays inside the
    system).
    """

    lattice_initial_potential: float
    lattice_kinetic: float
    lattice_potential: float
    lattice_dissipation: float
    nonreciprocal_work: float
    front_work: float
    back_work: float
    projectile_initial_kinetic: float
    projectile_kinetic: float
    contact_potential: float
    contact_dissipation: float
    hull_kinetic: float
    hull_potential: float
    hull_dissipation: float
    #: does the hull belong to the system (then the back port's work is internal)?
    with_hull: bool
    #: is the front port driven by the projectile (then its work is internal)?
    with_projectile: bool

    @property
    def lattice_error(self) -> float:
        """Section 11's balance of the lattice alone (J)."""
        return (
            self.lattice_initial_potential
            + self.front_work
            - self.back_work
            + self.nonreciprocal_work
            - self.lattice_kinetic
            - self.lattice_potential
            - self.lattice_dissipation
        )

    @property
    def energy_in(self) -> float:
        """What enters the whole system from outside (J): the energy stored at the start (the projectile's
        kinetic, the lattice's potential), the front port's work, the non-reciprocal work, minus the work given
        to a prescribed back port."""
        given = self.projectile_initial_kinetic if self.with_projectile else self.front_work
        back = 0.0 if self.with_hull else self.back_work
        return self.lattice_initial_potential + given + self.nonreciprocal_work - back

    @property
    def system_error(self) -> float:
        """The whole system's balance (J): energy in minus everything stored and dissipated."""
        held = (
            self.lattice_kinetic
            + self.lattice_potential
            + self.lattice_dissipation
            + self.projectile_kinetic
            + self.contact_potential
            + self.contact_dissipation
        )
        if self.with_hull:
            held += self.hull_kinetic + self.hull_potential + self.hull_dissipation
        return self.energy_in - held

    @property
    def system_error_relative(self) -> float:
        """``|system_error|`` relative to the energy put in (the projectile's, or the front port's work)."""
        scale = abs(self.projectile_initial_kinetic if self.with_projectile else self.front_work)
        return abs(self.system_error) / scale if scale > 0 else math.inf


@dataclass(frozen=True, eq=False)
class SystemResult:
    """One run of :func:`simulate_system`: time series at the sample times, the objective of section 6 (sampled
    and continuous), the contact's peak, and the energy terms at the horizon."""

    scene: SystemScene
    rtol: float
    atol: float
    horizon: float
    sample_interval: float
    times: np.ndarray
    backplate_force: np.ndarray
    contact_force: np.ndarray
    x_front: np.ndarray
    v_front: np.ndarray
    hull_position: np.ndarray
    hull_velocity: np.ndarray
    projectile_position: np.ndarray
    projectile_velocity: np.ndarray
    peak_backplate_force: float
    peak_sample_time: float
    peak_backplate_force_continuous: float
    peak_time: float
    peak_contact_force_continuous: float
    peak_contact_time: float
    #: ∫ F_bp dt over the run (N s)
    backplate_impulse: float
    energy: EnergyTerms
    final_state: np.ndarray
    n_rhs: int
    n_steps: int
    n_switches: int
    wall_time: float = field(default=0.0)


class _PeakSearch:
    """The continuous maximum of a signal over the pieces of the solution: a grid per piece, then a bounded
    scalar refinement of the best few grid points."""

    def __init__(self):
        self.best = (-math.inf, math.nan)
        self.candidates: list = []
        self.counter = 0

    def add(self, t0, t1, signal):
        grid = t0 + (t1 - t0) * np.linspace(0.0, 1.0, FINE_POINTS + 1)
        values = signal(grid)
        q = int(np.argmax(values))
        value = float(values[q])
        if value > self.best[0]:
            self.best = (value, float(grid[q]))
        item = (value, self.counter, float(grid[max(q - 1, 0)]), float(grid[min(q + 1, FINE_POINTS)]), signal)
        self.counter += 1
        if len(self.candidates) < CANDIDATES:
            heapq.heappush(self.candidates, item)
        elif value > self.candidates[0][0]:
            heapq.heapreplace(self.candidates, item)

    def result(self):
        value, at = self.best
        for _, _, lo, hi, signal in self.candidates:
            if hi <= lo:
                continue
            found = minimize_scalar(
                lambda s, _signal=signal: -float(_signal(np.array([s]))[0]),
                bounds=(lo, hi),
                method="bounded",
                options={"xatol": 1e-13 * max(1.0, hi)},
            )
            if -found.fun > value:
                value, at = float(-found.fun), float(found.x)
        return value, at


def _phases(scene: SystemScene, horizon: float) -> list:
    """The intervals between breaks (the pulse's end, the given inputs' breaks) with what holds on each."""
    cuts = {0.0, horizon}
    if scene.load_mode == "pulse" and 0 < scene.lattice.t_active < horizon:
        cuts.add(scene.lattice.t_active)
    for signal in (scene.front_force, scene.back_position, scene.back_velocity):
        if signal is not None:
            cuts.update(b for b in signal.breaks if 0 < b < horizon)
    cuts = sorted(cuts)
    phases = []
    for t0, t1 in zip(cuts, cuts[1:]):
        middle = 0.5 * (t0 + t1)
        pick = lambda s, _at=middle: None if s is None else s.piece_at(_at)  # noqa: E731
        phases.append(
            (
                t0,
                t1,
                Phase(
                    load_on=middle <= scene.lattice.t_active,
                    front_force=pick(scene.front_force),
                    back_position=pick(scene.back_position),
                    back_velocity=pick(scene.back_velocity),
                ),
            )
        )
    return phases


def simulate_system(
    scene: SystemScene, horizon: float = 8.0, sample_interval: float = 0.01, rtol: float = 1e-12, atol: float = 1e-14
) -> SystemResult:
    """Integrate ``scene`` from rest (the projectile touching the face at its speed) to ``horizon`` as one ODE
    (module docstring: DOP853, every switch an event)."""
    if not isinstance(scene, SystemScene):
        raise ValueError(f"simulate_system: scene must be a SystemScene, got {type(scene).__name__}")
    for name, value in (("horizon", horizon), ("sample_interval", sample_interval), ("rtol", rtol), ("atol", atol)):
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not (math.isfinite(value) and value > 0):
            raise ValueError(f"simulate_system: {name} must be a positive finite number, got {value!r}")
    started = time.perf_counter()
    model = SystemModel(scene)
    W = model.W
    z = np.zeros(model.size)
    pr = scene.projectile
    if pr is not None:
        z[model.P + 1] = pr.speed
    phases = _phases(scene, horizon)

    # the modes at t = 0: each indicator's sign, or the sign of its rate where it starts at zero
    values = model.indicators(0.0, z, phases[0][2])
    modes = values > 0
    if pr is not None and values[model.touch] == 0.0:
        modes[model.touch] = pr.speed > 0
    modes[W : 2 * W] &= modes[:W]
    initial_potential = model.stored_energies(0.0, z, modes, phases[0][2])[1]

    times = sample_times(horizon, sample_interval)
    series = {
        name: np.full(times.size, np.nan)
        for name in ("backplate", "contact", "x_front", "v_front", "hull_x", "hull_v", "proj_x", "proj_v")
    }

    def signals(t, states, frozen, phase):
        bp = model.backplate_force(t, states, frozen, phase)
        fc = model.contact(states, frozen)[0]
        x_front, v_front = model.front(states)
        return (bp, fc, x_front, v_front, states[model.H], states[model.H + 1], states[model.P], states[model.P + 1])

    def record_samples(chosen, states, frozen, phase):
        for name, values in zip(series, signals(times[chosen], states, frozen, phase)):
            series[name][chosen] = values

    record_samples(np.array([0]), z[:, None], modes, phases[0][2])
    backplate_peaks, contact_peaks = _PeakSearch(), _PeakSearch()
    n_rhs = n_steps = n_switches = 0

    def record(t0, t1, interpolant, phase):
        """Samples in (t0, t1] and the continuous peaks over [t0, t1], under the current modes."""
        frozen = modes.copy()
        chosen = np.flatnonzero((times > t0) & (times <= t1))
        if chosen.size:
            record_samples(chosen, interpolant(times[chosen]), frozen, phase)
        backplate_peaks.add(t0, t1, lambda s: np.atleast_1d(model.backplate_force(s, interpolant(s), frozen, phase)))
        if pr is not None:
            contact_peaks.add(t0, t1, lambda s: np.atleast_1d(model.contact(interpolant(s), frozen)[0]))

    first_step = None
    phase = phases[0][2]
    for t_start, t_end, phase in phases:
        t = t_start
        at_one_instant = 0
        while t < t_end:
            frozen = modes.copy()
            solver = DOP853(
                lambda s, zz, _m=frozen, _p=phase: model.derivative(s, zz, _m, _p),
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
                    raise RuntimeError(f"simulate_system: DOP853 failed at t = {solver.t!r}: {message}")
                n_steps += 1
                t_old, t_new = solver.t_old, solver.t
                interpolant = solver.dense_output()
                watched = model.watched(modes)
                end_values = model.indicators(t_new, solver.y, phase)
                wrong = np.flatnonzero(watched & ((end_values > 0) != modes))
                if not wrong.size:
                    record(t_old, t_new, interpolant, phase)
                    first_step = solver.h_abs
                    continue
                start_values = model.indicators(t_old, solver.y_old, phase)
                roots = []
                for q in wrong:
                    start, end = start_values[q], end_values[q]
                    if start == 0.0 or np.sign(start) == np.sign(end):
                        roots.append((t_old, q))
                    else:

                        def crossing(s, _q=q, _f=interpolant, _p=phase):
                            return model.indicators(s, _f(s), _p)[_q]

                        roots.append((brentq(crossing, t_old, t_new, xtol=1e-16, rtol=4 * np.finfo(float).eps), q))
                t_switch = min(root[0] for root in roots)
                if t_switch > t_old:
                    record(t_old, t_switch, interpolant, phase)
                z = interpolant(t_switch)
                together = [q for s, q in roots if s <= t_switch + SIMULTANEOUS_FRACTION * (t_new - t_old)]
                now = model.indicators(t_switch, z, phase)
                for q in together:
                    modes[q] = not modes[q]
                    # a child's flag restarts from its indicator's sign when its parent switches
                    if q < W:
                        modes[W + q] = modes[q] and now[W + q] > 0
                    elif q == model.touch:
                        modes[model.push] = modes[q] and now[model.push] > 0
                n_switches += len(together)
                at_one_instant = at_one_instant + 1 if t_switch == t else 0
                if at_one_instant > MAX_SWITCHES_AT_ONE_INSTANT:
                    raise RuntimeError(f"simulate_system: the modes chatter at t = {t_switch!r}")
                t = t_switch
                first_step = max(solver.h_abs, 1e-12)
                switched = True
                break
            n_rhs += solver.nfev
            if not switched:
                z = solver.y.copy()
                t = t_end

    for name, values in series.items():
        if not np.all(np.isfinite(values)):
            raise RuntimeError(f"simulate_system: a sample time was not reached ({name})")
    bp = series["backplate"]
    peak_index = int(np.argmax(bp))
    peak = float(bp[peak_index])
    continuous, peak_time = backplate_peaks.result()
    if peak > continuous:
        continuous, peak_time = peak, float(times[peak_index])
    contact_peak, contact_time = contact_peaks.result() if pr is not None else (0.0, math.nan)

    stored = model.stored_energies(horizon, z, modes, phase)
    integral = dict(zip(SystemModel.INTEGRALS, (float(x) for x in z[model.I :])))
    energy = EnergyTerms(
        lattice_initial_potential=initial_potential,
        lattice_kinetic=stored[0],
        lattice_potential=stored[1],
        lattice_dissipation=integral["lattice_dissipation"],
        nonreciprocal_work=integral["nonreciprocal_work"],
        front_work=integral["front_work"],
        back_work=integral["back_work"],
        projectile_initial_kinetic=0.5 * pr.mass * pr.speed**2 if pr is not None else 0.0,
        projectile_kinetic=stored[2],
        contact_potential=stored[3],
        contact_dissipation=integral["contact_dissipation"],
        hull_kinetic=stored[4],
        hull_potential=stored[5],
        hull_dissipation=integral["hull_dissipation"],
        with_hull=scene.hull is not None,
        with_projectile=pr is not None,
    )
    return SystemResult(
        scene=scene,
        rtol=rtol,
        atol=atol,
        horizon=horizon,
        sample_interval=sample_interval,
        times=times,
        backplate_force=bp,
        contact_force=series["contact"],
        x_front=series["x_front"],
        v_front=series["v_front"],
        hull_position=series["hull_x"],
        hull_velocity=series["hull_v"],
        projectile_position=series["proj_x"],
        projectile_velocity=series["proj_v"],
        peak_backplate_force=peak,
        peak_sample_time=float(times[peak_index]),
        peak_backplate_force_continuous=continuous,
        peak_time=peak_time,
        peak_contact_force_continuous=float(contact_peak),
        peak_contact_time=float(contact_time),
        backplate_impulse=integral["backplate_impulse"],
        energy=energy,
        final_state=z.copy(),
        n_rhs=n_rhs,
        n_steps=n_steps,
        n_switches=n_switches,
        wall_time=time.perf_counter() - started,
    )
