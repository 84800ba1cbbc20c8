"""The FMU built from today's sources gives the outputs recorded in tests/data/recorded_outputs.json.

Bit for bit where the bits are determined (the recording's machine, C library and libm variant: see
tests/recorded_outputs.py for why those and nothing else), else to the FMU's accuracy on the quantities that
do not depend on the step sequence's details (peaks and energy integrals). `python tests/recorded_outputs.py`
records them again, which a change that is meant to change the numbers does (and says so).
"""

from __future__ import annotations

import json
import math

import pytest

from recorded_outputs import (
    CO_SIMULATION_CASES,
    DATA,
    EXCHANGE_SETTING,
    MODEL_EXCHANGE_CASES,
    co_simulation_run,
    decode,
    fixed_step_exchange,
    libm_identity,
)

RECORD = json.loads(DATA.read_text())
SAME_BITS = RECORD["environment"] == libm_identity()
# Off the recording's libm the step sequence may differ by a step, so the outputs agree to the solvers' accuracy.
STABLE_OUTPUTS = (
    "peak_backplate_force",
    "peak_backplate_force_continuous",
    "external_work",
    "dissipated_energy",
    "nonreciprocal_work",
)
ACCURACY = 1e-5


def recorded(interface, setting, order, rule, symmetry=None) -> dict:
    for run in RECORD["runs"]:
        if (run["interface"], run["setting"], tuple(run["order"]), run["diagonal_rule"], run.get("use_symmetry")) == (
            interface,
            setting,
            tuple(order),
            rule,
            symmetry,
        ):
            return {name: decode(value) for name, value in run["outputs"].items()}
    raise LookupError(f"no recorded {interface} run {setting} {order} {rule} {symmetry}")


def check(outputs: dict, expected: dict) -> None:
    assert set(expected) <= set(outputs), set(expected) - set(outputs)
    if SAME_BITS:
        differing = {name: (outputs[name], value) for name, value in expected.items() if outputs[name] != value}
        assert not differing, differing
    else:
        for name in STABLE_OUTPUTS:
            assert math.isclose(outputs[name], expected[name], rel_tol=ACCURACY), (name, outputs[name], expected[name])


def _id(case) -> str:
    return "-".join(str(part if not isinstance(part, tuple) else "".join(f"{m:x}" for m in part)) for part in case)


@pytest.mark.parametrize("setting, order, rule, symmetry", CO_SIMULATION_CASES, ids=map(_id, CO_SIMULATION_CASES))
def test_co_simulation_gives_the_recorded_outputs(lattice, setting, order, rule, symmetry):
    check(
        co_simulation_run(lattice, setting, order, rule, symmetry),
        recorded("co-simulation", setting, order, rule, symmetry),
    )


@pytest.mark.parametrize("order, rule", MODEL_EXCHANGE_CASES, ids=map(_id, MODEL_EXCHANGE_CASES))
def test_model_exchange_gives_the_recorded_outputs(fmu_path, order, rule):
    check(fixed_step_exchange(fmu_path, order, rule), recorded("model-exchange", EXCHANGE_SETTING, order, rule))


def test_the_record_covers_every_case():
    assert len(RECORD["runs"]) == len(CO_SIMULATION_CASES) + len(MODEL_EXCHANGE_CASES)
