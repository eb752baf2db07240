"""``jaxflex optimize`` as a user runs it."""

from __future__ import annotations

import json

import pytest
from conftest import run_jaxflex
from test_optim_optimize import few_mode_model

import jaxflex
from jaxflex.trajectory_io import read_trajectory_csv


@pytest.fixture(scope="module")
def model_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("model") / "part.npz"
    few_mode_model().save(path)
    return path


def test_optimize_writes_trajectory_report_and_plots(model_file, tmp_path):
    out = tmp_path / "opt"
    args = "--distance 0 0 0.8 --vmax 1.5 --amax 8 --jmax 80 80 60 --threshold 1e-3 "
    args += "--robust --grid 3 2 --clearance 0.03"
    proc = run_jaxflex("optimize", str(model_file), *args.split(), "-o", str(out))
    assert proc.returncode == 0, proc.stderr
    assert "cycle" in proc.stdout and "worst case" in proc.stdout
    assert "shortest move" in proc.stderr  # the progress display
    for name in (
        "trajectory.csv",
        "report.json",
        "profiles.png",
        "deviation.png",
        "robust.png",
        "deviation_worst_case.png",
    ):
        assert (out / name).stat().st_size > 0, name
    report = json.loads((out / "report.json").read_text())
    assert report["limits"]["jmax_m_s3"] == [80.0, 80.0, 60.0]
    assert report["robust"]["freq_scale"] == [0.9, 1.1]
    assert report["clearance_m"] == 0.03
    assert report["deviation"]["peak_during_move_m"] <= 0.03
    assert report["worst_case"]["cycle_time_s"] >= report["n_steps"] * report["dt_s"] - 1e-12
    acc, dt_s = read_trajectory_csv(out / "trajectory.csv")
    model = jaxflex.load_model(model_file)
    assert jaxflex.cycle_time(model, acc, dt_s, 1e-3) == pytest.approx(
        report["cycle_time_s"], abs=2e-9
    )


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--threshold", "0"], "--threshold"),
        (["--threshold", "1e-3", "--vmax", "1", "2"], "--vmax"),
        (["--threshold", "1e-3", "--amax", "-1"], "amax[x]"),
        (["--threshold", "1e-3", "--distance", "0", "0", "80"], "max_duration_s"),
    ],
)
def test_bad_requests_exit_2_with_a_clear_message(model_file, tmp_path, args, message):
    base = [str(model_file), "--distance", "0", "0", "0.8", "-o", str(tmp_path), "--quiet"]
    proc = run_jaxflex("optimize", *base, *args)
    assert proc.returncode == 2
    assert message in proc.stderr and "Traceback" not in proc.stderr
