"""Soak: the FMU's life cycle repeated many times with the process's resident memory sampled along the way
(``python -m bench.soak`` writes the page; tests/test_soak.py runs a short soak).

Why: loops that evaluate an FMU many thousand times are known to leak or crash in the importers users run. A
cycle is what a search evaluation does: reset, set an order, initialise, advance over the horizon, read the
outputs. The lifecycle, not the physics, is what could leak, so a small lattice and a short horizon serve.

Growth is counted after the warm-up (the first fifth of the cycles): the median of the last quarter of the
samples after it minus the median of the first quarter, so that the allocator's noise does not count; the
least-squares slope is kept beside it.
"""

from __future__ import annotations

import itertools
import shutil
import statistics
import subprocess
import time
import zipfile
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import psutil
from fmpy import read_model_description

from .executors import make_executor
from .loop import Evaluator
from .objective import FMURun
from .simulation import LatticeFMU, material_columns, model_description

ROWS = COLS = 3
HORIZON = 1e-3  # s simulated per cycle
ME_STEPS = 10  # explicit Euler steps of a Model Exchange cycle
SAMPLES = 200  # resident-memory samples per configuration
WARM_UP = 0.2  # fraction of the cycles before the growth is counted
LIMIT_BYTES = 1 << 20  # 1 MB
DRIVER_SOURCE = Path(__file__).resolve().with_name("soak_driver.c")
INCLUDE = Path(__file__).resolve().parents[1] / "fmu_src" / "include"


@dataclass(frozen=True)
class Growth:
    """Resident memory over the cycles after the warm-up."""

    warm_bytes: float  # median of the first quarter of the samples after the warm-up
    growth_bytes: float  # median of the last quarter minus warm_bytes
    slope_bytes_per_million: float  # least-squares slope over the samples after the warm-up

    @property
    def flat(self) -> bool:
        return self.growth_bytes < LIMIT_BYTES


