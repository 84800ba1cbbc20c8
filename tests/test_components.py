"""The projectile and hull FMUs (fmu_src/projectile/, fmu_src/hull/): model folders on the shared FMI glue, built
from their own variable tables (docs/model.md section 11)."""

from __future__ import annotations

import math
import struct
import zipfile
import zlib

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu
from fmpy.validation import validate_fmu
from scipy.linalg import expm

import build_fmu
from builder.component import build_component_fmu, model_dir
from builder.platforms import ALL_PLATFORMS, PLATFORMS, compiler_for, header_machine
from builder.sources import SourceTree
from fmu_src.component_table import COMPONENT_MODELS, component_table


@pytest.fixture(scope="module")
def component_fmus(tmp_path_factory):
    """{(model, FMI version): path} of every component FMU."""
    folder = tmp_path_factory.mktemp("components")
    return {
        (model, version): build_component_fmu(model, folder / f"{model}{version}.fmu", fmi_version=version, werror=True)
        for model in COMPONENT_MODELS
        for version in (2, 3)
    }


@pytest.mark.parametrize("version", [2, 3])
@pytest.mark.parametrize("model", COMPONENT_MODELS)
def test_every_component_fmu_is_valid(component_fmus, model, version):
    assert validate_fmu(str(component_fmus[model, version])) == []


@pytest.mark.parametrize("model", COMPONENT_MODELS)
def test_a_component_is_a_model_folder_of_the_shared_glue(component_fmus, model):
    """The model folder holds the model and its table; the FMU's glue is the lattice's, file for file, and the
    code every component shares (common/component_model.c) is in it, which the lattice's FMU is built without."""
    assert {p.name for p in model_dir(model).glob("*.[ch]")} == {"model.c", "model.h"}
    lattice = {path.name for path in SourceTree(fmi_version=2).files()}
    assert "component_model.c" not in lattice
    with zipfile.ZipFile(component_fmus[model, 2]) as archive:
        for path in SourceTree(model_dir(model), 2, component=True).files():
            if path.parent.name != model:
                assert path.name in lattice or path.parent.name == "common", path
                assert archive.read(f"sources/{path.name}") == path.read_bytes(), path.name
        assert "sources/component_model.c" in archive.namelist()


@pytest.mark.parametrize("version", [2, 3])
def test_the_model_structure_declares_each_output_s_dependencies(component_fmus, version):
    """contact_force depends directly on the face's inputs; the hull's outputs and the projectile's other
    outputs are states, depending on no input (no algebraic loop through either port)."""

    def depends(model):
        description = read_model_description(str(component_fmus[model, version]))
        return {unknown.variable.name: sorted(v.name for v in unknown.dependencies) for unknown in description.outputs}

    assert depends("projectile") == {
        "contact_force": ["v_front", "x_front"],
        "projectile_position": [],
        "projectile_velocity": [],
        "face_work": [],
    }
    assert depends("hull") == {"x": [], "v": [], "dissipated_energy": []}


def _projectile_on_a_rigid_face(fmu, step, stop_time=0.3, fmi_type="CoSimulation", **parameters):
    return simulate_fmu(
        str(fmu),
        stop_time=stop_time,
        step_size=step,
        output_interval=step,
        fmi_type=fmi_type,
        start_values=parameters,
        output=["contact_force", "projectile_velocity", "projectile_position"],
    )


@pytest.mark.parametrize("step", [1e-4, 1e-3, 1e-2])
def test_the_step_averaged_force_carries_the_projectile_s_momentum_exactly(component_fmus, step):
    """Over each step contact_force is the impulse divided by the step: summed over the steps it gives the
    momentum the projectile lost, to rounding, whatever the step."""
    table = component_table("projectile")
    mass, speed = table.variable("projectile_mass").start, table.variable("projectile_speed").start
    result = _projectile_on_a_rigid_face(component_fmus["projectile", 2], step)
    impulse = float(np.sum(result["contact_force"][1:]) * step)
    lost = mass * (speed - result["projectile_velocity"][-1])
    assert impulse > 1.5 * mass * speed  # it bounced off
    assert impulse == pytest.approx(lost, rel=1e-12)


def test_an_elastic_contact_returns_the_projectile_at_its_speed(component_fmus):
    """Without contact damping a rigid face sends the projectile back at the speed it came with (energy is
    conserved); with damping it comes back slower."""
    speed = component_table("projectile").variable("projectile_speed").start
    elastic = _projectile_on_a_rigid_face(component_fmus["projectile", 2], 1e-3, contact_damping=0.0)
    assert elastic["projectile_velocity"][-1] == pytest.approx(-speed, rel=1e-7)
    damped = _projectile_on_a_rigid_face(component_fmus["projectile", 2], 1e-3, contact_damping=0.2)
    assert -speed < damped["projectile_velocity"][-1] < -0.3 * speed


