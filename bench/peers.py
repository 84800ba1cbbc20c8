"""The FMU against the strongest peers a Python user can install with pip, at equal accuracy.

    pip install -e ".[bench]"                # numba, jax, diffrax (benchmark-only)
    python -m bench.peers                    # 5 orders, every scene; writes the page (it records the run time)
    python -m bench.peers --quick            # 3 orders, fewer rounds
    python -m bench.peers --scenes plate     # one scene: its tables printed, the page left as it is

Why: "faster than scipy over numpy" says little; a user who cares would compile the right-hand side. Routes,
each over docs/model.md's right-hand side written once in bench/peer_models.py (checked against reference/lattice.py,
for the plate reference/lattice3d.py, to 1e-12 before anything is timed), each in two phases split at the load's
switch-off, with the backplate force sampled every 0.01 s from its own dense output (docs/model.md section 6):
- the FMU through fmpy (orchestrator.simulation.LatticeFMU: reset, parameters, one doStep, outputs), as it
  ships (use_symmetry 1: for the armour scene it integrates ux and vx of the upper half, for the plate under a
  centred patch a quarter of the plate, the whole model's solution with the whole model's steps), and with
  use_symmetry 0 (the whole lattice, as the peers integrate it), so that the comparison is shown at equal model
  too (the peers do not integrate a quarter plate: that would need the mirror planes written into their kernels);
- scipy.integrate.odeint (LSODA) over a numba right-hand side;
- scipy.integrate.solve_ivp(method="DOP853") over the same numba right-hand side;
- diffrax Tsit5 with a PID controller over a JAX right-hand side, the whole solve jit-compiled (CPU, x64).
The peers step across the backplate's switches (the FMU locates them as events); what that costs them in
accuracy is what the tolerance walk below pays for.

Three scenes: on the 2-D 11 x 11 lattice the 8 s scene (the FMU at its default setting, read from its model
description) and the search evaluation (the FMU as the searches run it: the orchestrator's solver, rtol and
horizon); on the plate (docs/model.md section 10, the plate_11x11x11 scene: 11 x 11 x 11 under a centred 3 x 3
patch, its FMU built from that scene) the search evaluation. Equal accuracy: the error of a run is the relative
error of its sampled peak against the FMU's DOP853 at rtol 1e-13; the target is the FMU's worst error over the
orders at its setting; each peer walks a tolerance ladder (rtol from 100 times the FMU's down to 1e-12, four
steps per decade, atol = rtol / 100) from loose to tight and is timed at the first rtol whose worst error over
the orders is within the target and whose next tighter rtol is too (so that a lucky loose setting is not
taken); a setting is abandoned at the first order that misses the target. On the plate a peer's run on the walk
is stopped past PLATE_WALK_CPU_LIMIT and counted as failed (LSODA switches to BDF at loose tolerances there, and
its finite-difference Jacobians of the whole plate cost far more than its tighter Adams runs). Timing: CPU time
per run (time.process_time), the routes interleaved order by order and round by round (the first route
rotates), the fastest of the rounds per route and order; numba's and JAX's compile times are measured apart and
never enter a run's time. Also checks the published peaks to 1e-5 with every route over the 8 s scene.

The page holds every scene from one run: a run of some scenes (--scenes) prints its tables and leaves the page as
it is, so that no page mixes figures of two commits.
"""

from __future__ import annotations

import contextlib
import importlib.util
import math
import os
import statistics
import time
from dataclasses import dataclass
from pathlib import Path

os.environ.setdefault("JAX_PLATFORMS", "cpu")
# one thread for XLA's own kernels: the FMU and scipy run on one core, and process_time would count the others
os.environ.setdefault("XLA_FLAGS", "--xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1")

import numpy as np  # noqa: E402

from fmu_src.published import PUBLISHED_PEAKS  # noqa: E402
from orchestrator.objective import SEARCH_HORIZON  # noqa: E402
from orchestrator.simulation import LatticeFMU, SimulationError  # noqa: E402
from reference import Scene  # noqa: E402
from reference.lattice3d import PlateScene  # noqa: E402
from reference.simulate import sample_times  # noqa: E402

from .common import (
    STUDY_BEST,
    add_fmu_option,
    bench_orders,
    default_setting,
    lattice_fmu,
    order_text,  # noqa: E402
    search_parameters,
)
from .measurements import Page, Run, Table, write_page  # noqa: E402
from .peer_models import (
    PlatePacked,
    check_against_reference,
    check_plate_against_reference,
    jax_plate_rhs,  # noqa: E402
    jax_rhs,
    numba_kernels,
    pack,
    pack_plate,
    plate_check_scenes,
    plate_numba_kernels,
)

PUBLISHED_TOLERANCE = 1e-5
SAMPLE_INTERVAL = 0.01
REFERENCE_TOLERANCES = {"rtol": 1e-13, "atol": 1e-15}
LADDER_STEPS_PER_DECADE = 4
LADDER_START = 100.0  # times the FMU's rtol: every peer errs above the target there (seen on every run)
LADDER_END = 1e-12
ROUTES = ("fmu", "fmu_whole", "odeint", "dop853", "diffrax")
PEERS = ROUTES[2:]
LABELS = {
    "fmu": "FMU via fmpy",
    "fmu_whole": "FMU via fmpy, whole lattice (use_symmetry 0)",
    "odeint": "scipy odeint (LSODA) + numba",
    "dop853": "scipy solve_ivp DOP853 + numba",
    "diffrax": "diffrax Tsit5 (JAX, CPU)",
}


