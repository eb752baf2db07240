"""The results directory of a sweep; every file is written atomically as soon as it exists.

    DIR/cases/<case_id>.json     one record per finished case (ok or error), sealed
    DIR/models/<layout_id>.npz   the modal model of each analysed layout (jaxflex format)
    DIR/spec.json                the validated specification of the last run
    DIR/results.csv, *.png       table and plots (optim.sweep.table, optim.sweep.plots)
    DIR/rejected/                stored files that failed their check on read, kept aside

A case counts as finished when its record exists and passes optim.sweep.records.check_record
(a stored model: jaxflex's model file checks, its FE summary and the sweep's sizes). A file
that does not is reported (JaxflexWarning naming the file and what is wrong), moved to
``rejected/`` and its case computed again: never trusted, never fatal. A killed run loses at
most the cases that were running. The directory is the sweep's resumable state: a run that
fails or is interrupted keeps what it stored and the table of it (pending cases marked; not
undone with the command's other outputs, jaxflex.files.kept_writes). Errors
of the case itself (stage "fe" or "optimization": a bad layout, an infeasible move) are final
like results; failures of the machinery (a lost worker) are retried by the next run.
"""

from __future__ import annotations

import contextlib
import json
import os
import warnings
from collections.abc import Iterator, Mapping
from pathlib import Path

from jaxflex.errors import InputError, JaxflexWarning, ModelError, ModelFileError
from jaxflex.files import (
    check_target,
    kept_writes,
    make_output_dir,
    remove_stale_temporaries,
    write_text_atomic,
)
from jaxflex.model import ModalModel, load_model
from optim.sweep.records import RecordError, as_stored, check_fe_summary, check_record

FINAL_STAGES = ("fe", "optimization")
ROOT_FILES = ("spec.json", "results.csv", "sweep.png", "deviation.png")
REJECTED = "rejected"


def is_final(record: dict) -> bool:
    """A record that a rerun keeps: a result, or an error of the case itself."""
    return record.get("status") == "ok" or record.get("stage") in FINAL_STAGES


