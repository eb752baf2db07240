"""Where classical methods fail and the exact recursion does not (DESIGN: test stability)."""

from __future__ import annotations

import numpy as np
import pytest
from closed_forms import piecewise_linear_response

import jaxflex
from jaxflex.integrators import central_difference_modal, newmark_modal


def one_mode(freq_hz: float, zeta: float = 0.0) -> jaxflex.ModalModel:
    shapes = np.zeros((1, 3, 1))
    shapes[0, 2, 0] = 1.0
    return jaxflex.ModalModel(
        freq_hz=[freq_hz], zeta=[zeta], gamma=[[0, 0, 1.0]], shapes=shapes, points=np.zeros((1, 3))
    )


def hat_input(n: int) -> np.ndarray:
    acc = np.zeros((n + 1, 3))
    acc[1, 2] = 1.0
    return acc


@pytest.mark.parametrize("omega_dt", [2.05, 2.5, 10.0])
def test_central_difference_blows_up_above_two_over_omega(omega_dt):
    dt, n = 0.01, 400
    model = one_mode(omega_dt / dt / (2 * np.pi))
    acc = hat_input(n)
    cd = np.abs(np.asarray(central_difference_modal(model, acc, dt))[:, 0])
    exact = np.asarray(jaxflex.simulate(model, acc, dt).q)[:, 0]
    expected = -piecewise_linear_response(dt * np.arange(n + 1), acc[:, 2], dt, omega_dt / dt, 0.0)
    # exact recursion: round-off only; undamped, so the amplitude stays at its initial value
    np.testing.assert_allclose(exact, expected, atol=1e-12 * np.abs(expected).max())
    # central difference: the amplification factor exceeds 1, growth over 400 steps is enormous
    # (or overflows to inf/nan, which the negated comparison also catches)
    assert not cd[-1] <= 1e6 * np.abs(expected).max()


def test_central_difference_is_stable_below_the_limit():
    dt, n = 0.01, 400
    omega_dt = 0.2
    model = one_mode(omega_dt / dt / (2 * np.pi))
    acc = hat_input(n)
    cd = np.asarray(central_difference_modal(model, acc, dt))[:, 0]
    expected = -piecewise_linear_response(dt * np.arange(n + 1), acc[:, 2], dt, omega_dt / dt, 0.0)
    # second-order method: error O((w h)^2) of the amplitude per period, 6 periods here
    assert np.abs(cd - expected).max() < 0.2 * np.abs(expected).max()


@pytest.mark.parametrize("omega_dt", [0.1, 0.5, 1.0, 2.0])
def test_newmark_period_error_grows_with_omega_dt(omega_dt):
    """Average-acceleration Newmark oscillates at (2 / h) arctan(w h / 2) instead of w: its
    period is too long by ~ (w h)^2 / 12. Measured from the discrete free vibration."""
    dt, n = 0.01, 400
    omega = omega_dt / dt
    model = one_mode(omega / (2 * np.pi))
    q = np.asarray(newmark_modal(model, hat_input(n), dt))[:, 0]
    k = 200 + int(np.argmax(np.abs(q[200:-1])))
    measured = np.arccos((q[k + 1] + q[k - 1]) / (2 * q[k])) / dt  # undamped 3-term recurrence
    theory = 2 / dt * np.arctan(omega_dt / 2)
    assert measured == pytest.approx(theory, rel=1e-9)
    period_error = omega / measured - 1
    assert period_error == pytest.approx(omega_dt**2 / 12, rel=0.25 * omega_dt**2 + 1e-3)
    exact = np.asarray(jaxflex.simulate(model, hat_input(n), dt).q)[:, 0]
    expected = -piecewise_linear_response(dt * np.arange(n + 1), hat_input(n)[:, 2], dt, omega, 0.0)
    np.testing.assert_allclose(exact, expected, atol=1e-12 * np.abs(expected).max())


def test_float32_drifts_over_long_horizons_float64_does_not():
    """An undamped 1 Hz mode driven for 1000 s at dt = 10 ms: float32 coefficients carry a
    relative error ~6e-8, i.e. a frequency error, so the phase error grows with time."""
    model = one_mode(1.0)
    dt = 0.01
    errors = {}
    for n in (1_000, 100_000):
        t = np.arange(n + 1) * dt
        acc = np.zeros((n + 1, 3))
        acc[:, 2] = np.sin(2 * np.pi * 0.37 * t)
        q64 = np.asarray(jaxflex.simulate(model, acc, dt).q)[:, 0]
        q32 = np.asarray(jaxflex.simulate(model, acc, dt, dtype="float32").q, dtype=float)[:, 0]
        errors[n] = np.abs(q32 - q64).max() / np.abs(q64).max()
        if n == 1_000:
            expected = -piecewise_linear_response(t, acc[:, 2], dt, 2 * np.pi, 0.0)
            np.testing.assert_allclose(q64, expected, atol=1e-11 * np.abs(expected).max())
    assert errors[1_000] < 1e-5
    assert errors[100_000] > 10 * errors[1_000]