@pytest.mark.parametrize("version", [2, 3])
def test_model_exchange_and_co_simulation_agree(component_fmus, version):
    fmu = component_fmus["projectile", version]
    cs = _projectile_on_a_rigid_face(fmu, 1e-3)
    me = _projectile_on_a_rigid_face(fmu, 1e-3, fmi_type="ModelExchange")
    scale = np.abs(cs["projectile_position"]).max()
    assert np.abs(cs["projectile_position"] - me["projectile_position"]).max() < 1e-3 * scale
    assert np.abs(cs["projectile_velocity"] - me["projectile_velocity"]).max() < 1e-3 * 3.6


@pytest.mark.parametrize("version", [2, 3])
def test_the_hull_answers_a_held_force_exactly(component_fmus, version):
    """Co-Simulation holds F over each step: the hull's motion is the exact response to that staircase (the
    matrix exponential of each step), to RK4's accuracy."""
    m, k, c, step = 20.0, 2.0e4, 200.0, 0.01
    times = np.arange(0.0, 0.5 + step / 2, step)
    forces = 1000.0 * np.sin(7.0 * times)
    inputs = np.array(list(zip(times, forces)), dtype=[("time", np.float64), ("F", np.float64)])
    result = simulate_fmu(
        str(component_fmus["hull", version]),
        stop_time=0.5,
        step_size=step,
        output_interval=step,
        start_values={"m": m, "k": k, "c": c},
        input=inputs,
        output=["x", "v"],
    )
    a = np.array([[0.0, 1.0], [-k / m, -c / m]])
    phi = expm(a * step)
    gamma = np.linalg.solve(a, (phi - np.eye(2)) @ np.array([0.0, 1.0 / m]))
    state, expected = np.zeros(2), [0.0]
    for force in forces[:-1]:
        state = phi @ state + gamma * force
        expected.append(state[0])
    scale = np.abs(expected).max()
    assert scale > 0.01
    assert np.abs(result["x"] - np.array(expected)).max() <= 1e-6 * scale


def test_a_component_refuses_a_parameter_after_initialisation_and_a_bad_value(component_fmus, tmp_path):
    from fmpy import extract
    from fmpy.fmi1 import FMICallException
    from fmpy.fmi2 import FMU2Slave

    fmu = component_fmus["hull", 2]
    description = read_model_description(str(fmu))
    references = {v.name: v.valueReference for v in description.modelVariables}
    slave = FMU2Slave(
        guid=description.guid,
        unzipDirectory=extract(str(fmu), str(tmp_path / "unzipped")),
        modelIdentifier=description.coSimulation.modelIdentifier,
        instanceName="hull",
    )
    slave.instantiate(loggingOn=True)
    with pytest.raises(FMICallException):
        slave.setReal([references["m"]], [-1.0])
    slave.setupExperiment(startTime=0.0)
    slave.enterInitializationMode()
    slave.exitInitializationMode()
    slave.setReal([references["F"]], [100.0])  # the input: any time
    slave.doStep(0.0, 0.01)
    assert slave.getReal([references["x"]])[0] > 0.0
    with pytest.raises(FMICallException):
        slave.setReal([references["k"]], [1.0])
    slave.terminate()
    slave.freeInstance()


