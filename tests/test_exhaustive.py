"""The exhaustive sweep: chunks, force limits, the certificate, and the sweep as a step of a study."""

from __future__ import annotations

import itertools
import json
import math
import shutil
from dataclasses import dataclass

import pytest

from builder.build import build_fmu
from orchestrator import run as cli
from orchestrator.design import DesignSpace
from orchestrator.exhaustive import ScreenChunk, chunk_ranges, coverage, evaluate_chunk, screening_threshold
from orchestrator.executors import make_executor
from orchestrator.loop import Evaluator
from orchestrator.types import Evaluation, censored, failed

SPACE = DesignSpace(5, 5)


@dataclass(frozen=True)
class Weighted:
    """value = sum_j weight_j * material_j (the optimum puts the largest weights on the smallest materials);
    ``broken`` designs fail; with ``limit``, a design whose value passes it is censored."""

    weights: tuple = (5.0, 4.0, 3.0, 2.0, 1.0)
    broken: tuple = ()
    limit: float | None = None

    @property
    def key(self):
        return f"weighted|{self.weights}|{self.broken}|{self.limit}"

    def with_limit(self, limit):
        return Weighted(self.weights, self.broken, limit)

    def __call__(self, order):
        if tuple(order) in self.broken:
            return failed(order, "refused")
        value = sum(w * m for w, m in zip(self.weights, order))
        if self.limit is not None and value > self.limit:
            return censored(order, self.limit, 0.1)
        return Evaluation(tuple(order), float(value), "ok")


@dataclass(frozen=True)
class Unlimited:
    """The same function without a force limit: every design runs to its value."""

    function: Weighted

    def __call__(self, order):
        return self.function(order)


def test_a_chunk_keeps_its_best_its_candidates_its_failures_and_a_histogram():
    broken = ((1, 2, 3, 4, 5),)
    chunk = evaluate_chunk(Unlimited(Weighted(broken=broken)), SPACE, 0, 120, keep=3, screening_error=0.01)
    values = sorted(Weighted()(o).value for o in itertools.permutations(range(1, 6)) if o not in broken)
    assert [s.value for s in chunk.best] == values[:3]
    assert chunk.failed == 1 and chunk.failures[0].order == broken[0]
    threshold = screening_threshold(values[0], 0.01)
    assert sorted(s.value for s in chunk.within) == [v for v in values if v <= threshold]
    assert sum(count for _, count in chunk.histogram) == 119


def test_a_chunk_lowers_its_force_limit_as_its_best_improves_and_never_censors_a_candidate():
    chunk = evaluate_chunk(Weighted(), SPACE, 0, 120, keep=3, screening_error=0.01, limit=80.0)
    free = evaluate_chunk(Unlimited(Weighted()), SPACE, 0, 120, keep=3, screening_error=0.01)
    assert chunk.censored > 0 and chunk.final_limit < 80.0
    assert chunk.best[0] == free.best[0] and chunk.within == free.within


def test_chunks_as_tasks_are_cached_by_their_range_whatever_their_limit():
    with make_executor("serial") as executor:
        evaluator = Evaluator(executor)
        one = ScreenChunk(Weighted(), SPACE, 0, 60, 3, 0.01, limit=None)
        two = ScreenChunk(Weighted(), SPACE, 0, 60, 3, 0.01, limit=50.0)
        first, second = evaluator.run([one, two])
    assert one.key == two.key and first is second and evaluator.simulated == 1


def test_coverage_finds_gaps_and_overlaps():
    ranges = chunk_ranges(120, 50)
    assert ranges == [(0, 50), (50, 100), (100, 120)]
    chunks = [evaluate_chunk(Weighted(), SPACE, a, b, keep=1, screening_error=0.0) for a, b in ranges]
    assert coverage(chunks, 120) == (True, "ranks 0..119, each once")
    assert coverage(chunks[:1] + chunks[2:], 120)[0] is False
    assert "overlap" in coverage(chunks + chunks[:1], 120)[1]


# ---------------------------------------------------------------------------------------------- on the FMU
@pytest.fixture(scope="module")
def fmu6(tmp_path_factory):
    return build_fmu("armour_11x11", tmp_path_factory.mktemp("fmu6") / "MassSpringLattice11x6.fmu", cols=6, werror=True)


SWEEP = [
    "--cols",
    "6",
    "--method",
    "exhaustive",
    "random",
    "--budget",
    "30",
    "--repeats",
    "1",
    "--diagonal-rule",
    "receiver",
    "--no-sensitivity",
    "--no-progress",
    "--chunk-size",
    "60",
]


