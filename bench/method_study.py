"""Which integration method reaches the search evaluation's accuracy with the fewest right-hand sides?

    pip install -e ".[bench]"          # numba
    python bench/method_study.py --out bench/out/method_study            # ~1.5-3 min (2 loaded cores)
    python bench/method_study.py --out /tmp/ms --quick                   # ~40 s: 4 orders, rtol 1e-3 to 1e-7

The search evaluation (issue 12, item 2): the 11 x 11 lattice, receiver rule, 1 s horizon, the backplate force
sampled every 0.01 s; the objective is the largest sample. A setting is good enough when the worst relative
error of that peak over the orders is <= --target (3e-5), against the FMU's DOP853 at rtol 1e-12, atol 1e-14.

Every Runge-Kutta method here runs through one tableau-driven integrator (numba, over bench/peer_models.py's
right-hand side of SPEC.md) that handles the backplate as the FMU does (fmu_src/lattice/model.c, solver.c):

- the wall modes of the column-C masses (free / in contact and receding / in contact and approaching, which
  decides the wall damping) are frozen for a step, so no stage sees a switch;
- after an accepted step, if a row's mode differs at its end, the earliest switch is located by bisection on
  the method's dense output of that row's indicator (contact: ux_C - gap; damping: vx_C while in contact),
  switches within 1e-9 of the step after it count as one event (mirror-image rows cross within rounding of
  each other), the step is cut back to the last of them (state from the dense output, its error control
  untouched: the next step keeps the size proposed for the full one), the modes switch, and the next step
  starts with a fresh f(y);
- the load's switch-off at t_active = 0.15 s is a step limit (and the next f(y) is taken afresh);
- the backplate force is sampled from the dense output (0 in a step without contact);
- step-size control as SciPy's RK45 and the FMU: RMS norm of the error over atol + rtol max(|y|, |y_new|),
  safety 0.9, factor limits 0.2 and 10 (at most 1 after a rejection), exponent -1 / (error order + 1),
  Hairer's starting step; FSAL pairs reuse f(y_new); a dense output needing extra stages evaluates them
  only in the steps whose dense output is used (an event or a sample while in contact), and they count.

Methods: Tsitouras 5(4) (the searches' pair today: it calibrates this integrator against the C FMU),
Dormand-Prince 5(4), Bogacki-Shampine 3(2) and 5(4), Verner's efficient 6(5) and 7(6), Fine's general
Runge-Kutta-Nystrom 5(4) (the damping makes the acceleration depend on the velocity), and LSODA (scipy's
solve_ivp, Adams while non-stiff) segment by segment between the switches, restarted at each one
(bench/method_tableaux.py has the tableaux and their sources). For each method the rtol ladder (quarter
decades, atol = rtol / 100) is walked from loose to tight; the method's setting is the loosest rtol whose
worst error is within the target and whose next tighter rtol is too (as bench/peers.py chooses).

Writes method_study.csv (every method, rtol and order), method_study_summary.csv (the chosen settings) and
method_study.png (worst error against mean right-hand sides per run, one line per method) to --out.
Right-hand sides are counted exactly; no time is measured.
"""
from __future__ import annotations

import argparse
import math
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent))

from common import REVERSED, SEQUENTIAL, STUDY_BEST, order_text, random_orders, write_csv  # noqa: E402
from method_tableaux import PAIRS, NystromPair, Pair  # noqa: E402
from peer_models import pack  # noqa: E402

BEST_KNOWN = (1, 10, 9, 6, 4, 5, 7, 8, 3, 2, 11)
HORIZON = 1.0
SAMPLE_INTERVAL = 0.01
REFERENCE = {"solver": "dop853", "rtol": 1e-12, "atol": 1e-14}
FMU_OUTPUTS = ("peak_backplate_force", "rhs_evaluations", "steps_accepted", "steps_rejected")
LADDER_TOP, LADDER_BOTTOM, STEPS_PER_DECADE = 1e-3, 1e-8, 4
METHODS = ("tsit5", "dp5", "bs3", "bs5", "vern6", "vern7", "fine_rkn5", "lsoda")

# the integrator's parameters, packed in one float array for the numba kernel
P_RTOL, P_ATOL, P_T_END, P_T_LOAD_OFF, P_INTERVAL, P_K_WALL, P_C_WALL, P_GAP = range(8)
# what it returns
R_PEAK, R_RHS, R_ACCEPTED, R_REJECTED, R_EVENTS, R_DENSE_RHS, R_FAILED = range(7)
KIND_RK, KIND_RKN = 0, 1
HYSTERESIS = 1e-12  # m and m/s: see run_lsoda
SIMULTANEOUS_EVENT_FRACTION = 1e-9  # as fmu_src/lattice/model.c
FREE, RECEDING, APPROACHING = 0, 1, 2


