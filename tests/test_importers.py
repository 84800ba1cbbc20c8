"""The FMU in importers we did not write: libcosim (every run); FMI4j, fmi-sim and OMSimulator (opt-in:
-m importers).

Each importer sets a material order, co-simulates 8 s in 0.01 s communication steps, reads
peak_backplate_force and must agree with fmpy to 1e-9 relative (the FMU is deterministic and independent of
the communication step, so in practice they agree to the last bit). fmi-sim also runs the FMI 3.0 FMU,
and the Model Exchange interface with its own (forward Euler) solver.
(The source-only FMU rebuilt by `fmpy compile` is in test_source_fmu.py.)

The heavy toolchains are built once and cached (default ~/.cache/mass-spring-lattice, or $MSL_CACHE_DIR):
the FMI4j Maven project's classes and dependency jars, keyed by a hash of tests/fmi4j/, and the fmi-sim
binary installed there by `cargo install fmi-sim` (or $FMI_SIM, or an fmi-sim on PATH).

OMSimulator 3 lives in an environment of its own (`pip install omsimulator` downloads binaries at install
time; the README says how to build it from source): $OMSIMULATOR_PYTHON names that environment's Python
(for example oms-venv/bin/python), which runs tests/omsimulator/oms_run.py. Without it the OMSimulator
tests are skipped. They cover FMI 2 Co-Simulation, FMI 2 Model Exchange at OMSimulator's defaults and at a
tight tolerance, FMI 3 Co-Simulation with the order set, and the design file through the C entry
oms_importFile and the Python SSP class (the armour system's three FMUs: test_armour_system.py).
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import importlib.metadata
import json
import os
import re
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ElementTree
from dataclasses import dataclass
from pathlib import Path

import pytest

from compatibility import RowRecorder, compatibility_row
from fmu_src.published import PUBLISHED_PEAKS
from fmu_src.published import SEQUENTIAL_ORDER as PUBLISHED_SEQUENTIAL
from fmu_src.published import STUDY_BEST_ORDER as PUBLISHED_BEST
from orchestrator.simulation import LatticeFMU
from orchestrator.ssp import COMPONENT, SYSTEM, read_design_parameters, write_best_design_ssp

ORDERS = [PUBLISHED_BEST, PUBLISHED_SEQUENTIAL]
HORIZON, STEP = 8.0, 0.01
RELATIVE_TOLERANCE = 1e-9
AGREES = (
    f"both published orders' peak_backplate_force within {RELATIVE_TOLERANCE:g} of fmpy's on the same FMU "
    f"({HORIZON:g} s in {STEP:g} s communication steps)"
)
FMI4J_PROJECT = Path(__file__).resolve().parent / "fmi4j"
CACHE_DIR = Path(os.environ.get("MSL_CACHE_DIR") or Path.home() / ".cache" / "mass-spring-lattice")


@pytest.fixture(scope="module")
def fmpy_peaks(fmu_path):
    """The reference: fmpy driving the same FMU with the same 800 doSteps of 0.01 s."""
    with LatticeFMU(fmu_path) as fmu:
        return {
            order: fmu.simulate(order, horizon=HORIZON, communication_step=STEP)["peak_backplate_force"]
            for order in ORDERS
        }


def assert_agrees(peak: float, reference: float, importer: str) -> None:
    relative = abs(peak - reference) / abs(reference)
    assert relative <= RELATIVE_TOLERANCE, (
        f"{importer} gives {peak!r}, fmpy {reference!r}: relative difference {relative:.3g} > {RELATIVE_TOLERANCE}"
    )


# ---------------------------------------------------------------------------------------------------- libcosim


def libcosim_peak(fmu_path, order, horizon=HORIZON, step=STEP) -> float:
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver
    from libcosimpy.CosimSlave import CosimLocalSlave

    log_output_level(CosimLogLevel.WARNING)
    execution = CosimExecution.from_step_size(step_size=int(round(step * 1e9)))  # libcosim counts nanoseconds
    index = execution.add_local_slave(CosimLocalSlave(fmu_path=str(fmu_path), instance_name="lattice"))
    references = {v.name.decode(): v.reference for v in execution.slave_variables(index)}
    for column, material in enumerate(order, 1):
        assert execution.integer_initial_value(index, references[f"material[{column}]"], material)
    observer = CosimObserver.create_last_value()
    execution.add_observer(observer)
    assert execution.simulate_until(target_time=int(round(horizon * 1e9))), execution.status()
    status = execution.status()
    assert status.current_time == int(round(horizon * 1e9))
    return observer.last_real_values(index, [references["peak_backplate_force"]])[0]


def test_libcosim_agrees_with_fmpy(request, fmu_path, fmpy_peaks):
    with compatibility_row(
        request,
        "libcosim (libcosimpy)",
        importlib.metadata.version("libcosimpy"),
        fmi_version="2.0",
        interface="CS",
        checked=AGREES,
    ) as row:
        for order in ORDERS:
            peak = libcosim_peak(fmu_path, order)
            row.reached(order, peak)
            assert_agrees(peak, fmpy_peaks[order], f"libcosim, order {order}")


# ------------------------------------------------------------------------------------------------------- FMI4j


def fmi4j_build() -> Path:
    """Classes and dependency jars of tests/fmi4j, built with Maven once per content of that folder."""
    digest = hashlib.sha256()
    for path in sorted(p for p in FMI4J_PROJECT.rglob("*") if p.is_file() and "target" not in p.parts):
        digest.update(path.relative_to(FMI4J_PROJECT).as_posix().encode())
        digest.update(path.read_bytes())
    build = CACHE_DIR / f"fmi4j-{digest.hexdigest()[:16]}"
    done = build / "BUILD_OK"
    if done.is_file():
        return build
    if shutil.which("mvn") is None:
        pytest.skip(
            "FMI4j: Maven (mvn) is not installed, and tests/fmi4j has not been built before "
            "(apt-get install maven, with Java 17)"
        )
    command = ["mvn", "-B", "-q", "-f", str(FMI4J_PROJECT / "pom.xml"), "process-classes", f"-Dfmi4j.build.dir={build}"]
    result = subprocess.run(command, capture_output=True, text=True, timeout=900)
    assert result.returncode == 0, f"{' '.join(command)} failed:\n{result.stdout[-4000:]}\n{result.stderr[-4000:]}"
    done.write_text(" ".join(command) + "\n")
    return build


def fmi4j_peaks(fmu_path, orders) -> dict:
    if shutil.which("java") is None:
        pytest.skip("FMI4j: java is not installed (apt-get install openjdk-17-jdk-headless)")
    build = fmi4j_build()
    classpath = os.pathsep.join([str(build / "classes"), str(build / "dependency" / "*")])
    arguments = [",".join(map(str, order)) for order in orders]
    command = ["java", "-cp", classpath, "lattice.PeakForce", str(fmu_path), repr(HORIZON), repr(STEP), *arguments]
    result = subprocess.run(command, capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, f"FMI4j run failed:\n{result.stdout}\n{result.stderr}"
    peaks = {}
    for line in result.stdout.splitlines():
        if line.startswith("peak "):
            _, order_text, value = line.split()
            peaks[tuple(int(m) for m in order_text.split(","))] = float(value)
    assert set(peaks) == set(orders), result.stdout
    return peaks


def fmi4j_version() -> str:
    """The FMI4j version tests/fmi4j/pom.xml builds against."""
    namespace = {"m": "http://maven.apache.org/POM/4.0.0"}
    return ElementTree.parse(FMI4J_PROJECT / "pom.xml").getroot().find("m:properties/m:fmi4j.version", namespace).text


@pytest.mark.importers
def test_fmi4j_agrees_with_fmpy(request, fmu_path, fmpy_peaks):
    with compatibility_row(request, "FMI4j", fmi4j_version(), fmi_version="2.0", interface="CS", checked=AGREES) as row:
        peaks = fmi4j_peaks(fmu_path, ORDERS)  # one JVM for both orders
        for order in ORDERS:
            row.reached(order, peaks[order])
            assert_agrees(peaks[order], fmpy_peaks[order], f"FMI4j, order {order}")


# ----------------------------------------------------------------------------------------------------- fmi-sim

FMI_SIM_VERSION = "0.7.0"  # what these tests were written against; FMI 3 notes below are about this version


LIBRARY_FOLDERS = (Path("/usr/lib"), Path("/usr/lib64"), Path("/usr/local/lib"), Path("/usr/local/lib64"))
LIBCLANG_NAME = re.compile(r"libclang(-\d+(\.\d+)*)?\.so(\.\d+)*")  # not libclang-cpp, libclangAST...


def is_libclang(name: str) -> bool:
    """Whether a file name is one bindgen (clang-sys) loads as libclang: libclang.so, libclang-14.so, libclang.so.1."""
    return LIBCLANG_NAME.fullmatch(name) is not None


def libclang_library() -> Path | None:
    """The libclang a cargo build of fmi-sim would load, where clang-sys looks for it: $LIBCLANG_PATH, llvm-config's
    library folder, the system's library folders; None when there is none (building would fail after minutes)."""
    folders = []
    if os.environ.get("LIBCLANG_PATH"):
        given = Path(os.environ["LIBCLANG_PATH"])
        folders.append(given.parent if given.is_file() else given)
    llvm_config = shutil.which("llvm-config")
    if llvm_config:
        done = subprocess.run([llvm_config, "--libdir"], capture_output=True, text=True)
        if done.returncode == 0 and done.stdout.strip():
            folders.append(Path(done.stdout.strip()))
    for root in LIBRARY_FOLDERS:
        folders += [root, *root.glob("llvm-*/lib"), *root.glob("*-linux-gnu")]
    for folder in folders:
        found = sorted(p for p in folder.glob("libclang*.so*") if is_libclang(p.name)) if folder.is_dir() else []
        if found:
            return found[0]
    return None


