"""--export-optuna: every evaluation of evaluations.csv is one Optuna trial with the same values, failed and
censored evaluations as failed and pruned trials; --start-file reads the best designs back from the storage."""

from __future__ import annotations

import csv

import pytest

from command_line import main

optuna = pytest.importorskip("optuna", reason='needs the optuna extra (pip install -e ".[optuna]")')

QUICK = ["--repeats", "1", "--no-sensitivity", "--no-progress", "--executor", "serial"]


def csv_rows(folder) -> list[dict]:
    with (folder / "evaluations.csv").open() as handle:
        return list(csv.DictReader(handle))


def trials_by_rule(storage: str) -> dict[str, list]:
    found = {}
    for name in optuna.get_all_study_names(storage=storage):
        study = optuna.load_study(study_name=name, storage=storage)
        found[study.user_attrs["diagonal_rule"]] = sorted(study.get_trials(deepcopy=False), key=lambda t: t.number)
    return found


def test_every_evaluation_is_a_trial_with_the_same_values(fmu_path, tmp_path, capfd):
    storage = f"sqlite:///{tmp_path / 'study.db'}"
    out = tmp_path / "r"
    assert (
        main(
            "--fmu",
            fmu_path,
            "--out",
            out,
            "--budget",
            "20",
            "--method",
            "sa",
            "cmaes",
            "sequential",
            "--export-optuna",
            storage,
            *QUICK,
        )
        == 0
    )
    assert f"optuna-dashboard {storage}" in capfd.readouterr().out
    rows = csv_rows(out)
    trials = trials_by_rule(storage)
    assert sorted(trials) == sorted({r["diagonal_rule"] for r in rows})
    statuses = set()
    for rule, found in trials.items():
        own = [r for r in rows if r["diagonal_rule"] == rule]
        assert len(found) == len(own)
        for trial, row in zip(found, own):
            attrs = trial.user_attrs
            stored = (attrs["method"], str(attrs["seed"]), str(attrs["index"]))
            assert stored == (row["method"], row["seed"], row["index"])
            assert [trial.params[f"column_{c:02d}"] for c in range(1, 12)] == [int(m) for m in row["order"].split()]
            statuses.add(row["status"])
            if row["status"] == "ok":
                assert trial.state == optuna.trial.TrialState.COMPLETE and trial.values == [float(row["value"])]
            elif row["status"] == "censored":
                assert trial.state == optuna.trial.TrialState.PRUNED and trial.values is None
                assert attrs["censored_above"] == float(row["censored_above"])
            else:
                assert trial.state == optuna.trial.TrialState.FAIL and trial.values is None
    assert "ok" in statuses and "censored" in statuses  # the annealing's force limits censor some
    record = (out / "report.html").read_text()
    assert "optuna-dashboard" in record

    # the storage read back as starting designs: each rule's best trial, evaluated first by every search
    best = {
        rule: min((t for t in found if t.state == optuna.trial.TrialState.COMPLETE), key=lambda t: t.values[0])
        for rule, found in trials.items()
    }
    designs = [" ".join(str(t.params[f"column_{c:02d}"]) for c in range(1, 12)) for t in best.values()]
    again = tmp_path / "again"
    assert (
        main(
            "--fmu",
            fmu_path,
            "--out",
            again,
            "--budget",
            "5",
            "--method",
            "cmaes",
            "--start-file",
            storage,
            "--diagonal-rule",
            "mean",
            *QUICK,
        )
        == 0
    )
    first = [r["order"] for r in csv_rows(again) if r["index"] in ("1", "2")]
    assert sorted(first) == sorted(dict.fromkeys(designs))


def test_failed_evaluations_are_failed_trials(fmu_path, tmp_path):
    storage = f"sqlite:///{tmp_path / 'failed.db'}"
    code = main(
        "--fmu",
        fmu_path,
        "--out",
        tmp_path / "r",
        "--case",
        "solver=rk4",
        "--case",
        "fixed_step=0.05",
        "--budget",
        "4",
        "--method",
        "random",
        "--export-optuna",
        storage,
        *QUICK,
    )
    assert code == 3  # no answer: every evaluation failed; the export still holds them
    rows = csv_rows(tmp_path / "r")
    found = [t for trials in trials_by_rule(storage).values() for t in trials]
    assert len(found) == len(rows) > 0
    assert all(t.state == optuna.trial.TrialState.FAIL and t.user_attrs["message"] for t in found)


