"""Stored sweep records and models are checked on read: a damaged, edited or forged one is
reported by file, moved to rejected/ and its case computed again; two sweeps never write one
directory at once (the tiny sweep of tests/sweep_cases.py)."""

from __future__ import annotations

import json
import math
import shutil
import warnings
import zipfile

import numpy as np
import pytest
from sweep_cases import SPEC, assert_same_table, start_sweep, wait_for_records

from jaxflex.errors import InputError, JaxflexWarning
from optim.sweep import load_spec, read_table, run_sweep
from optim.sweep.records import RecordError, as_stored, check_record, sealed
from optim.sweep.store import ResultStore


def _nan_cycle(r):
    r["opt"]["cycle_time_s"] = math.nan


def _blank(r):
    for key in list(r):
        if key not in ("case_id", "status"):
            del r[key]


def _forged_error(r):
    _blank(r)
    r.update(status="error", stage="optimization", error_type="InputError", error="forged")


def _edit_cycle(r):
    r["opt"]["cycle_time_s"] = r["opt"]["transfer_time_s"] * 0.5


# (what the issue lists, how the record is damaged, reseal: the seal is recomputed, as a
# forger who knows the format would do, so that the schema or the consistency check must
# catch it; the message part it must give)
DAMAGES = [
    ("kinematic_floor_s: 0", lambda r: r["opt"].update(kinematic_floor_s=0), True,
     "opt.kinematic_floor_s: 0 is outside"),
    ("opt: [1, 2]", lambda r: r.update(opt=[1, 2]), True, "opt: must be an object"),
    ('cycle_time_s: "abc"', lambda r: r["opt"].update(cycle_time_s="abc"), True,
     "opt.cycle_time_s: must be a number"),
    ("NaN cycle time", _nan_cycle, True, "opt.cycle_time_s: nan is outside"),
    ("blank row", _blank, True, "fe: must be an object"),
    ("edited cycle time", _edit_cycle, False, "does not match its seal"),
    ("edited cycle time, resealed", _edit_cycle, True, "is not the larger of the transfer"),
    ("forged error", _forged_error, False, "does not match its seal"),
]  # fmt: skip


@pytest.fixture(scope="module")
def good_record(serial_sweep):
    run, _ = serial_sweep
    return next(r for r in run.records.values() if r["status"] == "ok")


@pytest.mark.parametrize(
    ("what", "damage", "reseal", "message"), DAMAGES, ids=[d[0] for d in DAMAGES]
)
def test_a_damaged_record_is_named(good_record, what, damage, reseal, message):
    check_record(good_record, good_record["case_id"], 0.01)  # the undamaged one passes
    record = json.loads(json.dumps(good_record))
    record.pop("sha256")
    damage(record)
    record = sealed(record) if reseal else {**record, "sha256": good_record["sha256"]}
    with pytest.raises(RecordError, match=message.replace("[", r"\[")):
        check_record(record, good_record["case_id"], 0.01)


def test_records_of_another_case_or_grid_are_refused(good_record):
    with pytest.raises(RecordError, match="is not its file's 'other'"):
        check_record(good_record, "other", 0.01)
    with pytest.raises(RecordError, match="is not n_steps x dt"):
        check_record(good_record, good_record["case_id"], 0.02)


