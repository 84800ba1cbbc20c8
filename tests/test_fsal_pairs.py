"""The 5(4) pairs with a free dense output, Tsitouras' (solver = 3, "tsit5"), Dormand and Prince's (4, "dopri5")
and Fine's Runge-Kutta-Nystrom pair (5, "rkn5"): their peaks converge to DOP853's tight-tolerance ones as rtol
falls, the energy balance closes, and the dense output keeps the steps independent of the communication
points."""

import pytest

from fmu_src.published import PUBLISHED_PEAKS
from fmu_src.published import SEQUENTIAL_ORDER as PUBLISHED_SEQUENTIAL
from fmu_src.published import STUDY_BEST_ORDER as PUBLISHED_BEST
from orchestrator.simulation import SimulationError

PEAKS = ("peak_backplate_force", "peak_backplate_force_continuous")
OUTPUTS = PEAKS + (
    "peak_time",
    "last_contact_time",
    "backplate_force",
    "kinetic_energy",
    "potential_energy",
    "external_work",
    "dissipated_energy",
    "nonreciprocal_work",
    "energy_balance_error",
    "ux_right_edge",
    "uy_centre",
    "rhs_evaluations",
    "steps_accepted",
    "steps_rejected",
)


def tolerances(rtol):
    return {"rtol": rtol, "atol": rtol * 1e-2}


@pytest.fixture(scope="module")
def references(fmu_path):
    from orchestrator.simulation import LatticeFMU

    with LatticeFMU(fmu_path) as fmu:
        return {
            order: fmu.simulate(order, horizon=1.0, parameters={"rtol": 1e-12, "atol": 1e-14}, outputs=PEAKS)
            for order in (PUBLISHED_SEQUENTIAL, PUBLISHED_BEST)
        }


@pytest.mark.parametrize("solver", ["tsit5", "dopri5", "rkn5"])
@pytest.mark.parametrize("order", [PUBLISHED_SEQUENTIAL, PUBLISHED_BEST], ids=["sequential", "study_best"])
def test_peaks_converge_to_the_tight_dop853_ones(lattice, references, order, solver):
    errors = {}
    for rtol in (1e-4, 1e-6, 1e-8, 1e-10):
        result = lattice.simulate(order, horizon=1.0, parameters={"solver": solver, **tolerances(rtol)}, outputs=PEAKS)
        errors[rtol] = max(abs(result[name] / references[order][name] - 1.0) for name in PEAKS)
    assert errors[1e-4] < 3e-4 and errors[1e-6] < 3e-6 and errors[1e-8] < 3e-8 and errors[1e-10] < 1e-9, errors
    assert errors[1e-10] < errors[1e-8] < errors[1e-6] < errors[1e-4]


def test_published_peak_over_8_s(lattice):
    result = lattice.simulate(
        PUBLISHED_BEST,
        horizon=8.0,
        parameters={"solver": 3, **tolerances(1e-9)},
        outputs=PEAKS + ("energy_balance_error", "external_work"),
    )
    assert result["peak_backplate_force"] == pytest.approx(PUBLISHED_PEAKS[PUBLISHED_BEST], rel=1e-6)
    assert abs(result["energy_balance_error"]) <= 1e-7 * result["external_work"]


@pytest.mark.parametrize("solver", ["tsit5", "dopri5", "rkn5"])
def test_one_do_step_gives_the_outputs_of_many(lattice, solver):
    parameters = {"solver": solver, **tolerances(1e-5)}
    whole = lattice.simulate(PUBLISHED_SEQUENTIAL, horizon=1.0, parameters=parameters, outputs=OUTPUTS)
    stepped = lattice.simulate(
        PUBLISHED_SEQUENTIAL, horizon=1.0, parameters=parameters, outputs=OUTPUTS, communication_step=0.0173
    )
    assert whole == stepped


def test_fewer_right_hand_sides_than_dop853_at_the_search_tolerance(lattice, references):
    # over the two published orders and the reversed one (43 orders in bench/solver_work_precision.py: 0.73)
    counts, errors = {"dop853": 0, "tsit5": 0}, {}
    for order in (PUBLISHED_BEST, PUBLISHED_SEQUENTIAL, tuple(reversed(PUBLISHED_SEQUENTIAL))):
        for solver in ("dop853", "tsit5"):
            result = lattice.simulate(
                order,
                horizon=1.0,
                parameters={"solver": solver, **tolerances(1e-5)},
                outputs=PEAKS + ("rhs_evaluations",),
            )
            counts[solver] += result["rhs_evaluations"]
            if order in references:
                reference = references[order]["peak_backplate_force"]
                errors[solver, order] = abs(result["peak_backplate_force"] / reference - 1)
    assert counts["tsit5"] < 0.8 * counts["dop853"], counts
    assert max(error for (solver, _), error in errors.items() if solver == "tsit5") < 3e-5, errors


def test_an_unknown_solver_is_refused_by_name(lattice):
    with pytest.raises(SimulationError, match=r"solver = 6 .*4 \(adaptive DOPRI5\) or 5 \(adaptive Fine RKN 5\(4\)\)"):
        lattice.simulate(PUBLISHED_BEST, horizon=0.1, parameters={"solver": 6})


@pytest.mark.parametrize("use_symmetry", [0, 1])
def test_the_nystrom_pair_over_8_s_and_on_the_whole_lattice(lattice, use_symmetry):
    """Fine's pair on the published scene, on the reduced state and on the whole one (its position, velocity and
    integral parts are combined apart, so both layouts matter): the published peak and a closing balance."""
    result = lattice.simulate(
        PUBLISHED_BEST,
        horizon=8.0,
        parameters={"solver": "rkn5", "use_symmetry": use_symmetry, **tolerances(1e-9)},
        outputs=PEAKS + ("energy_balance_error", "external_work"),
    )
    assert result["peak_backplate_force"] == pytest.approx(PUBLISHED_PEAKS[PUBLISHED_BEST], rel=1e-6)
    assert abs(result["energy_balance_error"]) <= 1e-7 * result["external_work"]