class ResultStore:
    """Read and write the files of one sweep directory. ``dt_s`` (the sweep's sample step),
    when given, is part of the checks of the records on read."""

    def __init__(self, directory: str | Path, dt_s: float | None = None):
        self.root = Path(directory)
        self.cases_dir = self.root / "cases"
        self.models_dir = self.root / "models"
        self.dt_s = dt_s
        if self.root.is_dir():  # before anything is made: never a link, FIFO or device there
            for name in ROOT_FILES:
                check_target(self.root / name)
            for folder in (self.cases_dir, self.models_dir):
                if os.path.lexists(folder):
                    make_output_dir(folder)  # an existing one is only checked
        with kept_writes():
            for folder in (self.root, self.cases_dir, self.models_dir):
                make_output_dir(folder)

    def remove_temporaries(self) -> None:
        """Remove the temporary files a killed run left (call while holding the lock)."""
        for stale in (*self.cases_dir.glob(".*.tmp"), *self.models_dir.glob(".*.tmp")):
            with contextlib.suppress(FileNotFoundError, IsADirectoryError):
                stale.unlink()
        for name in ROOT_FILES:
            remove_stale_temporaries(self.root / name)

    def reject(self, path: Path, problem: str) -> None:
        """Report ``path`` as untrusted and move it to ``rejected/`` (its case is computed
        again; the file stays for whoever wants to look at it)."""
        target_dir = self.root / REJECTED
        target_dir.mkdir(exist_ok=True)
        target = target_dir / path.name
        count = 1
        while target.exists():
            target = target_dir / f"{path.name}.{count}"
            count += 1
        try:
            os.replace(path, target)
            where = f"moved to {target}"
        except OSError as exc:
            where = f"could not be moved aside ({exc})"
        warnings.warn(
            f"{path}: {problem}; not trusted, {where}, and its case computed again",
            JaxflexWarning,
            stacklevel=3,
        )

    def _read_checked(self, path: Path, case_id: str) -> dict:
        try:
            record = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, ValueError, RecursionError) as exc:
            raise RecordError(f"unreadable ({type(exc).__name__}: {exc})") from exc
        check_record(record, case_id, self.dt_s)
        return record

    def read_record(self, case_id: str) -> dict | None:
        """The stored record of ``case_id`` if there is one that passes its check; a record
        that does not is rejected (:meth:`reject`) and None returned."""
        path = self.record_path(case_id)
        if not os.path.lexists(path):
            return None
        try:
            return self._read_checked(path, case_id)
        except RecordError as exc:
            self.reject(path, f"case record {exc}")
            return None

    def iter_records(self) -> Iterator[dict]:
        """Every stored record that passes its check, one at a time (others are reported
        and skipped, left where they are: they may belong to another spec's cases)."""
        for path in sorted(self.cases_dir.glob("*.json")):
            try:
                yield self._read_checked(path, path.stem)
            except RecordError as exc:
                warnings.warn(f"{path}: case record ignored: {exc}", JaxflexWarning, stacklevel=2)

    def records(self) -> dict[str, dict]:
        """Every stored record by case id (all in memory; see :meth:`iter_records`)."""
        return {record["case_id"]: record for record in self.iter_records()}

    def record_path(self, case_id: str) -> Path:
        return self.cases_dir / f"{case_id}.json"

    def load_record(self, case_id: str) -> dict:
        """The stored record of ``case_id``; InputError naming the file if it is missing or
        fails its check (it changed after the run read it)."""
        path = self.record_path(case_id)
        try:
            return self._read_checked(path, case_id)
        except RecordError as exc:
            raise InputError(f"{path}: case record {exc}") from None

    def save_record(self, record: dict) -> dict:
        """Store a computed record, sealed (optim.sweep.records.as_stored: a record that fails
        its own check is stored as an error saying so); returns what was stored."""
        stored = as_stored(record, self.dt_s)
        with kept_writes():
            write_text_atomic(
                self.record_path(record["case_id"]), json.dumps(stored, sort_keys=True) + "\n"
            )
        return stored

    def model_path(self, layout_id: str) -> Path:
        return self.models_dir / f"{layout_id}.npz"

    def save_model(self, layout_id: str, model: ModalModel, fe_summary: dict) -> None:
        with kept_writes():
            model.with_meta(sweep_fe=fe_summary).save(self.model_path(layout_id))

    def load_model(self, layout_id: str) -> tuple[ModalModel, dict] | None:
        """(model, FE summary) of a stored layout, or None (missing; or rejected: unreadable,
        invalid, or without an FE summary that is valid and of the model's size)."""
        path = self.model_path(layout_id)
        if not os.path.lexists(path):
            return None
        try:
            model = load_model(path)
            summary = model.meta.get("sweep_fe")
            try:
                check_fe_summary(summary)
            except RecordError as exc:
                raise ModelError(f"meta sweep_fe: {exc}") from None
            size = (model.n_modes, model.n_points)
            if size != (summary["n_modes"], summary["n_points"]):
                raise ModelError(
                    f"has {size[0]} modes x {size[1]} points, its FE summary "
                    f"{summary['n_modes']} x {summary['n_points']}"
                )
        except (ModelFileError, ModelError) as exc:
            self.reject(path, f"stored model {exc}")
            return None
        return model, summary

    def save_spec(self, source: dict) -> None:
        with kept_writes():
            write_text_atomic(self.root / "spec.json", json.dumps(source, indent=2) + "\n")


class StoredRecords(Mapping):
    """The records of a run's cases by case id, read from the store when asked for: memory
    holds each case's status only, so a sweep of any size keeps its client small."""

    def __init__(self, store: ResultStore):
        self._store = store
        self._status: dict[str, str] = {}

    def add(self, record: dict) -> None:
        """Count a record that is in the store."""
        self._status[record["case_id"]] = record["status"]

    def count(self, status: str) -> int:
        return sum(s == status for s in self._status.values())

    def __getitem__(self, case_id: str) -> dict:
        if case_id not in self._status:
            raise KeyError(case_id)
        return self._store.load_record(case_id)

    def __contains__(self, case_id: object) -> bool:
        return case_id in self._status

    def __iter__(self) -> Iterator[str]:
        return iter(self._status)

    def __len__(self) -> int:
        return len(self._status)