def test_a_storage_that_is_not_a_url_is_refused_before_any_simulation(fmu_path, tmp_path, capfd):
    assert main("--fmu", fmu_path, "--out", tmp_path / "r", "--export-optuna", "study.db", *QUICK) == 2
    err = capfd.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "--export-optuna study.db: not a database URL" in err, err
    assert not (tmp_path / "r").exists()


@pytest.mark.parametrize("tables", ["optuna's tables", "optuna's add_trials"])
def test_trials_numbered_after_an_existing_study_and_read_back_through_optuna(tmp_path, tables, monkeypatch):
    """The trials are written in batches of one transaction: more than one batch, into a storage that holds
    another study already, read back through Optuna's public API with their numbers, values, states and times;
    the same through Optuna's add_trials where its tables are not importable."""
    import orchestrator.optuna_export

    if tables == "optuna's add_trials":
        monkeypatch.setattr(orchestrator.optuna_export, "_rdb_tables", lambda: None)
    monkeypatch.setattr(orchestrator.optuna_export, "BATCH_TRIALS", 40)  # three batches, the last one short
    from orchestrator.loop import SearchRun
    from orchestrator.optuna_export import export
    from orchestrator.types import Evaluation, censored, failed

    storage = f"sqlite:///{tmp_path / 'many.db'}"
    earlier = optuna.create_study(storage=storage, study_name="earlier")
    earlier.add_trial(optuna.trial.create_trial(value=1.0))
    materials = [f"m{k}" for k in range(1, 12)]
    count = 2 * 40 + 7
    evaluations = []
    for k in range(count):
        order = tuple((k + c) % 11 + 1 for c in range(11))
        if k % 20 == 3:
            evaluations.append(censored(order, limit=900.0 + k, stopped_at=0.001))
        elif k % 20 == 4:
            evaluations.append(failed(order, "diverged"))
        else:
            evaluations.append(Evaluation(order, 1000.0 + k / 8, "ok", seconds=0.25))
    run = SearchRun(
        method="random",
        seed=5,
        budget=count,
        label="mean",
        evaluations=tuple(evaluations),
        best_order=evaluations[0].order,
        best_value=1000.0,
        best_index=1,
        failed=0,
        censored=0,
        reevaluated=0,
        distinct=count,
        stalled=False,
        truncated=False,
        stop_reason="budget",
        wall_seconds=1.0,
        batches=count,
        cache_hits=0,
    )
    (study,) = export(storage, [run], ("F_peak",), 11, materials, "case", "run7", "0" * 64)
    assert (study.name, study.trials) == ("run7 mean", count)

    loaded = optuna.load_study(study_name="run7 mean", storage=storage)
    trials = loaded.get_trials(deepcopy=False)
    assert [t.number for t in trials] == list(range(count))
    assert len(optuna.load_study(study_name="earlier", storage=storage).trials) == 1
    for trial, evaluation in zip(trials, evaluations):
        assert [trial.params[f"column_{c:02d}"] for c in range(1, 12)] == list(evaluation.order)
        assert trial.user_attrs["order"] == list(evaluation.order)
        assert trial.user_attrs["materials"] == [materials[m - 1] for m in evaluation.order]
        assert trial.datetime_complete is not None and trial.datetime_start <= trial.datetime_complete
        if evaluation.ok:
            assert trial.state == optuna.trial.TrialState.COMPLETE
            assert trial.values == pytest.approx([evaluation.value], rel=1e-12)
        elif evaluation.censored:
            assert trial.state == optuna.trial.TrialState.PRUNED
            assert trial.user_attrs["censored_above"] == pytest.approx(evaluation.limit)
        else:
            assert trial.state == optuna.trial.TrialState.FAIL and trial.user_attrs["message"] == "diverged"
    assert loaded.best_trial.number == 0

    # a study added afterwards through Optuna itself continues the numbering
    loaded.add_trial(optuna.trial.create_trial(value=1.0))
    assert loaded.get_trials(deepcopy=False)[-1].number == count
