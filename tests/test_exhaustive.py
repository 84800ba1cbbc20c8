"""The exhaustive sweep: ranks, chunks, checkpoints, restarts, verification and the cost guard."""
from __future__ import annotations

import itertools
import json
import math
import os
import signal
import subprocess
import sys
import time
from concurrent.futures import Future

import pytest

from orchestrator import exhaustive
from orchestrator.exhaustive import (chunk_ranges, evaluate_chunk, order_from_rank, orders_in_range, rank_of,
                                     run_exhaustive)
from orchestrator.executors import SerialExecutor
from orchestrator.search.problems import Flaky, Limited, QuadraticAssignment, brute_force
from orchestrator.types import Evaluation

QAP7 = QuadraticAssignment.random(7, 11)
QAP6 = QuadraticAssignment.random(6, 2)


@pytest.fixture(scope="module")
def qap7_optimum():
    (optimum,), value = brute_force(QAP7, 7)
    return optimum, value


# ---------------------------------------------------------------- ranks
@pytest.mark.parametrize("columns", [1, 2, 3, 5, 6])
def test_ranks_are_the_lexicographic_permutations_and_invert(columns):
    expected = list(itertools.permutations(range(1, columns + 1)))
    decoded = [order_from_rank(r, columns) for r in range(math.factorial(columns))]
    assert decoded == expected
    assert [rank_of(o) for o in decoded] == list(range(math.factorial(columns)))