@dataclass(frozen=True)
class PlateShape:
    """The plate FMU's lattice (docs/model.md section 10), as the peers must integrate it."""

    rows: int
    cols: int
    depth: int
    load_patch: int

    def scene(self, order) -> PlateScene:
        return PlateScene(
            rows=self.rows, cols=self.cols, depth=self.depth, order=tuple(order), load_patch=self.load_patch
        )

    @property
    def text(self) -> str:
        patch = f"a centred {self.load_patch} x {self.load_patch} patch" if self.load_patch else "the whole face"
        return f"{self.rows} x {self.cols} x {self.depth} plate under {patch}"


@dataclass(frozen=True)
class Scenario:
    name: str
    label: str
    horizon: float
    fmu_rtol: float
    fmu_atol: float
    fmu_solver: str  # the FMU's solver parameter, by the name its model description declares
    plate: PlateShape | None = None  # None: the 2-D lattice of the armour scene
    #: a peer's run on the tolerance walk stopped past this CPU time counts as failed (None: never stopped)
    walk_cpu_limit: float | None = None

    def pack(self, order):
        """The peers' arrays of one order (the 2-D kernels' or the plate's)."""
        return pack(Scene(order=order)) if self.plate is None else pack_plate(self.plate.scene(order))


#: the plate's tolerance walk stops a peer's run past this CPU time: LSODA at loose tolerances switches to BDF,
#: whose finite-difference Jacobian of the plate's states (one right-hand side per state) and dense LU cost orders
#: of magnitude more than its Adams runs; a stopped run is recorded as failed, so the walk goes on to tighter
#: tolerances where that peer is fast (which favours it)
PLATE_WALK_CPU_LIMIT = 5.0


def scenarios(
    search: dict, default: dict, plate_search: dict | None = None, plate: PlateShape | None = None, lattice: bool = True
) -> dict[str, Scenario]:
    """The scenes: the searches' evaluation (``search``: the orchestrator's parameters) and the 8 s scene at the
    FMU's default setting (``default``: read from the FMU) on the 2-D lattice (unless not ``lattice``), and the
    search evaluation of the plate (``plate_search``: the orchestrator's parameters over the plate FMU) if
    given."""
    out = {}
    if lattice:
        out["search"] = Scenario(
            "search",
            f"search evaluation ({SEARCH_HORIZON:g} s)",
            SEARCH_HORIZON,
            search["rtol"],
            search["atol"],
            search["solver"],
        )
        out["scene8s"] = Scenario("scene8s", "8 s scene", 8.0, default["rtol"], default["atol"], default["solver"])
    if plate is not None:
        out["plate"] = Scenario(
            "plate",
            f"{plate.text}, search evaluation ({SEARCH_HORIZON:g} s)",
            SEARCH_HORIZON,
            plate_search["rtol"],
            plate_search["atol"],
            plate_search["solver"],
            plate=plate,
            walk_cpu_limit=PLATE_WALK_CPU_LIMIT,
        )
    return out


class RouteFailed(RuntimeError):
    """A run gave no number (solver failure): recorded as failed, never as a peak."""


class StoppedRun(RouteFailed):
    """A run of the tolerance walk stopped at its CPU time limit (after_jacobian: it had made a finite-difference
    Jacobian): recorded as failed."""

    def __init__(self, message: str, after_jacobian: bool):
        super().__init__(message)
        self.after_jacobian = after_jacobian


# ------------------------------------------------------------------------------------------- routes
def phases(horizon: float, t_active: float):
    """[(t0, t1, load_on, sample indices in (t0, t1])] with the samples of docs/model.md §6 (t = 0 sampled apart)."""
    ts = sample_times(horizon, SAMPLE_INTERVAL)
    out = []
    if t_active > 0:
        out.append((0.0, min(t_active, horizon), 1.0))
    if t_active < horizon:
        out.append((t_active, horizon, 0.0))
    return ts, [(t0, t1, on, np.flatnonzero((ts > t0) & (ts <= t1))) for t0, t1, on in out]


class FMURoute:
    """The FMU as shipped (use_symmetry 1: the armour scene's ux and vx of its upper half, a quarter of the plate
    under a centred load), or integrating the whole lattice as the peers do (use_symmetry 0): the same steps, so
    the same accuracy."""

    def __init__(self, fmu: LatticeFMU, horizon: float, solver: str, use_symmetry: int = 1):
        self.fmu, self.horizon, self.solver, self.use_symmetry = fmu, horizon, solver, use_symmetry

    def run(self, order, packed, rtol, atol, cpu_limit=None):
        """(peak, right-hand sides); the FMU is never stopped (cpu_limit is the scipy routes')."""
        try:
            result = self.fmu.simulate(
                order,
                horizon=self.horizon,
                parameters={"solver": self.solver, "rtol": rtol, "atol": atol, "use_symmetry": self.use_symmetry},
                outputs=("peak_backplate_force", "rhs_evaluations"),
            )
        except SimulationError as exc:
            raise RouteFailed(str(exc)) from None
        return result["peak_backplate_force"], int(result["rhs_evaluations"])


class OverCPULimit(Exception):
    """Raised from a right-hand side once a run has used its CPU time limit."""


class Limited:
    """A right-hand side that raises OverCPULimit once ``seconds`` of CPU time have passed since it was made (odeint
    and solve_ivp pass the exception on), and counts the longest run of calls at one t: a finite-difference
    Jacobian makes one call per state at one t. Only the tolerance walk's runs are wrapped, never a timed one."""

    def __init__(self, rhs, seconds: float, time_first: bool):
        self.rhs, self.time_first = rhs, time_first
        self.deadline = time.process_time() + seconds
        self.t, self.calls_at_t, self.most_calls_at_one_t = None, 0, 0

    def __call__(self, a, b, *args):
        t = a if self.time_first else b
        if t == self.t:
            self.calls_at_t += 1
        else:
            self.t, self.calls_at_t = t, 1
        self.most_calls_at_one_t = max(self.most_calls_at_one_t, self.calls_at_t)
        if time.process_time() > self.deadline:
            raise OverCPULimit
        return self.rhs(a, b, *args)