def study_orders(random_count: int = 6, seed: int = 12) -> dict[str, tuple[int, ...]]:
    orders = {"sequential": SEQUENTIAL, "study_best": STUDY_BEST, "best_known": BEST_KNOWN, "reversed": REVERSED}
    for k, order in enumerate(random_orders(random_count, seed)):
        orders[f"random{k + 1}"] = order
    return orders


def ladder(top: float = LADDER_TOP, bottom: float = LADDER_BOTTOM) -> list[float]:
    steps = int(round(math.log10(top / bottom) * STEPS_PER_DECADE))
    return [10.0 ** (math.log10(top) - k / STEPS_PER_DECADE) for k in range(steps + 1)]


# ---------------------------------------------------------------------------------------------- numba kernel
_KERNEL = {}


def kernels():
    """(integrate, rhs_frozen): compiled on first use (numba is a bench-only dependency)."""
    if _KERNEL:
        return _KERNEL["integrate"], _KERNEL["rhs_frozen"]
    import numba

    from peer_models import numba_kernels

    _, _, rhs_into = numba_kernels()
    njit = numba.njit(cache=False, boundscheck=False)

    @njit
    def rhs(y, out, load_on, modes, columns, diagonals, scalars_no_wall, load, params):
        """SPEC's right-hand side with the backplate's modes frozen (mode, not the state, decides it)."""
        rhs_into(y, out, load_on, columns, diagonals, scalars_no_wall, load)
        R = load.shape[1]
        C = columns.shape[1]
        N = R * C
        k_w, c_w, gap, inverse_mass = params[P_K_WALL], params[P_C_WALL], params[P_GAP], scalars_no_wall[6]
        for i in range(R):
            if modes[i] != FREE:
                a = i * C + C - 1
                force = k_w * (y[a] - gap)
                if modes[i] == APPROACHING:
                    force += c_w * y[2 * N + a]
                out[2 * N + a] -= force * inverse_mass

    @njit
    def wall_mode(ux, vx, gap):
        if ux - gap <= 0.0:
            return FREE
        return APPROACHING if vx > 0.0 else RECEDING

    @njit
    def rhs_frozen(y, load_on, modes, columns, diagonals, scalars_no_wall, load, params):
        out = np.empty_like(y)
        rhs(y, out, load_on, modes, columns, diagonals, scalars_no_wall, load, params)
        return out

    @njit
    def dense_weights(D, n_dense, x, w):
        P = D.shape[1]
        for q in range(n_dense):
            s = 0.0
            for p in range(P - 1, -1, -1):
                s = (s + D[q, p]) * x
            w[q] = s

    @njit
    def dense_value(kind, i, x, h, y_old, y_end, K, w, n_dense, end_stage, N2):
        """Component i of the step's dense output at t_old + x h (w: the RK weights at x)."""
        if kind == KIND_RK:
            s = 0.0
            for q in range(n_dense):
                if w[q] != 0.0:
                    s += w[q] * K[q, i]
            return y_old[i] + h * s
        # Nystrom: quintic Hermite in u (u, u', u'' at both ends), its derivative for u'
        x2 = x * x
        x3 = x2 * x
        x4 = x3 * x
        x5 = x4 * x
        j = i if i < N2 else i - N2  # the position component
        u0, u1 = y_old[j], y_end[j]
        v0, v1 = y_old[N2 + j], y_end[N2 + j]
        a0, a1 = K[0, N2 + j], K[end_stage, N2 + j]
        if i < N2:
            return ((1.0 - 10.0 * x3 + 15.0 * x4 - 6.0 * x5) * u0 + (10.0 * x3 - 15.0 * x4 + 6.0 * x5) * u1
                    + h * ((x - 6.0 * x3 + 8.0 * x4 - 3.0 * x5) * v0 + (-4.0 * x3 + 7.0 * x4 - 3.0 * x5) * v1)
                    + h * h * ((0.5 * x2 - 1.5 * x3 + 1.5 * x4 - 0.5 * x5) * a0 + (0.5 * x3 - x4 + 0.5 * x5) * a1))
        return ((30.0 * x2 - 60.0 * x3 + 30.0 * x4) * (u1 - u0) / h
                + (1.0 - 18.0 * x2 + 32.0 * x3 - 15.0 * x4) * v0 + (-12.0 * x2 + 28.0 * x3 - 15.0 * x4) * v1
                + h * ((x - 4.5 * x2 + 6.0 * x3 - 2.5 * x4) * a0 + (1.5 * x2 - 4.0 * x3 + 2.5 * x4) * a1))

    @njit
    def integrate(kind, A, b, e, e2, has_e2, n_step, end_stage, D, n_dense, error_order,
                  abar, bp, ept, columns, diagonals, scalars_no_wall, load, params):
        """One run of the search evaluation; returns [peak, rhs, accepted, rejected, events, dense rhs, failed].

        kind KIND_RK: A, b, e, e2 (if has_e2), D as in method_tableaux.Pair. KIND_RKN: A is the position
        matrix a, b the position weights, e btilde; abar, bp, ept (bptilde) the velocity ones; D unused."""
        R = load.shape[1]
        C = columns.shape[1]
        N = R * C
        n = 4 * N
        N2 = 2 * N
        rtol, atol = params[P_RTOL], params[P_ATOL]
        t_end, t_load_off, interval, gap = params[P_T_END], params[P_T_LOAD_OFF], params[P_INTERVAL], params[P_GAP]
        k_w, c_w = params[P_K_WALL], params[P_C_WALL]
        S = A.shape[0]
        c = np.zeros(S)
        for q in range(S):
            for j in range(S):
                c[q] += abar[q, j] if kind == KIND_RKN else A[q, j]
        K = np.zeros((S, n))
        y = np.zeros(n)
        y_old = np.zeros(n)
        y_end = np.zeros(n)
        y_new = np.zeros(n)
        stage = np.zeros(n)
        scale = np.zeros(n)
        w = np.zeros(S)
        modes = np.zeros(R, np.int64)
        modes_end = np.zeros(R, np.int64)
        located = np.zeros(2 * R)
        out = np.zeros(7)
        exponent = -1.0 / (error_order + 1.0)
        n_rhs = 0
        dense_rhs = 0
        accepted = 0
        rejected = 0
        events = 0
        t = 0.0
        t_old = 0.0
        h_last = 0.0
        h_abs = 0.0
        load_on = 1.0
        k0_valid = False
        end_valid = False  # K[end_stage] is f(y) at the current state, in the current modes and phase
        next_sample = 1  # the sample at t = 0 is 0 (the lattice starts at rest, off the wall)
        peak = 0.0
        stalled = 0
        h = 0.0
        h_next = 0.0
        while t < t_end:
            t_limit = t_end
            if load_on != 0.0 and t_load_off < t_limit:
                t_limit = t_load_off
            if not k0_valid:
                if end_valid:
                    K[0, :] = K[end_stage, :]
                else:
                    rhs(y, K[0], load_on, modes, columns, diagonals, scalars_no_wall, load, params)
                    n_rhs += 1
                k0_valid = True
            if h_abs <= 0.0:  # Hairer's starting step, as SciPy's select_initial_step and the FMU
                for i in range(n):
                    scale[i] = atol + abs(y[i]) * rtol
                d0 = 0.0
                d1 = 0.0
                for i in range(n):
                    d0 += (y[i] / scale[i]) ** 2
                    d1 += (K[0, i] / scale[i]) ** 2
                d0 = math.sqrt(d0 / n)
                d1 = math.sqrt(d1 / n)
                h0 = 1e-6 if (d0 < 1e-5 or d1 < 1e-5) else 0.01 * d0 / d1
                h0 = min(h0, t_limit - t)
                for i in range(n):
                    stage[i] = y[i] + h0 * K[0, i]
                rhs(stage, K[1], load_on, modes, columns, diagonals, scalars_no_wall, load, params)
                n_rhs += 1
                d2 = 0.0
                for i in range(n):
                    d2 += ((K[1, i] - K[0, i]) / scale[i]) ** 2
                d2 = math.sqrt(d2 / n) / h0
                if d1 <= 1e-15 and d2 <= 1e-15:
                    h1 = max(1e-6, h0 * 1e-3)
                else:
                    h1 = (0.01 / max(d1, d2)) ** (1.0 / (error_order + 1.0))
                h_abs = min(100.0 * h0, min(h1, t_limit - t))
            was_rejected = False
            while True:
                h = h_abs
                if t + h * (1.0 + 1e-9) >= t_limit:
                    h = t_limit - t
                h_abs = h
                if h < 10.0 * abs(np.nextafter(t, np.inf) - t):
                    out[R_FAILED] = 1.0
                    out[R_PEAK] = peak
                    out[R_RHS] = n_rhs
                    return out
                if kind == KIND_RK:
                    for q in range(1, n_step):
                        if q == end_stage:  # FSAL: the last stage is f(y_new)
                            for i in range(n):
                                s = 0.0
                                for j in range(q):
                                    s += b[j] * K[j, i]
                                y_new[i] = y[i] + h * s
                            rhs(y_new, K[q], load_on, modes, columns, diagonals, scalars_no_wall, load, params)
                        else:
                            for i in range(n):
                                s = 0.0
                                for j in range(q):
                                    s += A[q, j] * K[j, i]
                                stage[i] = y[i] + h * s
                            rhs(stage, K[q], load_on, modes, columns, diagonals, scalars_no_wall, load, params)
                        n_rhs += 1
                    if end_stage >= n_step:
                        for i in range(n):
                            s = 0.0
                            for j in range(n_step):
                                s += b[j] * K[j, i]
                            y_new[i] = y[i] + h * s
                else:
                    for q in range(1, n_step):
                        if q == end_stage:
                            for i in range(N2):
                                su = 0.0
                                sv = 0.0
                                for j in range(q):
                                    su += b[j] * K[j, N2 + i]
                                    sv += bp[j] * K[j, N2 + i]
                                y_new[i] = y[i] + h * y[N2 + i] + h * h * su
                                y_new[N2 + i] = y[N2 + i] + h * sv
                            rhs(y_new, K[q], load_on, modes, columns, diagonals, scalars_no_wall, load, params)
                        else:
                            for i in range(N2):
                                su = 0.0
                                sv = 0.0
                                for j in range(q):
                                    su += A[q, j] * K[j, N2 + i]
                                    sv += abar[q, j] * K[j, N2 + i]
                                stage[i] = y[i] + c[q] * h * y[N2 + i] + h * h * su
                                stage[N2 + i] = y[N2 + i] + h * sv
                            rhs(stage, K[q], load_on, modes, columns, diagonals, scalars_no_wall, load, params)
                        n_rhs += 1
                finite = True
                for i in range(n):
                    if not math.isfinite(y_new[i]):
                        finite = False
                    scale[i] = atol + max(abs(y[i]), abs(y_new[i])) * rtol
                norm = 0.0
                norm2 = 0.0
                if kind == KIND_RK:
                    for i in range(n):
                        s = 0.0
                        s2 = 0.0
                        for q in range(n_step):
                            s += e[q] * K[q, i]
                            if has_e2:
                                s2 += e2[q] * K[q, i]
                        norm += (h * s / scale[i]) ** 2
                        norm2 += (h * s2 / scale[i]) ** 2
                    norm = math.sqrt(norm / n)
                    if has_e2:
                        norm = max(norm, math.sqrt(norm2 / n))
                else:
                    for i in range(N2):
                        su = 0.0
                        sv = 0.0
                        for q in range(n_step):
                            su += e[q] * K[q, N2 + i]
                            sv += ept[q] * K[q, N2 + i]
                        norm += (h * h * su / scale[i]) ** 2 + (h * sv / scale[N2 + i]) ** 2
                    norm = math.sqrt(norm / n)
                if norm < 1.0 and finite:
                    factor = 10.0 if norm == 0.0 else min(10.0, 0.9 * norm ** exponent)
                    if was_rejected:
                        factor = min(1.0, factor)
                    h_next = h_abs * factor
                    break
                h_abs *= max(0.2, 0.9 * norm ** exponent) if math.isfinite(norm) else 0.2
                was_rejected = True
                rejected += 1
            # accept
            y_old[:] = y
            y[:] = y_new
            y_end[:] = y_new
            t_old = t
            t = t + h
            h_last = h
            h_abs = h_next
            accepted += 1
            end_valid = end_stage < n_step
            k0_valid = False
            free_before = True
            changed = False
            for i in range(R):
                a = i * C + C - 1
                modes_end[i] = wall_mode(y[a], y[2 * N + a], gap)
                if modes[i] != FREE:
                    free_before = False
                if modes_end[i] != modes[i]:
                    changed = True
            sample_in_step = next_sample * interval <= t + 1e-9 * interval
            if changed or (sample_in_step and not free_before):
                # the dense output, in the step's own modes and phase: its extra stages, if any
                if kind == KIND_RK:
                    for q in range(n_step, n_dense):
                        if q == end_stage:
                            rhs(y_end, K[q], load_on, modes, columns, diagonals, scalars_no_wall, load, params)
                            end_valid = True
                        else:
                            for i in range(n):
                                s = 0.0
                                for j in range(q):
                                    s += A[q, j] * K[j, i]
                                stage[i] = y_old[i] + h * s
                            rhs(stage, K[q], load_on, modes, columns, diagonals, scalars_no_wall, load, params)
                        n_rhs += 1
                        dense_rhs += 1
            if changed:
                earliest = t
                n_located = 0
                for r in range(R):
                    if modes_end[r] == modes[r]:
                        continue
                    contact_before = modes[r] != FREE
                    contact_after = modes_end[r] != FREE
                    for indicator in range(2):
                        a = r * C + C - 1
                        if indicator == 0:
                            if contact_before == contact_after:
                                continue
                            component, offset = a, gap
                        else:
                            if not contact_before or (modes[r] == APPROACHING) == (modes_end[r] == APPROACHING):
                                continue
                            component, offset = 2 * N + a, 0.0
                        positive_at_end = y_end[component] - offset > 0.0
                        low = t_old
                        high = t
                        for _ in range(200):
                            if high - low <= 4.0 * 2.220446049250313e-16 * max(abs(high), 1.0):
                                break
                            middle = 0.5 * (low + high)
                            x = (middle - t_old) / h_last
                            if kind == KIND_RK:
                                dense_weights(D, n_dense, x, w)
                            value = dense_value(kind, component, x, h_last, y_old, y_end, K, w, n_dense, end_stage, N2)
                            if (value - offset > 0.0) == positive_at_end:
                                high = middle
                            else:
                                low = middle
                        located[n_located] = high
                        n_located += 1
                        earliest = min(earliest, high)
                # switches within SIMULTANEOUS_EVENT_FRACTION of the step after the earliest are one event, cut
                # at the last of them (mirror-image rows cross within rounding of each other), as the FMU does
                cut_time = earliest
                for k in range(n_located):
                    if located[k] <= earliest + SIMULTANEOUS_EVENT_FRACTION * h_last:
                        cut_time = max(cut_time, located[k])
                if t_old < earliest and cut_time < t:
                    x = (cut_time - t_old) / h_last
                    if kind == KIND_RK:
                        dense_weights(D, n_dense, x, w)
                    for i in range(n):
                        y[i] = dense_value(kind, i, x, h_last, y_old, y_end, K, w, n_dense, end_stage, N2)
                    t = cut_time
                    end_valid = False
                    events += 1
                    stalled = stalled + 1 if t - t_old <= 1e-12 * (1.0 + abs(t)) else 0
                    if stalled > 1000:
                        out[R_FAILED] = 1.0
                        break
                for i in range(R):
                    a = i * C + C - 1
                    m = wall_mode(y[a], y[2 * N + a], gap)
                    if m != modes[i]:
                        end_valid = False
                    modes[i] = m
            contact_free = free_before
            for i in range(R):
                if modes[i] != FREE:
                    contact_free = False
            # samples of this step (before the load switches: the dense output is the step's)
            while next_sample * interval <= t + 1e-9 * interval:
                ts = next_sample * interval
                force = 0.0
                if not contact_free:
                    at_end = ts >= t
                    x = (ts - t_old) / h_last
                    if kind == KIND_RK and not at_end:
                        dense_weights(D, n_dense, x, w)
                    for r in range(R):
                        a = r * C + C - 1
                        if at_end:
                            ux = y[a]
                            vx = y[2 * N + a]
                        else:
                            ux = dense_value(kind, a, x, h_last, y_old, y_end, K, w, n_dense, end_stage, N2)
                            vx = dense_value(kind, 2 * N + a, x, h_last, y_old, y_end, K, w, n_dense, end_stage, N2)
                        p = ux - gap
                        if p > 0.0:
                            force += k_w * p + c_w * max(vx, 0.0)
                if force > peak:
                    peak = force
                next_sample += 1
            if load_on != 0.0 and t >= t_load_off:
                load_on = 0.0
                end_valid = False
        out[R_PEAK] = peak
        out[R_RHS] = n_rhs
        out[R_ACCEPTED] = accepted
        out[R_REJECTED] = rejected
        out[R_EVENTS] = events
        out[R_DENSE_RHS] = dense_rhs
        return out

    _KERNEL.update(integrate=integrate, rhs_frozen=rhs_frozen)
    return integrate, rhs_frozen