def test_ranks_round_trip_on_eleven_columns():
    total = math.factorial(11)
    for rank in (0, 1, 12345, 9_999_999, total // 2, total - 1):
        assert rank_of(order_from_rank(rank, 11)) == rank
    assert order_from_rank(total - 1, 11) == tuple(range(11, 0, -1))
    assert rank_of((1, 10, 9, 6, 4, 5, 7, 8, 3, 2, 11)) < total


def test_orders_in_range_follow_the_ranks():
    assert list(orders_in_range(6, 100, 260)) == [order_from_rank(r, 6) for r in range(100, 260)]
    assert list(orders_in_range(4, 20, 24)) == [order_from_rank(r, 4) for r in range(20, 24)]
    assert chunk_ranges(10, 4) == [(0, 4), (4, 8), (8, 10)]


def test_bad_ranks_and_orders_are_refused():
    with pytest.raises(ValueError, match="rank"):
        order_from_rank(720, 6)
    with pytest.raises(ValueError, match="permutation"):
        rank_of((1, 1, 2))


# ---------------------------------------------------------------- one chunk
def test_chunk_keeps_its_best_counts_failures_and_histograms_the_rest():
    objective = Flaky(QAP6, period=5, mode="nan")
    content = evaluate_chunk(objective, 6, 0, 720, keep=5, all_peaks=True)
    values = {o: QAP6.value(o) for o in itertools.permutations(range(1, 7))}
    ok = {o: v for o, v in values.items() if not objective.fails(o)}
    assert content["n_failed"] == 720 - len(ok) > 0
    assert {tuple(o) for o, _ in content["failed"]} == set(values) - set(ok)
    assert [p for _, p in content["best"]] == sorted(ok.values())[:5]
    assert sum(content["histogram"].values()) == len(ok)
    assert [p is None for p in content["peaks"]] == [objective.fails(o) for o in values]  # rank order
    json.dumps(content)


def test_chunk_keeps_every_order_within_the_screening_bound():
    content = evaluate_chunk(QAP6, 6, 0, 720, keep=1, screening_error=0.05)
    best = min(QAP6.value(o) for o in itertools.permutations(range(1, 7)))
    bound = best * 1.05 / 0.95
    expected = sorted(QAP6.value(o) for o in itertools.permutations(range(1, 7)) if QAP6.value(o) <= bound)
    assert [p for _, p in content["within"]] == expected and len(expected) > 1


def test_chunk_lowers_the_limit_of_a_censoring_objective_as_its_best_improves():
    plain = evaluate_chunk(QAP6, 6, 0, 720, keep=3, screening_error=0.01)
    limited = evaluate_chunk(Limited(QAP6), 6, 0, 720, keep=3, screening_error=0.01,
                             objective_with_limit=Limited(QAP6).with_limit, limit=1e9)
    assert limited["best"] == plain["best"] and limited["within"] == plain["within"]
    assert limited["n_censored"] > 0 and limited["n_failed"] == 0
    assert limited["final_limit"] == pytest.approx(plain["best"][0][1] * 1.01 / 0.99)
    assert sum(limited["histogram"].values()) + limited["n_censored"] == 720
    unlimited_start = evaluate_chunk(Limited(QAP6), 6, 0, 720, keep=3, screening_error=0.01,
                                     objective_with_limit=Limited(QAP6).with_limit)  # no incumbent yet
    assert unlimited_start["best"] == plain["best"] and unlimited_start["n_censored"] > 0


# ---------------------------------------------------------------- the sweep
class Noisy:
    """QAP7 screened with a deterministic relative error of at most ``error``."""

    def __init__(self, error):
        self.error = error

    def __repr__(self):
        return f"Noisy({self.error})"

    def __call__(self, order):
        wobble = (sum((k + 3) * p * p for k, p in enumerate(order)) % 201 - 100) / 100
        return Evaluation(tuple(order), QAP7.value(order) * (1 + self.error * wobble), "ok")


def test_sweep_finds_the_optimum_through_the_screening_error(tmp_path, qap7_optimum):
    optimum, value = qap7_optimum
    result = run_exhaustive(Noisy(0.02), 7, SerialExecutor(), tmp_path / "ck", 500, full_objective=QAP7,
                            screening_error=0.02, full_error=0.0, keep=5)
    assert result["orders"] == 5040 and result["chunks"] == 11 and result["from_checkpoint"] == 0
    assert tuple(result["optimum"]["order"]) == optimum and result["optimum"]["peak"] == pytest.approx(value, rel=1e-12)
    assert result["full_fidelity_checks"] == len({tuple(c["order"]) for c in result["candidates"] + result["top"]}) > 5
    assert result["screening_bound_held"] and result["max_screening_error_seen"] <= 0.02
    assert sum(result["histogram"]["counts"].values()) == 5040 and result["orders_per_core_second"] > 0


class Interrupting(SerialExecutor):
    """Runs ``allowed`` submits, then breaks as a killed pool does."""

    def __init__(self, allowed):
        super().__init__()
        self.allowed = allowed

    def submit(self, fn, /, *args, **kwargs):
        self.allowed -= 1
        if self.allowed < 0:
            raise RuntimeError("pool broken")
        return super().submit(fn, *args, **kwargs)


def test_restart_skips_finished_chunks_and_gives_the_same_result(tmp_path, qap7_optimum):
    with pytest.raises(RuntimeError, match="run again to resume"):
        run_exhaustive(QAP7, 7, Interrupting(4), tmp_path, 500, screening_error=0.0)
    assert len(list(tmp_path.glob("chunk_*.json"))) == 4
    resumed = run_exhaustive(QAP7, 7, SerialExecutor(), tmp_path, 500, full_objective=QAP7, screening_error=0.0)
    fresh = run_exhaustive(QAP7, 7, SerialExecutor(), tmp_path / "fresh", 500, full_objective=QAP7,
                           screening_error=0.0)
    assert resumed["from_checkpoint"] == 4 and fresh["from_checkpoint"] == 0
    assert resumed["top"] == fresh["top"] and resumed["histogram"] == fresh["histogram"]
    assert tuple(resumed["optimum"]["order"]) == qap7_optimum[0]


class DyingOnce(SerialExecutor):
    """The future of one chunk raises once, as when its worker dies."""

    def __init__(self):
        super().__init__()
        self.died = False

    def submit(self, fn, /, *args, **kwargs):
        if fn is evaluate_chunk and args[2] == 1000 and not self.died:
            self.died = True
            future = Future()
            future.set_exception(RuntimeError("worker died"))
            return future
        return super().submit(fn, *args, **kwargs)


def test_a_dead_worker_costs_only_its_chunk(tmp_path, qap7_optimum):
    result = run_exhaustive(QAP7, 7, DyingOnce(), tmp_path, 500, full_objective=QAP7, screening_error=0.0)
    assert result["chunks_rerun"] == 1 and result["orders"] == 5040
    assert tuple(result["optimum"]["order"]) == qap7_optimum[0]


def test_checkpoint_of_another_sweep_is_refused(tmp_path):
    run_exhaustive(QAP6, 6, SerialExecutor(), tmp_path, 100, screening_error=0.0)
    with pytest.raises(ValueError, match=r"differs in: chunk_size") as err:
        run_exhaustive(QAP6, 6, SerialExecutor(), tmp_path, 120, screening_error=0.0)
    assert "\n" not in str(err.value)
    with pytest.raises(ValueError, match=r"differs in: .*objective"):
        run_exhaustive(Noisy(0.0), 6, SerialExecutor(), tmp_path, 100, screening_error=0.0)
    with pytest.raises(ValueError, match=r"differs in: scene"):
        run_exhaustive(QAP6, 6, SerialExecutor(), tmp_path, 100, screening_error=0.0, scene={"load": 2})


def test_a_sweep_beyond_the_limit_is_refused_with_its_projected_cost(tmp_path):
    with pytest.raises(ValueError, match=r"core-hours") as err:
        run_exhaustive(QAP7, 7, SerialExecutor(), tmp_path, 500, screening_error=0.0, max_orders=1000)
    assert "\n" not in str(err.value) and "dask" in str(err.value) and not any(tmp_path.iterdir())
    with pytest.raises(ValueError, match=r"core-hours"):  # dask alone is not enough: it must be confirmed
        run_exhaustive(QAP7, 7, SerialExecutor(), tmp_path, 500, screening_error=0.0, max_orders=1000,
                       executor_kind="dask")
    result = run_exhaustive(QAP7, 7, SerialExecutor(), tmp_path, 500, screening_error=0.0, max_orders=1000,
                            executor_kind="dask", confirm=True)
    assert result["orders"] == 5040


def test_peak_table_holds_every_order_by_rank(tmp_path):
    run_exhaustive(QAP6, 6, SerialExecutor(), tmp_path, 100, screening_error=0.0, all_peaks=True)
    table = exhaustive.peak_table(tmp_path, 6)
    assert list(table) == [QAP6.value(order_from_rank(r, 6)) for r in range(720)]


SWEEP_SCRIPT = """
import json, sys
from orchestrator.exhaustive import run_exhaustive
from orchestrator.executors import make_executor
from orchestrator.search.problems import Delayed, QuadraticAssignment
objective = Delayed(QuadraticAssignment.random(7, 11), 0.001)
with make_executor("process", workers=2) as executor:
    result = run_exhaustive(objective, 7, executor, sys.argv[1], 168, screening_error=0.0,
                            full_objective=QuadraticAssignment.random(7, 11), in_flight=2)
print(json.dumps({k: result[k] for k in ("from_checkpoint", "orders", "optimum")}))
"""


def test_sweep_killed_with_sigkill_resumes_from_its_checkpoint(tmp_path, qap7_optimum):
    """The process group (client and pool workers) is SIGKILLed midway; a new run finishes the sweep."""
    folder = tmp_path / "ck"
    child = subprocess.Popen([sys.executable, "-c", SWEEP_SCRIPT, str(folder)], start_new_session=True,
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 120
    while len(list(folder.glob("chunk_*.json"))) < 4 and child.poll() is None and time.monotonic() < deadline:
        time.sleep(0.05)
    os.killpg(child.pid, signal.SIGKILL)
    child.wait()
    assert child.returncode == -signal.SIGKILL, child.stderr.read()
    finished = len(list(folder.glob("chunk_*.json")))
    assert 4 <= finished < 30
    resumed = subprocess.run([sys.executable, "-c", SWEEP_SCRIPT, str(folder)], capture_output=True, text=True,
                             timeout=300)
    assert resumed.returncode == 0, resumed.stderr
    result = json.loads(resumed.stdout.strip().splitlines()[-1])
    assert result["from_checkpoint"] >= finished and result["orders"] == 5040
    assert tuple(result["optimum"]["order"]) == qap7_optimum[0]


# ------------------------------------------------------------------------------------- the CLI's sweep
@pytest.fixture(scope="module")
def fmu6(tmp_path_factory):
    import build_fmu

    return build_fmu.build_fmu(output=tmp_path_factory.mktemp("fmu6") / "MassSpringLattice.fmu", cols=6)


def test_run_method_exhaustive_finds_the_optimum_and_resumes_from_its_checkpoint(fmu6, tmp_path, capfd):
    """`run.py --method exhaustive` on 11 x 6 (720 orders): results.json's exhaustive section, the optimum
    equal to the best of every order at full fidelity (brute force here), and a second run served from the
    checkpoint."""
    from orchestrator import run as cli
    from orchestrator.executors import make_executor as executors
    from orchestrator.loop import Evaluator
    from orchestrator.objective import FULL, SampledPeak

    argv = ["--fmu", str(fmu6), "--method", "exhaustive", "--out", str(tmp_path / "out"), "--workers", "2",
            "--no-progress", "--no-which-model", "--no-sensitivity", "--no-local-check", "--chunk-size", "60"]
    assert cli.main(argv) == 0, capfd.readouterr().err
    first = json.loads((tmp_path / "out" / "results.json").read_text())
    sweep = first["exhaustive"]
    assert sweep["orders"] == 720 and sweep["chunks"] == 12 and sweep["from_checkpoint"] == 0
    assert sweep["full_fidelity_checks"] >= 1 and sweep["orders_per_core_second"] > 0
    # brute force at full fidelity: the sweep's optimum is the best of all 720 orders
    orders = [tuple(p) for p in itertools.permutations(range(1, 7))]
    with executors("process", 2) as executor:
        everything = SampledPeak(fmu6, 6, 8.0).evaluate(orders, Evaluator(executor), FULL)
    truth = min((e for e in everything if e.ok), key=lambda e: e.peak)
    assert sweep["optimum"]["order"] == list(truth.order) == first["best"]["order"]
    assert sweep["optimum"]["peak"] == pytest.approx(truth.peak, rel=1e-12)
    assert (tmp_path / "out" / "exhaustive.png").stat().st_size > 1000
    assert cli.main(argv) == 0
    again = json.loads((tmp_path / "out" / "results.json").read_text())["exhaustive"]
    assert again["from_checkpoint"] == 12 and again["optimum"] == sweep["optimum"]


def test_run_refuses_a_sweep_beyond_the_local_limit_with_its_cost(fmu_path, tmp_path, capfd):
    from orchestrator import run as cli

    code = cli.main(["--fmu", str(fmu_path), "--method", "exhaustive", "--out", str(tmp_path), "--no-progress",
                     "--executor", "serial"])
    err = capfd.readouterr().err
    assert code == 2 and "core-hours" in err and "--confirm-exhaustive" in err, err
    assert len(err.strip().splitlines()) == 1
    assert not (tmp_path / "exhaustive").exists()