def test_the_sweep_certifies_the_brute_force_optimum_and_resumes_without_simulating(fmu6, tmp_path, capfd):
    out = tmp_path / "sweep"
    assert cli.main(["--fmu", str(fmu6), "--out", str(out), *SWEEP]) == 0, capfd.readouterr().err
    results = json.loads((out / "results.json").read_text())
    (sweep,) = results["steps"]["exhaustive"]["sweeps"]
    certificate = json.loads((out / "exhaustive" / "certificate.json").read_text())
    assert certificate == sweep["certificate"]
    assert certificate["certified"], certificate["reasons"]
    assert certificate["covered_once"] and certificate["designs"] == 720 == math.factorial(6)
    assert certificate["screened"] + certificate["censored"] + certificate["failed"] == 720
    assert certificate["max_screening_error_seen"] <= certificate["screening_error"]
    assert certificate["gap"] > 2 * certificate["integration_error"]
    assert sweep["initial_limit"] is not None  # the first chunks started at the random search's best
    # the brute force at full fidelity, through the same evaluator kinds (the FMU's default accuracy)
    from orchestrator.objective import FMURun

    full = FMURun(str(fmu6), 8.0)
    with make_executor("process", workers=2) as executor:
        values = Evaluator(executor).evaluate([(full, o) for o in itertools.permutations(range(1, 7))])
    best = min(values, key=lambda e: e.value)
    assert certificate["optimum"]["order"] == list(best.order)
    assert certificate["optimum"]["full"] == pytest.approx(best.value, rel=1e-12)
    (answer,) = results["answers"]
    assert answer["order"] == list(best.order) and answer["evidence"]["status"] == "certified"

    moved = tmp_path / "copied"
    shutil.copytree(out, moved)
    capfd.readouterr()
    assert cli.main(["--fmu", str(fmu6), "--out", str(moved), "--resume", *SWEEP]) == 0, capfd.readouterr().err
    again = json.loads((moved / "results.json").read_text())
    assert again["evaluator"]["simulated"] == 0
    assert again["steps"]["exhaustive"]["sweeps"][0]["certificate"] == certificate


def test_a_tampered_chunk_is_refused_never_trusted(fmu6, tmp_path, capfd):
    out = tmp_path / "sweep"
    assert cli.main(["--fmu", str(fmu6), "--out", str(out), *SWEEP]) == 0
    journal = out / "journal.jsonl"
    lines = journal.read_text().splitlines()
    number = next(i for i, line in enumerate(lines) if '"kind":"chunk"' in line)
    entry = json.loads(lines[number])
    entry["result"]["best"][0]["value"] *= 0.5  # a lowered best value
    lines[number] = json.dumps(entry)
    journal.write_text("\n".join(lines) + "\n")
    capfd.readouterr()
    assert cli.main(["--fmu", str(fmu6), "--out", str(out), "--resume", *SWEEP]) == 2
    err = capfd.readouterr().err
    assert f"line {number + 1} fails its checksum" in err and len(err.strip().splitlines()) == 1


def test_a_forged_chunk_with_a_valid_checksum_is_caught_by_the_verification(fmu6, tmp_path, capfd):
    """Beyond the checksum: a chunk whose best value was lowered and its line re-signed makes the sweep's
    verification see a screening error far past its bound; the run says so and exits 3, never certifying."""
    from orchestrator.journal import _sum

    out = tmp_path / "sweep"
    assert cli.main(["--fmu", str(fmu6), "--out", str(out), *SWEEP]) == 0
    journal = out / "journal.jsonl"
    lines = journal.read_text().splitlines()
    number = next(i for i, line in enumerate(lines) if '"kind":"chunk"' in line and '"best":[{' in line)
    entry = json.loads(lines[number])
    entry.pop("sum")
    entry["result"]["best"][0]["value"] *= 0.5
    lines[number] = json.dumps({**entry, "sum": _sum(entry)}, separators=(",", ":"))
    journal.write_text("\n".join(lines) + "\n")
    capfd.readouterr()
    assert cli.main(["--fmu", str(fmu6), "--out", str(out), "--resume", *SWEEP]) == 3
    err = capfd.readouterr().err
    assert "screening error" in err and "passed its bound" in err and len(err.strip().splitlines()) == 1
    certificate = json.loads((out / "exhaustive" / "certificate.json").read_text())
    assert not certificate["certified"] and not certificate["screening_bound_held"]
