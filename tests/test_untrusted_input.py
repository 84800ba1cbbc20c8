"""The FMU against untrusted input, through fmpy, FMI 2 and FMI 3 alike.

- Serialised FMU states: truncated, extended, bit-flipped and crafted ones (a changed size or parameter
  with the checksum recomputed, as an attacker would) are refused with an error and a logged reason, and
  never change the instance: it continues to the same peak as if they had never been offered.
- Refused doStep arguments (negative, NaN or infinite step, wrong time, past the stop time, too much work)
  leave the instance usable: they are the importer's mistakes, not the model's (common/instance.h).
- Bounded work: settings that would make one doStep run for ever are refused, naming the cap. Every such
  run goes through a worker process with a timeout, so a regression shows as a failure, not a hung suite.
"""

from __future__ import annotations

import math
import random
import struct
import subprocess
import sys
import textwrap
import zlib

import pytest
from fmpy.fmi1 import FMICallException

from isolated import IsolatedFMU
from conftest import ROOT
from fmu_src.published import PUBLISHED_PEAKS, STUDY_BEST_ORDER as PUBLISHED_BEST
from orchestrator.simulation import LatticeFMU
from test_fmi3 import Instance as Fmi3Instance

pytestmark = pytest.mark.quick  # a first check: python -m pytest -m quick

ROWS = COLS = 11
N_STATE = 4 * ROWS * COLS + 3  # LATTICE_STATE_SIZE: positions, velocities, three energy integrals
HALF_ROWS = (ROWS + 1) // 2  # the upper half of the mirror-symmetric lattice, middle row included
HALF_STATE = 2 * HALF_ROWS * COLS + 3  # its ux and vx (a load along x leaves uy and vy at 0) and the integrals
HEADER_SIZE, CHECKSUM_AT = 64, 8  # common/instance.c: SavedHeader, and the CRC-32 of the bytes after it
HANG_TIMEOUT = 20.0  # seconds: the bound for a call that used to run for ever


class Fmi2:
    """LatticeFMU's instance, driven call by call (its messages are what the FMU logged)."""

    def __init__(self, fmu_path):
        self.fmu = LatticeFMU(fmu_path)
        self.slave, self.messages = self.fmu._slave, self.fmu._messages

    def start(self, order=PUBLISHED_BEST, stop=2.0):
        self.slave.reset()
        self.slave.setupExperiment(startTime=0.0, stopTime=stop)
        self.slave.enterInitializationMode()
        self.slave.setInteger([self.fmu.value_reference(f"material[{j}]") for j in range(1, COLS + 1)], list(order))
        self.slave.exitInitializationMode()

    def peak(self):
        return self.slave.getReal([self.fmu.value_reference("peak_backplate_force_continuous")])[0]

    def get_state(self):
        return self.slave.getFMUstate()

    def set_state(self, state):
        self.slave.setFMUstate(state)

    def free_state(self, state):
        self.slave.freeFMUstate(state)

    def serialize(self, state):
        return bytes(self.slave.serializeFMUstate(state))

    def deserialize(self, data):
        return self.slave.deSerializeFMUstate(data)

    def close(self):
        self.fmu.close()


class Fmi3(Fmi2):
    def __init__(self, fmu3_path):
        self.instance = Fmi3Instance(fmu3_path)
        self.slave, self.messages = self.instance.slave, self.instance.messages

    def start(self, order=PUBLISHED_BEST, stop=2.0):
        self.slave.reset()
        self.instance.start(order, stop)

    def peak(self):
        return self.slave.getFloat64([self.instance.vr("peak_backplate_force_continuous")])[0]

    def get_state(self):
        return self.slave.getFMUState()

    def set_state(self, state):
        self.slave.setFMUState(state)

    def free_state(self, state):
        self.slave.freeFMUState(state)

    def serialize(self, state):
        return bytes(self.slave.serializeFMUState(state))

    def deserialize(self, data):
        return self.slave.deserializeFMUState(data)

    def close(self):
        self.instance.close()


@pytest.fixture(params=["fmi2", "fmi3"])
def fmu(request):
    driver = (
        Fmi2(request.getfixturevalue("fmu_path"))
        if request.param == "fmi2"
        else Fmi3(request.getfixturevalue("fmu3_path"))
    )
    yield driver
    driver.close()


