"""CSV files written for people hold no cell a spreadsheet would execute: text starting
with =, +, -, @, a tab or a carriage return is escaped in the sweep's results.csv (and read
back unchanged); the trajectory file holds numbers only."""

from __future__ import annotations

import copy
import csv

import numpy as np
from conftest import smooth_move
from sweep_cases import SPEC

from jaxflex import as_move
from jaxflex._trajectory_io import COLUMNS, write_trajectory_csv
from optim.sweep import load_spec, read_table
from optim.sweep.cases import expand
from optim.sweep.table import FORMULA_STARTS, table_rows, write_table

HOSTILE = ['=HYPERLINK("http://x")', "+1+1", "-2+3", "@SUM(A1)", "'=quoted"]
# names in a spec are stripped of white space; error messages are not
ERRORS = ["\tcmd", "\rcmd", "=1\r\n=2"]


def _raw_cells(path):
    with open(path, newline="", encoding="utf-8") as handle:
        return [cell for row in csv.reader(handle) for cell in row]


def test_results_table_escapes_formulas_and_reads_them_back(tmp_path):
    spec = copy.deepcopy(SPEC)
    cups = spec["layouts"][0]["cups"]
    spec["layouts"] = [  # other radii: cases of other layouts (ids from the content)
        {"name": name, "cups": [[x, y, 0.03 + 0.001 * i] for x, y, _ in cups]}
        for i, name in enumerate(HOSTILE)
    ]
    spec["moves"] = [{"name": "=move", "distance_m": [-0.4, 0, 0.1]}]
    spec.pop("grids")
    cases = expand(load_spec(spec))
    path = tmp_path / "results.csv"
    errors = {
        case.case_id: {"status": "error", "stage": "fe", "error": text}
        for case, text in zip(cases, ERRORS, strict=False)
    }
    write_table(path, table_rows(cases, errors))
    assert not [c for c in _raw_cells(path) if c.startswith(FORMULA_STARTS)]
    rows = read_table(path)
    assert [r["layout"] for r in rows] == HOSTILE
    assert {r["move"] for r in rows} == {"=move"}
    assert [r["error"] for r in rows[: len(ERRORS)]] == ["\tcmd", "\ncmd", "=1\n=2"]
    assert len(rows) == len(HOSTILE)  # a carriage return above became a line break
    assert {r["distance_m"] for r in rows} == {"-0.4 0 0.1"}


def test_trajectory_file_is_numbers_only(tmp_path):
    path = tmp_path / "trajectory.csv"
    write_trajectory_csv(path, as_move(smooth_move(40, 0.01), 0.01))
    header, *cells = path.read_text(encoding="utf-8").splitlines()
    assert header.split(",") == list(COLUMNS)
    values = np.array([[float(v) for v in line.split(",")] for line in cells])
    assert values.shape == (41, len(COLUMNS)) and np.isfinite(values).all()
    assert not [c for line in cells for c in line.split(",") if c.startswith(("=", "@", "+"))]