# ----------------------------------------------------------------------------------------------- the routes
def _packed_arrays(packed):
    scalars_no_wall = packed.scalars.copy()
    scalars_no_wall[7] = 0.0  # the wall is added by the frozen-mode kernel
    params = np.zeros(8)
    params[P_T_END] = HORIZON
    params[P_T_LOAD_OFF] = packed.t_active
    params[P_INTERVAL] = SAMPLE_INTERVAL
    params[P_K_WALL], params[P_C_WALL], params[P_GAP] = packed.scalars[3], packed.scalars[4], packed.scalars[5]
    return scalars_no_wall, params


def run_pair(pair, packed, rtol: float, atol: float, horizon: float = HORIZON) -> dict:
    """One search evaluation with an explicit pair: peak, right-hand sides, steps, events (cut-backs)."""
    integrate, _ = kernels()
    scalars_no_wall, params = _packed_arrays(packed)
    params[P_RTOL], params[P_ATOL], params[P_T_END] = rtol, atol, horizon
    empty = np.zeros((1, 1))
    if isinstance(pair, NystromPair):
        S = pair.n_step
        result = integrate(KIND_RKN, pair.a, pair.b, pair.btilde, pair.btilde, False, S, pair.end_stage, empty, S,
                           pair.error_order, pair.abar, pair.bp, pair.bptilde, packed.columns, packed.diagonals,
                           scalars_no_wall, packed.load, params)
    else:
        has_e2 = pair.e2 is not None
        S = pair.A.shape[0]
        result = integrate(KIND_RK, pair.A, pair.b, pair.e, pair.e2 if has_e2 else pair.e, has_e2, pair.n_step,
                           pair.end_stage, pair.D, pair.n_dense, pair.error_order, np.zeros((S, S)), np.zeros(S),
                           np.zeros(S), packed.columns, packed.diagonals, scalars_no_wall, packed.load, params)
    if result[R_FAILED]:
        return {"failed": "step size collapsed or the switches chatter"}
    return {"peak": float(result[R_PEAK]), "rhs": int(result[R_RHS]), "accepted": int(result[R_ACCEPTED]),
            "rejected": int(result[R_REJECTED]), "events": int(result[R_EVENTS]),
            "dense_rhs": int(result[R_DENSE_RHS])}


