"""The lattice's ports (docs/model.md section 11): load_mode, the front port (F_front in, x_front and v_front out),
the back port (x_back, v_back in: a moving backplate), their <ModelStructure> dependencies and the energy balance
with ports, through FMI 2 and FMI 3 Co-Simulation and fmpy's Model Exchange.
"""

from __future__ import annotations

import math
import shutil
import xml.etree.ElementTree as ET
import zipfile

import numpy as np
import pytest
from fmpy import extract, read_model_description, simulate_fmu
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave
from fmpy.fmi3 import FMU3Slave

from fmu_src.variables import enumeration_values

STEP = 0.01
PULSE_FORCE, PULSE_END = 1200.0, 0.15  # the study's pulse (docs/model.md section 4)
MODES = enumeration_values("load_mode")
PULSE, INPUT, PROJECTILE = MODES["pulse"], MODES["input"], MODES["projectile"]
OUTPUTS = (
    "peak_backplate_force",
    "peak_backplate_force_continuous",
    "external_work",
    "energy_balance_error",
    "x_front",
    "v_front",
    "backplate_force",
    "potential_energy",
    "kinetic_energy",
    "contact_force",
    "projectile_position",
    "projectile_velocity",
)
# The peak comes near 0.3 s, and the lattice has left the plate for good before 1 s (README, horizon study).
HORIZON = 1.0


def pulse_force(t: float) -> float:
    """The pulse as an importer holds it over steps of STEP starting at t (on for 0 <= t <= t_active)."""
    return PULSE_FORCE if t < PULSE_END - 0.5 * STEP else 0.0


def moving_backplate(t: float) -> tuple[float, float]:
    """A backplate that oscillates along x by 2 mm at 1.5 Hz: (x_back, v_back)."""
    omega, amplitude = 2.0 * math.pi * 1.5, 2e-3
    return amplitude * math.sin(omega * t), amplitude * omega * math.cos(omega * t)


class Slave:
    """One Co-Simulation instance (FMI 2 or 3) with its variables by name."""

    def __init__(self, path, horizon=HORIZON, load_mode=PULSE, use_symmetry=1, solver=0):
        self.description = read_model_description(str(path))
        self.fmi3 = self.description.fmiVersion.startswith("3")
        self.vr = {v.name: v.valueReference for v in self.description.modelVariables}
        self.unzip_dir = extract(str(path))
        kind = FMU3Slave if self.fmi3 else FMU2Slave
        self.slave = kind(
            guid=self.description.guid,
            unzipDirectory=self.unzip_dir,
            modelIdentifier=self.description.coSimulation.modelIdentifier,
            instanceName="ports",
        )
        self.slave.instantiate()
        if self.fmi3:
            self.slave.enterInitializationMode(startTime=0.0, stopTime=horizon)
            self.slave.setInt32([self.vr["use_symmetry"]], [use_symmetry])
            self.slave.setInt64([self.vr["load_mode"], self.vr["solver"]], [load_mode, solver])  # Enumerations
        else:
            self.slave.setupExperiment(startTime=0.0, stopTime=horizon)
            self.slave.enterInitializationMode()
            self.slave.setInteger(
                [self.vr["load_mode"], self.vr["use_symmetry"], self.vr["solver"]], [load_mode, use_symmetry, solver]
            )
        self.slave.exitInitializationMode()

    def set(self, **values):
        names = list(values)
        refs = [self.vr[name] for name in names]
        (self.slave.setFloat64 if self.fmi3 else self.slave.setReal)(refs, [values[n] for n in names])

    def get(self, *names) -> dict[str, float]:
        values = (self.slave.getFloat64 if self.fmi3 else self.slave.getReal)([self.vr[n] for n in names])
        return dict(zip(names, values))

    def close(self):
        self.slave.terminate()
        self.slave.freeInstance()
        shutil.rmtree(self.unzip_dir, ignore_errors=True)