def test_bad_records_and_models_are_reported_and_recomputed(serial_sweep, tmp_path, fuzz_tally):
    """Every damage of DAMAGES, a record that is a directory and a stored model whose
    meta_json is "[1,2]" in one results directory: the rerun names each file, moves it to
    rejected/, computes exactly those cases and ends with the undamaged table."""
    run, reference = serial_sweep
    out = tmp_path / "out"
    shutil.copytree(run.directory, out)
    store = ResultStore(out)
    ok = [c for c in run.cases if run.records[c.case_id]["status"] == "ok"]
    damaged = {}
    for case, (what, damage, reseal, _) in zip(ok, DAMAGES, strict=False):
        record = store.load_record(case.case_id)
        record.pop("sha256")
        damage(record)
        record = sealed(record) if reseal else {**record, "sha256": "0" * 64}
        store.record_path(case.case_id).write_text(json.dumps(record))
        damaged[case.case_id] = what
    # the bad layout's error record (of the first move) is a directory
    directory_case = next(c for c in run.cases if run.records[c.case_id]["status"] == "error")
    store.record_path(directory_case.case_id).unlink()
    store.record_path(directory_case.case_id).mkdir()
    damaged[directory_case.case_id] = "a record that is a directory"
    # a stored model whose meta_json is "[1,2]" (its cases keep their records: only the
    # model is recomputed, when a case of that layout is)
    model_layout = ok[0].layout_id
    _rewrite_member(store.model_path(model_layout), "meta_json", np.asarray("[1,2]"))

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        again = run_sweep(load_spec(SPEC), out, executor="serial", progress=False, plots=False)
    messages = [str(w.message) for w in caught if issubclass(w.category, JaxflexWarning)]
    named = {cid for cid in damaged if any(f"{cid}.json" in m for m in messages)}
    model_named = any(f"{model_layout}.npz" in m and "meta_json" in m for m in messages)
    fuzz_tally(
        "sweep records",
        tried=len(damaged) + 1,
        clear_errors=len(named) + model_named,
        crashes=0,
        hangs=0,
        corrupt_accepted=len(damaged) - len(named) + (not model_named),
    )
    assert named == set(damaged), messages
    assert model_named, messages
    assert again.computed == len(damaged)
    assert sorted(p.name for p in (out / "rejected").iterdir()) == sorted(
        [f"{cid}.json" for cid in damaged] + [f"{model_layout}.npz"]
    )
    assert_same_table(read_table(out / "results.csv"), reference)


def _rewrite_member(path, name, value) -> None:
    """Replace one member of an .npz archive (the others copied as they are)."""
    with zipfile.ZipFile(path) as src:
        members = {i.filename: src.read(i) for i in src.infolist()}
    tmp = path.with_suffix(".part")
    with zipfile.ZipFile(tmp, "w") as dst:
        for member, data in members.items():
            if member == f"{name}.npy":
                with dst.open(member, "w") as handle:
                    np.lib.format.write_array(handle, value)
            else:
                dst.writestr(member, data)
    tmp.replace(path)


def test_a_second_sweep_on_a_busy_directory_is_refused(tmp_path):
    """While one sweep writes a directory, another on the same directory stops at once with
    a message naming it, before computing anything."""
    spec_path = tmp_path / "spec.json"
    spec_path.write_text(json.dumps(SPEC))
    out = tmp_path / "out"
    proc = start_sweep(spec_path, out, "--serial")
    try:
        wait_for_records(proc, out / "cases", 1)
        n_before = len(list((out / "cases").glob("*.json")))
        with pytest.raises(InputError, match="is being written by another jaxflex run"):
            run_sweep(load_spec(SPEC), out, executor="serial", progress=False, plots=False)
        assert proc.poll() is None
        assert len(list((out / "cases").glob("*.json"))) >= n_before
    finally:
        proc.kill()
        proc.communicate()


def test_a_computed_record_that_fails_its_check_is_stored_as_an_error(good_record):
    """Stored as computed it would be rejected and recomputed on every rerun: it becomes a
    final error naming what is wrong."""
    record = json.loads(json.dumps(good_record))
    record["opt"]["cycle_time_s"] = math.inf
    stored = as_stored(record, 0.01)
    check_record(stored, record["case_id"], 0.01)
    assert (stored["status"], stored["stage"]) == ("error", "optimization")
    assert "fails its check: opt.cycle_time_s: inf is outside" in stored["error"]
    assert as_stored(good_record, 0.01) == good_record  # a good one is stored as it is