def _wall_mode(ux, vx, gap):
    if ux - gap <= 0.0:
        return FREE
    return APPROACHING if vx > 0.0 else RECEDING


def run_lsoda(packed, rtol: float, atol: float, horizon: float = HORIZON) -> dict:
    """LSODA (scipy's solve_ivp) segment by segment: modes frozen within a segment, each switch found by
    solve_ivp's event location on the indicators (each one only in the direction that leaves the current
    mode), the integration restarted there with the toggled mode; the load's switch-off ends a segment.
    Each indicator switches HYSTERESIS past its threshold (a wall force step of k_w * 1e-12 m = 1e-8 N): at a
    restart every indicator then starts clear of zero, which solve_ivp's root bracketing needs.)"""
    from scipy.integrate import solve_ivp

    _, rhs_frozen = kernels()
    scalars_no_wall, params = _packed_arrays(packed)
    R, C = packed.rows, packed.cols
    N = R * C
    gap, k_w, c_w = params[P_GAP], params[P_K_WALL], params[P_C_WALL]
    wall = np.arange(R) * C + C - 1
    args = (packed.columns, packed.diagonals, scalars_no_wall, packed.load, params)
    t, y = 0.0, np.zeros(4 * N)
    modes = np.zeros(R, np.int64)
    load_on = 1.0
    counts = {"rhs": 0, "accepted": 0, "events": 0, "jacobians": 0, "segments": 0}
    peak, next_sample = 0.0, 1

    def force_of(state):
        p = state[wall] - gap
        vx = state[2 * N + wall]
        return float(np.where(p > 0, k_w * p + c_w * np.maximum(vx, 0.0), 0.0).sum())

    while t < horizon:
        t_stop = packed.t_active if load_on and t < packed.t_active else horizon
        frozen = modes.copy()

        def fun(_t, state, frozen=frozen, load_on=load_on):
            counts["rhs"] += 1
            return rhs_frozen(state, load_on, frozen, *args)

        events = []
        for r in range(R):
            a = wall[r]

            def contact(_t, state, a=a, shift=gap + (HYSTERESIS if frozen[r] == FREE else -HYSTERESIS)):
                return state[a] - shift
            contact.terminal = True
            contact.direction = -1.0 if frozen[r] != FREE else 1.0
            events.append(contact)
            if frozen[r] != FREE:
                def damping(_t, state, a=a, shift=HYSTERESIS if frozen[r] == RECEDING else -HYSTERESIS):
                    return state[2 * N + a] - shift
                damping.terminal = True
                damping.direction = -1.0 if frozen[r] == APPROACHING else 1.0
                events.append(damping)
        try:
            sol = solve_ivp(fun, (t, t_stop), y, method="LSODA", rtol=rtol, atol=atol, events=events,
                            dense_output=True)
        except ValueError as exc:  # brentq: an indicator's sign differs between a step's end and its dense output
            return {"failed": f"event location at t = {t:.9g} s: {exc}"}
        if sol.status < 0:
            return {"failed": sol.message}
        counts["accepted"] += len(sol.t) - 1
        counts["jacobians"] += sol.njev
        counts["segments"] += 1
        t_segment = float(sol.t[-1])
        while next_sample * SAMPLE_INTERVAL <= t_segment + 1e-9 * SAMPLE_INTERVAL:
            ts = next_sample * SAMPLE_INTERVAL
            state = sol.y[:, -1] if ts >= t_segment else sol.sol(ts)
            peak = max(peak, force_of(state))
            next_sample += 1
        t, y = t_segment, sol.y[:, -1].copy()
        if sol.status == 1:  # an event: the fired row's mode toggles (its state may sit on either side of
            # the switch by rounding); every other row takes the mode of its state, as the FMU does (rows that
            # switch at the same time by symmetry would otherwise start past their switch and never fire)
            counts["events"] += 1
            fired = min((te[0], k) for k, te in enumerate(sol.t_events) if len(te))[1]
            modes = np.array([_wall_mode(y[a], y[2 * N + a], gap) for a in wall], dtype=np.int64)
            k = 0
            for r in range(R):
                a = wall[r]
                if k == fired:  # contact on or off
                    modes[r] = FREE if frozen[r] != FREE else (APPROACHING if y[2 * N + a] > 0 else RECEDING)
                k += 1
                if frozen[r] != FREE:
                    if k == fired:  # damping on or off
                        modes[r] = RECEDING if frozen[r] == APPROACHING else APPROACHING
                    k += 1
        elif load_on and t >= packed.t_active:
            load_on = 0.0
    return {"peak": peak, "rhs": counts["rhs"], "accepted": counts["accepted"], "rejected": float("nan"),
            "events": counts["events"], "dense_rhs": 0, "jacobians": counts["jacobians"]}


