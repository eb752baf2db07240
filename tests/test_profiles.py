"""Grid-aligned jerk-limited moves and exact kinematics."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from ruckig import InputParameter, Ruckig, Trajectory

from jaxflex._profile import integrate, jerk_limited_move
from jaxflex.errors import InputError


def test_integration_is_exact_for_a_cubic_position():
    # a(t) = 6 t is linear: x = t^3 exactly, v = 3 t^2
    dt_s = 0.1
    t = np.arange(11) * dt_s
    acc = np.outer(6 * t, [1.0, 0.0, -2.0])
    vel, pos = integrate(acc, dt_s)
    np.testing.assert_allclose(vel[:, 0], 3 * t**2, rtol=1e-13)
    np.testing.assert_allclose(pos[:, 2], -2 * t**3, rtol=1e-13, atol=1e-15)


def ruckig_duration(length, vmax, amax, jmax):
    """Time-optimal jerk-limited rest-to-rest duration of a 1-D move (ruckig)."""
    inp = InputParameter(1)
    inp.current_position, inp.target_position = [0.0], [float(length)]
    inp.max_velocity, inp.max_acceleration, inp.max_jerk = [vmax], [amax], [jmax]
    traj = Trajectory(1)
    Ruckig(1).calculate(inp, traj)
    return traj.duration


@settings(max_examples=40, deadline=None)
@given(
    distance=st.tuples(*[st.floats(-2, 2)] * 3).filter(lambda d: np.linalg.norm(d) > 1e-3),
    vmax=st.floats(0.2, 3),
    amax=st.floats(1, 20),
    jmax=st.floats(10, 400),
    dt_s=st.sampled_from([0.004, 0.01, 0.02]),
)
def test_limits_and_end_state_hold_exactly(distance, vmax, amax, jmax, dt_s):
    move = jerk_limited_move(distance, vmax, amax, jmax, dt_s)
    assert move.dt_s == dt_s and move.at_rest
    acc = move.acc
    vel, pos = integrate(move)
    tol = 1e-9
    assert np.all(acc[0] == 0) and np.all(acc[-1] == 0)
    np.testing.assert_allclose(pos[-1], distance, atol=1e-12)
    np.testing.assert_allclose(vel[-1], 0, atol=1e-12)
    assert np.all(np.abs(acc) <= amax * (1 + tol))
    assert np.all(np.abs(np.diff(acc, axis=0)) / dt_s <= jmax * (1 + tol))
    assert np.all(np.abs(vel) <= vmax * (1 + tol))  # velocity is monotone between samples
    # Along the straight line the binding limits are min_i limit_i / |u_i| (u: unit direction).
    # The time-optimal 1-D motion (ruckig) is a lower bound; ours rounds the jerk, constant-
    # acceleration and cruise phases to whole steps: at most 2 (2 + 1) + 1 = 7 steps longer.
    u = np.asarray(distance) / np.linalg.norm(distance)
    moving = np.abs(u) > 1e-12
    lim = [np.min(x / np.abs(u[moving])) for x in (vmax, amax, jmax)]
    floor = ruckig_duration(np.linalg.norm(distance), *lim)
    duration = (len(acc) - 1) * dt_s
    assert floor - 1e-9 <= duration <= floor + 7 * dt_s


def test_single_axis_move_is_time_optimal_on_the_grid():
    move = jerk_limited_move([0, 0, 1.0], 2.0, 10.0, 100.0, 0.01)
    assert move.duration_s == pytest.approx(ruckig_duration(1.0, 2.0, 10.0, 100.0))


def test_bad_moves():
    with pytest.raises(InputError, match="zero length"):
        jerk_limited_move([0, 0, 0], 1, 1, 1, 0.01)
    with pytest.raises(InputError, match=r"vmax\[y\]"):
        jerk_limited_move([1, 0, 0], [1, -1, 1], 1, 1, 0.01)
    with pytest.raises(InputError, match="distance_m"):
        jerk_limited_move([1, 0], 1, 1, 1, 0.01)
