"""The journal and the run folder: nothing a command, a kill or an edit does loses work or is trusted blindly."""

from __future__ import annotations

import json
import math
import multiprocessing
import os

import pytest

from orchestrator.journal import JOURNAL_NAME, Journal, JournalError
from orchestrator.runfolder import FolderError, RunFolder, TEMP_PREFIX, make_temp_root, remove_dead_temp_roots
from orchestrator.types import Evaluation, RunOutputs, failed

pytestmark = pytest.mark.quick  # a first check: python -m pytest -m quick

KINDS = {"evaluation": Evaluation}
SETTINGS = {"case": {"F_total": 1200.0, "rules": ["receiver", "mean"]}, "fmu_sha256": "abc"}


OUTPUT_NAMES = (
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


def evaluation(order=(1, 2, 3), value=1405.9057831694442):
    outputs = RunOutputs(
        dict(zip(OUTPUT_NAMES, (value, value + 1.5, 0.31, 0.72, 1.0, 2.0, 3.0, 4.0, -5.0, 1e-7, 100, 10, 2))), 8.0
    )
    return Evaluation(order, value, "ok", "", 0.001, outputs)


def write(folder, entries):
    with Journal(folder, SETTINGS, KINDS) as journal:
        for key, result in entries:
            journal.append(key, result)
        return journal.run_id


def test_a_resumed_journal_gives_back_the_typed_results_bit_for_bit(tmp_path):
    entries = [
        ("a#1,2,3", evaluation()),
        ("a#3,2,1", failed((3, 2, 1), "diverged")),
        ("b#1,2,3", evaluation(value=0.1 + 0.2)),
    ]
    write(tmp_path, entries)
    with Journal(tmp_path, SETTINGS, KINDS, resume=True) as journal:
        loaded = journal.load()
    assert loaded == dict(entries)
    assert loaded["b#1,2,3"].value == 0.1 + 0.2  # repr round trip: exact


class WrittenBefore:
    """An evaluation's record as journals already on disk hold it: the outputs flat, max_compression null for
    an FMU without that output."""

    kind = "evaluation"

    def as_record(self):
        return {
            "order": [1, 2, 3],
            "value": 1405.9057831694442,
            "status": "ok",
            "message": "",
            "seconds": 0.001,
            "outputs": {
                "peak_backplate_force": 1405.9057831694442,
                "peak_backplate_force_continuous": 1407.4057831694442,
                "peak_time": 0.31,
                "last_contact_time": 0.72,
                "kinetic_energy": 1.0,
                "potential_energy": 2.0,
                "external_work": 3.0,
                "dissipated_energy": 4.0,
                "nonreciprocal_work": -5.0,
                "energy_balance_error": 1e-07,
                "rhs_evaluations": 100,
                "steps_accepted": 10,
                "steps_rejected": 2,
                "horizon": 8.0,
                "max_compression": None,
            },
            "values": [],
            "limit": None,
            "stopped_at": None,
            "cases": [],
            "work": None,
        }


def test_a_journal_written_with_the_outputs_flat_resumes_with_its_outputs_by_name(tmp_path):
    write(tmp_path, [("a#1,2,3", WrittenBefore())])
    with Journal(tmp_path, SETTINGS, KINDS, resume=True) as journal:
        loaded = journal.load()["a#1,2,3"]
    expected = evaluation().outputs
    assert loaded.outputs.horizon == 8.0 and isinstance(loaded.outputs["rhs_evaluations"], int)
    assert {name: loaded.outputs[name] for name in OUTPUT_NAMES} == expected.values
    assert math.isnan(loaded.outputs["max_compression"])  # null: no number
    assert loaded.value == loaded.outputs["peak_backplate_force"]


def test_an_unknown_output_is_refused_naming_the_outputs_there_are():
    with pytest.raises(KeyError) as refused:
        evaluation().outputs["impulse"]
    assert str(refused.value).startswith("no output 'impulse': the FMU's outputs are peak_backplate_force, ")


def test_settings_are_compared_by_value_and_a_difference_is_named(tmp_path):
    write(tmp_path, [])
    with Journal(tmp_path, json.loads(json.dumps(SETTINGS)), KINDS, resume=True):
        pass
    other = {**SETTINGS, "case": {**SETTINGS["case"], "F_total": 2400.0}}
    with pytest.raises(JournalError, match=r"case\.F_total=1200\.0 there, 2400\.0 here"):
        Journal(tmp_path, other, KINDS, resume=True)


def test_a_cut_last_line_is_removed_before_the_resume_appends(tmp_path):
    write(tmp_path, [("a#1,2,3", evaluation()), ("a#2,1,3", evaluation((2, 1, 3)))])
    path = tmp_path / JOURNAL_NAME
    data = path.read_bytes()
    path.write_bytes(data[:-40])  # a kill or a full disk in the middle of the last line
    with Journal(tmp_path, SETTINGS, KINDS, resume=True) as journal:
        assert journal.repaired
        assert set(journal.load()) == {"a#1,2,3"}
        journal.append("a#2,1,3", evaluation((2, 1, 3)))
    for _ in range(2):  # every later resume still reads it
        with Journal(tmp_path, SETTINGS, KINDS, resume=True) as journal:
            assert not journal.repaired and set(journal.load()) == {"a#1,2,3", "a#2,1,3"}


def test_a_changed_or_forged_line_is_refused_with_its_number(tmp_path):
    write(tmp_path, [("a#1,2,3", evaluation()), ("a#1,3,2", evaluation((1, 3, 2), 1500.0))])
    path = tmp_path / JOURNAL_NAME
    lines = path.read_text().splitlines()
    forged = json.loads(lines[2])
    forged["result"]["value"] = 1000.0  # this run's key, another value
    path.write_text("\n".join(lines[:2] + [json.dumps(forged)]) + "\n")
    with pytest.raises(JournalError, match=r"line 3 fails its checksum"):
        Journal(tmp_path, SETTINGS, KINDS, resume=True)


def test_a_line_of_another_run_is_refused(tmp_path):
    write(tmp_path / "one", [("a#1,2,3", evaluation())])
    write(tmp_path / "two", [("a#1,2,3", evaluation())])
    one = (tmp_path / "one" / JOURNAL_NAME).read_text().splitlines()
    two = (tmp_path / "two" / JOURNAL_NAME).read_text().splitlines()
    (tmp_path / "one" / JOURNAL_NAME).write_text("\n".join(one + two[1:]) + "\n")
    with pytest.raises(JournalError, match="line 3 belongs to another run"):
        Journal(tmp_path / "one", SETTINGS, KINDS, resume=True)


def test_a_new_journal_never_replaces_an_existing_one(tmp_path):
    write(tmp_path, [("a#1,2,3", evaluation())])
    with pytest.raises(FileExistsError):
        Journal(tmp_path, SETTINGS, KINDS)
    assert Journal.inspect(tmp_path).entries == 1


# ---------------------------------------------------------------------------------------------- run folders
def start(out, **flags):
    folder = RunFolder.open(out, resume=flags.get("resume", False), overwrite=flags.get("overwrite", False))
    return folder


def finish(folder, entries=()):
    with Journal(folder.partial, SETTINGS, KINDS, resume=folder.previous is not None) as journal:
        for key, result in entries:
            journal.append(key, result)
        (folder.partial / "report.html").write_text(journal.run_id)
        journal.finish()
    folder.publish()
    folder.release()


def test_an_unfinished_run_is_refused_without_resume_and_kept_with_overwrite(tmp_path):
    out = tmp_path / "results"
    folder = start(out)
    with Journal(folder.partial, SETTINGS, KINDS) as journal:
        journal.append("a#1,2,3", evaluation())
        first = journal.run_id
    folder.release()  # the run died
    with pytest.raises(FolderError, match=r"holds an unfinished run \(1 results.*--resume.*--overwrite"):
        start(out)
    resumed = start(out, resume=True)
    assert resumed.previous.run_id == first
    resumed.release()
    again = start(out, overwrite=True)
    assert (again.partial / f"journal-{first}.jsonl").is_file()
    finish(again)
    assert (out / f"journal-{first}.jsonl").is_file() and (out / "report.html").is_file()


def test_a_finished_run_is_replaced_only_as_a_whole(tmp_path):
    out = tmp_path / "results"
    finish(start(out), [("a#1,2,3", evaluation())])
    first = (out / "report.html").read_text()
    second = start(out)  # the same command again: the old run stays until the new one is finished
    assert (out / "report.html").read_text() == first and (out / JOURNAL_NAME).is_file()
    finish(second)
    assert (out / "report.html").read_text() != first
    assert not second.partial.exists()
    replay = start(out, resume=True)  # a finished run resumed: its journal replayed, its report rewritten
    assert replay.previous.finished and (replay.partial / JOURNAL_NAME).is_file()
    finish(replay)
    assert Journal.inspect(out).finished


def test_one_run_per_folder(tmp_path):
    out = tmp_path / "results"
    holder = start(out)
    with pytest.raises(FolderError, match=rf"in use by a running run \(pid {os.getpid()} on "):
        start(out, resume=True)
    holder.release()
    start(out).release()


def test_a_finished_run_leaves_no_lock_file_beside_its_folder(tmp_path):
    out = tmp_path / "results"
    run = start(out)
    assert run.lock_path.is_file()
    finish(run)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["results"]


def test_a_lock_removed_as_it_was_taken_is_taken_again_at_the_path(tmp_path, monkeypatch):
    """The run that held the lock removes its file as another run locks it: that run must lock the file now at
    the path (a third run would create and lock it), not the removed one."""
    import portalocker

    from orchestrator import runfolder

    out = tmp_path / "results"
    lock_path = out.with_name(f".{out.name}.lock")
    real_lock, locked = portalocker.lock, []

    def lock_as_the_holder_leaves(handle, flags):
        real_lock(handle, flags)
        if not locked:
            lock_path.unlink()  # the holder ended between our open and our lock
        locked.append(os.fstat(handle.fileno()).st_ino)

    monkeypatch.setattr(runfolder.portalocker, "lock", lock_as_the_holder_leaves)
    run = start(out)
    monkeypatch.setattr(runfolder.portalocker, "lock", real_lock)
    assert len(locked) == 2  # it tried again
    with open(lock_path) as other, pytest.raises(portalocker.exceptions.LockException):
        portalocker.lock(other, portalocker.LOCK_EX | portalocker.LOCK_NB)  # the file at the path is the one held
    run.release()


def _hold_lock_then_die(out, ready):
    RunFolder.open(out, resume=False, overwrite=False)
    ready.set()
    os._exit(0)  # dies holding the lock


def test_a_dead_runs_lock_does_not_block(tmp_path):
    out = tmp_path / "results"
    ready = multiprocessing.Event()
    process = multiprocessing.get_context("fork").Process(target=_hold_lock_then_die, args=(out, ready))
    process.start()
    process.join(10)
    assert ready.is_set()
    start(out).release()


def test_a_folder_of_other_files_is_never_replaced(tmp_path):
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "thesis.tex").write_text("precious")
    with pytest.raises(FolderError, match="holds files that are not a run of this program"):
        start(tmp_path / "mine")
    assert (tmp_path / "mine" / "thesis.tex").read_text() == "precious"


def test_a_dead_runs_temporary_folder_is_removed_by_the_next_run(tmp_path, monkeypatch):
    monkeypatch.setattr("tempfile.tempdir", str(tmp_path))
    dead = tmp_path / f"{TEMP_PREFIX}999999999-x"
    dead.mkdir()
    mine = make_temp_root()
    assert not dead.exists() and os.path.isdir(mine)
    assert remove_dead_temp_roots() == 0