class ScipyRoute:
    """odeint (LSODA) or solve_ivp(DOP853) over the numba right-hand side (the 2-D lattice's, or the plate's for
    ``plate``), sampled from the dense output."""

    def __init__(self, kind: str, horizon: float, plate: bool = False):
        import scipy.integrate

        self.kind, self.horizon = kind, horizon
        self.odeint, self.solve_ivp = scipy.integrate.odeint, scipy.integrate.solve_ivp
        self.rhs_odeint, self.rhs_solve_ivp, _ = plate_numba_kernels() if plate else numba_kernels()
        self.lsoda_methods = set()
        self.last_jacobians = None

    def run(self, order, packed, rtol, atol, cpu_limit=None):
        """(peak, right-hand sides); RouteFailed if the solver fails or, with cpu_limit (s), the run exceeds it."""
        if cpu_limit is None:
            return self._run(packed, rtol, atol, self.rhs_odeint, self.rhs_solve_ivp)
        rhs_odeint = Limited(self.rhs_odeint, cpu_limit, time_first=False)
        rhs_solve_ivp = Limited(self.rhs_solve_ivp, cpu_limit, time_first=True)
        try:
            return self._run(packed, rtol, atol, rhs_odeint, rhs_solve_ivp)
        except OverCPULimit:
            self.last_jacobians = None
            most = max(rhs_odeint.most_calls_at_one_t, rhs_solve_ivp.most_calls_at_one_t)
            why = (
                f", after a finite-difference Jacobian ({most} right-hand sides at one t, {packed.state_size} states)"
                if most >= packed.state_size
                else ""
            )
            raise StoppedRun(f"{self.kind}: stopped past {cpu_limit:g} s CPU{why}", most >= packed.state_size) from None

    def _run(self, packed, rtol, atol, rhs_odeint, rhs_solve_ivp):
        ts, parts = phases(self.horizon, packed.t_active)
        args = packed.kernel_args()
        y = np.zeros(packed.state_size)
        states = np.empty((ts.size, y.size))
        states[0] = y
        n_rhs = jacobians = 0
        for t0, t1, load_on, sel in parts:
            t_out = ts[sel]
            if t_out.size == 0 or t_out[-1] < t1:
                t_out = np.append(t_out, t1)
            if self.kind == "odeint":
                ys, info = self.odeint(
                    rhs_odeint,
                    y,
                    np.concatenate([[t0], t_out]),
                    args=(load_on, *args),
                    rtol=rtol,
                    atol=atol,
                    full_output=True,
                    mxstep=100000,
                )
                if info["message"] != "Integration successful.":
                    raise RouteFailed(f"odeint: {info['message']}")
                n_rhs += int(info["nfe"][-1])  # LSODA counts its finite-difference Jacobians' calls here too
                jacobians += int(info["nje"][-1])
                self.lsoda_methods.update(int(m) for m in info["mused"])
                ys = ys[1:]
            else:
                sol = self.solve_ivp(
                    rhs_solve_ivp,
                    (t0, t1),
                    y,
                    method="DOP853",
                    t_eval=t_out,
                    args=(load_on, *args),
                    rtol=rtol,
                    atol=atol,
                )
                if sol.status != 0:
                    raise RouteFailed(f"solve_ivp: {sol.message}")
                n_rhs += int(sol.nfev)
                ys = sol.y.T
            states[sel] = ys[: sel.size]
            y = np.ascontiguousarray(ys[-1])
        self.last_jacobians = jacobians if self.kind == "odeint" else None
        force = packed.backplate_force(states)
        if not np.all(np.isfinite(force)):
            raise RouteFailed(f"{self.kind}: a non-finite backplate force")
        return float(force.max()), n_rhs