def run(
    path, load_mode=PULSE, front=None, back=None, horizon=HORIZON, use_symmetry=1, solver=0, step=STEP
) -> dict[str, float]:
    """A run over `horizon` in steps of `step`, the inputs set before each step from front(t) and back(t)."""
    instance = Slave(path, horizon, load_mode, use_symmetry, solver)
    try:
        for i in range(round(horizon / step)):
            t = i * step
            if front is not None:
                instance.set(F_front=front(t))
            if back is not None:
                x_back, v_back = back(t)
                instance.set(x_back=x_back, v_back=v_back)
            instance.slave.doStep(t, step)
        return instance.get(*OUTPUTS)
    finally:
        instance.close()


@pytest.fixture(params=[2, 3], ids=["fmi2", "fmi3"])
def co_simulation_fmu(request, fmu_path, fmu3_path):
    return fmu_path if request.param == 2 else fmu3_path


def test_input_mode_driven_with_the_pulse_gives_the_pulse_peak(co_simulation_fmu):
    pulse = run(co_simulation_fmu)
    driven = run(co_simulation_fmu, INPUT, front=pulse_force)
    assert driven["peak_backplate_force"] == pytest.approx(pulse["peak_backplate_force"], rel=1e-7)
    assert driven["peak_backplate_force_continuous"] == pytest.approx(
        pulse["peak_backplate_force_continuous"], rel=1e-7
    )
    assert driven["external_work"] == pytest.approx(pulse["external_work"], rel=1e-7)
    assert abs(driven["energy_balance_error"]) <= 1e-6 * driven["external_work"]


def test_inputs_set_to_what_they_are_leave_the_pulse_bit_for_bit(co_simulation_fmu):
    """A master that sets every input at every step, unchanged (a resting hull, no force), changes nothing."""
    pulse = run(co_simulation_fmu)
    assert run(co_simulation_fmu, front=lambda t: 0.0, back=lambda t: (0.0, 0.0)) == pulse


def test_input_mode_without_a_force_leaves_the_lattice_at_rest(fmu_path):
    at_rest = run(fmu_path, INPUT, front=lambda t: 0.0)
    assert at_rest["peak_backplate_force"] == 0.0
    assert at_rest["external_work"] == 0.0
    assert at_rest["x_front"] == 0.0 and at_rest["v_front"] == 0.0


def test_the_mirror_symmetric_solver_keeps_the_ports_exact(fmu_path):
    whole = run(fmu_path, INPUT, front=pulse_force, back=moving_backplate, use_symmetry=0)
    half = run(fmu_path, INPUT, front=pulse_force, back=moving_backplate, use_symmetry=1)
    for name in OUTPUTS:
        assert half[name] == pytest.approx(whole[name], rel=1e-8, abs=1e-9), name


@pytest.mark.parametrize("load_mode", [PULSE, INPUT], ids=["pulse", "input"])
def test_the_energy_balance_closes_with_a_moving_backplate(co_simulation_fmu, load_mode):
    front = pulse_force if load_mode == INPUT else None
    still = run(co_simulation_fmu, load_mode, front=front)
    moving = run(co_simulation_fmu, load_mode, front=front, back=moving_backplate)
    # the backplate's motion reaches the lattice: it is pushed otherwise than by the rigid wall
    assert moving["peak_backplate_force"] != pytest.approx(still["peak_backplate_force"], rel=1e-3)
    assert abs(moving["energy_balance_error"]) <= 1e-6 * moving["external_work"]


def test_a_backplate_set_off_its_path_does_work_that_the_balance_counts(fmu_path):
    """x_back jumps by 1 mm at each step (the importer's backplate off the path v_back gives): the jumps' work on
    the lattice goes into external_work."""
    jumping = run(fmu_path, back=lambda t: (1e-3 * (round(t / STEP) % 2), 0.0))
    assert abs(jumping["energy_balance_error"]) <= 1e-6 * jumping["external_work"]


