"""Input shapers against their defining conditions and closed forms."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import jaxflex
from jaxflex.errors import InputError
from jaxflex.response import modal_states
from optim.shapers import convolve, residual_vibration, shaper


def single_mode(freq_hz, zeta):
    return jaxflex.ModalModel(
        freq_hz=[freq_hz],
        zeta=[zeta],
        gamma=[[0, 0, 1.0]],
        shapes=[[[0], [0], [1.0]]],
        points=[[0, 0, 0]],
    )


@settings(max_examples=30, deadline=None)
@given(freq=st.floats(0.5, 50), zeta=st.floats(0.0, 0.2))
def test_zv_and_zvd_cancel_the_design_mode(freq, zeta):
    # Closed forms (Singer & Seering 1990): V(w_n) = 0 exactly, and for ZVD dV/dw = 0 too.
    omega = 2 * np.pi * freq
    for kind in ("ZV", "ZVD"):
        s = shaper(kind, omega, zeta)
        assert s.amplitudes.sum() == pytest.approx(1.0, abs=1e-14)
        assert s.residual_vibration(np.array([omega]), zeta)[0] < 1e-12
    zvd = shaper("ZVD", omega, zeta)
    h = 1e-4 * omega
    slope = (
        zvd.residual_vibration(np.array([omega + h]), zeta)
        - zvd.residual_vibration(np.array([omega - h]), zeta)
    ) / (2 * h)
    # V ~ c (w - w_n)^2 near the design point: the central difference of a double root is 0
    assert abs(slope[0]) * omega < 1e-6


def test_undamped_ei_is_the_closed_form():
    # Singhose, Seering & Singer (1996): A = ((1+V)/4, (1-V)/2, (1+V)/4), t = (0, T/2, T)
    s = shaper("EI", 2 * np.pi * 2.0, 0.0)
    np.testing.assert_allclose(s.amplitudes, [0.2625, 0.475, 0.2625], atol=1e-10)
    np.testing.assert_allclose(s.times_s, [0.0, 0.25, 0.5], atol=1e-10)


@pytest.mark.parametrize("zeta", [0.01, 0.02, 0.05, 0.1])
def test_damped_ei_meets_its_conditions(zeta):
    s = shaper("EI", 2 * np.pi, zeta)
    f = np.linspace(0.6, 1.4, 8001)
    v = s.residual_vibration(2 * np.pi * f, zeta)
    assert v[4000] == pytest.approx(0.05, abs=1e-9)  # V(w_n) = Vtol
    assert np.argmax(v[2000:6000]) + 2000 == pytest.approx(4000, abs=2)  # a local peak there
    below, above = v[:4000], v[4000:]
    assert below.min() < 1e-4 and above.min() < 1e-4  # zero vibration on both sides
    assert v[(f > 0.87) & (f < 1.13)].max() <= 0.05 + 1e-9  # within Vtol over +-13 %


def test_shaped_step_response_leaves_no_residual_vibration():
    # Independent check through the modal recursion: a step of acceleration shaped by ZV at
    # the mode's frequency leaves the oscillator at rest relative to its static deflection.
    freq, zeta, dt_s = 2.0, 0.03, 1e-3
    s = shaper("ZV", 2 * np.pi * freq, zeta)
    model = single_mode(freq, zeta)
    t = dt_s * np.arange(4001)
    acc = np.zeros((t.size, 3))
    for amp, delay in zip(s.amplitudes, s.times_s, strict=True):
        acc[:, 2] += amp * np.clip((t - delay) / dt_s, 0, 1)  # steps smoothed over one sample
    acc[-1] = 0.0
    omega = 2 * np.pi * freq
    static = -1.0 / omega**2

    def amplitude(a):  # of the oscillation about the static deflection, at the end
        q, qd = np.asarray(modal_states(model, a, dt_s))[-2, 0]
        return np.hypot(q - static, qd / omega)

    unshaped = np.zeros_like(acc)
    unshaped[1:-1, 2] = 1.0
    # The shaped residual is limited by the one-sample ramps of each impulse (O((omega dt)^2)
    # of the unshaped residual, ~6e-6 here); the unshaped step keeps ~e^{-zeta omega t}.
    assert amplitude(acc) < 1e-4 * amplitude(unshaped)


def test_multi_mode_convolution_cancels_every_mode():
    zeta = 0.02
    s = convolve(shaper("ZVD", 2 * np.pi * 3.0, zeta), shaper("ZV", 2 * np.pi * 11.0, zeta))
    assert len(s.amplitudes) == 6 and s.amplitudes.sum() == pytest.approx(1.0)
    assert np.all(np.diff(s.times_s) >= 0)
    assert s.duration_s == pytest.approx(
        1 / (3.0 * np.sqrt(1 - zeta**2)) + 0.5 / (11.0 * np.sqrt(1 - zeta**2))
    )
    v = residual_vibration(s.amplitudes, s.times_s, 2 * np.pi * np.array([3.0, 11.0]), zeta)
    assert np.all(v < 1e-12)


def test_bad_shaper_requests():
    with pytest.raises(InputError, match="kind"):
        shaper("ZVDD", 1.0, 0.02)
    with pytest.raises(InputError, match="omega_rad_s"):
        shaper("ZV", 0.0, 0.02)
    with pytest.raises(InputError, match="zeta"):
        shaper("ZV", 1.0, 1.0)