def run_method(method: str, packed, rtol: float, atol: float) -> dict:
    if method == "lsoda":
        return run_lsoda(packed, rtol, atol)
    return run_pair(PAIRS[method](), packed, rtol, atol)


# ------------------------------------------------------------------------------------------------ the study
def fmu_peaks(fmu_path, orders: dict, parameters: dict) -> dict:
    from orchestrator.simulation import LatticeFMU

    with LatticeFMU(fmu_path) as fmu:
        return {label: fmu.simulate(order, horizon=HORIZON, parameters=parameters, outputs=FMU_OUTPUTS)
                for label, order in orders.items()}


def choose(rows: list[dict], target: float) -> dict | None:
    """The loosest rtol whose worst error is within the target and whose next tighter rtol is too."""
    by_rtol = sorted({r["rtol"] for r in rows}, reverse=True)
    worst = {rtol: worst_error([r for r in rows if r["rtol"] == rtol]) for rtol in by_rtol}
    for k, rtol in enumerate(by_rtol[:-1]):
        if worst[rtol] <= target and worst[by_rtol[k + 1]] <= target:
            return {"rtol": rtol, "worst_error": worst[rtol]}
    return None


def worst_error(rows: list[dict]) -> float:
    if any(r.get("failed") for r in rows):
        return float("inf")
    return max(r["error"] for r in rows)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", default="bench/out/method_study", help="folder for the CSVs and the chart")
    parser.add_argument("--fmu", help="the lattice FMU (default: build one from fmu_src/ into a temporary folder)")
    parser.add_argument("--methods", nargs="*", default=list(METHODS), choices=METHODS)
    parser.add_argument("--random", type=int, default=6, help="random orders besides the four named ones")
    parser.add_argument("--seed", type=int, default=12, help="seed of the random orders")
    parser.add_argument("--target", type=float, default=3e-5, help="worst relative peak error a search needs")
    parser.add_argument("--quick", action="store_true", help="4 orders, rtol 1e-3 to 1e-7 (for a test)")
    args = parser.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    orders = study_orders(args.random, args.seed)
    rtols = ladder()
    if args.quick:
        orders = dict(list(orders.items())[:4])
        rtols = ladder(1e-3, 1e-7)
    if args.fmu:
        fmu_path = Path(args.fmu)
    else:
        import build_fmu

        fmu_path = build_fmu.build_fmu(output=Path(tempfile.mkdtemp(prefix="method_study_")) / "MassSpringLattice.fmu")
    from reference import Scene

    packs = {label: pack(Scene(order=order)) for label, order in orders.items()}
    log(f"{len(orders)} orders; reference: the FMU's DOP853 at rtol 1e-12, atol 1e-14")
    reference = {label: r["peak_backplate_force"] for label, r in fmu_peaks(fmu_path, orders, REFERENCE).items()}
    start = time.process_time()
    kernels()
    run_pair(PAIRS["tsit5"](), packs["sequential"], 1e-3, 1e-5)  # compile
    log(f"numba compile {time.process_time() - start:.1f} s CPU")

    rows = []
    for method in args.methods:
        for rtol in rtols:
            for label, packed in packs.items():
                result = run_method(method, packed, rtol, rtol * 1e-2)
                row = {"method": method, "rtol": rtol, "atol": rtol * 1e-2, "order": label,
                       "order_text": order_text(orders[label]), "reference_peak": reference[label]}
                if "failed" in result:
                    row.update(failed=result["failed"], error=float("inf"))
                else:
                    row.update(result, error=abs(result["peak"] / reference[label] - 1.0), failed="")
                rows.append(row)
            these = [r for r in rows if r["method"] == method and r["rtol"] == rtol]
            log(f"  {method:9s} rtol {rtol:8.2e}: worst {worst_error(these):9.2e}, mean rhs "
                f"{statistics.mean(r.get('rhs', 0) for r in these):7.0f}")

    # calibration: the C FMU's Tsit5 over the same ladder
    calibration = []
    for rtol in rtols:
        fmu = fmu_peaks(fmu_path, orders, {"solver": "tsit5", "rtol": rtol, "atol": rtol * 1e-2})
        for label, r in fmu.items():
            calibration.append({"method": "fmu_tsit5", "rtol": rtol, "atol": rtol * 1e-2, "order": label,
                                "order_text": order_text(orders[label]), "reference_peak": reference[label],
                                "peak": r["peak_backplate_force"], "rhs": r["rhs_evaluations"],
                                "accepted": r["steps_accepted"], "rejected": r["steps_rejected"],
                                "error": abs(r["peak_backplate_force"] / reference[label] - 1.0), "failed": ""})
    rows += calibration
    write_csv(out / "method_study.csv", rows)

    summary = []
    for method in list(args.methods) + ["fmu_tsit5"]:
        mine = [r for r in rows if r["method"] == method]
        chosen = choose(mine, args.target)
        entry = {"method": method, "rtol": "", "worst_error": "", "rhs_median": "", "rhs_min": "", "rhs_max": "",
                 "rhs_mean": "", "accepted_median": "", "rejected_median": "", "events_median": "",
                 "dense_rhs_median": ""}
        if chosen:
            at = [r for r in mine if r["rtol"] == chosen["rtol"]]
            rhs = [r["rhs"] for r in at]
            entry.update(rtol=chosen["rtol"], worst_error=chosen["worst_error"], rhs_median=statistics.median(rhs),
                         rhs_min=min(rhs), rhs_max=max(rhs), rhs_mean=statistics.mean(rhs),
                         accepted_median=statistics.median(r["accepted"] for r in at),
                         rejected_median=statistics.median(r["rejected"] for r in at),
                         events_median=(statistics.median(r.get("events", 0) for r in at)
                                        if method != "fmu_tsit5" else ""),
                         dense_rhs_median=statistics.median(r.get("dense_rhs", 0) for r in at)
                         if method != "fmu_tsit5" else "")
        summary.append(entry)
    write_csv(out / "method_study_summary.csv", summary)
    chart(rows, out / "method_study.png", args.target)

    print(f"\n{len(orders)} orders, 1 s, sampled peak; target worst error <= {args.target:g} (confirmed by the next "
          f"tighter rtol); right-hand sides per run at that setting")
    print(f"{'method':10s} {'rtol':>9s} {'worst err':>9s} {'RHS median':>10s} {'range':>11s} {'accepted':>8s} "
          f"{'rejected':>8s} {'events':>6s} {'dense':>5s}")
    for e in summary:
        if e["rtol"] == "":
            print(f"{e['method']:10s} never within the target on this ladder")
            continue
        print(f"{e['method']:10s} {e['rtol']:9.2e} {e['worst_error']:9.2e} {e['rhs_median']:10.0f} "
              f"{e['rhs_min']:5d}-{e['rhs_max']:<5d} {e['accepted_median']:8.0f} {e['rejected_median']:8.0f} "
              f"{e['events_median'] if e['events_median'] != '' else '':>6} {e['dense_rhs_median']:>5}")
    calibrate = [(m, f) for m, f in ((r, c) for r in rows if r["method"] == "tsit5" for c in calibration
                                     if c["rtol"] == r["rtol"] and c["order"] == r["order"])]
    ratios = [m["rhs"] / f["rhs"] for m, f in calibrate if not m["failed"]]
    peak_differences = [abs(m["peak"] / f["peak"] - 1.0) for m, f in calibrate if not m["failed"]]
    if ratios:
        print(f"\ncalibration (this Tsit5 against the C FMU's, every rtol and order): RHS ratio "
              f"{min(ratios):.3f}-{max(ratios):.3f} (median {statistics.median(ratios):.3f}), peaks differ by "
              f"{min(peak_differences):.1e}-{max(peak_differences):.1e} "
              f"(median {statistics.median(peak_differences):.1e})")
    print(f"wrote {out / 'method_study.csv'}, {out / 'method_study_summary.csv'} and {out / 'method_study.png'}")
    return 0