def test_build_fmu_builds_a_component_and_refuses_scene_options(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert build_fmu.main(["--model", "hull", "-o", str(tmp_path / "Hull.fmu")]) == 0
    assert read_model_description(str(tmp_path / "Hull.fmu")).coSimulation.modelIdentifier == "Hull"
    with pytest.raises(SystemExit) as exit_:
        build_fmu.main(["--model", "projectile", "--rows", "5"])
    assert exit_.value.code == 2
    assert "--rows: only for --model lattice" in capsys.readouterr().err


@pytest.mark.parametrize("fmi_type", ["CoSimulation", "ModelExchange"])
def test_the_hull_s_energy_balance_closes(component_fmus, fmi_type):
    """A constant push F does work F x; the hull holds it as kinetic and spring energy and its damper's
    dissipated_energy."""
    m, k, c, force = 20.0, 2.0e4, 200.0, 1000.0
    result = simulate_fmu(
        str(component_fmus["hull", 2]),
        stop_time=0.3,
        output_interval=1e-3,
        fmi_type=fmi_type,
        start_values={"m": m, "k": k, "c": c, "F": force},
        output=["x", "v", "dissipated_energy"],
        relative_tolerance=1e-10,
    )
    work = force * result["x"]
    stored = 0.5 * m * result["v"] ** 2 + 0.5 * k * result["x"] ** 2 + result["dissipated_energy"]
    assert result["dissipated_energy"][-1] > 0.1 * work[-1]
    assert np.abs(work - stored).max() < 1e-6 * work.max()


@pytest.mark.parametrize("version", [2, 3])
@pytest.mark.parametrize("model", COMPONENT_MODELS)
def test_a_component_cross_builds_for_every_platform(model, version, tmp_path):
    """`--platforms all`: a binary for each platform the build makes, each of its platform's architecture."""
    for name in ALL_PLATFORMS[version]:
        try:
            compiler_for(PLATFORMS[name])
        except RuntimeError as exc:
            pytest.skip(str(exc))
    fmu = build_component_fmu(model, tmp_path / f"{model}.fmu", fmi_version=version, platforms="all", werror=True)
    with zipfile.ZipFile(fmu) as archive:
        binaries = [name for name in archive.namelist() if name.startswith("binaries/") and not name.endswith("/")]
        machines = {header_machine(archive.read(name), name) for name in binaries}
    assert len(binaries) == len(ALL_PLATFORMS[version]) == len(machines)


def test_the_projectile_s_lost_energy_is_its_work_on_the_face(component_fmus):
    """A face receding at 1 m/s: the projectile strikes it through an elastic contact, leaves it 2 (3.6 - 1) m/s
    slower than the face, and the kinetic energy it lost is face_work, the work its contact force did on the face.
    (Co-Simulation: FMPy's Model Exchange holds an input between output points, so the face would jump.)"""
    table = component_table("projectile")
    mass, speed, face_speed = table.variable("projectile_mass").start, table.variable("projectile_speed").start, 1.0
    times = np.linspace(0.0, 0.5, 501)
    inputs = np.array(
        list(zip(times, face_speed * times, np.full_like(times, face_speed))),
        dtype=[("time", np.float64), ("x_front", np.float64), ("v_front", np.float64)],
    )
    result = simulate_fmu(
        str(component_fmus["projectile", 2]),
        stop_time=0.5,
        step_size=1e-3,
        output_interval=1e-3,
        input=inputs,
        start_values={"contact_damping": 0.0},
        output=["projectile_velocity", "face_work", "contact_force"],
    )
    assert result["contact_force"][-1] == 0.0  # it has left the face
    assert result["projectile_velocity"][-1] == pytest.approx(2 * face_speed - speed, rel=1e-4)
    lost = 0.5 * mass * (speed**2 - result["projectile_velocity"][-1] ** 2)
    assert result["face_work"][-1] == pytest.approx(lost, rel=1e-6)


def _slave(fmu, folder, name, logging=False):
    from fmpy import extract
    from fmpy.fmi2 import FMU2Slave

    description = read_model_description(str(fmu))
    slave = FMU2Slave(
        guid=description.guid,
        unzipDirectory=extract(str(fmu), str(folder / name)),
        modelIdentifier=description.coSimulation.modelIdentifier,
        instanceName=name,
    )
    slave.instantiate(loggingOn=logging)  # fmpy prints what the FMU logs
    slave.setupExperiment(startTime=0.0)
    slave.enterInitializationMode()
    slave.exitInitializationMode()
    return slave, {v.name: v.valueReference for v in description.modelVariables}


HEADER_SIZE, CHECKSUM_AT = 64, 8  # common/instance.c: SavedHeader, and the CRC-32 of the bytes after it


def _with_value(data: bytes, offset: int, value: float) -> bytes:
    """`data` with the double at `offset` replaced and the checksum recomputed, as a crafted state would be."""
    crafted = bytearray(data)
    crafted[offset : offset + 8] = struct.pack("<d", value)
    crafted[CHECKSUM_AT : CHECKSUM_AT + 4] = struct.pack("<I", zlib.crc32(bytes(crafted[CHECKSUM_AT + 4 :])))
    return bytes(crafted)


@pytest.mark.parametrize("model", COMPONENT_MODELS)
def test_a_component_refuses_a_crafted_state_and_restores_its_own(component_fmus, tmp_path, capsys, model):
    """The shared checks (common/component_model.c) refuse a value that is not finite and a parameter out of its
    range; the hull's own driver check a non-finite input slope; the intact state restores."""
    from fmpy.fmi1 import FMICallException

    slave, refs = _slave(component_fmus[model, 2], tmp_path, model, logging=True)
    slave.doStep(0.0, 1e-3)
    state = slave.getFMUstate()
    data = bytes(slave.serializeFMUstate(state))
    slave.freeFMUstate(state)
    count = len(refs)
    parameter = "m" if model == "hull" else "projectile_mass"
    output = "x" if model == "hull" else "projectile_position"
    crafted = {
        "is not finite": _with_value(data, HEADER_SIZE + 8 * refs[output], math.nan),
        f"{parameter} = -1 is not allowed": _with_value(data, HEADER_SIZE + 8 * refs[parameter], -1.0),
    }
    if model == "hull":  # struct Model: the core's values, time and two flags, then the input slope
        crafted["input slope is not finite"] = _with_value(data, HEADER_SIZE + 8 * count + 16, math.inf)
    for reason, state_bytes in crafted.items():
        capsys.readouterr()
        with pytest.raises(FMICallException):
            slave.deSerializeFMUstate(state_bytes)
        assert reason in capsys.readouterr().out
    restored = slave.deSerializeFMUstate(data)
    slave.setFMUstate(restored)
    slave.freeFMUstate(restored)
    slave.doStep(1e-3, 1e-3)
    slave.terminate()
    slave.freeInstance()


def test_the_hull_extrapolates_its_input_with_the_derivative_a_master_sets(component_fmus, tmp_path):
    """One step with F and dF/dt set (FMI 2's input interpolation) is many short steps of that ramp."""
    slope, step = 4.0e4, 0.05
    ramped, refs = _slave(component_fmus["hull", 2], tmp_path, "ramped")
    ramped.setReal([refs["F"]], [100.0])
    ramped.setRealInputDerivatives([refs["F"]], [1], [slope])
    ramped.doStep(0.0, step)
    fine, _ = _slave(component_fmus["hull", 2], tmp_path, "fine")
    pieces = 2000
    for i in range(pieces):
        fine.setReal([refs["F"]], [100.0 + slope * (i + 0.5) * step / pieces])  # the ramp's mean over each piece
        fine.doStep(i * step / pieces, step / pieces)
    x, v = ramped.getReal([refs["x"], refs["v"]])
    assert x == pytest.approx(fine.getReal([refs["x"]])[0], rel=1e-6)
    assert v == pytest.approx(fine.getReal([refs["v"]])[0], rel=1e-5)
    # the output derivatives at the communication point: x' = v, v' = (F - k x - c v) / m with F at its end
    dx, dv = ramped.getRealOutputDerivatives([refs["x"], refs["v"]], [1, 1])
    m, k, c = 20.0, 2.0e4, 200.0
    assert dx == v and dv == pytest.approx((100.0 + slope * step - k * x - c * v) / m, rel=1e-12)
    for slave in (ramped, fine):
        slave.terminate()
        slave.freeInstance()


def test_the_projectile_follows_an_accelerating_face_from_its_input_derivatives(component_fmus, tmp_path):
    """A face accelerating at a: one step given x_front, v_front and the derivative of v_front is many short
    steps given the face's exact motion; contact_force's output derivative is 0 (a step's mean, to be held)."""

    accel, step = 20.0, 0.05
    one, refs = _slave(component_fmus["projectile", 2], tmp_path, "one")
    one.setRealInputDerivatives([refs["v_front"]], [1], [accel])
    one.doStep(0.0, step)
    many, _ = _slave(component_fmus["projectile", 2], tmp_path, "many")
    pieces = 1000
    for i in range(pieces):
        t = i * step / pieces
        many.setReal([refs["x_front"], refs["v_front"]], [0.5 * accel * t * t, accel * t])
        many.setRealInputDerivatives([refs["v_front"]], [1], [accel])
        many.doStep(t, step / pieces)
    velocity = one.getReal([refs["projectile_velocity"]])[0]
    assert velocity == pytest.approx(many.getReal([refs["projectile_velocity"]])[0], rel=1e-7)
    assert velocity < 3.6 - 0.1  # the contact slowed it
    assert one.getRealOutputDerivatives([refs["contact_force"]], [1]) == [0.0]
    speed = one.getReal([refs["projectile_velocity"]])[0]
    assert one.getRealOutputDerivatives([refs["projectile_position"]], [1]) == [speed]
    for slave in (one, many):
        slave.terminate()
        slave.freeInstance()