@pytest.fixture()
def saved(fmu):
    """A state 0.2 s into the run, serialised, and the peak a straight run reaches at 0.5 s from there."""
    fmu.start()
    fmu.slave.doStep(0.0, 0.2)
    state = fmu.get_state()
    data = fmu.serialize(state)
    fmu.free_state(state)
    fmu.slave.doStep(0.2, 0.3)
    return data, fmu.peak()


def refused(fmu, data, *reasons):
    """deserialising `data` fails with one of `reasons` logged."""
    fmu.messages.clear()
    with pytest.raises(FMICallException):
        fmu.deserialize(data)
    assert any(reason in message for message in fmu.messages for reason in reasons), fmu.messages


def continues_to(fmu, data, peak):
    """The intact state, restored, still continues to the straight run's peak: nothing refused changed it."""
    state = fmu.deserialize(data)
    fmu.set_state(state)
    fmu.free_state(state)
    fmu.slave.doStep(0.2, 0.3)
    assert fmu.peak() == peak


def with_checksum(data: bytearray) -> bytes:
    """Recomputes the CRC-32 over everything after it: what a crafted state would do to pass the check."""
    data[CHECKSUM_AT : CHECKSUM_AT + 4] = struct.pack("<I", zlib.crc32(bytes(data[CHECKSUM_AT + 4 :])))
    return bytes(data)


def test_every_state_of_a_run_is_accepted(fmu):
    """The checks refuse nothing the FMU itself saves: before initialisation, and at every communication point
    of a run with an awkward step (the solver ahead of the communication time, samples pending)."""
    fmu.slave.reset()
    states = [fmu.get_state()]
    fmu.start(stop=1.0)
    states.append(fmu.get_state())
    time, step = 0.0, 0.0173
    while time + step <= 1.0:
        fmu.slave.doStep(time, step)
        time += step
        states.append(fmu.get_state())
    for state in states:
        restored = fmu.deserialize(fmu.serialize(state))
        fmu.set_state(restored)
        fmu.free_state(restored)
        fmu.free_state(state)
    assert len(states) == 59


