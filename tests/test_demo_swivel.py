"""`jaxflex demo --scene swivel`: the built-in plate carried upright and swivelled 90 degrees
about the vertical while it moves 1 m; a scene vibration limits (the Euler load of the turn
is normal to the sheet)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import run_jaxflex

import jaxflex
from jaxflex.pose import fixed_axis_path
from jaxflex.turning import simulate_turning


@pytest.mark.slow
def test_demo_swivel_scene_is_limited_by_vibration(tmp_path):
    """The fastest move (ruckig, the kinematic floor) leaves the plate ringing above the
    threshold, so ruckig + free decay is far longer than the floor; the optimum is shorter
    than every baseline; the bound on the neglected terms is far below the threshold (the
    cycle time holds with them); the written trajectory, re-simulated from the files by the
    turning engine, rings above the threshold during the move and ends below it."""
    out = tmp_path / "swivel"
    proc = run_jaxflex("demo", "--scene", "swivel", "-o", str(out))
    assert proc.returncode == 0, proc.stderr
    assert "turned 90 deg about z (the part carried upright)" in proc.stdout
    summary = json.loads((out / "demo.json").read_text())
    report = json.loads((out / "optimized" / "report.json").read_text())
    threshold = summary["threshold_m"]
    baselines = summary["baselines_cycle_time_s"]
    assert report["source"] == "optimised"
    assert all(summary["cycle_time_s"] < c for c in baselines.values())
    # measured: ruckig + free decay 2.664 s against a floor of 0.800 s
    assert baselines["ruckig + free decay"] > summary["cycle_time_s"] + 1.0
    assert report["turn"]["neglected_bound_m"] < 0.1 * threshold
    model = jaxflex.load_model(out / "model.npz")
    table = np.loadtxt(out / "optimized" / "trajectory.csv", delimiter=",", skiprows=1)
    header = (out / "optimized" / "trajectory.csv").read_text().splitlines()[0].split(",")
    acc = table[:, [header.index(f"a{c}_m_s2") for c in "xyz"]]
    path = fixed_axis_path("z", table[:, header.index("turn_acc_rad_s2")], summary["dt_s"])
    response = simulate_turning(model, path, acc, pivot_m=report["turn"]["pivot_m"], extend_s=0.5)
    n = path.n_steps
    assert response.deviation_m[:n].max() > 10 * threshold  # measured 13.5 mm
    assert response.deviation_m[n:].max() <= threshold