def test_libclang_is_told_from_its_neighbours():
    assert all(
        is_libclang(n)
        for n in ("libclang.so", "libclang.so.1", "libclang-14.so", "libclang-14.0.6.so", "libclang-14.so.1")
    )
    assert not any(
        is_libclang(n) for n in ("libclang-cpp.so.14", "libclang-cpp.so", "libclangAST.a", "libclangBasic.so")
    )


def test_without_libclang_fmi_sim_is_skipped_with_the_reason_not_built(tmp_path, monkeypatch):
    """Where only libclang-cpp is installed, a cargo build of fmi-sim fails after minutes: skip at once, saying why."""
    lib = tmp_path / "usr" / "lib" / "llvm-14" / "lib"
    lib.mkdir(parents=True)
    (lib / "libclang-cpp.so.14").write_bytes(b"")
    monkeypatch.setattr(sys.modules[__name__], "LIBRARY_FOLDERS", (tmp_path / "usr" / "lib",))
    monkeypatch.setattr(sys.modules[__name__], "CACHE_DIR", tmp_path / "cache")
    monkeypatch.delenv("LIBCLANG_PATH", raising=False)
    monkeypatch.delenv("FMI_SIM", raising=False)
    monkeypatch.setenv("PATH", str(tmp_path))  # no llvm-config, no fmi-sim
    (tmp_path / "cargo").write_text("#!/bin/sh\nexit 99\n")
    (tmp_path / "cargo").chmod(0o755)
    assert libclang_library() is None
    with pytest.raises(pytest.skip.Exception, match="needs libclang"):
        fmi_sim_binary()