def test_truncated_and_extended_states_are_refused(fmu, saved):
    data, peak = saved
    for damaged in (data[:-1], data[:HEADER_SIZE], data[: len(data) // 2], data + b"\0"):
        refused(fmu, damaged, f"the serialised state has {len(damaged)} bytes")
    continues_to(fmu, data, peak)


def test_every_bit_flip_is_refused(fmu, saved):
    """Every header byte and 300 random bytes of the model, each with one bit flipped: CRC-32 catches any
    single-bit error; the header's own fields are checked before it."""
    data, peak = saved
    rng = random.Random(14)
    positions = list(range(HEADER_SIZE)) + rng.sample(range(HEADER_SIZE, len(data)), 300)
    for position in positions:
        flipped = bytearray(data)
        flipped[position] ^= 1 << rng.randrange(8)
        refused(fmu, bytes(flipped), "checksum", "magic number", "format version", "size fields", "another build")
    continues_to(fmu, data, peak)


def test_a_state_with_a_changed_size_and_a_valid_checksum_is_refused(fmu, saved):
    """The crash of the issue: the solver's state size changed. Here the checksum is recomputed too, so only
    the size checks stand between the crafted state and the heap."""
    data, peak = saved
    # Solver: method (DOP853), n, n_second_order; the armour scene is mirror-symmetric and loaded along x, so by
    # default (use_symmetry) the solver integrates ux and vx of the upper half, HALF_ROWS rows of it
    solver_sizes = struct.pack("<iii", 0, HALF_STATE, HALF_ROWS * COLS)
    assert data.count(solver_sizes) == 1
    at = data.index(solver_sizes)
    for n, n_second_order in (
        (10**6, HALF_ROWS * COLS),
        (HALF_STATE, 10**6),
        (-1, HALF_ROWS * COLS),
        (4, 2),
        (N_STATE, 2 * ROWS * COLS),
    ):  # the last: the whole lattice's, not the reduced one's
        crafted = bytearray(data)
        crafted[at + 4 : at + 12] = struct.pack("<ii", n, n_second_order)
        refused(fmu, with_checksum(crafted), "its sizes")
    crafted = bytearray(data)
    crafted[16:24] = struct.pack("<Q", len(data) * 2)  # the header's own size field
    refused(fmu, with_checksum(crafted), "size fields")
    continues_to(fmu, data, peak)


def test_crafted_fields_with_a_valid_checksum_are_refused(fmu, saved):
    data, peak = saved
    order = struct.pack(f"<{COLS}i", *PUBLISHED_BEST)
    assert data.count(order) == 1
    at = data.index(order)
    crafted = bytearray(data)
    crafted[at : at + 4] = struct.pack("<i", 1000)  # material[1] = 1000 would index far outside the table
    refused(fmu, with_checksum(crafted), "material")
    crafted = bytearray(data)
    crafted[12:16] = struct.pack("<i", 99)  # the FMI state machine's state: used as a shift
    refused(fmu, with_checksum(crafted), "instance fields")
    crafted = bytearray(data)
    crafted[32:40] = bytes(8)  # the build's hash: a state of another build of the FMU
    refused(fmu, with_checksum(crafted), "another build")
    continues_to(fmu, data, peak)


def test_a_state_of_the_other_fmi_version_is_refused(fmu_path, fmu3_path):
    fmi2, fmi3 = Fmi2(fmu_path), Fmi3(fmu3_path)
    try:
        fmi2.start()
        fmi3.start()
        states = fmi2.get_state(), fmi3.get_state()
        data2, data3 = fmi2.serialize(states[0]), fmi3.serialize(states[1])
        refused(fmi2, data3, "magic number")
        refused(fmi3, data2, "magic number")
    finally:
        fmi2.close()
        fmi3.close()


@pytest.mark.parametrize(
    "point, step, reason",
    [
        (0.0, -0.1, "communicationStepSize = -0.1 is not allowed"),
        (0.0, math.nan, "communicationStepSize = nan is not allowed"),
        (0.0, math.inf, "communicationStepSize = inf is not allowed"),
        (0.5, 0.1, "does not match the FMU's time"),
        (math.nan, 0.1, "does not match the FMU's time"),
        (0.0, 2.1e6, "beyond the stop time"),
        (0.0, 1.9e6, "samples per doStep"),
    ],
)
def test_a_refused_do_step_argument_leaves_the_instance_usable(fmu, point, step, reason):
    """The importer's mistake is refused with its reason, and the next right doStep goes on as if it had never
    been made: the same peak as a run without it."""
    fmu.start(stop=2e6)
    fmu.slave.doStep(0.0, 0.2)
    clean = fmu.get_state()
    fmu.slave.doStep(0.2, 0.3)
    expected = fmu.peak()
    fmu.set_state(clean)
    fmu.free_state(clean)
    fmu.messages.clear()
    with pytest.raises(FMICallException):
        fmu.slave.doStep(0.2 + point, step)
    assert any(reason in message for message in fmu.messages), fmu.messages
    fmu.slave.doStep(0.2, 0.3)
    assert fmu.peak() == expected


@pytest.fixture(scope="module")
def isolated(fmu_path):
    with IsolatedFMU(fmu_path, timeout=HANG_TIMEOUT) as runner:
        yield runner


@pytest.mark.parametrize(
    "parameters, reasons",
    [
        ({"peak_sample_interval": 1e-300}, ("samples per doStep", "peak_sample_interval = 1e-300")),
        ({"solver": 1, "fixed_step": 1e-12}, ("solver steps per doStep", "fixed_step = 1e-12")),
        ({"solver": 2, "fixed_step": 1e-12}, ("solver steps per doStep", "fixed_step = 1e-12")),
    ],
)
def test_settings_that_would_never_finish_are_refused_naming_the_cap(isolated, parameters, reasons):
    status, message, _ = isolated.run(PUBLISHED_BEST, 1.0, parameters)
    assert status == "error", (status, message)
    assert all(reason in message for reason in reasons), message


def test_the_published_run_is_well_inside_the_caps(isolated):
    status, result, _ = isolated.run(PUBLISHED_BEST, 8.0, {})
    assert status == "ok", result
    assert result["peak_backplate_force"] == pytest.approx(PUBLISHED_PEAKS[PUBLISHED_BEST], rel=1e-6)


DO_STEP_WITHOUT_STOP_TIME = """
import sys
sys.path.insert(0, {tests!r})
from test_untrusted_input import Fmi2, Fmi3
fmu = Fmi{version}({path!r})
fmu.start(stop=None)
fmu.slave.doStep(0.0, 0.1)
for step in (float("inf"), 1e300):
    try:
        fmu.slave.doStep(0.1, step)
    except Exception:
        pass
    else:
        raise SystemExit("doStep of %g was accepted" % step)
print(fmu.messages[-2])
print(fmu.messages[-1])
fmu.slave.doStep(0.1, 0.3)
print(fmu.peak())
fmu.close()
"""


@pytest.mark.parametrize("version", [2, 3])
def test_do_step_to_infinity_without_a_stop_time_returns_an_error(fmu_path, fmu3_path, version):
    script = DO_STEP_WITHOUT_STOP_TIME.format(
        tests=str(ROOT / "tests"), version=version, path=str(fmu_path if version == 2 else fmu3_path)
    )
    result = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(script)], capture_output=True, text=True, timeout=HANG_TIMEOUT, cwd=ROOT
    )
    assert result.returncode == 0, result.stderr
    infinite, huge, peak = result.stdout.splitlines()
    assert "communicationStepSize = inf is not allowed" in infinite
    assert "samples per doStep" in huge
    assert float(peak) > 1000  # the instance stepped on to 0.4 s, past the peak, after both refusals