def test_the_front_port_is_the_weighted_face(fmu_path):
    """x_front, v_front: the load's weights (1/2 at the edge rows, normalised to 1) over column 1's masses."""
    instance = Slave(fmu_path, load_mode=INPUT)
    try:
        for i in range(10):
            instance.set(F_front=PULSE_FORCE)
            instance.slave.doStep(i * STEP, STEP)
        rows = 11
        weights = np.array([0.5] + [1.0] * (rows - 2) + [0.5]) / (rows - 1)
        ux = instance.get(*(f"ux[{i},1]" for i in range(1, rows + 1)))
        vx = instance.get(*(f"vx[{i},1]" for i in range(1, rows + 1)))
        port = instance.get("x_front", "v_front")
        assert port["x_front"] == pytest.approx(float(weights @ np.array(list(ux.values()))), rel=1e-12)
        assert port["v_front"] == pytest.approx(float(weights @ np.array(list(vx.values()))), rel=1e-12)
        assert port["x_front"] > 0.0 and port["v_front"] > 0.0  # pushed along +x
    finally:
        instance.close()


def test_the_backplate_force_follows_x_back_at_once(fmu_path):
    """backplate_force depends directly on x_back (its declared dependency): set, it answers without a step."""
    instance = Slave(fmu_path)
    try:
        for i in range(30):  # into contact (the peak comes near 0.3 s)
            instance.slave.doStep(i * STEP, STEP)
        touching = instance.get("backplate_force")["backplate_force"]
        assert touching > 0.0
        instance.set(x_back=-1e-3)  # the plate 1 mm nearer: each mass in contact presses 1 mm further
        nearer = instance.get("backplate_force")["backplate_force"]
        assert nearer > touching
        instance.set(x_back=1.0)  # far away: nothing touches it
        assert instance.get("backplate_force")["backplate_force"] == 0.0
    finally:
        instance.close()


def test_inputs_are_refused_out_of_range_and_outputs_cannot_be_set(fmu_path):
    instance = Slave(fmu_path)
    try:
        with pytest.raises(FMICallException):
            instance.set(F_front=math.inf)
        with pytest.raises(FMICallException):
            instance.set(x_front=0.0)
    finally:
        instance.close()


def _structure(path) -> ET.Element:
    with zipfile.ZipFile(path) as archive:
        return ET.fromstring(archive.read("modelDescription.xml"))


def test_every_output_declares_its_input_dependencies(fmu_path, fmu3_path):
    """No output without a dependencies attribute (an importer takes it to depend on every input: a false
    algebraic loop); the backplate force and what is computed from it now depend on the back port only."""
    root = _structure(fmu_path)
    variables = root.find("ModelVariables").findall("ScalarVariable")
    index = {v.get("name"): str(i) for i, v in enumerate(variables, start=1)}
    inputs = {v.get("name") for v in variables if v.get("causality") == "input"}
    assert inputs == {"F_front", "x_back", "v_back"}
    outputs = {
        variables[int(u.get("index")) - 1].get("name"): u.get("dependencies")
        for u in root.find("ModelStructure").find("Outputs")
    }
    assert all(dependencies is not None for dependencies in outputs.values())
    assert outputs["x_front"] == outputs["v_front"] == outputs["kinetic_energy"] == ""
    assert outputs["backplate_force"] == f"{index['x_back']} {index['v_back']}"
    assert outputs["potential_energy"] == outputs["backplate_force"]
    root3 = _structure(fmu3_path)
    reference = {v.get("name"): v.get("valueReference") for v in root3.find("ModelVariables")}
    outputs3 = {
        u.get("valueReference"): u.get("dependencies") for u in root3.find("ModelStructure") if u.tag == "Output"
    }
    assert all(dependencies is not None for dependencies in outputs3.values())
    assert outputs3[reference["x_front"]] == ""
    assert outputs3[reference["backplate_force"]] == f"{reference['x_back']} {reference['v_back']}"


