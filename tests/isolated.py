"""An FMU in a process that can be killed: for the tests whose FMU runs could hang.

Why a separate process: a solver setting past its limits could make the FMU's doStep run for ever (the
failure tests/test_stability.py guards against); a test that drives such settings must survive that, so
those runs go through :class:`IsolatedFMU`, which kills and restarts its worker when a run takes longer than a
timeout.
"""

from __future__ import annotations

import multiprocessing
import time

ALL_OUTPUTS = (
    "peak_backplate_force",
    "peak_backplate_force_continuous",
    "peak_time",
    "last_contact_time",
    "kinetic_energy",
    "potential_energy",
    "external_work",
    "dissipated_energy",
    "nonreciprocal_work",
    "energy_balance_error",
    "rhs_evaluations",
    "steps_accepted",
    "steps_rejected",
)


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

    def run(
        self,
        order,
        horizon: float,
        parameters: dict | None = None,
        outputs=ALL_OUTPUTS,
        timeout: float | None = None,
        **options,
    ):
        """options: LatticeFMU.simulate's communication_step and record (a Trajectory comes back in the result)."""
        if self._process is None or not self._process.is_alive():
            self._start()
        limit = self.timeout if timeout is None else timeout
        self._connection.send(
            (
                tuple(order) if order is not None else None,
                float(horizon),
                dict(parameters or {}),
                tuple(outputs),
                options,
            )
        )
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