ADAPTIVE_STEPS_CAP = """
import sys
sys.path.insert(0, {tests!r})
from test_untrusted_input import Fmi2
fmu = Fmi2({path!r})
fmu.slave.setupExperiment(startTime=0.0, stopTime=None)
fmu.slave.enterInitializationMode()
fmu.slave.setReal([fmu.fmu.value_reference("peak_sample_interval")], [1e6])  # few samples: only steps count
fmu.slave.exitInitializationMode()
try:
    fmu.slave.doStep(0.0, 1e9)
except Exception:
    print(fmu.messages[-1])
else:
    raise SystemExit("a doStep of 1e9 s was accepted")
fmu.start()
fmu.slave.doStep(0.0, 0.4)
print(fmu.peak())
fmu.close()
"""


@pytest.mark.slow
def test_the_adaptive_solver_stops_at_the_cap_of_steps_per_do_step(fmu_path):
    """Without a stop time and with a long peak_sample_interval, nothing but the steps cap bounds a doStep of
    1e9 s: it fails (a model failure: the instance needs a reset) after 200000 steps, about 7 s of CPU."""
    script = ADAPTIVE_STEPS_CAP.format(tests=str(ROOT / "tests"), path=str(fmu_path))
    result = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(script)],
        capture_output=True,
        text=True,
        timeout=3 * HANG_TIMEOUT,
        cwd=ROOT,
    )
    assert result.returncode == 0, result.stderr
    message, peak = result.stdout.splitlines()
    assert "reached the cap of 200000 solver steps per doStep" in message
    assert float(peak) > 1000  # after fmi2Reset the instance runs again


@pytest.mark.parametrize(
    "order, parameters, name",
    [
        ((2**32 + 1,) + PUBLISHED_BEST[1:], {}, "order"),  # wrapped, it would be material 1
        (PUBLISHED_BEST, {"diagonal_rule": 2**32}, "diagonal_rule"),  # wrapped, it would be 0
        (PUBLISHED_BEST, {"solver": -(2**31) - 1}, "solver"),
        (PUBLISHED_BEST, {"solver": 1.5}, "solver"),
    ],
)
def test_integers_that_do_not_fit_32_bits_are_refused_not_wrapped(lattice, order, parameters, name):
    with pytest.raises(ValueError, match=rf"^{name} = .* is not allowed: FMI integers are whole numbers"):
        lattice.simulate(order, horizon=0.05, parameters=parameters)
    assert lattice.simulate(PUBLISHED_BEST, horizon=0.05)["external_work"] > 0