def test_output_derivatives_and_input_derivatives(fmu_path):
    instance = Slave(fmu_path, load_mode=INPUT)
    try:
        instance.set(F_front=PULSE_FORCE)
        for i in range(5):
            instance.slave.doStep(i * STEP, STEP)
        vr = instance.vr
        (speed,) = instance.slave.getRealOutputDerivatives([vr["x_front"]], [1])
        assert speed == instance.get("v_front")["v_front"]
        (acceleration,) = instance.slave.getRealOutputDerivatives([vr["v_front"]], [1])
        before = instance.get("v_front")["v_front"]
        instance.slave.doStep(5 * STEP, 1e-6)
        after = instance.get("v_front")["v_front"]
        assert (after - before) / 1e-6 == pytest.approx(acceleration, rel=1e-3)
        with pytest.raises(FMICallException):
            instance.slave.getRealOutputDerivatives([vr["kinetic_energy"]], [1])
        with pytest.raises(FMICallException):
            instance.slave.getRealOutputDerivatives([vr["x_front"]], [2])
        with pytest.raises(FMICallException):
            instance.slave.setRealInputDerivatives([vr["F_front"]], [2], [1.0])
        with pytest.raises(FMICallException):
            instance.slave.setRealInputDerivatives([vr["x_front"]], [1], [1.0])
    finally:
        instance.close()


def test_model_exchange_takes_the_inputs_the_importer_sets(fmu_path):
    """fmpy's CVode drives F_front with the pulse (a step signal at t_active) and gives the pulse's peak."""
    signal = np.array(
        [(0.0, PULSE_FORCE), (PULSE_END, PULSE_FORCE), (PULSE_END, 0.0), (HORIZON, 0.0)],
        dtype=[("time", np.float64), ("F_front", np.float64)],
    )
    common = {
        "fmi_type": "ModelExchange",
        "solver": "CVode",
        "relative_tolerance": 1e-9,
        "output_interval": STEP,
        "stop_time": HORIZON,
        "output": ["peak_backplate_force", "external_work", "energy_balance_error"],
    }
    pulse = simulate_fmu(str(fmu_path), **common)
    driven = simulate_fmu(str(fmu_path), start_values={"load_mode": INPUT}, input=signal, **common)
    assert driven["peak_backplate_force"][-1] == pytest.approx(pulse["peak_backplate_force"][-1], rel=1e-6)
    assert abs(driven["energy_balance_error"][-1]) <= 1e-6 * driven["external_work"][-1]


def _start(path, name) -> float:
    return float(next(v.start for v in read_model_description(str(path)).modelVariables if v.name == name))


def test_the_default_projectile_carries_the_pulses_momentum(fmu_path):
    momentum = _start(fmu_path, "projectile_mass") * _start(fmu_path, "projectile_speed")
    assert momentum == pytest.approx(_start(fmu_path, "F_total") * _start(fmu_path, "t_active"), rel=1e-12)


def _impact_energy(path) -> float:
    return 0.5 * _start(path, "projectile_mass") * _start(path, "projectile_speed") ** 2


def test_projectile_mode_strikes_rebounds_and_closes_its_energy_balance(co_simulation_fmu):
    struck = run(co_simulation_fmu, PROJECTILE)
    # the body pushed the lattice into the backplate, which threw it back: it leaves against +x
    assert struck["peak_backplate_force"] > 0.0
    assert struck["projectile_velocity"] < 0.0 and struck["contact_force"] == 0.0
    # the balance holds the body's kinetic energy, the contact's potential and its dissipation
    assert abs(struck["energy_balance_error"]) <= 1e-6 * _impact_energy(co_simulation_fmu)
    assert struck["external_work"] == 0.0  # the contact's work stays inside the model; the wall does not move
    # the other modes leave the body at rest and no contact force
    pulse = run(co_simulation_fmu)
    assert pulse["projectile_velocity"] == pulse["projectile_position"] == pulse["contact_force"] == 0.0


def test_projectile_mode_the_contact_pushes_while_the_body_overlaps_the_face(fmu_path):
    instance = Slave(fmu_path, load_mode=PROJECTILE)
    try:
        instance.slave.doStep(0.0, 0.02)
        early = instance.get("contact_force", "projectile_position", "x_front", "projectile_velocity", "v_front")
        assert early["projectile_position"] > early["x_front"] and early["contact_force"] > 0.0
        assert early["projectile_velocity"] < _start(fmu_path, "projectile_speed")  # slowed by the contact
        assert early["v_front"] > 0.0  # the face is pushed along +x
    finally:
        instance.close()