def fmi_sim_binary() -> str:
    """$FMI_SIM, an fmi-sim on PATH, or the cached one; built with cargo into the cache on first use."""
    cached = CACHE_DIR / f"fmi-sim-{FMI_SIM_VERSION}" / "bin" / "fmi-sim"
    for candidate in (os.environ.get("FMI_SIM"), shutil.which("fmi-sim"), str(cached)):
        if candidate and Path(candidate).is_file() and os.access(candidate, os.X_OK):
            return candidate
    if shutil.which("cargo") is None:
        pytest.skip(
            "fmi-sim: not installed and no cargo to build it (install Rust, then "
            f"`cargo install fmi-sim --version {FMI_SIM_VERSION} --locked`, or set FMI_SIM)"
        )
    if libclang_library() is None:
        pytest.skip(
            "fmi-sim: building it needs libclang, and there is none here (libclang-cpp is another library; "
            "Debian: apt-get install -y libclang-dev, or set LIBCLANG_PATH)"
        )
    command = [
        "cargo",
        "install",
        "fmi-sim",
        "--version",
        FMI_SIM_VERSION,
        "--locked",
        "--root",
        str(cached.parents[1]),
    ]
    result = subprocess.run(command, capture_output=True, text=True, timeout=3600)  # minutes on 2 cores, once
    assert result.returncode == 0, f"{' '.join(command)} failed:\n{result.stderr[-5000:]}"
    return str(cached)


