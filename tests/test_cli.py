"""The command line as a user runs it."""

from __future__ import annotations

import json

from conftest import run_jaxflex

import jaxflex
from jaxflex.trajectory_io import read_trajectory_csv


def test_demo_runs_the_whole_pipeline(tmp_path):
    out = tmp_path / "demo"
    proc = run_jaxflex("demo", "-o", str(out))
    assert proc.returncode == 0, proc.stderr
    assert "cycle" in proc.stdout and "FMI 3.0" in proc.stdout
    for name in (
        "model.npz",
        "optimized/trajectory.csv",
        "optimized/report.json",
        "optimized/deviation.png",
        "part_fmi2.fmu",
        "part_fmi3.fmu",
        "demo.json",
    ):
        assert (out / name).stat().st_size > 0, name
    summary = json.loads((out / "demo.json").read_text())
    model = jaxflex.load_model(out / "model.npz")
    acc, dt = read_trajectory_csv(out / "optimized" / "trajectory.csv")
    # the reported cycle time is the exact one of the saved model and trajectory
    assert summary["cycle_time_s"] == jaxflex.cycle_time(model, acc, dt, summary["threshold_m"])
    assert summary["cycle_time_s"] >= (len(acc) - 1) * dt
    # both FMUs reproduce jaxflex (fmpy run inside the demo), to round-off
    assert all(f["ok"] and f["max_rel_diff"] < 1e-9 for f in summary["fmus"].values())
    assert not list(out.rglob("*.tmp"))


def test_bad_option_gives_a_clear_error(tmp_path):
    proc = run_jaxflex("demo", "-o", str(tmp_path), "--threshold", "-1")
    assert proc.returncode == 2
    assert "--threshold" in proc.stderr and "Traceback" not in proc.stderr
