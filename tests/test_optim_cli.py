"""``jaxflex optimize`` as a user runs it."""

from __future__ import annotations

import json
import re

import pytest
from conftest import run_jaxflex
from test_optim_optimize import few_mode_model

import jaxflex
from jaxflex._model_file import ARRAY_FIELDS, write_model_file
from jaxflex._trajectory_io import read_trajectory_csv


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
    # the progress display, redirected: plain lines with count and total, no "\r" frames
    assert re.search(r"shortest move: \d+/\d+ test in ", proc.stderr), proc.stderr
    assert re.search(r"baselines: \d+/\d+ move in ", proc.stderr)
    assert "\r" not in proc.stderr
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
    move = read_trajectory_csv(out / "trajectory.csv")
    model = jaxflex.load_model(model_file)
    assert jaxflex.cycle_time(model, move, threshold_m=1e-3) == pytest.approx(
        report["cycle_time_s"], abs=2e-9
    )


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--threshold", "0"], "--threshold"),
        (["--threshold", "1e-3", "--vmax", "1", "2"], "--vmax"),
        (["--threshold", "1e-3", "--amax", "-1"], "amax[x]"),
        (["--threshold", "1e-3", "--distance", "0", "0", "80"], "max_duration_s"),
        # extreme requests are refused up front (budgets from the problem), naming the option
        (["--threshold", "1e-3", "--vmax", "1e-6"], "(--vmax, --amax, --jmax)"),
        (["--threshold", "1e-3", "--distance", "0", "0", "1e9"], "(--max-duration)"),
        (["--threshold", "1e-3", "--dt", "1e6"], "lasts at least 2 steps = 2e+06 s"),
        (["--threshold", "1e-3", "--clearance", "1e-12"], "(--clearance, --max-duration)"),
        (["--threshold", "1e-3", "--max-duration", "1000", "--vmax", "0.001"], "--max-steps"),
        (["--threshold", "1e-300"], "Raise the threshold (--threshold)"),
    ],
)
def test_bad_requests_exit_2_with_a_clear_message(model_file, tmp_path, args, message):
    base = [str(model_file), "--distance", "0", "0", "0.8", "-o", str(tmp_path), "--quiet"]
    proc = run_jaxflex("optimize", *base, *args)
    assert proc.returncode == 2
    assert message in proc.stderr and "Traceback" not in proc.stderr
    assert "allowed 0 s" not in proc.stderr


def test_participation_factors_out_of_range_are_named(tmp_path):
    """A model file whose participation factors were scaled by 1e200 (it passed validation
    before the physical ranges, then made the settle search grow without bound) is refused on
    load, naming the field and the range."""
    model = few_mode_model()
    arrays = {name: getattr(model, name) for name in ARRAY_FIELDS}
    arrays["gamma"] = arrays["gamma"] * 1e200
    path = tmp_path / "scaled.npz"
    write_model_file(path, arrays, None, {})
    args = ["--distance", "0", "0", "0.8", "--threshold", "1e-3", "-o", str(tmp_path / "o")]
    proc = run_jaxflex("optimize", str(path), *args, "--quiet")
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert "ModalModel.gamma" in proc.stderr and "outside the physical range" in proc.stderr
