"""Unit slips caught: a threshold above every deviation (mm given as m) or below what the
model resolves, a robust grid that checks one corner; printed by the command line as one
warning line each, kept in the report."""

from __future__ import annotations

import json

import pytest
from conftest import run_jaxflex
from test_optim_optimize import few_mode_model

import optim
from jaxflex._advice import DEFAULT_RESOLUTION, model_resolution, threshold_advice
from optim.advice import grid_advice


def kinds(advice):
    return [kind for kind, _message in advice]


def test_threshold_advice():
    peak = 6e-3
    assert kinds(threshold_advice(0.5, 0.0, peak, 1e-3)) == ["threshold_above_peak"]
    assert "0.5 mm is 0.0005" in threshold_advice(0.5, 0.0, peak, 1e-3)[0][1]
    assert kinds(threshold_advice(1e-9, 0.9, peak, 1e-3)) == ["threshold_below_resolution"]
    assert threshold_advice(5e-4, 0.9, peak, 1e-3) == []  # a threshold meant as given
    assert threshold_advice(5e-4, 0.0, 4e-4, 1e-3) != []  # never exceeded: above the peak


def test_model_resolution_reads_the_truncation_from_fem_meta():
    model = few_mode_model()  # no fem meta: the default
    assert model_resolution(model, [0, 0, 1]) == DEFAULT_RESOLUTION
    meta = {"effective_mass": {"static_residual_fraction": [None, None, 0.05]}}
    assert model_resolution(model.with_meta(**meta), [0, 0, 1]) == 0.05


@pytest.mark.parametrize(
    ("grid", "expected"),
    [((1, 1), ["sparse_robust_grid"] * 2), ((2, 2), ["sparse_robust_grid"]), ((3, 2), [])],
)
def test_sparse_robust_grids_are_named(grid, expected):
    assert kinds(grid_advice(optim.RobustSpec(n_freq=grid[0], n_zeta=grid[1]))) == expected
    assert grid_advice(None) == []
    assert grid_advice(optim.RobustSpec((1.0, 1.0), None, 1, 1)) == []  # no range: no advice


def test_cli_prints_each_warning_once_and_the_report_keeps_them(tmp_path):
    model_file = tmp_path / "part.npz"
    few_mode_model().save(model_file)
    out = tmp_path / "opt"
    args = ["--distance", "0", "0", "0.8", "--threshold", "0.5", "--robust", "--grid", "1", "1"]
    proc = run_jaxflex("optimize", str(model_file), *args, "-o", str(out))
    assert proc.returncode == 0, proc.stderr
    warnings = [line for line in proc.stderr.splitlines() if ": warning: " in line]
    assert len(warnings) == 3, proc.stderr
    assert all(line.startswith("jaxflex optimize: warning: ") for line in warnings)
    assert "n_freq = 1" in proc.stderr and "checked at 0.9 only" in proc.stderr
    assert "threshold_m = 0.5 m (500 mm) is above" in proc.stderr
    assert "\r" not in proc.stderr
    report = json.loads((out / "report.json").read_text())
    assert sorted(w["kind"] for w in report["warnings"]) == [
        "sparse_robust_grid",
        "sparse_robust_grid",
        "threshold_above_peak",
    ]
    assert proc.stdout.startswith("best move: optimised, worst case ")
