"""A move is one object (samples and step): the entry points take a Move alone, raw samples
with their step, and refuse raw samples without one or a step that is not the move's."""

from __future__ import annotations

import numpy as np
import pytest

import jaxflex
from jaxflex.errors import InputError
from jaxflex.response import deviation_curve
from tests.conftest import smooth_move


def test_a_move_carries_its_step_into_the_kinematics():
    # constant acceleration from rest: v = a t, x = a t^2 / 2 exactly (closed form)
    dt_s, a = 0.02, np.array([1.5, -0.5, 2.0])
    move = jaxflex.as_move(np.tile(a, (11, 1)), dt_s)
    vel, pos = jaxflex.integrate(move)
    t = dt_s * np.arange(11)[:, None]
    np.testing.assert_allclose(vel, a * t, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(pos, a * t**2 / 2, rtol=1e-12, atol=1e-15)
    assert move.duration_s == pytest.approx(0.2)


def test_entry_points_take_a_move_alone(small_model):
    dt_s, threshold_m = 0.01, 1e-4
    acc = smooth_move(30, dt_s)
    move = jaxflex.as_move(acc, dt_s, at_rest=True)
    by_move = jaxflex.analyze_move(small_model, move, threshold_m=threshold_m)
    by_array = jaxflex.analyze_move(small_model, acc, dt_s, threshold_m)
    assert by_move == by_array
    assert jaxflex.cycle_time(small_model, move, threshold_m=threshold_m) == by_move.cycle_time_s
    response = jaxflex.simulate(small_model, move, extend_s=0.1)
    # the step comes with the move: 30 steps of the move, then 0.1 s of free decay
    assert response.t[-1] == pytest.approx(0.4)
    t, _ = deviation_curve(small_model, move, 0.5, 4)
    np.testing.assert_allclose(np.diff(t[: 30 * 4]), dt_s / 4, rtol=1e-12)


def test_raw_samples_need_their_step_and_a_move_keeps_its_own(small_model):
    acc = smooth_move(10, 0.01)
    for call in (
        lambda: jaxflex.as_move(acc),
        lambda: jaxflex.integrate(acc),
        lambda: jaxflex.analyze_move(small_model, acc, threshold_m=1e-4),
        lambda: jaxflex.simulate(small_model, acc),
    ):
        with pytest.raises(InputError, match="dt_s"):
            call()
    move = jaxflex.as_move(acc, 0.01)
    with pytest.raises(InputError, match=r"dt_s: 0\.02 s, but the move is sampled every 0\.01 s"):
        jaxflex.simulate(small_model, move, 0.02)
