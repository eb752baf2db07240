"""The preprint's R1 path: CSV layout and errors (agreement with the scan: test_simulate)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import smooth_move

from jaxflex._convolution import (
    convolve_unit_response,
    read_unit_response_csv,
    unit_response,
    write_unit_response_csv,
)
from jaxflex.errors import InputError


def test_csv_round_trip_and_use(tmp_path, small_model):
    dt_s, n = 0.01, 40
    r1 = unit_response(small_model, dt_s, n)
    path = tmp_path / "r1_z.csv"
    write_unit_response_csv(path, r1[2])
    back = read_unit_response_csv(path)
    np.testing.assert_array_equal(back, r1[2])  # repr() keeps every bit
    acc = smooth_move(n, dt_s, distance=(0, 0, 1.0))
    np.testing.assert_array_equal(
        convolve_unit_response(back[None], acc, axes=(2,)),
        convolve_unit_response(r1[2:], acc, axes=(2,)),
    )
    rows = path.read_text().splitlines()
    assert len(rows) == 1 + small_model.n_points  # header + K rows
    assert len(rows[1].split(",")) == 3 * (n + 1)


def test_headerless_csv(tmp_path):
    path = tmp_path / "r1.csv"
    path.write_text("0,0,0,1,2,3\n0,0,0,4,5,6\n")
    r1 = read_unit_response_csv(path)
    assert r1.shape == (2, 2, 3)
    assert r1[1, 1].tolist() == [4.0, 5.0, 6.0]


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("0,0,0\n1,2\n", "different lengths"),
        ("0,0,0,1\n1,2,3,4\n", "multiple of 3"),
        ("x,y,z\n1,2,oops\n", "line 2"),
        ("", "no data"),
        ("0,0,nan\n", "non-finite"),
    ],
)
def test_malformed_csv(tmp_path, text, message):
    path = tmp_path / "r1.csv"
    path.write_text(text)
    with pytest.raises(InputError, match=message):
        read_unit_response_csv(path)


def test_convolution_input_checks(small_model):
    r1 = unit_response(small_model, 0.01, 10)
    acc = smooth_move(10, 0.01)
    with pytest.raises(InputError, match="covers 10 steps"):
        convolve_unit_response(r1, np.vstack([acc, np.zeros((5, 3))]))
    with pytest.raises(InputError, match="axes"):
        convolve_unit_response(r1[2:], acc, axes=(2,))
    bad = acc.copy()
    bad[0] = 1.0
    with pytest.raises(InputError, match="first sample"):
        convolve_unit_response(r1, bad)