@functools.lru_cache(maxsize=None)
def fmi_sim_version(binary: str) -> str:
    """What `fmi-sim --version` says (its last word), or the version these tests install."""
    done = subprocess.run([binary, "--version"], capture_output=True, text=True, timeout=60)
    words = done.stdout.split()
    return words[-1] if done.returncode == 0 and words else FMI_SIM_VERSION


def fmi_sim_failure(stderr: str) -> str:
    """fmi-sim's error on the first line (a compatibility row keeps only that), then the whole of its stderr."""
    cause = next((line.strip() for line in stderr.splitlines() if line.strip().startswith("Error")), "no error line")
    return f"fmi-sim failed: {cause[:250]}\n{stderr[-5000:]}"


def fmi_sim_peak(fmu, csv: Path, init_values=()) -> float:
    """Runs fmi-sim co-simulation for 8 s in 0.01 s steps; the last row's peak_backplate_force."""
    command = [
        fmi_sim_binary(),
        "--model",
        str(fmu),
        "-o",
        str(csv),
        "co-simulation",
        "-f",
        repr(HORIZON),
        "--step",
        repr(STEP),
    ]
    for name, value in init_values:
        command += ["--init-values", f"{name}={value}"]
    result = subprocess.run(
        command,
        capture_output=True,
        text=True,
        timeout=600,
        env={**os.environ, "RUST_BACKTRACE": "0", "RUST_LOG": "warn"},
    )
    assert result.returncode == 0, fmi_sim_failure(result.stderr)
    lines = csv.read_text().splitlines()
    header, last = lines[0].split(","), lines[-1].split(",")
    assert len(lines) == round(HORIZON / STEP) + 2 and float(last[0]) == HORIZON, lines[-1]
    return float(last[header.index("peak_backplate_force")])


@pytest.mark.importers
def test_fmi_sim_agrees_with_fmpy(request, fmu_path, fmpy_peaks, tmp_path):
    with compatibility_row(
        request, "fmi-sim", fmi_sim_version(fmi_sim_binary()), fmi_version="2.0", interface="CS", checked=AGREES
    ) as row:
        for order in ORDERS:
            init_values = [(f"material[{column}]", material) for column, material in enumerate(order, 1)]
            peak = fmi_sim_peak(fmu_path, tmp_path / "out.csv", init_values)
            row.reached(order, peak)
            assert_agrees(peak, fmpy_peaks[order], f"fmi-sim (FMI 2.0), order {order}")


@pytest.mark.importers
def test_fmi_sim_runs_the_fmi3_fmu_to_the_same_peak(request, tmp_path, fmpy_peaks):
    """fmi-sim 0.7 sets one scalar per --init-values, not an FMI 3 array, so the order goes in as the start
    value of `material` in the FMU itself (a scene parameter of build_fmu.py)."""
    import build_fmu

    with compatibility_row(
        request,
        "fmi-sim",
        fmi_sim_version(fmi_sim_binary()),
        fmi_version="3.0",
        interface="CS",
        checked=AGREES,
        note="the order set as the FMU's start values (fmi-sim sets no array element)",
    ) as row:
        for order in ORDERS:
            scene = build_fmu.Scene.load(build_fmu.DEFAULT_SCENE)
            scene.parameters = {**scene.parameters, "material": list(order)}
            fmu3 = build_fmu.build_fmu(scene, tmp_path / "MassSpringLattice-fmi3.fmu", werror=True, fmi_version=3)
            peak = fmi_sim_peak(fmu3, tmp_path / "out.csv")
            row.reached(order, peak)
            assert_agrees(peak, fmpy_peaks[order], f"fmi-sim (FMI 3.0), order {order}")


EULER_CHECKED = (
    "the published best order's peak within 1e-3 of the published peak and the energy balance closed "
    "to 1e-3 of the work put in (1 s of forward Euler at 1e-5 s)"
)


