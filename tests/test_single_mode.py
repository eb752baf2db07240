"""One mode against closed forms: ramp, step-like ramp to a plateau, single hat."""

from __future__ import annotations

import numpy as np
import pytest
from closed_forms import piecewise_linear_response, ramp_response, step_response

import jaxflex


def one_mode(freq_hz: float, zeta: float) -> jaxflex.ModalModel:
    """q driven by -a_z (gamma_z = 1), observed at one point with shape 1 in z: u_z = q."""
    shapes = np.zeros((1, 3, 1))
    shapes[0, 2, 0] = 1.0
    return jaxflex.ModalModel(
        freq_hz=[freq_hz],
        zeta=[zeta],
        gamma=[[0.0, 0.0, 1.0]],
        shapes=shapes,
        points=[[0.0, 0.0, 0.0]],
    )


def displacement_z(model, acc, dt_s, **kw):
    r = jaxflex.simulate(model, acc, dt_s, displacement=True, **kw)
    return np.asarray(r.t), np.asarray(r.displacement)[:, 0, 2]


CASES = [(0.5, 0.02), (7.0, 0.0), (30.0, 0.05), (300.0, 0.3), (2000.0, 0.02)]


@pytest.mark.parametrize(("freq_hz", "zeta"), CASES)
@pytest.mark.parametrize("dt_s", [0.001, 0.01, 0.025])
def test_ramp(freq_hz, zeta, dt_s):
    model, omega = one_mode(freq_hz, zeta), 2 * np.pi * freq_hz
    n = 80
    acc = np.zeros((n + 1, 3))
    acc[:, 2] = 3.0 * np.arange(n + 1) * dt_s  # a = 3 t
    t, u = displacement_z(model, acc, dt_s)
    expected = -3.0 * ramp_response(t, omega, zeta)
    scale = np.max(np.abs(expected))
    # exact recursion: only round-off, accumulated over n steps (n * 1e-15 relative)
    np.testing.assert_allclose(u, expected, rtol=0, atol=1e-11 * scale)


@pytest.mark.parametrize(("freq_hz", "zeta"), CASES)
def test_step_reached_by_one_ramp_step(freq_hz, zeta):
    """a ramps to 2 m/s^2 over the first step, then stays: the response is a ramp response
    minus a shifted one, and tends to the static deflection -2 / omega^2."""
    model, omega, dt_s = one_mode(freq_hz, zeta), 2 * np.pi * freq_hz, 0.01
    n = 400
    acc = np.full((n + 1, 3), 0.0)
    acc[1:, 2] = 2.0
    t, u = displacement_z(model, acc, dt_s)
    expected = -2.0 * (ramp_response(t, omega, zeta) - ramp_response(t - dt_s, omega, zeta)) / dt_s
    scale = max(np.max(np.abs(expected)), 2.0 / omega**2)
    np.testing.assert_allclose(u, expected, rtol=0, atol=1e-11 * scale)
    if zeta > 0 and zeta * omega * n * dt_s > 40:
        assert u[-1] == pytest.approx(-2.0 / omega**2, rel=1e-9)


def test_step_closed_form_agrees_with_ramp_difference_in_the_limit():
    """Sanity of the oracle: (r(t) - r(t - h)) / h -> step response as h -> 0."""
    omega, zeta, h = 2 * np.pi * 5.0, 0.05, 1e-6
    t = np.linspace(0.01, 1.0, 50)
    diff = (ramp_response(t, omega, zeta) - ramp_response(t - h, omega, zeta)) / h
    np.testing.assert_allclose(diff, step_response(t - h / 2, omega, zeta), rtol=1e-6)


@pytest.mark.parametrize(("freq_hz", "zeta"), CASES)
@pytest.mark.parametrize("dt_s", [0.01, 0.025])
def test_hat_and_free_continuation(freq_hz, zeta, dt_s):
    model, omega = one_mode(freq_hz, zeta), 2 * np.pi * freq_hz
    n = 10
    acc = np.zeros((n + 1, 3))
    acc[1, 2] = 1.0
    t, u = displacement_z(model, acc, dt_s, extend_s=50 * dt_s)
    expected = -piecewise_linear_response(t, acc[:, 2], dt_s, omega, zeta)
    scale = np.max(np.abs(expected))
    np.testing.assert_allclose(u, expected, rtol=0, atol=1e-11 * scale)