def growth_after_warm_up(samples: Sequence[tuple[int, float]], warm_up: float = WARM_UP) -> Growth:
    """How much resident memory grew after the first ``warm_up`` fraction of the cycles: medians of the first
    and last quarters of the later samples (robust to the allocator's noise), and the fitted slope."""
    if len(samples) < 8:
        raise ValueError(f"samples: at least 8 (cycle, bytes) pairs needed, got {len(samples)}")
    last_cycle = max(cycle for cycle, _ in samples)
    later = sorted((c, b) for c, b in samples if c >= warm_up * last_cycle)
    if len(later) < 4:
        raise ValueError("samples: fewer than 4 after the warm-up")
    quarter = max(1, len(later) // 4)
    warm = statistics.median(b for _, b in later[:quarter])
    final = statistics.median(b for _, b in later[-quarter:])
    cycles = np.array([c for c, _ in later], dtype=float)
    slope = float(np.polyfit(cycles, np.array([b for _, b in later], dtype=float), 1)[0]) if np.ptp(cycles) else 0.0
    return Growth(float(warm), float(final - warm), slope * 1e6)


@dataclass(frozen=True)
class SoakResult:
    configuration: str
    cycles: int
    seconds: float
    growth: Growth
    failures: int  # FMI calls that failed (driver), evaluations that failed, or bad inputs not refused

    @property
    def per_second(self) -> float:
        return self.cycles / self.seconds if self.seconds > 0 else float("nan")


@dataclass(frozen=True)
class NotRun:
    configuration: str
    reason: str


# ---------------------------------------------------------------- the native driver (Linux and Wine)


@dataclass(frozen=True)
class UnpackedFMU:
    folder: Path
    fmi_version: int
    token: str
    states: int
    indicators: int
    material_references: tuple[int, ...]  # material[1] ... material[C], or FMI 3's one array material
    output_references: tuple[int, ...]
    columns: int

    def material_argument(self) -> str:
        """The driver's MATERIAL_VRS: the scalars' value references, or FMI 3's array as "VR*C"."""
        listed = ",".join(map(str, self.material_references))
        return listed if len(self.material_references) == self.columns else f"{listed}*{self.columns}"

    def binary(self, windows: bool) -> Path:
        if self.fmi_version == 2:
            sub = "win64" if windows else "linux64"
        else:
            sub = "x86_64-windows" if windows else "x86_64-linux"
        return next((self.folder / "binaries" / sub).glob("*.dll" if windows else "*.so"))


def unpack(fmu: Path, folder: Path) -> UnpackedFMU:
    description = read_model_description(str(fmu))
    with zipfile.ZipFile(fmu) as archive:
        archive.extractall(folder)
    (folder / "resources").mkdir(exist_ok=True)
    materials = tuple(
        v.valueReference for v in description.modelVariables if v.name.startswith("material[") or v.name == "material"
    )
    outputs = tuple(
        v.valueReference
        for v in description.modelVariables
        if v.causality == "output" and v.type in ("Real", "Float64")
    )
    return UnpackedFMU(
        folder,
        int(description.fmiVersion[0]),
        description.guid,
        description.numberOfContinuousStates,
        description.numberOfEventIndicators,
        materials,
        outputs,
        material_columns(description),
    )


def compile_driver(folder: Path, windows: bool) -> Path | str:
    """The driver's executable, or why it could not be made."""
    compiler = "x86_64-w64-mingw32-gcc" if windows else "gcc"
    if shutil.which(compiler) is None:
        return f"{compiler} not found"
    output = folder / ("soak_driver.exe" if windows else "soak_driver")
    libraries = ["-lpsapi"] if windows else ["-ldl"]
    done = subprocess.run(
        [compiler, "-std=gnu11", "-O2", f"-I{INCLUDE}", str(DRIVER_SOURCE), "-o", str(output), *libraries],
        check=False,
        capture_output=True,
        text=True,
    )
    return output if done.returncode == 0 else f"{compiler} failed: {done.stderr.strip().splitlines()[-1:]}"


def run_driver(
    driver: Path, fmu: UnpackedFMU, model_exchange: bool, windows: bool, cycles: int, environment: dict
) -> SoakResult:
    binary = fmu.binary(windows)
    if fmu.fmi_version == 2:
        resources = fmu.folder.joinpath("resources").as_uri()
    else:
        resources = str(fmu.folder / "resources") + "/"
    if windows:
        binary_text = "Z:" + str(binary).replace("/", "\\")
        resources = resources if fmu.fmi_version == 2 else "Z:" + resources.replace("/", "\\")
        launcher = ["wine", str(driver)]
    else:
        binary_text = str(binary)
        launcher = [str(driver)]
    command = [
        *launcher,
        str(fmu.fmi_version),
        "me" if model_exchange else "cs",
        binary_text,
        fmu.token,
        resources,
        str(fmu.states),
        str(fmu.indicators),
        str(cycles),
        str(max(1, cycles // SAMPLES)),
        repr(HORIZON),
        str(ME_STEPS),
        fmu.material_argument(),
        ",".join(map(str, fmu.output_references)),
    ]
    start = time.perf_counter()
    done = subprocess.run(command, check=False, capture_output=True, text=True, env=environment)
    seconds = time.perf_counter() - start
    samples, failures = [], None
    for line in done.stdout.splitlines():
        words = line.split()
        if words[:1] == ["rss"]:
            samples.append((int(words[1]), float(words[2])))
        elif words[:1] == ["done"]:
            failures = int(words[2])
    name = (
        f"FMI {fmu.fmi_version} {'Model Exchange' if model_exchange else 'Co-Simulation'}, "
        f"{'Windows DLL under Wine' if windows else 'Linux'}"
    )
    if failures is None:
        raise SystemExit(f"{name}: the driver stopped (exit {done.returncode}): {done.stderr.strip()[-300:]}")
    return SoakResult(name, cycles, seconds, growth_after_warm_up(samples), failures)


# ---------------------------------------------------------------- through the orchestrator


def tree_rss() -> float:
    """Resident bytes of this process and every process it started (pool workers, Dask's nannies and workers)."""
    me = psutil.Process()
    total = me.memory_info().rss
    for child in me.children(recursive=True):
        try:
            total += child.memory_info().rss
        except psutil.Error:
            pass
    return float(total)


def soak_loop(
    name: str, count: int, batch: int, run_batch: Callable[[int], int], rss: Callable[[], float]
) -> SoakResult:
    """Runs ``run_batch(size)`` (it returns its failures) until ``count`` cycles ran, sampling ``rss``."""
    every = max(batch, count // SAMPLES)
    samples, failures, done, next_sample = [], 0, 0, 0
    start = time.perf_counter()
    while done < count:
        if done >= next_sample:
            samples.append((done, rss()))
            next_sample += every
        size = min(batch, count - done)
        failures += run_batch(size)
        done += size
    samples.append((done, rss()))
    return SoakResult(name, count, time.perf_counter() - start, growth_after_warm_up(samples), failures)


BATCH = 6  # evaluations per Evaluator


def first_orders(fmu: Path, count: int) -> tuple[tuple[int, ...], ...]:
    """The first ``count`` orders (lexicographic) of the FMU's columns."""
    return tuple(
        itertools.islice(itertools.permutations(range(1, material_columns(model_description(fmu)) + 1)), count)
    )


def evaluator_soak(fmu: Path, kind: str, count: int, workers: int) -> SoakResult:
    """``count`` evaluations through a fresh Evaluator per batch of BATCH orders (fresh, so that its cache does not
    answer them) on one executor kept for the whole soak."""
    task = FMURun(str(fmu), HORIZON)
    orders = first_orders(fmu, BATCH)
    with make_executor(kind, workers) as executor:

        def run_batch(size: int) -> int:
            results = Evaluator(executor).evaluate([(task, order) for order in orders[:size]])
            return sum(1 for result in results if not getattr(result, "ok", True))

        Evaluator(executor).evaluate([(task, order) for order in orders])  # workers started before sampling
        return soak_loop(
            f"Evaluator, {'process pool' if kind == 'process' else 'Dask local cluster'} of {workers} workers",
            count,
            len(orders),
            run_batch,
            tree_rss,
        )


def bad_inputs(columns: int) -> tuple[tuple[str, tuple[int, ...], dict], ...]:
    """One bad input of each kind for a lattice of ``columns`` columns: (kind, order, parameters)."""
    order = tuple(range(1, columns + 1))
    return (
        ("a material out of range", (0, *order[1:]), {}),
        ("a repeated material", (1, *order[:-1]), {}),
        ("too few columns", order[:-1], {}),
        ("a parameter out of range", order, {"rtol": -1.0}),
    )


def refusal_soak(fmu: Path, count: int) -> SoakResult:
    """``count`` bad inputs given to ``LatticeFMU.simulate``, each kind in turn: each must be refused."""
    process = psutil.Process()
    with LatticeFMU(fmu) as lattice:
        inputs = bad_inputs(lattice.columns)

        def run_batch(size: int) -> int:
            accepted = 0
            for _, order, parameters in inputs[:size]:
                try:
                    lattice.simulate(order, horizon=HORIZON, parameters=parameters)
                    accepted += 1
                except (ValueError, RuntimeError):
                    pass
            return accepted

        return soak_loop(
            f"refused bad inputs ({', '.join(kind for kind, _, _ in inputs)})",
            count,
            len(inputs),
            run_batch,
            lambda: float(process.memory_info().rss),
        )


def simulate_soak(fmu: Path, count: int) -> SoakResult:
    """``count`` cycles through ``LatticeFMU.simulate``: the orchestrator's own FMI 2 Co-Simulation path."""
    process = psutil.Process()
    with LatticeFMU(fmu) as lattice:
        orders = first_orders(fmu, 24)
        lattice.simulate(orders[0], horizon=HORIZON)

        def run_batch(size: int) -> int:
            for order in orders[:size]:
                lattice.simulate(order, horizon=HORIZON)
            return 0

        return soak_loop(
            "LatticeFMU.simulate (the orchestrator's FMI 2 Co-Simulation path), Linux",
            count,
            len(orders),
            run_batch,
            lambda: float(process.memory_info().rss),
        )
