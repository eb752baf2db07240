"""Limits: validation naming the field, and the exact check (also between samples)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from jaxflex._profile import as_move, end_weights, enforce_end_state, integrate
from jaxflex.errors import InputError
from optim.limits import Limits, check_profile, velocity_extrema
from optim.options import RobustSpec


def dense_velocity(acc, dt_s, samples=2001):
    """|v| on a fine grid of every step, from the exact quadratic (brute force)."""
    vel, _ = integrate(acc, dt_s)
    tau = np.linspace(0.0, dt_s, samples)[:, None, None]
    a0, a1, v0 = acc[:-1], acc[1:], vel[:-1]
    return v0 + a0 * tau + (a1 - a0) * tau**2 / (2 * dt_s)  # (samples, n, 3)


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"vmax": [1, -1, 1], "amax": 1, "jmax": 1}, r"vmax\[y\]"),
        ({"vmax": 1, "amax": 0, "jmax": 1}, r"amax\[x\]"),
        ({"vmax": 1, "amax": 1, "jmax": np.inf}, r"jmax\[x\]"),
        ({"vmax": 1, "amax": 1, "jmax": [1, 2]}, "jmax"),
        ({"vmax": 1, "amax": 1, "jmax": 1, "vpath": -2}, "vpath"),
        ({"vmax": "fast", "amax": 1, "jmax": 1}, "vmax"),
    ],
)
def test_bad_limits_name_the_field(kwargs, field):
    with pytest.raises(InputError, match=field):
        Limits(**kwargs)


def test_limits_round_trip_through_json_form():
    lim = Limits([1, 2, 3], 10, 100, apath=12.0)
    assert Limits.from_dict(lim.as_dict()).as_dict() == lim.as_dict()
    assert lim.as_dict()["vmax_m_s"] == [1.0, 2.0, 3.0]


@settings(max_examples=60, deadline=None)
@given(
    samples=st.lists(st.floats(-5, 5), min_size=3, max_size=12),
    dt_s=st.sampled_from([0.004, 0.01, 0.05]),
)
def test_velocity_extrema_match_a_dense_evaluation(samples, dt_s):
    # The closed-form interior extremum must equal the brute-force maximum of |v| over each
    # step: a grid of 2001 points misses the true peak by at most
    # |a|max (dt/2000)^2 / dt ~ 1e-6 relative, hence the tolerance.
    acc = np.zeros((len(samples) + 2, 3))
    acc[1:-1, 1] = samples
    vel, _ = integrate(acc, dt_s)
    value, _, _ = velocity_extrema(acc, vel, dt_s)
    dense = dense_velocity(acc, dt_s)
    closed = np.maximum(np.abs(value[:, 1]), np.maximum(np.abs(vel[:-1, 1]), np.abs(vel[1:, 1])))
    np.testing.assert_allclose(closed, np.abs(dense[:, :, 1]).max(axis=0), rtol=0, atol=2e-6 * dt_s)


def test_a_velocity_peak_between_samples_is_reported():
    # a_k > 0, a_{k+1} < 0: the velocity peaks inside the step, above both sample values.
    dt_s = 0.1
    acc = np.array([[0, 0, 0], [0, 0, 10.0], [0, 0, -10.0], [0, 0, 0]])
    vel, _ = integrate(acc, dt_s)
    peak = np.abs(dense_velocity(acc, dt_s)[:, :, 2]).max()
    assert peak > np.abs(vel[:, 2]).max()
    limit = 0.5 * (peak + np.abs(vel[:, 2]).max())  # between the sampled and the true peak
    check = check_profile(as_move(acc, dt_s), Limits(limit, 100, 1000))
    (violation,) = [v for v in check.violations if v.quantity == "velocity"]
    assert violation.axis == "z"
    assert violation.value == pytest.approx(peak, rel=1e-6)
    assert 0.1 < violation.time_s < 0.2
    assert violation.excess == pytest.approx(peak - limit, rel=1e-5)


def test_path_speed_peak_between_samples_is_reported():
    dt_s = 0.1
    acc = np.zeros((4, 3))
    acc[1, :2], acc[2, :2] = [6.0, 8.0], [-6.0, -8.0]
    speed = np.linalg.norm(dense_velocity(acc, dt_s), axis=2).max()
    check = check_profile(as_move(acc, dt_s), Limits(100, 100, 1000, vpath=0.99 * speed))
    (violation,) = check.violations
    assert (violation.quantity, violation.axis) == ("velocity", "path")
    assert violation.value == pytest.approx(speed, rel=1e-6)


def test_every_violation_is_listed_with_time_and_size():
    dt_s = 0.01
    acc = np.zeros((6, 3))
    acc[1:5, 0] = [3.0, 5.0, 5.0, 3.0]
    check = check_profile(as_move(acc, dt_s), Limits(10, 4, 250), distance_m=[1, 0, 0])
    kinds = {(v.quantity, round(v.time_s, 3)) for v in check.violations}
    assert ("acceleration", 0.02) in kinds and ("acceleration", 0.03) in kinds
    assert ("jerk", 0.005) in kinds and ("jerk", 0.045) in kinds  # |3 / 0.01| = 300 > 250
    assert ("end position", 0.05) in kinds and ("end velocity", 0.05) in kinds
    assert not check.ok and "exceeds" in check.summary()


def test_end_state_correction_is_exact_and_minimal():
    rng = np.random.default_rng(3)
    acc = rng.normal(size=(41, 3))
    acc[[0, -1]] = 0
    target = np.array([0.2, -0.1, 0.05])
    fixed = enforce_end_state(as_move(acc, 0.01), target)
    assert fixed.at_rest and fixed.dt_s == 0.01
    vel, pos = integrate(fixed)
    # exact up to float64 round-off of sums of 40 O(1) terms
    np.testing.assert_allclose(vel[-1], 0, atol=1e-14)
    np.testing.assert_allclose(pos[-1], target, atol=1e-14)
    # minimal: the change lies in the row space of the two end functionals (least norm)
    w = end_weights(40, 0.01)[:, 1:-1]
    change = (fixed.acc - acc)[1:-1]
    projector = w.T @ np.linalg.solve(w @ w.T, w)
    np.testing.assert_allclose(projector @ change, change, atol=1e-9)


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"freq_scale": (1.1, 0.9)}, "freq_scale"),
        ({"freq_scale": (0.0, 1.1)}, "freq_scale"),
        ({"zeta": (0.0, 0.03)}, "zeta"),
        ({"zeta": (0.03, 0.01)}, "zeta"),
        ({"n_freq": 0}, "n_freq"),
    ],
)
def test_bad_robust_specs_name_the_field(kwargs, field):
    with pytest.raises(InputError, match=field):
        RobustSpec(**kwargs)


def test_robust_grid_covers_the_range():
    grid = RobustSpec((0.9, 1.1), (0.01, 0.03), n_freq=5, n_zeta=3).grid()
    assert len(grid) == 15
    assert sorted({s for s, _ in grid}) == pytest.approx([0.9, 0.95, 1.0, 1.05, 1.1])
    assert sorted({z for _, z in grid}) == pytest.approx([0.01, 0.02, 0.03])
