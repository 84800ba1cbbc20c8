"""What the benchmarks share: paths, the FMUs (built fresh), the orders, an FMU in a process that can be killed.

Why a separate process: a solver setting past its limits can make the FMU's doStep run for ever (see
tests/test_stability.py); a benchmark that sweeps such settings must survive that, so every run goes
through :class:`IsolatedFMU`, which kills and restarts its worker when a run takes longer than a timeout.
"""
from __future__ import annotations

import csv
import math
import multiprocessing
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

SEQUENTIAL = tuple(range(1, 12))
STUDY_BEST = (1, 7, 5, 9, 3, 6, 11, 8, 2, 4, 10)
REVERSED = tuple(range(11, 0, -1))
ALL_OUTPUTS = ("peak_backplate_force", "peak_backplate_force_continuous", "peak_time", "last_contact_time",
               "kinetic_energy", "potential_energy", "external_work", "dissipated_energy", "nonreciprocal_work",
               "energy_balance_error", "rhs_evaluations", "steps_accepted", "steps_rejected")


def random_orders(count: int, seed: int, n: int = 11) -> list[tuple[int, ...]]:
    import numpy as np

    rng = np.random.default_rng(seed)
    return [tuple(int(x) + 1 for x in rng.permutation(n)) for _ in range(count)]


def bench_orders(random_count: int = 2, seed: int = 2024) -> dict[str, tuple[int, ...]]:
    """sequential, the study's best, reversed (the stiffest we know), and random ones."""
    orders = {"sequential": SEQUENTIAL, "study_best": STUDY_BEST, "reversed": REVERSED}
    for k, order in enumerate(random_orders(random_count, seed)):
        orders[f"random{k + 1}"] = order
    return orders


def order_text(order) -> str:
    return "-".join(str(m) for m in order)


def build_fmus(out: Path, c: bool = True, reference: bool = False) -> dict[str, Path]:
    """Build the C FMU (from fmu_src/ as it is now) and/or the reference FMU into out/fmus/."""
    import build_fmu

    folder = Path(out) / "fmus"
    folder.mkdir(parents=True, exist_ok=True)
    paths = {}
    if c:
        paths["c"] = build_fmu.build_fmu(output=folder / "MassSpringLattice.fmu")
    if reference:
        from reference.fmu import build_reference_fmu

        paths["reference"] = build_reference_fmu(folder / "MassSpringLatticeReference.fmu")
    return paths


def write_csv(path: Path, rows: list[dict], columns: list[str] | None = None) -> None:
    columns = columns or list(dict.fromkeys(k for row in rows for k in row))
    with open(path, "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=columns, extrasaction="ignore")
        writer.writeheader()
        for row in rows:
            writer.writerow({k: _cell(row.get(k)) for k in columns})


def _cell(value):
    if isinstance(value, float):
        return "" if math.isnan(value) else repr(value)
    if isinstance(value, (tuple, list)):
        return order_text(value)
    return "" if value is None else value


# ---------------------------------------------------------------------------- an FMU in a killable process
def _worker(connection, fmu_path: str) -> None:
    from orchestrator.simulation import LatticeFMU, SimulationError

    fmu = LatticeFMU(fmu_path, instance_name="isolated")
    while True:
        job = connection.recv()
        if job is None:
            break
        order, horizon, parameters, outputs, options = job
        start = time.perf_counter()
        try:
            result = fmu.simulate(order, horizon=horizon, parameters=parameters, outputs=outputs, **options)
            connection.send(("ok", result, time.perf_counter() - start))
        except SimulationError as exc:
            connection.send(("error", str(exc), time.perf_counter() - start))
        except Exception as exc:  # noqa: BLE001 - reported to the caller, never a number
            connection.send(("error", f"{type(exc).__name__}: {exc}", time.perf_counter() - start))
    fmu.close()


class RunTimeout(RuntimeError):
    """The FMU did not return within the timeout (its worker was killed)."""


class IsolatedFMU:
    """``LatticeFMU.simulate`` in a worker process; a run over ``timeout`` seconds kills the worker.

    ``run`` returns ``(status, result_or_message, seconds)`` with status "ok", "error" (an FMI error: the
    message is the FMU's) or "timeout"; seconds is measured in the worker around the simulation.
    """

    def __init__(self, fmu_path, timeout: float = 60.0):
        self.fmu_path = str(fmu_path)
        self.timeout = float(timeout)
        self._context = multiprocessing.get_context("spawn")
        self._process = None
        self._connection = None

    def _start(self) -> None:
        parent, child = self._context.Pipe()
        self._process = self._context.Process(target=_worker, args=(child, self.fmu_path), daemon=True)
        self._process.start()
        self._connection = parent

    def run(self, order, horizon: float, parameters: dict | None = None, outputs=ALL_OUTPUTS,
            timeout: float | None = None, **options):
        """options: LatticeFMU.simulate's communication_step and record (a Trajectory comes back in the result)."""
        if self._process is None or not self._process.is_alive():
            self._start()
        limit = self.timeout if timeout is None else timeout
        self._connection.send((tuple(order) if order is not None else None, float(horizon), dict(parameters or {}),
                               tuple(outputs), options))
        if self._connection.poll(limit):
            return self._connection.recv()
        self.kill()
        return "timeout", f"no return within {limit:g} s (worker killed)", limit

    def kill(self) -> None:
        if self._process is not None:
            self._process.kill()
            self._process.join()
        self._process = None
        self._connection = None

    def close(self) -> None:
        if self._process is not None and self._process.is_alive():
            try:
                self._connection.send(None)
                self._process.join(timeout=10)
            except (OSError, BrokenPipeError):
                pass
            if self._process.is_alive():
                self._process.kill()
                self._process.join()
        self._process = None

    def __enter__(self):
        return self

    def __exit__(self, *exc_info):
        self.close()