@pytest.mark.parametrize(
    "variant", [{"use_symmetry": 0}, {"solver": 5}, {"step": HORIZON}], ids=["whole-lattice", "rkn5", "one-step"]
)
def test_projectile_mode_agrees_across_solvers_layouts_and_communication(fmu_path, variant):
    """The quarter (here half) lattice with the body, Fine's Nystrom pair (which takes the body as second order)
    and one doStep over the horizon agree with the default run of 0.01 s steps."""
    default = run(fmu_path, PROJECTILE)
    other = run(fmu_path, PROJECTILE, **variant)
    for name in ("peak_backplate_force", "peak_backplate_force_continuous", "projectile_velocity", "x_front"):
        assert other[name] == pytest.approx(default[name], rel=1e-6), name
    assert abs(other["energy_balance_error"]) <= 1e-6 * _impact_energy(fmu_path)


def test_projectile_mode_under_model_exchange(fmu_path):
    """fmpy's CVode integrates the body with the lattice and locates the contact's opening as an event."""
    names = ["peak_backplate_force", "projectile_velocity", "energy_balance_error"]
    result = simulate_fmu(
        str(fmu_path),
        fmi_type="ModelExchange",
        solver="CVode",
        relative_tolerance=1e-9,
        output_interval=STEP,
        stop_time=HORIZON,
        start_values={"load_mode": PROJECTILE},
        output=names,
    )
    co_simulation = run(fmu_path, PROJECTILE)
    assert result["peak_backplate_force"][-1] == pytest.approx(co_simulation["peak_backplate_force"], rel=1e-6)
    assert result["projectile_velocity"][-1] == pytest.approx(co_simulation["projectile_velocity"], rel=1e-6)
    assert abs(result["energy_balance_error"][-1]) <= 1e-6 * _impact_energy(fmu_path)


def _coupled_projectile(path, step, interpolate, horizon=0.5) -> float:
    """peak_backplate_force of the lattice in input mode struck by a projectile the master integrates (Jacobi
    coupling over `step`): the body computes the contact force from x_front, v_front, the lattice takes it as
    F_front. With `interpolate`, the master hands the lattice dF/dt (fmi2SetRealInputDerivatives) and
    extrapolates the face with its output derivatives; else each holds the other's values over a step."""
    mass, speed = _start(path, "projectile_mass"), _start(path, "projectile_speed")
    stiffness, exponent = _start(path, "contact_stiffness"), _start(path, "contact_exponent")
    damping = _start(path, "contact_damping")
    substeps = 20

    def contact(overlap, rate):
        """The contact force and its partial derivatives by the overlap and by its rate (docs/model.md 11)."""
        if overlap <= 0.0:
            return 0.0, 0.0, 0.0
        force = stiffness * overlap**exponent * max(1.0 + damping * rate, 0.0)
        by_rate = stiffness * overlap**exponent * damping if force > 0.0 else 0.0
        return force, exponent * force / overlap, by_rate

    def body_over_step(position, velocity, x_face, v_face, a_face):
        """The body over one step by RK4 substeps; the face's x_front and v_front held over the step, or (with
        interpolation) extrapolated from them and v_front's derivative a_face."""

        def acceleration(tau, x, v):
            if interpolate:
                x_now, v_now = x_face + v_face * tau + 0.5 * a_face * tau * tau, v_face + a_face * tau
            else:
                x_now, v_now = x_face, v_face
            return -contact(x - x_now, v - v_now)[0] / mass

        h = step / substeps
        for j in range(substeps):
            tau = j * h
            k1x, k1v = velocity, acceleration(tau, position, velocity)
            k2x, k2v = (
                velocity + 0.5 * h * k1v,
                acceleration(tau + 0.5 * h, position + 0.5 * h * k1x, velocity + 0.5 * h * k1v),
            )
            k3x, k3v = (
                velocity + 0.5 * h * k2v,
                acceleration(tau + 0.5 * h, position + 0.5 * h * k2x, velocity + 0.5 * h * k2v),
            )
            k4x, k4v = velocity + h * k3v, acceleration(tau + h, position + h * k3x, velocity + h * k3v)
            position += h / 6.0 * (k1x + 2 * k2x + 2 * k3x + k4x)
            velocity += h / 6.0 * (k1v + 2 * k2v + 2 * k3v + k4v)
        return position, velocity

    instance = Slave(path, horizon, INPUT)
    vr = instance.vr
    position, velocity = 0.0, speed
    try:
        for i in range(round(horizon / step)):
            face = instance.get("x_front", "v_front")
            x_face, v_face = face["x_front"], face["v_front"]
            a_face = instance.slave.getRealOutputDerivatives([vr["v_front"]], [1])[0] if interpolate else 0.0
            force, by_overlap, by_rate = contact(position - x_face, velocity - v_face)
            instance.set(F_front=force)
            if interpolate:
                rate = by_overlap * (velocity - v_face) + by_rate * (-force / mass - a_face)
                instance.slave.setRealInputDerivatives([vr["F_front"]], [1], [rate])
            position, velocity = body_over_step(position, velocity, x_face, v_face, a_face)
            instance.slave.doStep(i * step, step)
        return instance.get("peak_backplate_force")["peak_backplate_force"]
    finally:
        instance.close()