class DiffraxRoute:
    """diffrax Tsit5 + PIDController over the JAX right-hand side; the whole two-phase solve is one compiled
    function of (order's arrays, rtol, atol), so one compilation serves every order and tolerance."""

    def __init__(self, horizon: float, packed):
        import jax

        jax.config.update("jax_enable_x64", True)
        import diffrax
        import jax.numpy as jnp

        self.jax, self.horizon = jax, horizon
        self.key = self.compiled_for(packed)
        rows, cols = packed.rows, packed.cols
        if isinstance(packed, PlatePacked):
            rhs = jax_plate_rhs(rows, cols, packed.depth, packed.equal_diagonal_alphas)
            N, components, faces = rows * cols * packed.depth, 3, rows * packed.depth
        else:
            rhs = jax_rhs(rows, cols, packed.equal_diagonal_alphas)
            N, components, faces = rows * cols, 2, rows
        ts, parts = phases(horizon, packed.t_active)
        wall = np.arange(faces) * cols + cols - 1
        self.counter, self.counts = [0], {}

        def count(_):
            self.counter[0] += 1

        def make(counting: bool):
            def vector_field(t, y, args):
                load_on, arrays = args
                if counting:
                    jax.debug.callback(count, t)
                return rhs(y, load_on, *arrays)

            term = diffrax.ODETerm(vector_field)
            solver = diffrax.Tsit5()

            def solve(arrays, rtol, atol):
                scalars = arrays[-2]  # both kinds of kernel arguments end with (scalars, load)
                controller = diffrax.PIDController(rtol=rtol, atol=atol)
                y = jnp.zeros(2 * components * N)
                forces = [jnp.zeros(1)]  # t = 0: at rest, no contact
                steps = []
                for t0, t1, load_on, sel in parts:
                    t_out = ts[sel]
                    if t_out.size == 0 or t_out[-1] < t1:
                        t_out = np.append(t_out, t1)
                    sol = diffrax.diffeqsolve(
                        term,
                        solver,
                        t0,
                        t1,
                        None,
                        y,
                        args=(load_on, arrays),
                        saveat=diffrax.SaveAt(ts=jnp.asarray(t_out)),
                        stepsize_controller=controller,
                        adjoint=diffrax.ForwardMode(),
                        max_steps=1_000_000,
                    )
                    ys = sol.ys[: sel.size]
                    p = ys[:, wall] - scalars[5]
                    vx = ys[:, components * N + wall]
                    forces.append(jnp.where(p > 0, scalars[3] * p + scalars[4] * jnp.maximum(vx, 0), 0.0).sum(axis=1))
                    steps.append(sol.stats["num_steps"])
                    y = sol.ys[-1]
                return jnp.max(jnp.concatenate(forces)), jnp.stack(steps)

            return jax.jit(solve)

        example = (packed.kernel_args(), 1e-6, 1e-8)
        start_cpu, start_wall = time.process_time(), time.perf_counter()
        self.solve = make(False).lower(*example).compile()
        self.compile_cpu, self.compile_wall = time.process_time() - start_cpu, time.perf_counter() - start_wall
        self.solve_counting = make(True).lower(*example).compile()

    @staticmethod
    def compiled_for(packed):
        return (
            type(packed),
            packed.rows,
            packed.cols,
            getattr(packed, "depth", 1),
            packed.equal_diagonal_alphas,
            packed.t_active,
        )

    def run(self, order, packed, rtol, atol, cpu_limit=None):
        """(peak, None): one compiled call, never stopped (cpu_limit is the scipy routes')."""
        if self.compiled_for(packed) != self.key:
            raise ValueError("DiffraxRoute: compiled for another lattice or material table")
        try:
            peak, _ = self.solve(packed.kernel_args(), rtol, atol)
            peak = float(peak)  # waits for the result
        except Exception as exc:  # noqa: BLE001 - e.g. max_steps reached: a failed run, not a number
            raise RouteFailed(f"diffrax: {type(exc).__name__}: {str(exc).splitlines()[0]}") from None
        if not math.isfinite(peak):
            raise RouteFailed("diffrax: a non-finite peak")
        return peak, None

    def count(self, packed, rtol, atol) -> int:
        """The right-hand sides of a run, counted by a second compiled solve (a callback per evaluation, so never
        the timed one); a run is deterministic, so each order and setting is counted once."""
        key = (b"".join(np.ascontiguousarray(a).tobytes() for a in packed.kernel_args()), rtol, atol)
        if key not in self.counts:
            self.counter[0] = 0
            peak, _ = self.solve_counting(packed.kernel_args(), rtol, atol)
            float(peak)
            self.jax.effects_barrier()
            self.counts[key] = self.counter[0]
        return self.counts[key]


def timed(route, order, packed, rtol, atol, cpu_limit=None, count=True):
    """(peak, rhs, cpu seconds) of one run, or (None, the RouteFailed, cpu seconds) if it failed; rhs None when
    the route cannot count them during the run and ``count`` is false (the walk needs errors, not counts)."""
    start = time.process_time()
    try:
        peak, n_rhs = route.run(order, packed, rtol, atol, cpu_limit)
    except RouteFailed as exc:
        return None, exc, time.process_time() - start
    seconds = time.process_time() - start
    if n_rhs is None and count:
        n_rhs = route.count(packed, rtol, atol)
    return peak, n_rhs, seconds


# --------------------------------------------------------------------------------------------- study
def compile_numba(kernels, packed) -> dict:
    """numba's compile time of one pair of kernels (numba_kernels or plate_numba_kernels): the first calls of
    both right-hand sides on ``packed``'s arrays (compiled in this process, no cache)."""
    rhs_odeint, rhs_solve_ivp, _ = kernels()
    y = np.zeros(packed.state_size)
    start_cpu, start_wall = time.process_time(), time.perf_counter()
    rhs_odeint(y, 0.0, 1.0, *packed.kernel_args())
    rhs_solve_ivp(0.0, y, 1.0, *packed.kernel_args())
    return {"cpu": time.process_time() - start_cpu, "wall": time.perf_counter() - start_wall}


