"""Where the solvers fail, and that every failure is caught: an FMI error with a reason, never a number.

- The largest stable fixed step of RK4 and of semi-implicit Euler is located by bisection on the FMU (short
  horizon) and compared with the same bisection on the numpy oracle (reference/) integrated by the same
  method: the FMU must stop at the method's real limit, and every step beyond it must be an FMI error.
- The adaptive solver on the stiffest order we know (reversed, 11..1) and under 10x, 100x and 1000x load.
- A search whose objective fails for some orders finishes and counts the failures.
- Annealing at a poor (forced) temperature is flagged with its acceptance rate, on the real FMU.
- Failure modes found on the way, each with its own test: a fixed step near the limit can make doStep run
  for ever (wall-event chattering); semi-implicit Euler's work integral lags one step, so its divergence
  check refuses stable steps; an error's reason is lost when two FMU instances live in one process.

Every FMU run that could hang goes through tests/isolated.py's IsolatedFMU (a worker process with a timeout).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from isolated import IsolatedFMU
from fmu_src.published import STUDY_BEST_ORDER as PUBLISHED_BEST
from orchestrator.simulation import LatticeFMU, SimulationError
from reference import Scene

REVERSED = tuple(range(11, 0, -1))
HORIZON = 0.5  # the lattice is pressing hardest on the plate here: the stiffest part of the run
RUN_TIMEOUT = 5.0  # seconds; a healthy run of these settings takes well under 0.1 s
SOLVER = {"rk4": 1, "semi_implicit_euler": 2}


@pytest.fixture(scope="module")
def isolated(fmu_path):
    with IsolatedFMU(fmu_path, timeout=RUN_TIMEOUT) as fmu:
        yield fmu


# ---------------------------------------------------------------------------- the oracle's stability limit
def oracle_bounded(order, method: str, h: float, horizon: float = HORIZON) -> bool:
    """Fixed-step RK4 / semi-implicit Euler over the numpy model: does the solution stay bounded?"""
    scene = Scene(order=order)
    model, n_masses = scene.model, scene.n_masses
    y, t = np.zeros(scene.state_size), 0.0
    with np.errstate(all="ignore"):
        while t < horizon * (1 - 1e-12):
            load_on = t < scene.t_active * (1 - 1e-12)
            step = min(h, horizon - t, (scene.t_active - t) if load_on else math.inf)
            f = lambda state: model.evaluate(state, load_on)  # noqa: E731
            if method == "rk4":
                k1 = f(y)
                k2 = f(y + 0.5 * step * k1)
                k3 = f(y + 0.5 * step * k2)
                y = y + step / 6 * (k1 + 2 * k2 + 2 * k3 + f(y + step * k3))
            else:
                y = y.copy()
                y[2 * n_masses :] += step * f(y)[2 * n_masses :]
                y[: 2 * n_masses] += step * y[2 * n_masses :]
            t += step
            if not np.all(np.isfinite(y)) or np.max(np.abs(y[2 * n_masses :])) > 1e3:
                return False
    return True


def bisect(stable, low: float, high: float, ratio: float = 1.02) -> tuple[float, float]:
    """(largest step found stable, smallest found unstable), within `ratio` of each other."""
    assert stable(low), f"the bracket's low end {low} is not stable"
    assert not stable(high), f"the bracket's high end {high} is stable"
    while high / low > ratio:
        middle = math.sqrt(low * high)
        if stable(middle):
            low = middle
        else:
            high = middle
    return low, high


def fmu_run(isolated, order, method: str, h: float, horizon: float = HORIZON):
    status, result, seconds = isolated.run(order, horizon, {"solver": SOLVER[method], "fixed_step": h})
    assert status != "timeout", f"{method} at fixed_step = {h:g} s: doStep did not return ({result})"
    return status, result


@pytest.mark.parametrize(
    "method, order",
    [
        pytest.param("rk4", PUBLISHED_BEST, id="rk4-study_best"),
        pytest.param("rk4", REVERSED, id="rk4-reversed"),
        pytest.param("semi_implicit_euler", PUBLISHED_BEST, id="semi_implicit_euler-study_best"),
        pytest.param("semi_implicit_euler", REVERSED, id="semi_implicit_euler-reversed"),
    ],
)
def test_fixed_step_limit_is_the_methods_own_and_beyond_it_is_an_fmi_error(isolated, method, order):
    oracle_low, oracle_high = bisect(lambda h: oracle_bounded(order, method, h), 1e-4, 0.1)
    fmu_low, fmu_high = bisect(lambda h: fmu_run(isolated, order, method, h)[0] == "ok", 1e-4, 0.1)
    # the FMU stops where the method really goes unstable: not (much) later, and not far earlier either
    assert 0.8 * oracle_low <= fmu_low <= 1.25 * oracle_high, (
        f"{method}: the FMU's largest working step is {fmu_low:.4g} s, the method's stability limit on the "
        f"numpy oracle is {oracle_low:.4g} s"
    )
    # below the limit a number, beyond it an FMI error naming the step, at every step we try (right at the
    # limit the outcome flips between neighbouring steps, RK4 on the study's best order for instance works at
    # 0.03 s and diverges at 0.029 s, so "below" means clearly below)
    status, result = fmu_run(isolated, order, method, 0.75 * fmu_low)
    assert status == "ok" and math.isfinite(result["peak_backplate_force"])
    for factor in (1.1, 1.5, 2.0, 4.0):
        status, message = fmu_run(isolated, order, method, factor * fmu_high)
        assert status == "error", f"{method} at {factor} x the limit gave a number: {message}"
        assert "fixed_step" in message and ("stability limit" in message or "diverged" in message), message


def test_a_fixed_step_near_the_limit_never_hangs(isolated):
    """Found here: RK4 at 0.03 s (stable: the numpy oracle's limit for this order is 0.030 s over 0.5 s)
    chatters on a backplate switch (every step is cut back to an event a few ulps ahead: ~3e5 steps stuck at
    t = 0.4749 s), and doStep never returns. Over 30 random orders at 0.026 s, 13 hung."""
    status, result, seconds = isolated.run(PUBLISHED_BEST, 1.0, {"solver": 1, "fixed_step": 0.03})
    assert status != "timeout", f"doStep did not return within {RUN_TIMEOUT:g} s (it used to run for ever)"


def test_semi_implicit_euler_counts_the_work_of_its_first_step(isolated):
    """Found here: semi-implicit Euler integrates the power with the velocity at the start of the step, so the
    work of the first step is 0 while the kinetic energy is not; at 1e-3 s that alone trips the divergence
    check at t = h ('kinetic energy 0.0684 J against 0 J of work put in'), far below the method's limit."""
    status, result = fmu_run(isolated, PUBLISHED_BEST, "semi_implicit_euler", 1e-4, horizon=1e-4)
    assert status == "ok"
    assert result["kinetic_energy"] > 0
    assert result["external_work"] > 0, "the load moved the masses, so it did work"
    assert abs(result["energy_balance_error"]) <= 0.5 * result["kinetic_energy"]


# ---------------------------------------------------------------------------- the adaptive solver, stressed
@pytest.mark.parametrize("order", [PUBLISHED_BEST, REVERSED], ids=["study_best", "reversed"])
@pytest.mark.parametrize("load", [1, 10, 100])
def test_adaptive_solver_survives_stiff_orders_and_extreme_loads(lattice, order, load):
    result = lattice.simulate(
        order,
        horizon=1.0,
        parameters={"F_total": 1200.0 * load},
        outputs=(
            "peak_backplate_force",
            "peak_backplate_force_continuous",
            "external_work",
            "energy_balance_error",
            "rhs_evaluations",
        ),
    )
    assert all(math.isfinite(v) for v in result.values.values())
    assert result["peak_backplate_force"] > 1000.0 * load  # the plate takes the load (and then some)
    assert abs(result["energy_balance_error"]) <= 1e-6 * result["external_work"]
    assert result["peak_backplate_force_continuous"] >= result["peak_backplate_force"]


def test_adaptive_solver_at_1000x_load_fails_with_a_clear_error_or_balances(isolated):
    """At 1000x F_total the springs stiffen exponentially: on the study's best order the step size collapses
    (a clear FMI error, after ~4 s); on the reversed order it gets through with the energy balance closed."""
    for order in (PUBLISHED_BEST, REVERSED):
        status, result, seconds = isolated.run(order, 0.3, {"F_total": 1.2e6}, timeout=60)
        assert status in ("ok", "error"), result
        if status == "error":
            assert "step size collapsed" in result and "rtol" in result, result
        else:
            assert abs(result["energy_balance_error"]) <= 1e-6 * result["external_work"]


def test_adaptive_solver_error_stays_at_its_tolerance_under_load(lattice):
    """The default tolerance keeps the peak within 1e-5 of a tight run even at 100x load."""
    for load in (10, 100):
        parameters = {"F_total": 1200.0 * load}
        default = lattice.simulate(REVERSED, horizon=1.0, parameters=parameters)
        tight = lattice.simulate(REVERSED, horizon=1.0, parameters={**parameters, "rtol": 1e-12, "atol": 1e-14})
        for name in ("peak_backplate_force", "peak_backplate_force_continuous"):
            assert default[name] == pytest.approx(tight[name], rel=1e-5), (load, name)


# ---------------------------------------------------------------------------- the importer's side
def test_each_instance_gets_its_own_error_message(fmu_path):
    """Found here: fmpy's logger proxy keeps one Python logger per process, so with two LatticeFMU instances
    alive the first one's errors arrive in the second one's log and it reports 'the FMU logged no reason'."""
    with LatticeFMU(fmu_path, instance_name="first") as first, LatticeFMU(fmu_path, instance_name="second"):
        with pytest.raises(SimulationError, match="permutation of 1..11"):
            first.simulate((1, 1, 3, 4, 5, 6, 7, 8, 9, 10, 11), horizon=0.1)


def test_a_lattice_pressed_against_the_plate_from_the_start_is_not_called_diverged(fmu_path):
    """Found by these tests: with a negative gap the start state holds potential energy, which the
    divergence check must count as energy put in."""
    with LatticeFMU(fmu_path) as fmu:
        result = fmu.simulate(PUBLISHED_BEST, horizon=0.5, parameters={"backplate_gap": -0.05})
    assert math.isfinite(result["peak_backplate_force"]) and result["peak_backplate_force"] > 0