def test_input_interpolation_reduces_a_coupled_loops_error_at_the_same_step(fmu_path):
    """The projectile integrated by the master and coupled through the front port against projectile mode (the
    same physics as one model): at the same communication step, the loop with input interpolation and output
    derivatives is nearer the one-model answer."""
    description = read_model_description(str(fmu_path))
    assert description.coSimulation.canInterpolateInputs and description.coSimulation.maxOutputDerivativeOrder == 1
    one_model = run(fmu_path, PROJECTILE, horizon=0.5)["peak_backplate_force"]
    step = 0.005
    held = abs(_coupled_projectile(fmu_path, step, interpolate=False) - one_model)
    interpolated = abs(_coupled_projectile(fmu_path, step, interpolate=True) - one_model)
    assert interpolated < 0.5 * held, (interpolated, held)


@pytest.fixture(scope="module")
def small_plate(tmp_path_factory):
    """A 5 x 5 x 5 plate under a centred 3 x 3 patch: mirror-symmetric in y and in z (a quarter carries it)."""
    from builder.build import build_fmu

    return build_fmu(
        output=tmp_path_factory.mktemp("plate") / "plate.fmu", rows=5, cols=5, depth=5, load_patch=3, werror=True
    )


@pytest.mark.parametrize("load_mode", [INPUT, PROJECTILE], ids=["input", "projectile"])
def test_the_quarter_plate_keeps_the_ports_and_the_projectile_exact(small_plate, load_mode):
    """The ports and the body act along +x on a symmetric patch: the quarter plate integrates the whole (to the
    solver's accuracy: its steps are not the whole plate's to the last bit)."""
    front = pulse_force if load_mode == INPUT else None
    quarter = run(small_plate, load_mode, front=front, use_symmetry=1)
    whole = run(small_plate, load_mode, front=front, use_symmetry=0)
    for name in (
        "peak_backplate_force",
        "peak_backplate_force_continuous",
        "x_front",
        "v_front",
        "projectile_velocity",
        "kinetic_energy",
    ):
        assert quarter[name] == pytest.approx(whole[name], rel=1e-6, abs=1e-12), name
    energy_in = quarter["external_work"] if load_mode == INPUT else _impact_energy(small_plate)
    assert abs(quarter["energy_balance_error"]) <= 1e-6 * energy_in


def test_an_fmu_state_holds_the_body_the_contact_and_the_ports(fmu_path):
    """Projectile mode's body and contact, and a moving backplate's anchor, go into an FMU state: a run restored
    to it goes on as the run it was taken from."""
    instance = Slave(fmu_path, load_mode=PROJECTILE)
    try:
        for i in range(10):
            instance.set(x_back=1e-4 * i, v_back=1e-2)
            instance.slave.doStep(i * STEP, STEP)
        state = instance.slave.getFMUstate()

        def go_on():
            for i in range(10, 50):
                instance.set(x_back=1e-4 * i, v_back=1e-2)
                instance.slave.doStep(i * STEP, STEP)
            return instance.get(*OUTPUTS)

        first = go_on()
        instance.slave.setFMUstate(state)
        assert go_on() == first
        instance.slave.freeFMUstate(state)
    finally:
        instance.close()