def rhs_microseconds(kernels, packed, count: int, repeats: int = 5) -> dict:
    """CPU microseconds of one numba right-hand side (numba_kernels or plate_numba_kernels) at a typical state
    of ``packed``: alone (a compiled loop of ``count``) and called from Python as scipy calls it (dispatch
    included). diffrax's is in its runs' figures (CPU / RHS)."""
    import numba

    rhs_odeint, _, rhs_into = kernels()
    rng = np.random.default_rng(0)
    y = np.concatenate([rng.uniform(-0.03, 0.03, packed.state_size // 2), rng.uniform(-1, 1, packed.state_size // 2)])
    args = packed.kernel_args()

    @numba.njit(cache=False)
    def loop(y, count, args):
        out = np.empty_like(y)
        total = 0.0
        for _ in range(count):
            rhs_into(y, out, 1.0, *args)
            total += out[-1]
        return total

    loop(y, 1, args)
    out = {}
    best = math.inf
    for _ in range(repeats):
        start = time.process_time()
        loop(y, count, args)
        best = min(best, time.process_time() - start)
    out["numba"] = best / count * 1e6
    best = math.inf
    for _ in range(repeats):
        start = time.process_time()
        for _ in range(count // 4):
            rhs_odeint(y, 0.0, 1.0, *args)
        best = min(best, time.process_time() - start)
    out["numba_from_python"] = best / (count // 4) * 1e6
    return out


def study_scenario(
    scenario: Scenario, fmu: LatticeFMU, orders: dict, repeats: int, log, with_diffrax: bool = True
) -> dict:
    packs = {label: scenario.pack(order) for label, order in orders.items()}
    plate = scenario.plate is not None
    routes = {
        "fmu": FMURoute(fmu, scenario.horizon, scenario.fmu_solver),
        "fmu_whole": FMURoute(fmu, scenario.horizon, scenario.fmu_solver, use_symmetry=0),
        "odeint": ScipyRoute("odeint", scenario.horizon, plate),
        "dop853": ScipyRoute("dop853", scenario.horizon, plate),
    }
    log(f"\n== {scenario.label}")
    if with_diffrax:
        routes["diffrax"] = DiffraxRoute(scenario.horizon, next(iter(packs.values())))
        log(
            f"diffrax compiled in {routes['diffrax'].compile_cpu:.1f} s CPU ({routes['diffrax'].compile_wall:.1f} s "
            "wall)"
        )
    peers = [name for name in PEERS if name in routes]

    reference = {}
    for label, order in orders.items():
        reference[label] = fmu.simulate(
            order, horizon=scenario.horizon, parameters=REFERENCE_TOLERANCES, outputs=("peak_backplate_force",)
        )["peak_backplate_force"]

    stopped = {name: [] for name in peers}  # (rtol, after a Jacobian) of the walk's runs stopped at the CPU limit

    def errors_at(route_name, rtol, atol, target=None):
        """The runs of every order, or (given a target) up to the first whose error misses it: the setting has
        failed then, and the other orders cannot change that."""
        rows = []
        for label, order in orders.items():
            cpu_limit = scenario.walk_cpu_limit if route_name in peers else None
            peak, n_rhs, seconds = timed(routes[route_name], order, packs[label], rtol, atol, cpu_limit, count=False)
            error = abs(peak / reference[label] - 1) if peak is not None else math.nan
            if isinstance(n_rhs, StoppedRun):
                stopped[route_name].append((rtol, n_rhs.after_jacobian))
            rows.append(
                {
                    "scene": scenario.name,
                    "route": route_name,
                    "rtol": rtol,
                    "atol": atol,
                    "order": label,
                    "peak": peak if peak is not None else math.nan,
                    "error": error,
                    "rhs": n_rhs if peak is not None else None,
                    "cpu_ms_single": seconds * 1e3,
                    "lsoda_jacobians": getattr(routes[route_name], "last_jacobians", None),
                    "failure": "" if peak is not None else str(n_rhs),
                }
            )
            if peak is None:
                log(f"    {route_name} failed on {label}: {n_rhs}")
            if target is not None and not error <= target:
                break
        return rows

    def worst(rows):
        return max((r["error"] if math.isfinite(r["error"]) else math.inf) for r in rows)

    ladder_rows = errors_at("fmu", scenario.fmu_rtol, scenario.fmu_atol)
    target = worst(ladder_rows)
    log(
        f"FMU ({scenario.fmu_solver}) at rtol {scenario.fmu_rtol:g}, atol {scenario.fmu_atol:g}: "
        f"worst error {target:.2e} "
        "(the target every peer must meet)"
    )
    chosen = {"fmu": (scenario.fmu_rtol, scenario.fmu_atol), "fmu_whole": (scenario.fmu_rtol, scenario.fmu_atol)}
    top = math.log10(LADDER_START * scenario.fmu_rtol)
    steps = int(round((top - math.log10(LADDER_END)) * LADDER_STEPS_PER_DECADE))
    ladder = [10.0 ** (top - k / LADDER_STEPS_PER_DECADE) for k in range(steps + 1)]
    for name in peers:
        passed_at = None
        for rtol in ladder:
            rows = errors_at(name, rtol, rtol * 1e-2, target)
            ladder_rows += rows
            ok = worst(rows) <= target
            log(
                f"  {name:8s} rtol {rtol:8.1e}: worst error {worst(rows):.2e} "
                + ("ok" if ok else f"(over the target at {rows[-1]['order']})")
            )
            if ok and passed_at is not None:
                break
            passed_at = rtol if ok else None
        else:
            passed_at = None
        chosen[name] = (passed_at, passed_at * 1e-2) if passed_at is not None else None
        if passed_at is None:
            log(f"  {name}: never reached the FMU's accuracy on the ladder (down to rtol {ladder[-1]:.0e})")

    # interleaved timing at the chosen settings
    timing = {(name, label): [] for name in routes for label in orders}
    results = {}
    active = [name for name in routes if chosen[name] is not None]
    for round_index in range(repeats):
        rotation = active[round_index % len(active) :] + active[: round_index % len(active)]
        for label, order in orders.items():
            for name in rotation:
                rtol, atol = chosen[name]
                peak, n_rhs, seconds = timed(routes[name], order, packs[label], rtol, atol)
                if peak is None:
                    results[(name, label)] = {"failure": str(n_rhs)}
                    continue
                timing[(name, label)].append(seconds)
                results[(name, label)] = {
                    "peak": peak,
                    "rhs": n_rhs,
                    "lsoda_jacobians": getattr(routes[name], "last_jacobians", None),
                }
    rows = []
    for name in active:
        for label in orders:
            result = results[(name, label)]
            times = timing[(name, label)]
            row = {
                "scene": scenario.name,
                "route": name,
                "order": label,
                "order_materials": orders[label],
                "rtol": chosen[name][0],
                "atol": chosen[name][1],
                "repeats": len(times),
            }
            if "failure" in result or not times:
                row["failure"] = result.get("failure", "no run")
            else:
                cpu = min(times)
                row.update(
                    peak=result["peak"],
                    reference_peak=reference[label],
                    error=abs(result["peak"] / reference[label] - 1),
                    rhs=result["rhs"],
                    lsoda_jacobians=result["lsoda_jacobians"],
                    cpu_ms=cpu * 1e3,
                    cpu_ms_median=statistics.median(times) * 1e3,
                    us_per_rhs=cpu / result["rhs"] * 1e6,
                )
            rows.append(row)
    for base, key in (("fmu", "ratio_to_fmu"), ("fmu_whole", "ratio_to_fmu_whole")):
        base_cpu = {r["order"]: r["cpu_ms"] for r in rows if r["route"] == base and "cpu_ms" in r}
        for row in rows:
            if "cpu_ms" in row and row["order"] in base_cpu:
                row[key] = row["cpu_ms"] / base_cpu[row["order"]]
    extra = {
        "routes": tuple(routes),
        "target": target,
        "chosen": chosen,
        "reference": reference,
        "lsoda_methods": sorted(routes["odeint"].lsoda_methods),
        "stopped": stopped,
        "repeats": repeats,
    }
    if with_diffrax:
        extra.update(
            diffrax_compile_cpu=routes["diffrax"].compile_cpu, diffrax_compile_wall=routes["diffrax"].compile_wall
        )
    return {"rows": rows, "ladder": ladder_rows, **extra}


def summarise(scenario: Scenario, study: dict) -> list[dict]:
    summary = []
    for name in study["routes"]:
        rows = [r for r in study["rows"] if r["route"] == name]
        good = [r for r in rows if "cpu_ms" in r]
        label = LABELS[name]
        if name == "fmu_whole" and scenario.plate is not None:
            label = label.replace("whole lattice", "whole plate")
        if name.startswith("fmu"):
            label = f"{label} ({scenario.fmu_solver}, C)"
        entry = {"scene": scenario.name, "route": name, "label": label}
        chosen = study["chosen"].get(name)
        if chosen is None or not good:
            entry["status"] = "did not reach the FMU's accuracy" if chosen is None else "failed"
            summary.append(entry)
            continue
        entry.update(
            status="ok" if len(good) == len(rows) else "some runs failed",
            rtol=chosen[0],
            atol=chosen[1],
            worst_error=max(r["error"] for r in good),
            orders=len(good),
            cpu_ms_min=min(r["cpu_ms"] for r in good),
            cpu_ms_max=max(r["cpu_ms"] for r in good),
            cpu_ms_mean=statistics.fmean(r["cpu_ms"] for r in good),
            rhs_min=min(r["rhs"] for r in good),
            rhs_max=max(r["rhs"] for r in good),
            us_per_rhs_min=min(r["us_per_rhs"] for r in good),
            us_per_rhs_max=max(r["us_per_rhs"] for r in good),
        )
        ratios = [r["ratio_to_fmu"] for r in good if "ratio_to_fmu" in r]
        if ratios and name != "fmu":
            entry.update(
                ratio_min=min(ratios),
                ratio_max=max(ratios),
                ratio_geomean=math.exp(statistics.fmean(math.log(x) for x in ratios)),
            )
        whole = [r["ratio_to_fmu_whole"] for r in good if "ratio_to_fmu_whole" in r]
        if whole and name in PEERS:  # the lead at equal model: both integrate the whole lattice
            entry.update(
                ratio_whole_min=min(whole),
                ratio_whole_max=max(whole),
                ratio_whole_geomean=math.exp(statistics.fmean(math.log(x) for x in whole)),
            )
        summary.append(entry)
    return summary


def check_published(study: dict, orders: dict) -> list[dict]:
    """Every route's 8 s peak of the two published orders against the published numbers (to 1e-5)."""
    out = []
    for row in study["rows"]:
        order = tuple(row["order_materials"])
        if order in PUBLISHED_PEAKS and "peak" in row:
            deviation = abs(row["peak"] / PUBLISHED_PEAKS[order] - 1)
            out.append(
                {
                    "route": row["route"],
                    "order": row["order"],
                    "peak": row["peak"],
                    "published": PUBLISHED_PEAKS[order],
                    "relative_deviation": deviation,
                    "ok": deviation <= PUBLISHED_TOLERANCE,
                }
            )
    return out


def summary_rows(summary: list[dict]) -> tuple:
    rows = []
    for s in summary:
        if "cpu_ms_min" not in s:
            rows.append((s["label"], s["status"], "", "", "", "", "", ""))
            continue
        rows.append(
            (
                s["label"],
                f"{s['rtol']:.1e}",
                f"{s['worst_error']:.1e}",
                f"{s['cpu_ms_min']:.2f}-{s['cpu_ms_max']:.2f}",
                f"{s['rhs_min']}-{s['rhs_max']}",
                f"{s['us_per_rhs_min']:.2f}-{s['us_per_rhs_max']:.2f}",
                f"{s['ratio_min']:.1f}-{s['ratio_max']:.1f}x ({s['ratio_geomean']:.1f}x)" if "ratio_min" in s else "",
                f"{s['ratio_whole_min']:.1f}-{s['ratio_whole_max']:.1f}x ({s['ratio_whole_geomean']:.1f}x)"
                if "ratio_whole_min" in s
                else "",
            )
        )
    return tuple(rows)


PLATE_SCENE = "plate_11x11x11"
SCENES = ("search", "scene8s", "plate")


def repeats_of(scene: str, quick: bool) -> int:
    """Interleaved timing rounds: the plate's runs are long (seconds for a peer) and steadier, so fewer."""
    return {"search": (8, 4), "scene8s": (4, 2), "plate": (3, 2)}[scene][1 if quick else 0]


def plate_shape(path) -> PlateShape:
    """The plate scene's lattice, and its load's patch as the FMU at ``path`` declares it (its start value)."""
    from orchestrator.fmu import describe
    from scenes import Scene as SceneFile

    scene = SceneFile.load(PLATE_SCENE)
    patch = describe(Path(path), scene.rows).start("load_patch")
    if patch is None:
        raise SystemExit(f"--plate-fmu: {path} has no load_patch parameter: not the {PLATE_SCENE} scene's FMU")
    return PlateShape(scene.rows, scene.cols, scene.depth, int(patch))


def checked_plate_fmu(given: str | None):
    """The plate FMU: the one given, checked against the plate scene (columns, continuous states), or built."""
    if given:
        from orchestrator.scene import resolve
        from orchestrator.study import CaseConfig

        try:
            resolve(CaseConfig(scene=PLATE_SCENE, fmu=given))
        except ValueError as exc:
            raise SystemExit(str(exc).replace("--fmu", "--plate-fmu", 1)) from None
    return lattice_fmu(given, scene=PLATE_SCENE, option="--plate-fmu")


def main(argv=None) -> int:
    run = Run.start(__file__, argv)
    parser = run.parser(__doc__, quick="sequential, study's best and one random order; fewer rounds")
    add_fmu_option(parser)
    parser.add_argument(
        "--plate-fmu",
        help=f"the plate FMU to measure (default: built from the {PLATE_SCENE} scene into a temporary folder)",
    )
    parser.add_argument(
        "--scenes",
        nargs="+",
        choices=SCENES,
        default=list(SCENES),
        help="the scenes to measure (default all); the page is written only when all are measured, "
        "otherwise the tables are printed",
    )
    parser.add_argument(
        "--random-orders", type=int, default=2, help="random orders beside sequential, study's best and reversed"
    )
    parser.add_argument(
        "--repeats",
        type=int,
        default=None,
        help="interleaved timing rounds (default 8 for the "
        "search evaluation, 4 for the 8 s scene, 3 for the plate; --quick: 4, 2 and 2)",
    )
    args = parser.parse_args(argv)
    missing = [name for name in ("numba", "jax", "diffrax") if importlib.util.find_spec(name) is None]
    if missing:
        parser.error(f'{", ".join(missing)} not installed: pip install -e ".[bench]"')
    if args.repeats is not None and args.repeats < 1:
        parser.error(f"--repeats must be at least 1, got {args.repeats}")
    scenes = [name for name in SCENES if name in args.scenes]
    lattice_scenes = [name for name in scenes if name != "plate"]
    orders = bench_orders(random_count=args.random_orders)
    if args.quick:
        orders = {k: orders[k] for k in ("sequential", "study's best", "random 1")}
    log = lambda text: print(text, flush=True)  # noqa: E731

    # compile and check every kernel before anything is timed (compile first: the checks would compile them too)
    numba_compile, kernels, micro = {}, {}, {}
    if lattice_scenes:
        numba_compile["lattice"] = compile_numba(numba_kernels, pack(Scene()))
        kernels["lattice"] = check_against_reference()
        log("kernels against reference/lattice.py: " + ", ".join(f"{k} {v:.1e}" for k, v in kernels["lattice"].items()))
        micro["lattice"] = rhs_microseconds(numba_kernels, pack(Scene(order=STUDY_BEST)), 20000)
    studies, summaries, plan = {}, {}, {}
    with contextlib.ExitStack() as stack:
        if "plate" in scenes:
            plate_path = stack.enter_context(checked_plate_fmu(args.plate_fmu))
            shape = plate_shape(plate_path)
            plate_packed = pack_plate(shape.scene(STUDY_BEST))
            numba_compile["plate"] = compile_numba(plate_numba_kernels, plate_packed)
            kernels["plate"] = check_plate_against_reference()
            log(
                "plate kernels against reference/lattice3d.py: "
                + ", ".join(f"{k} {v:.1e}" for k, v in kernels["plate"].items())
            )
            micro["plate"] = rhs_microseconds(plate_numba_kernels, plate_packed, 1000)
        if lattice_scenes:
            path = stack.enter_context(lattice_fmu(args.fmu))
            fmu = stack.enter_context(LatticeFMU(path))
            plan.update(scenarios(search_parameters(path), default_setting(path)))
            for name in lattice_scenes:
                studies[name] = study_scenario(
                    plan[name], fmu, orders, args.repeats or repeats_of(name, args.quick), log
                )
                summaries[name] = summarise(plan[name], studies[name])
        if "plate" in scenes:
            plate_fmu = stack.enter_context(LatticeFMU(plate_path))
            plan["plate"] = scenarios({}, {}, search_parameters(plate_path), shape, lattice=False)["plate"]
            studies["plate"] = study_scenario(
                plan["plate"], plate_fmu, orders, args.repeats or repeats_of("plate", args.quick), log
            )
            summaries["plate"] = summarise(plan["plate"], studies["plate"])
    page = measurement_page(run, plan, studies, summaries, orders, numba_compile, kernels, micro)
    if scenes != list(SCENES):
        # a page holds every scene from one command and one commit; a part of them is shown, not written
        for table in page.tables:
            log(f"\n{table.caption}\n" + "\n".join(" | ".join(map(str, row)) for row in table.rows))
        log(
            f"\nthe page is written by a run of every scene ({' '.join(SCENES)}); this run measured "
            f"{' '.join(scenes)}, so docs/measurements/{run.name}.md is unchanged"
        )
        return 0
    write_page(run, page)
    return 0


def measurement_page(run, plan, studies, summaries, orders, numba_compile, kernels, micro) -> Page:
    tables, notes, headline = [], [], []
    for name in studies:
        scenario, study = plan[name], studies[name]
        model = "whole-plate" if scenario.plate else "whole-lattice"
        tables.append(
            Table(
                (
                    "route",
                    "rtol",
                    "worst error",
                    "CPU ms per run",
                    "right-hand sides",
                    "us per right-hand side",
                    "peer / FMU (geometric mean)",
                    f"peer / {model} FMU",
                ),
                summary_rows(summaries[name]),
                caption=f"**{scenario.label[0].upper() + scenario.label[1:]}** (the FMU: "
                f"{scenario.fmu_solver} at rtol {scenario.fmu_rtol:g}, atol {scenario.fmu_atol:g}; "
                f"target error {study['target']:.1e}; timing rounds: {study['repeats']}):",
            )
        )
        lsoda = next((s for s in summaries[name] if s["route"] == "odeint" and "ratio_geomean" in s), None)
        fastest = min(
            (s for s in summaries[name] if s["route"] in PEERS and "ratio_geomean" in s),
            key=lambda s: s["ratio_geomean"],
            default=None,
        )
        if fastest:
            headline.append(
                f"{scenario.label}: the closest peer ({LABELS[fastest['route']]}) takes "
                f"{fastest['ratio_geomean']:.1f}x the FMU's CPU time"
                + (
                    f" ({fastest['ratio_whole_geomean']:.1f}x the whole-plate FMU's)"
                    if scenario.plate and "ratio_whole_geomean" in fastest
                    else ""
                )
                + (f", LSODA {lsoda['ratio_geomean']:.1f}x" if lsoda and lsoda is not fastest else "")
            )
        if study["lsoda_methods"]:
            used = {1: "Adams (non-stiff)", 2: "BDF (stiff)"}
            methods = ", ".join(used.get(m, str(m)) for m in study["lsoda_methods"])
            notes.append(f"{scenario.label}: LSODA used {methods} over the tolerance walk's finished runs.")
        for peer, runs in study["stopped"].items():
            if runs:
                jacobians = sum(1 for _, after in runs if after)
                timed_max = next(
                    (s["cpu_ms_max"] / 1e3 for s in summaries[name] if s["route"] == peer and "cpu_ms_max" in s), None
                )
                verdict = (
                    "each stopped run had already cost more CPU than any of its timed runs, so the stop can "
                    "only favour the peer"
                    if timed_max is not None and timed_max < scenario.walk_cpu_limit
                    else "the stop may have changed the setting it is timed at"
                )
                notes.append(
                    f"{scenario.label}: {len(runs)} of {LABELS[peer]}'s runs on the tolerance walk (at rtol "
                    f"{', '.join(sorted({f'{r:.1e}' for r, _ in runs}, key=float, reverse=True))}) were stopped "
                    f"past {scenario.walk_cpu_limit:g} s CPU and counted as failed, {jacobians} of them after a "
                    "finite-difference Jacobian (as many right-hand sides at one t as the model has states: LSODA "
                    f"had switched to BDF); {verdict}."
                )
        if name == "scene8s":
            checks = check_published(study, orders)
            worst = max(c["relative_deviation"] for c in checks) if checks else None
            if worst is not None:
                notes.append(
                    f"Every route gives both published peaks to {worst:.1e} (relative) at its 8 s setting "
                    f"({'within' if worst <= PUBLISHED_TOLERANCE else 'NOT within'} the "
                    f"{PUBLISHED_TOLERANCE:g} checked)."
                )
    if "lattice" in kernels:
        notes.append(
            f"Before timing, the kernels were checked against reference/lattice.py on "
            f"{len(kernels['lattice'])} quantities over six scenes: worst relative difference "
            + ", ".join(f"{k} {v:.1e}" for k, v in kernels["lattice"].items())
            + "."
        )
    if "plate" in kernels:
        notes.append(
            f"Before timing, the plate's kernels were checked against reference/lattice3d.py's right-hand "
            f"side over {len(plate_check_scenes())} small plates (5 x 5 x 5 and smaller, R != D, a centred "
            "patch and the whole face, both diagonal rules): worst relative difference "
            + ", ".join(f"{k} {v:.1e}" for k, v in kernels["plate"].items())
            + "."
        )
    compile_text = "; ".join(
        f"{'the plate' if k == 'plate' else 'the 2-D lattice'} {v['cpu']:.1f} s" for k, v in numba_compile.items()
    )
    diffrax_text = ", ".join(
        f"{plan[n].label} {studies[n]['diffrax_compile_cpu']:.1f} s CPU"
        for n in studies
        if "diffrax_compile_cpu" in studies[n]
    )
    micro_text = "; ".join(
        f"{'the plate' if k == 'plate' else 'the 2-D lattice'} {v['numba']:.2f} us in a "
        f"compiled loop and {v['numba_from_python']:.2f} us called from Python"
        for k, v in micro.items()
    )
    notes.append(
        f"Compile times, never in a run's time: numba (CPU) {compile_text}; diffrax {diffrax_text}. One "
        f"numba right-hand side costs: {micro_text}; the rest of a peer's time per right-hand side is its "
        "solver's own work."
    )
    if "plate" in studies:
        notes.append(
            "The plate: the FMU as shipped (`use_symmetry` 1) integrates a quarter of the plate under the "
            "centred patch, with the whole plate's steps; the peers integrate the whole plate (a quarter "
            "would need the mirror planes' conditions written into their kernels, which this benchmark "
            "does not do), so the last column compares them with the FMU integrating the whole plate "
            "(`use_symmetry` 0), at equal model."
        )
    summary = (
        f"{len(orders)} orders ({', '.join(f'{k} {order_text(v)}' for k, v in orders.items())}), on every scene. "
        "Each peer runs at the loosest rtol (quarter decades, atol = rtol / 100) whose worst sampled-peak error "
        "over the orders (against the FMU's DOP853 at rtol 1e-13) is within the FMU's, confirmed by the next "
        "tighter one. CPU time per run (`process_time`), the routes interleaved, the fastest round per order (the "
        "rounds of each scene in its table's caption: the plate's runs take seconds, so it has fewer); ranges over "
        "the orders. The whole-lattice FMU (`use_symmetry` 0) integrates what the peers integrate."
    )
    return Page(
        name=run.name,
        title="The FMU against its peers at equal accuracy",
        headline="; ".join(headline),
        summary=summary,
        tables=tuple(tables),
        notes=tuple(notes),
    )


if __name__ == "__main__":
    raise SystemExit(main())
