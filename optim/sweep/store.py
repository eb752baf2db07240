"""The results directory of a sweep; every file is written atomically as soon as it exists.

    DIR/cases/<case_id>.json     one record per finished case (ok or error)
    DIR/models/<layout_id>.npz   the modal model of each analysed layout (jaxflex format)
    DIR/spec.json                the validated specification of the last run
    DIR/results.csv, *.png       table and plots (optim.sweep.table, optim.sweep.plots)

A case counts as finished when its record exists: a killed run loses at most the cases that
were running. Errors of the case itself (stage "fe" or "optimization": a bad layout, an
infeasible move) are final like results; failures of the machinery (a lost worker) are
retried by the next run.
"""

from __future__ import annotations

import contextlib
import json
import warnings
from collections.abc import Iterator, Mapping
from pathlib import Path

from jaxflex.atomic import write_text_atomic
from jaxflex.errors import ModelFileError
from jaxflex.model import ModalModel, load_model

FINAL_STAGES = ("fe", "optimization")


def is_final(record: dict) -> bool:
    """A record that a rerun keeps: a result, or an error of the case itself."""
    return record.get("status") == "ok" or record.get("stage") in FINAL_STAGES


class ResultStore:
    """Read and write the files of one sweep directory."""

    def __init__(self, directory: str | Path):
        self.root = Path(directory)
        self.cases_dir = self.root / "cases"
        self.models_dir = self.root / "models"
        self.cases_dir.mkdir(parents=True, exist_ok=True)
        self.models_dir.mkdir(parents=True, exist_ok=True)
        for stale in (*self.cases_dir.glob(".*.tmp"), *self.models_dir.glob(".*.tmp")):
            with contextlib.suppress(FileNotFoundError):  # left by a killed run
                stale.unlink()

    def iter_records(self) -> Iterator[dict]:
        """Every stored record, one at a time (unreadable files are reported and skipped)."""
        for path in sorted(self.cases_dir.glob("*.json")):
            try:
                record = json.loads(path.read_text(encoding="utf-8"))
                if not isinstance(record.get("case_id"), str):
                    raise ValueError("no case_id")
            except (OSError, ValueError, AttributeError) as exc:
                warnings.warn(f"{path}: unreadable case record ignored ({exc})", stacklevel=2)
                continue
            yield record

    def records(self) -> dict[str, dict]:
        """Every stored record by case id (all in memory; see :meth:`iter_records`)."""
        return {record["case_id"]: record for record in self.iter_records()}

    def record_path(self, case_id: str) -> Path:
        return self.cases_dir / f"{case_id}.json"

    def load_record(self, case_id: str) -> dict:
        return json.loads(self.record_path(case_id).read_text(encoding="utf-8"))

    def save_record(self, record: dict) -> None:
        write_text_atomic(
            self.record_path(record["case_id"]), json.dumps(record, sort_keys=True) + "\n"
        )

    def model_path(self, layout_id: str) -> Path:
        return self.models_dir / f"{layout_id}.npz"

    def save_model(self, layout_id: str, model: ModalModel, fe_summary: dict) -> None:
        model.with_meta(sweep_fe=fe_summary).save(self.model_path(layout_id))

    def load_model(self, layout_id: str) -> tuple[ModalModel, dict] | None:
        """(model, FE summary) of a stored layout, or None (missing or unreadable)."""
        path = self.model_path(layout_id)
        if not path.is_file():
            return None
        try:
            model = load_model(path)
        except ModelFileError as exc:
            warnings.warn(f"{path}: stored model ignored ({exc})", stacklevel=2)
            return None
        summary = model.meta.get("sweep_fe")
        return (model, summary) if isinstance(summary, dict) else None

    def save_spec(self, source: dict) -> None:
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