@pytest.mark.importers
def test_fmi_sim_runs_model_exchange_with_its_euler_solver(request, tmp_path):
    """fmi-sim 0.7 integrates Model Exchange with forward Euler at the DefaultExperiment's step (its --step did
    not change it), so the FMU is built with a 1e-5 s step for it (at 0.01 s explicit Euler diverges). Euler is
    first order: it reaches the published best peak to 1e-3, and the energy integrals, which it integrates as
    states, close the balance to 1e-3 of the work put in."""
    import build_fmu

    scene = build_fmu.Scene.load(build_fmu.DEFAULT_SCENE)
    scene.communication_step, scene.horizon = 1e-5, 1.0
    binary = fmi_sim_binary()
    with compatibility_row(
        request,
        "fmi-sim",
        fmi_sim_version(binary),
        fmi_version="2.0",
        interface="ME",
        checked=EULER_CHECKED,
        note="its Model Exchange is forward Euler at the model's default step: the FMU built with a 1e-5 s step",
    ) as row:
        fmu = build_fmu.build_fmu(scene, tmp_path / "MassSpringLattice.fmu", werror=True)
        csv = tmp_path / "me.csv"
        command = [binary, "--model", str(fmu), "-o", str(csv), "model-exchange", "-f", "1"]
        for column, material in enumerate(PUBLISHED_BEST, 1):
            command += ["--init-values", f"material[{column}]={material}"]
        result = subprocess.run(
            command,
            capture_output=True,
            text=True,
            timeout=600,
            env={**os.environ, "RUST_BACKTRACE": "0", "RUST_LOG": "warn"},
        )
        assert result.returncode == 0, fmi_sim_failure(result.stderr)
        lines = csv.read_text().splitlines()
        header, last = lines[0].split(","), lines[-1].split(",")
        final = {
            name: float(last[header.index(name)])
            for name in ("time", "peak_backplate_force", "steps_accepted", "external_work", "energy_balance_error")
        }
        assert final["time"] == 1.0 and final["steps_accepted"] > 1e5 - 10  # 1e5 Euler steps and the events
        assert row.reached(PUBLISHED_BEST, final["peak_backplate_force"]) <= 1e-3
        assert abs(final["energy_balance_error"]) <= 1e-3 * final["external_work"]


# ------------------------------------------------------------------------------------------------ OMSimulator

OMSIMULATOR_DRIVER = Path(__file__).resolve().parent / "omsimulator" / "oms_run.py"
DESIGN_HORIZON = 1.0  # the peak and the last contact come before 1 s
DESIGN = {"material": list(PUBLISHED_BEST), "F_total": 1100.0, "c_wall": 12.0}  # order + non-default parameters
MEAN_ORDER = (5, 1, 2, 3, 8, 7, 6, 4, 9, 10, 11)  # a design searched under the mean rule


@dataclass(frozen=True)
class OMSimulatorRun:
    values: dict
    failures: list  # the calls whose status was not ok
    errors: list  # the error lines of OMSimulator's log (stdout and stderr)


def omsimulator_run(tmp_path: Path, **request) -> OMSimulatorRun:
    """Runs tests/omsimulator/oms_run.py with $OMSIMULATOR_PYTHON; its temporary files stay in tmp_path."""
    python = os.environ.get("OMSIMULATOR_PYTHON")
    if not python:
        pytest.skip(
            "OMSimulator: set OMSIMULATOR_PYTHON to the Python of an environment with OMSimulator 3 "
            "(README: OMSimulator)"
        )
    assert Path(python).is_file(), f"OMSIMULATOR_PYTHON={python} is not a file"
    work = tmp_path / "omsimulator"
    work.mkdir(exist_ok=True)
    request = {"temp_dir": str(work), **{k: str(v) if isinstance(v, Path) else v for k, v in request.items()}}
    (work / "request.json").write_text(json.dumps(request))
    result = subprocess.run(
        [python, str(OMSIMULATOR_DRIVER), str(work / "request.json")],
        capture_output=True,
        text=True,
        timeout=900,
        cwd=work,
        env={**os.environ, "TMPDIR": str(work)},
    )
    lines = result.stdout.splitlines()
    replies = [line[len("RESULT ") :] for line in lines if line.startswith("RESULT ")]
    assert result.returncode == 0 and len(replies) == 1, (
        f"OMSimulator exited with {result.returncode}:\n{result.stdout[-3000:]}\n{result.stderr[-3000:]}"
    )
    reply = json.loads(replies[0])
    logged = lines + result.stderr.splitlines()  # the FMU's own log messages come on stderr
    return OMSimulatorRun(reply["values"], reply["failures"], [line for line in logged if line.startswith("error:")])


