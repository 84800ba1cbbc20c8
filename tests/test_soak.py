"""A short soak of the FMU's life cycle (python -m bench.soak runs the long one and writes its page): resident
memory must not grow after the warm-up, natively through the C driver (FMI 2 and 3, Co-Simulation and Model
Exchange), through the orchestrator's own FMU path, through the Evaluator on a process pool, and while refusing
bad inputs."""

from __future__ import annotations

import random
import shutil

import pytest

from orchestrator import soak

CYCLES = 2000


def test_flat_noisy_memory_counts_as_flat():
    rng = random.Random(1)
    samples = [(c, 50e6 + rng.choice((0, 4096, 8192, 200e3))) for c in range(0, 100_000, 500)]
    growth = soak.growth_after_warm_up(samples)
    assert growth.flat
    assert abs(growth.growth_bytes) < 300e3


def test_a_leak_of_two_megabytes_is_found():
    samples = [(c, 50e6 + 2e6 * c / 100_000) for c in range(0, 100_001, 500)]
    growth = soak.growth_after_warm_up(samples)
    assert not growth.flat
    assert growth.slope_bytes_per_million == pytest.approx(20e6, rel=1e-6)


def test_warm_up_growth_is_not_counted():
    samples = [(c, 40e6 if c < 10_000 else 50e6) for c in range(0, 100_001, 500)]
    assert soak.growth_after_warm_up(samples).growth_bytes == 0


def test_too_few_samples_are_refused():
    with pytest.raises(ValueError, match="samples"):
        soak.growth_after_warm_up([(0, 1.0), (1, 1.0)])


@pytest.mark.skipif(shutil.which("gcc") is None, reason="the driver is compiled with gcc")
@pytest.mark.parametrize("model_exchange", [False, True], ids=["co-simulation", "model-exchange"])
@pytest.mark.parametrize("version", [2, 3])
def test_native_cycles_are_flat(version, model_exchange, fmu_path, fmu3_path, tmp_path):
    fmu = soak.unpack(fmu_path if version == 2 else fmu3_path, tmp_path / "fmu")
    driver = soak.compile_driver(tmp_path, windows=False)
    assert not isinstance(driver, str), driver
    result = soak.run_driver(driver, fmu, model_exchange, windows=False, cycles=CYCLES, environment={})
    assert result.failures == 0
    assert result.growth.flat, result.growth


def test_orchestrator_cycles_and_refusals_are_flat(fmu_path):
    cycles = soak.simulate_soak(fmu_path, CYCLES)
    refusals = soak.refusal_soak(fmu_path, CYCLES)
    assert cycles.failures == 0 and cycles.growth.flat, cycles.growth
    assert refusals.failures == 0, "a bad input was accepted"
    assert refusals.growth.flat, refusals.growth


def test_evaluator_on_a_process_pool_is_flat(fmu_path):
    result = soak.evaluator_soak(fmu_path, "process", CYCLES, workers=2)
    assert result.failures == 0
    assert result.growth.flat, result.growth


def test_a_local_dask_clusters_system_monitors_keep_a_short_history():
    """What grew in the Dask soak: every Dask process's system monitor history, an hour of samples by default.
    A local cluster keeps a few, in its scheduler and in each worker."""
    pytest.importorskip("distributed")
    from orchestrator.executors import LOCAL_MONITOR_SAMPLES, make_executor

    with make_executor("dask", workers=2) as executor:
        client = executor._client
        kept = client.run(lambda dask_worker: dask_worker.monitor.maxlen)
        assert list(kept.values()) == [LOCAL_MONITOR_SAMPLES] * 2
        assert client.run_on_scheduler(lambda dask_scheduler: dask_scheduler.monitor.maxlen) == LOCAL_MONITOR_SAMPLES
