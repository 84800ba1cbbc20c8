"""The evaluations where optimisation users already look: an Optuna storage (``--export-optuna STORAGE``), and
starting designs read back from one (``--start-file STORAGE``).

Each diagonal rule's searches become one Optuna study ("<run id> <rule>": the values of two rules are two
problems), each evaluation of ``evaluations.csv`` one trial in the same order: the material of each column as an
integer parameter ``column_01``... (1..M), the objective value(s), the state COMPLETE for a value, FAIL for a
failed evaluation, PRUNED for a censored one (stopped above a force limit: it has no value, its bound is the user
attribute ``censored_above``), and the method, seed, run index, order, materials, fidelity and seconds as user
attributes. ``optuna-dashboard STORAGE`` then shows the study. Optuna is an optional extra (``optuna``): the
study itself never needs it.

Optuna's ``Study.add_trials`` commits each trial on its own, with a query per parameter and attribute; a default
study has thousands of evaluations, so the trials of an RDB storage are inserted in one transaction, in batches
(a progress bar per study), as rows of Optuna's own tables; ``tests/test_optuna_export.py`` reads them back
through Optuna's public API.
"""

from __future__ import annotations

import json
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .design import Design
from .progress import Progress

EXTRA = 'pip install -e ".[optuna]"'


def _optuna(flag: str):
    try:
        import optuna
    except ImportError:
        raise ValueError(f"{flag}: needs Optuna, an optional extra ({EXTRA})") from None
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    return optuna


def check_storage(url: str, flag: str = "--export-optuna") -> None:
    """Refuses, before any simulation, a storage that is not an Optuna RDB URL (or Optuna missing)."""
    _optuna(flag)
    from sqlalchemy.engine import make_url
    from sqlalchemy.exc import ArgumentError

    try:
        make_url(url)
    except ArgumentError:
        raise ValueError(
            f"{flag} {url}: not a database URL; give an Optuna RDB storage such as "
            "sqlite:///study.db or postgresql://user@host/db"
        ) from None


BATCH_TRIALS = 1000  # trials a progress step inserts: one executemany per table


@dataclass(frozen=True)
class TrialRow:
    """One evaluation as an Optuna trial: its state (a ``TrialState``), objective values (None unless COMPLETE),
    the material of each column and the user attributes."""

    state: Any
    values: tuple[float, ...] | None
    params: dict[str, int]
    user_attrs: dict[str, Any]


def _rdb_tables():
    """SQLAlchemy, Optuna's table models and its session scope, or None where this Optuna has them elsewhere."""
    try:
        import sqlalchemy
        from optuna.storages._rdb import models
        from optuna.storages._rdb.storage import _create_scoped_session
    except ImportError:
        return None
    return sqlalchemy, models, _create_scoped_session


def _insert_trials(optuna, storage, target, trials: list[TrialRow], distribution, advance) -> None:
    """``trials`` into the study ``target`` of the RDB ``storage`` in one transaction, numbered after the study's
    trials, every parameter on ``distribution``; ``target.add_trials`` where Optuna's tables are not importable."""
    import datetime

    now = datetime.datetime.now()
    tables = _rdb_tables()
    if tables is None:
        from optuna.trial import create_trial

        for start in range(0, len(trials), BATCH_TRIALS):
            target.add_trials(
                [
                    create_trial(
                        state=t.state,
                        values=None if t.values is None else list(t.values),
                        user_attrs=t.user_attrs,
                        params=t.params,
                        distributions={name: distribution for name in t.params},
                    )
                    for t in trials[start : start + BATCH_TRIALS]
                ]
            )
            advance(min(start + BATCH_TRIALS, len(trials)))
        return
    from optuna.distributions import distribution_to_json

    sqlalchemy, models, _create_scoped_session = tables
    distribution_json = distribution_to_json(distribution)
    moment = now.astimezone(datetime.UTC).replace(tzinfo=None)  # Optuna's tables hold naive UTC
    trial_table = models.TrialModel.__table__
    study_id = storage.get_study_id_from_name(target.study_name)
    with _create_scoped_session(storage.scoped_session) as session:
        models.StudyModel.find_or_raise_by_id(study_id, session, for_update=True)
        number = session.query(models.TrialModel).filter(models.TrialModel.study_id == study_id).count()
        for start in range(0, len(trials), BATCH_TRIALS):
            batch = trials[start : start + BATCH_TRIALS]
            ids = (
                session.execute(
                    sqlalchemy.insert(trial_table).returning(trial_table.c.trial_id, sort_by_parameter_order=True),
                    [
                        {
                            "study_id": study_id,
                            "number": number + start + offset,
                            "state": trial.state,
                            "datetime_start": moment,
                            "datetime_complete": moment,
                        }
                        for offset, trial in enumerate(batch)
                    ],
                )
                .scalars()
                .all()
            )
            params: list[dict] = []
            values: list[dict] = []
            attributes: list[dict] = []
            for trial_id, trial in zip(ids, batch):
                params.extend(
                    {
                        "trial_id": trial_id,
                        "param_name": name,
                        "param_value": distribution.to_internal_repr(value),
                        "distribution_json": distribution_json,
                    }
                    for name, value in trial.params.items()
                )
                for objective, value in enumerate(trial.values or ()):
                    stored, kind = models.TrialValueModel.value_to_stored_repr(value)
                    values.append({"trial_id": trial_id, "objective": objective, "value": stored, "value_type": kind})
                attributes.extend(
                    {"trial_id": trial_id, "key": key, "value_json": json.dumps(value)}
                    for key, value in trial.user_attrs.items()
                )
            for model, rows in (
                (models.TrialParamModel, params),
                (models.TrialValueModel, values),
                (models.TrialUserAttributeModel, attributes),
            ):
                if rows:
                    session.execute(sqlalchemy.insert(model.__table__), rows)
            advance(start + len(batch))