OMSIMULATOR_VERSION = re.compile(r"(?:OMSimulator )?v?(?P<number>\d[\w.+-]*?)(?:-(?:linux|mingw|win|darwin)[\w-]*)?")


def omsimulator_version_number(text: str) -> str:
    """The release in OMSimulator.version's text ("OMSimulator v3.0.0.post167-g2940ef1-linux" -> "3.0.0.post167-
    g2940ef1"): the row names the version, not the platform it was built for."""
    match = OMSIMULATOR_VERSION.fullmatch(text.strip())
    return match["number"] if match else text.strip()


def test_the_omsimulator_version_is_its_release_number():
    assert omsimulator_version_number("OMSimulator v3.0.0.post167-g2940ef1-linux") == "3.0.0.post167-g2940ef1"
    assert omsimulator_version_number("OMSimulator v2.1.2-mingw-ucrt64") == "2.1.2"
    assert omsimulator_version_number("v3.0.0") == "3.0.0"


@functools.lru_cache(maxsize=None)
def omsimulator_version(python: str) -> str:
    done = subprocess.run(
        [python, "-c", "import OMSimulator; print(OMSimulator.version)"], capture_output=True, text=True, timeout=300
    )
    assert done.returncode == 0 and done.stdout.strip(), f"OMSimulator.version: {done.stderr[-2000:]}"
    return omsimulator_version_number(done.stdout.strip().splitlines()[-1])


def omsimulator_row(request, fmi_version: str, interface: str, checked: str, note: str | None = None):
    python = os.environ.get("OMSIMULATOR_PYTHON")
    if not python:
        pytest.skip(
            "OMSimulator: set OMSIMULATOR_PYTHON to the Python of an environment with OMSimulator 3 "
            "(README: OMSimulator)"
        )
    return compatibility_row(
        request,
        "OMSimulator",
        omsimulator_version(python),
        fmi_version=fmi_version,
        interface=interface,
        checked=checked,
        note=note,
        environment=("OMSIMULATOR_PYTHON=path/to/oms-venv/bin/python",),
    )


def order_parameters(order) -> dict:
    return {f"material[{column}]": material for column, material in enumerate(order, 1)}


def assert_clean(run: OMSimulatorRun, importer: str) -> None:
    assert not run.failures and not run.errors, f"{importer}: {run.failures} {run.errors[:5]}"


@pytest.mark.importers
def test_omsimulator_co_simulation_agrees_with_fmpy(request, fmu_path, fmpy_peaks, tmp_path):
    with omsimulator_row(request, "2.0", "CS", AGREES) as row:
        for order in ORDERS:
            run = omsimulator_run(
                tmp_path,
                entry="fmu",
                fmu=fmu_path,
                system="wc",
                stop_time=HORIZON,
                integers=order_parameters(order),
                outputs=["peak_backplate_force"],
            )
            assert_clean(run, "OMSimulator (FMI 2.0 CS)")
            row.reached(order, run.values["peak_backplate_force"])
            assert_agrees(run.values["peak_backplate_force"], fmpy_peaks[order], "OMSimulator (FMI 2.0 CS)")


