"""Times on the sample grid as the decimals the user wrote (jaxflex._grid), in the trajectory
file (with its jerk columns) and in the optimiser's report."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import jaxflex
import optim
from jaxflex import as_move
from jaxflex._analytic import simply_supported_plate
from jaxflex._grid import grid_time, grid_times, grid_values
from jaxflex._trajectory_io import COLUMNS, read_trajectory_csv, write_trajectory_csv


def test_known_cases_print_as_written():
    assert 82 * 0.01 == 0.8200000000000001  # what binary floating point gives
    assert repr(grid_time(82, 0.01)) == "0.82"
    assert grid_times(3, 0.1).tolist() == [0.0, 0.1, 0.2, 0.3]  # not 0.30000000000000004
    assert grid_values(0.9, 1.1, 21)[4] == 0.94  # numpy.linspace: 0.9400000000000001
    assert grid_values(0.01, 0.03, 3) == [0.01, 0.02, 0.03]
    assert grid_values(0.5, 2.0, 1) == [0.5]
    assert optim.RobustSpec().grid()[4] == (0.94, 0.01)


@given(n=st.integers(0, 100_000), dt=st.floats(1e-5, 1.0))
def test_grid_time_is_the_binary_product_to_a_few_ulp(n, dt):
    # both are within half an ulp of n times a decimal or binary step that differ by less
    # than n/2 ulp of dt (module docstring): a few ulp of the product
    assert grid_time(n, dt) == pytest.approx(n * dt, rel=4 * np.finfo(float).eps, abs=0)


def test_trajectory_file_has_exact_times_and_the_jerk(tmp_path):
    dt = 0.01
    acc = jaxflex.jerk_limited_move([0.3, 0.0, 1.0], vmax=2, amax=10, jmax=100, dt_s=dt).acc
    path = tmp_path / "trajectory.csv"
    write_trajectory_csv(path, as_move(acc, dt))
    lines = path.read_text().splitlines()
    assert lines[0].split(",") == list(COLUMNS)
    n = len(acc) - 1
    assert lines[-1].split(",")[0] == repr(grid_time(n, dt))  # e.g. "0.8", not 0.8000000000000002
    table = np.loadtxt(path, delimiter=",", skiprows=1)
    jerk = table[:, [COLUMNS.index(c) for c in ("jx_m_s3", "jy_m_s3", "jz_m_s3")]]
    np.testing.assert_array_equal(jerk[:-1], np.diff(acc, axis=0) / dt)
    assert not jerk[-1].any()  # at rest after the move
    read = read_trajectory_csv(path)
    np.testing.assert_array_equal(read.acc, acc)  # shortest round-trip decimals: exact
    assert read.dt_s == dt  # the step the file was written with, exactly
    write_trajectory_csv(path, as_move(acc, 1 / 300))  # a step without a short decimal
    assert read_trajectory_csv(path).dt_s == pytest.approx(1 / 300, rel=1e-12)


def test_report_json_prints_grid_times_exactly(tmp_path):
    model = simply_supported_plate(n_modes=4, points=20)
    spec = optim.RobustSpec(n_freq=3, n_zeta=2)
    result = optim.optimize(model, [0, 0, 1.0], optim.Limits(2, 10, 100), 0.01, 0.5, robust=spec)
    result.save(tmp_path)
    text = (tmp_path / "report.json").read_text()
    report = json.loads(text)
    assert '"transfer_time_s": 0.8,' in text and report["n_steps"] == 80
    for point in report["worst_case"]["grid"]:
        assert repr(point["freq_scale"]) in ("0.9", "1.0", "1.1")
        assert repr(point["zeta"]) in ("0.01", "0.03")
        assert repr(point["cycle_time_s"]) == "0.8"