def column_parameter(column: int) -> str:
    return f"column_{column:02d}"


@dataclass(frozen=True)
class ExportedStudy:
    name: str
    diagonal_rule: str
    trials: int


def export(
    storage: str,
    runs,
    outputs: tuple[str, ...],
    columns: int,
    materials: list[str],
    case_line: str,
    run_id: str,
    fmu_sha256: str,
    progress: Progress | None = None,
) -> tuple[ExportedStudy, ...]:
    """Every evaluation of the search ``runs`` into ``storage``, one Optuna study per diagonal rule, named
    "<run_id> <rule>" (ValueError, one line: a study of that name is there already)."""
    optuna = _optuna("--export-optuna")
    from optuna.distributions import IntDistribution
    from optuna.exceptions import DuplicatedStudyError
    from optuna.trial import TrialState

    rdb = optuna.storages.RDBStorage(storage)
    distribution = IntDistribution(1, len(materials))
    names = [column_parameter(c) for c in range(1, columns + 1)]
    exported = []
    for rule in dict.fromkeys(run.label for run in runs):
        name = f"{run_id} {rule}"
        try:
            target = optuna.create_study(storage=rdb, study_name=name, directions=["minimize"] * len(outputs))
        except DuplicatedStudyError:
            raise ValueError(
                f"--export-optuna {storage}: it holds a study named {name!r} already (this run was "
                "exported before); give another storage"
            ) from None
        with warnings.catch_warnings():  # set_metric_names is "experimental" since Optuna 3.2, and kept since
            warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
            target.set_metric_names(list(outputs))
        for key, value in (
            ("case", case_line),
            ("diagonal_rule", rule),
            ("fmu_sha256", fmu_sha256),
            ("materials", list(materials)),
        ):
            target.set_user_attr(key, value)
        trials = []
        for run in runs:
            if run.label != rule:
                continue
            for index, evaluation in enumerate(run.evaluations, start=1):
                attributes: dict[str, Any] = {
                    "method": run.method,
                    "seed": run.seed,
                    "index": index,
                    "order": list(evaluation.order),
                    "materials": [materials[m - 1] for m in evaluation.order],
                    "status": evaluation.status,
                    "fidelity": "search",
                    "seconds": evaluation.seconds,
                }
                if evaluation.ok:
                    state = TrialState.COMPLETE
                    values = tuple(evaluation.values) if len(outputs) > 1 else (evaluation.value,)
                elif evaluation.censored:
                    state, values = TrialState.PRUNED, None
                    attributes["censored_above"] = evaluation.limit
                else:
                    state, values = TrialState.FAIL, None
                    attributes["message"] = evaluation.message
                trials.append(TrialRow(state, values, dict(zip(names, map(int, evaluation.order))), attributes))
        with (progress or Progress()).bar(len(trials), f"Optuna export ({rule})", unit="trial") as advance:
            _insert_trials(optuna, rdb, target, trials, distribution, advance)
        exported.append(ExportedStudy(name, rule, len(trials)))
    return tuple(exported)


def designs_from_storage(url: str) -> list[Design]:
    """Starting designs from an Optuna storage: the best trial of each of its studies (for several objectives,
    each study's Pareto front), read from the ``column_NN`` parameters this module writes."""
    optuna = _optuna("--start-file")
    if url.startswith("sqlite:///") and not Path(url[len("sqlite:///") :]).is_file():
        raise ValueError(
            f"--start-file {url}: no such file {url[len('sqlite:///') :]} (an Optuna storage --export-optuna wrote)"
        )
    try:
        names = optuna.get_all_study_names(storage=url)
    except Exception as exc:  # noqa: BLE001 - any storage error is one line
        raise ValueError(f"--start-file {url}: cannot read the Optuna storage ({str(exc).splitlines()[0]})") from None
    designs: list[Design] = []
    for name in names:
        loaded = optuna.load_study(study_name=name, storage=url)
        complete = [t for t in loaded.get_trials(deepcopy=False) if t.state == optuna.trial.TrialState.COMPLETE]
        if not complete:
            continue
        best = loaded.best_trials if len(loaded.directions) > 1 else [loaded.best_trial]
        for trial in best:
            columns = sorted(k for k in trial.params if k.startswith("column_"))
            if not columns:
                raise ValueError(
                    f"--start-file {url}: study {name!r} has no column_NN parameters (the material of "
                    "each column, as --export-optuna writes them)"
                )
            designs.append(tuple(int(trial.params[k]) for k in columns))
    if not designs:
        raise ValueError(
            f"--start-file {url}: no complete trial in the storage's studies ({', '.join(names) or 'none'})"
        )
    return list(dict.fromkeys(designs))


__all__ = ["ExportedStudy", "check_storage", "designs_from_storage", "export"]