@pytest.mark.importers
@pytest.mark.parametrize("tolerance, relative", [(None, 1e-3), (1e-9, 1e-6)], ids=["defaults", "rtol_1e-9"])
def test_omsimulator_model_exchange_reaches_the_published_peak(request, fmu_path, tmp_path, tolerance, relative):
    """OMSimulator integrates Model Exchange with CVODE (BDF), by default at rtol 1e-4 and steps of at most
    1e-3 s, and re-initialises CVODE after every event; a lost wall switch must not cost more than that. The
    compatibility row is the tight tolerance's (one row per importer, version, platform, FMI and interface)."""
    checked = f"both published orders' peak_backplate_force within {relative:g} of the published peaks"
    rows = (
        omsimulator_row(
            request,
            "2.0",
            "ME",
            f"{checked} (CVODE at rtol {tolerance:g})",
            note="at its default rtol 1e-4: within 1e-3",
        )
        if tolerance
        else contextlib.nullcontext(RowRecorder())
    )
    with rows as row:
        for order in ORDERS:
            run = omsimulator_run(
                tmp_path,
                entry="fmu",
                fmu=fmu_path,
                system="sc",
                stop_time=HORIZON,
                tolerance=tolerance,
                integers=order_parameters(order),
                outputs=["peak_backplate_force", "energy_balance_error"],
            )
            assert_clean(run, "OMSimulator (FMI 2.0 ME)")
            peak = run.values["peak_backplate_force"]
            assert row.reached(order, peak) <= relative, (
                f"OMSimulator ME ({'defaults' if tolerance is None else f'rtol {tolerance}'}) gives {peak!r}, "
                f"published {PUBLISHED_PEAKS[order]!r}; energy_balance_error {run.values['energy_balance_error']!r} J"
            )


@pytest.mark.importers
def test_omsimulator_runs_the_fmi3_fmu_with_the_order_set(request, tmp_path):
    """OMSimulator 3 sets no FMI 3 array: the FMU built with --fmi3-scalars declares material[1] ... as Int32
    scalars, which it sets."""
    from builder import build as build_fmu

    with omsimulator_row(
        request,
        "3.0",
        "CS",
        "both published orders' peak_backplate_force within 1e-06 of the published peaks",
        note="built with --fmi3-scalars (the order as Int32 scalars material[j]: OMSimulator 3 sets no FMI 3 array)",
    ) as row:
        fmu3_path = build_fmu.build_fmu(
            output=tmp_path / "MassSpringLattice-fmi3.fmu", werror=True, fmi_version=3, fmi3_arrays=False
        )
        for order in ORDERS:
            run = omsimulator_run(
                tmp_path,
                entry="fmu",
                fmu=fmu3_path,
                system="wc",
                stop_time=HORIZON,
                integers=order_parameters(order),
                outputs=["peak_backplate_force"],
            )
            assert_clean(run, "OMSimulator (FMI 3.0 CS)")
            peak = run.values["peak_backplate_force"]
            assert row.reached(order, peak) <= 1e-6, (peak, PUBLISHED_PEAKS[order])


@pytest.mark.importers
def test_omsimulator_runs_the_fmi3_array_fmu_at_its_start_values_and_cannot_set_the_array(fmu3_path, tmp_path):
    """The default FMI 3 FMU declares `material` as an Int32 array. OMSimulator 3 loads and runs it at its start
    values (the sequential order) to the published peak; its setInteger knows no element `material[1]`, and on
    `material` it calls fmi3SetInt32 with one value, which the FMU refuses (an array is set whole) and
    OMSimulator logs, running on at the start values."""
    from fmpy import read_model_description

    (material,) = [v for v in read_model_description(str(fmu3_path)).modelVariables if v.name == "material"]
    assert material.type == "Int32" and len(material.dimensions) == 1
    run = omsimulator_run(
        tmp_path, entry="fmu", fmu=fmu3_path, system="wc", stop_time=HORIZON, outputs=["peak_backplate_force"]
    )
    assert_clean(run, "OMSimulator (FMI 3.0 CS, arrays)")
    peak = run.values["peak_backplate_force"]
    assert abs(peak - PUBLISHED_PEAKS[PUBLISHED_SEQUENTIAL]) <= 1e-6 * PUBLISHED_PEAKS[PUBLISHED_SEQUENTIAL]
    refused = omsimulator_run(
        tmp_path,
        entry="fmu",
        fmu=fmu3_path,
        system="wc",
        stop_time=HORIZON,
        integers={"material[1]": PUBLISHED_BEST[0], "material": PUBLISHED_BEST[0]},
        outputs=["peak_backplate_force"],
    )
    assert refused.failures == ["setInteger material[1]: error"]
    assert any("fmi3SetInt32" in line and "array" in line for line in refused.errors), refused.errors
    assert refused.values["peak_backplate_force"] == pytest.approx(peak, rel=1e-12)