def log(text: str) -> None:
    print(text, flush=True)


def chart(rows: list[dict], path: Path, target: float) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, axis = plt.subplots(figsize=(9, 6))
    for method in dict.fromkeys(r["method"] for r in rows):
        points = []
        for rtol in sorted({r["rtol"] for r in rows if r["method"] == method}, reverse=True):
            at = [r for r in rows if r["method"] == method and r["rtol"] == rtol]
            error = worst_error(at)
            if math.isfinite(error) and error > 0:
                points.append((statistics.mean(r["rhs"] for r in at), error, rtol))
        if not points:
            continue
        style = "s--" if method == "fmu_tsit5" else "o-"
        axis.loglog([p[0] for p in points], [p[1] for p in points], style, label=method, markersize=4)
    axis.axhline(target, color="grey", linestyle="--", linewidth=0.8, label=f"search needs {target:g}")
    axis.set_xlabel("mean right-hand sides per run (1 s search evaluation)")
    axis.set_ylabel("worst relative error of the sampled peak over the orders")
    axis.set_title("Methods on the search evaluation (11 x 11, receiver rule, rtol quarter decades)")
    axis.grid(True, which="both", alpha=0.3)
    axis.legend(fontsize=8)
    figure.tight_layout()
    figure.savefig(path, dpi=120)
    plt.close(figure)


if __name__ == "__main__":
    raise SystemExit(main())
