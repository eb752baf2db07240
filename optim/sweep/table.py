"""The results table of a sweep: one row per case in the spec's order, written as CSV.

Columns (SI units in the names): index, case_id, layout, move, status ("ok", "error",
"pending"), stage (of an error: "fe", "optimization", "worker"), n_cups, cups
("x:y:r;..." in m), distance_m ("x y z"), n_dof, n_modes, n_points, first_freq_hz, mass_kg,
cycle_time_s (exact, nominal model), worst_cycle_time_s (robust mode: worst case over the
check grid), transfer_time_s, settle_time_s, n_steps, kinematic_floor_s, best_baseline,
best_baseline_cycle_time_s, peak_deviation_m (during the move, exact samples every dt / 8),
deviation_at_stop_m, cycle_over_floor, fe_wall_s, opt_wall_s, fe_cpu_s, opt_cpu_s (wall and
CPU time of the two steps, s; the FE step is shared by the moves of a layout), worker, error.
Floats are written with full precision (repr), so equal runs give equal files apart from the
wall-time and worker columns (:data:`RUN_COLUMNS`).

Text a spreadsheet would execute as a formula (a layout named ``=HYPERLINK(...)``: cells
starting with ``=``, ``+``, ``-``, ``@``, a tab or a carriage return) is written with a
leading apostrophe, which spreadsheets show as text; a leading apostrophe of the text itself
is doubled, so :func:`read_table` gives back the text that was written (a carriage return in
it becomes a line break).
"""

from __future__ import annotations

import csv
from collections.abc import Iterable, Iterator, Mapping
from pathlib import Path

from jaxflex.files import atomic_open
from optim.sweep.cases import Case

_CASE = (
    "index",
    "case_id",
    "layout",
    "move",
    "status",
    "stage",
    "n_cups",
    "cups",
    "distance_m",
)
_FE = ("n_dof", "n_modes", "n_points", "first_freq_hz", "mass_kg")
_OPT = (
    "cycle_time_s",
    "worst_cycle_time_s",
    "transfer_time_s",
    "settle_time_s",
    "n_steps",
    "kinematic_floor_s",
    "best_baseline",
    "best_baseline_cycle_time_s",
    "peak_deviation_m",
    "deviation_at_stop_m",
)
RUN_COLUMNS = ("fe_wall_s", "opt_wall_s", "fe_cpu_s", "opt_cpu_s", "worker")  # vary per run
COLUMNS = (*_CASE, *_FE, *_OPT, "cycle_over_floor", *RUN_COLUMNS, "error")


def row(case: Case, record: dict | None) -> dict:
    """The table row of ``case`` from its record (None: not computed yet)."""
    out = {
        "index": case.index,
        "case_id": case.case_id,
        "layout": case.layout.name,
        "move": case.move.name,
        "status": "pending" if record is None else record["status"],
        "n_cups": len(case.layout.cups),
        "cups": ";".join(":".join(f"{v:g}" for v in cup) for cup in case.layout.cups),
        "distance_m": " ".join(f"{v:g}" for v in case.move.distance_m),
    }
    if record is None:
        return out
    out["stage"] = record.get("stage")
    out["worker"] = record.get("worker")
    out["error"] = record.get("error")
    fe, opt = record.get("fe") or {}, record.get("opt") or {}
    out.update({k: fe.get(k) for k in (*_FE, "fe_wall_s", "fe_cpu_s")})
    out.update({k: opt.get(k) for k in (*_OPT, "opt_wall_s", "opt_cpu_s")})
    for key in ("fe_wall_s", "fe_cpu_s"):  # an FE error carries its own timing
        if key in record:
            out[key] = record[key]
    if opt.get("cycle_time_s") is not None:
        out["cycle_over_floor"] = opt["cycle_time_s"] / opt["kinematic_floor_s"]
    return out


# what a spreadsheet reads as the start of a formula; the apostrophe marks escaped text
FORMULA_STARTS = ("=", "+", "-", "@", "\t", "\r")
ESCAPE = "'"


def _cell(value) -> str:
    if value is None:
        return ""
    if isinstance(value, float):
        return repr(value)
    if not isinstance(value, str):
        return str(value)
    # a carriage return would end the row unquoted (the rows end in "\n"): a line break
    text = value.replace("\r\n", "\n").replace("\r", "\n")
    return ESCAPE + text if text.startswith((*FORMULA_STARTS, ESCAPE)) else text


def _unescaped(text: str) -> str:
    return text[1:] if text.startswith(ESCAPE) else text


def table_rows(cases: Iterable[Case], records: Mapping[str, dict]) -> Iterator[dict]:
    """The rows of ``cases``, one at a time (records are read as needed)."""
    for case in cases:
        yield row(case, records.get(case.case_id))


def write_table(path: str | Path, rows: Iterable[dict]) -> None:
    """Write ``rows`` as CSV (header :data:`COLUMNS`) atomically, row by row."""
    with atomic_open(path, "w") as handle:
        writer = csv.writer(handle, lineterminator="\n")
        writer.writerow(COLUMNS)
        for r in rows:
            writer.writerow([_cell(r.get(c)) for c in COLUMNS])


def read_table(path: str | Path) -> list[dict[str, str]]:
    """The rows of a results CSV as dicts of strings (empty string for missing values), text
    unescaped (module docstring)."""
    with open(path, newline="", encoding="utf-8") as handle:
        return [{k: _unescaped(v) for k, v in row.items()} for row in csv.DictReader(handle)]