@pytest.mark.importers
@pytest.mark.parametrize("entry", ["import_file", "ssp_class"])
def test_omsimulator_runs_the_design_file_to_fmpys_peak(fmu_path, lattice, tmp_path, entry):
    design = write_best_design_ssp(fmu_path, DESIGN, tmp_path / "best_design.ssp", stop_time=DESIGN_HORIZON)
    run = omsimulator_run(
        tmp_path, entry=entry, ssp=design, system=SYSTEM, component=COMPONENT, outputs=["peak_backplate_force"]
    )
    assert_clean(run, f"OMSimulator ({entry})")
    parameters = {k: v for k, v in DESIGN.items() if k != "material"}
    expected = lattice.simulate(PUBLISHED_BEST, horizon=DESIGN_HORIZON, parameters=parameters)
    default = lattice.simulate(PUBLISHED_BEST, horizon=DESIGN_HORIZON)
    peak = run.values["peak_backplate_force"]
    assert_agrees(peak, expected["peak_backplate_force"], f"OMSimulator ({entry})")
    assert abs(peak - default["peak_backplate_force"]) > 1.0  # the parameter set was applied, not ignored


def libcosim_design_peak(design: Path) -> float:
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver

    log_output_level(CosimLogLevel.ERROR)
    execution = CosimExecution.from_ssp_file(str(design))  # the step comes from the .ssd
    observer = CosimObserver.create_last_value()
    execution.add_observer(observer)
    index = execution.slave_index_from_instance_name(COMPONENT)
    references = {v.name.decode(): v.reference for v in execution.slave_variables(index)}
    assert execution.simulate_until(target_time=int(round(DESIGN_HORIZON * 1e9))), execution.status()
    return observer.last_real_values(index, [references["peak_backplate_force"]])[0]


def test_the_mean_rule_design_runs_to_its_peak_in_libcosim_and_fmpy(fmu_path, lattice, tmp_path):
    """The design of a --diagonal-rule mean search: libcosim and FMPy reproduce its peak to 1e-9 (the writer
    refuses such a design for an FMU libcosim would run differently: test_ssp_validation)."""
    parameters = {"material": list(MEAN_ORDER), "diagonal_rule": "mean"}
    design = write_best_design_ssp(fmu_path, parameters, tmp_path / "mean.ssp", stop_time=DESIGN_HORIZON)
    reported = lattice.simulate(MEAN_ORDER, horizon=DESIGN_HORIZON, parameters={"diagonal_rule": "mean"})
    receiver = lattice.simulate(MEAN_ORDER, horizon=DESIGN_HORIZON)
    assert abs(reported["peak_backplate_force"] - receiver["peak_backplate_force"]) > 1.0  # the rules differ
    assert_agrees(libcosim_design_peak(design), reported["peak_backplate_force"], "libcosim (mean design)")
    start_values = read_design_parameters(design)  # what FMPy applies: fmpy.simulate_fmu(start_values=...)
    order = [start_values.pop(f"material[{j}]") for j in range(1, len(MEAN_ORDER) + 1)]
    rerun = lattice.simulate(order, horizon=DESIGN_HORIZON, parameters=start_values)
    assert_agrees(rerun["peak_backplate_force"], reported["peak_backplate_force"], "FMPy (mean design)")


@pytest.mark.importers
@pytest.mark.parametrize("entry", ["import_file", "ssp_class"])
def test_omsimulator_runs_the_mean_rule_design_to_its_peak(fmu_path, lattice, tmp_path, entry):
    design = write_best_design_ssp(
        fmu_path,
        {"material": list(MEAN_ORDER), "diagonal_rule": "mean"},
        tmp_path / "mean.ssp",
        stop_time=DESIGN_HORIZON,
    )
    run = omsimulator_run(
        tmp_path, entry=entry, ssp=design, system=SYSTEM, component=COMPONENT, outputs=["peak_backplate_force"]
    )
    assert_clean(run, f"OMSimulator ({entry}, mean design)")
    reported = lattice.simulate(MEAN_ORDER, horizon=DESIGN_HORIZON, parameters={"diagonal_rule": "mean"})
    assert_agrees(run.values["peak_backplate_force"], reported["peak_backplate_force"], f"OMSimulator ({entry})")
