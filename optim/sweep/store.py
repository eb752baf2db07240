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

    def records(self) -> dict[str, dict]:
        """Every stored record by case id (unreadable files are reported and ignored)."""
        out = {}
        for path in sorted(self.cases_dir.glob("*.json")):
            try:
                record = json.loads(path.read_text(encoding="utf-8"))
                out[record["case_id"]] = record
            except (OSError, ValueError, KeyError, TypeError) as exc:
                warnings.warn(f"{path}: unreadable case record ignored ({exc})", stacklevel=2)
        return out

    def save_record(self, record: dict) -> None:
        path = self.cases_dir / f"{record['case_id']}.json"
        write_text_atomic(path, json.dumps(record, sort_keys=True) + "\n")

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
