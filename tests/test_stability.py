"""Where classical methods fail and the exact recursion does not (DESIGN: test stability)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg
import scipy.sparse.linalg
from closed_forms import piecewise_linear_response
from threadpoolctl import threadpool_limits

import fem
import jaxflex
from fem.bench.metrics import settle_from_samples
from jaxflex._integrators import central_difference_modal, newmark_modal


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
    dt_s, n = 0.01, 400
    model = one_mode(omega_dt / dt_s / (2 * np.pi))
    acc = hat_input(n)
    cd = np.abs(np.asarray(central_difference_modal(model, acc, dt_s))[:, 0])
    exact = np.asarray(jaxflex.simulate(model, acc, dt_s).q)[:, 0]
    expected = -piecewise_linear_response(
        dt_s * np.arange(n + 1), acc[:, 2], dt_s, omega_dt / dt_s, 0.0
    )
    # exact recursion: round-off only; undamped, so the amplitude stays at its initial value
    np.testing.assert_allclose(exact, expected, atol=1e-12 * np.abs(expected).max())
    # central difference: the amplification factor exceeds 1, growth over 400 steps is enormous
    # (or overflows to inf/nan, which the negated comparison also catches)
    assert not cd[-1] <= 1e6 * np.abs(expected).max()


def test_central_difference_is_stable_below_the_limit():
    dt_s, n = 0.01, 400
    omega_dt = 0.2
    model = one_mode(omega_dt / dt_s / (2 * np.pi))
    acc = hat_input(n)
    cd = np.asarray(central_difference_modal(model, acc, dt_s))[:, 0]
    expected = -piecewise_linear_response(
        dt_s * np.arange(n + 1), acc[:, 2], dt_s, omega_dt / dt_s, 0.0
    )
    # second-order method: error O((w h)^2) of the amplitude per period, 6 periods here
    assert np.abs(cd - expected).max() < 0.2 * np.abs(expected).max()


@pytest.mark.parametrize("omega_dt", [0.1, 0.5, 1.0, 2.0])
def test_newmark_period_error_grows_with_omega_dt(omega_dt):
    """Average-acceleration Newmark oscillates at (2 / h) arctan(w h / 2) instead of w: its
    period is too long by ~ (w h)^2 / 12. Measured from the discrete free vibration."""
    dt_s, n = 0.01, 400
    omega = omega_dt / dt_s
    model = one_mode(omega / (2 * np.pi))
    q = np.asarray(newmark_modal(model, hat_input(n), dt_s))[:, 0]
    k = 200 + int(np.argmax(np.abs(q[200:-1])))
    measured = np.arccos((q[k + 1] + q[k - 1]) / (2 * q[k])) / dt_s  # undamped 3-term recurrence
    theory = 2 / dt_s * np.arctan(omega_dt / 2)
    assert measured == pytest.approx(theory, rel=1e-9)
    period_error = omega / measured - 1
    assert period_error == pytest.approx(omega_dt**2 / 12, rel=0.25 * omega_dt**2 + 1e-3)
    exact = np.asarray(jaxflex.simulate(model, hat_input(n), dt_s).q)[:, 0]
    expected = -piecewise_linear_response(
        dt_s * np.arange(n + 1), hat_input(n)[:, 2], dt_s, omega, 0.0
    )
    np.testing.assert_allclose(exact, expected, atol=1e-12 * np.abs(expected).max())


def test_float32_drifts_over_long_horizons_float64_does_not():
    """An undamped 1 Hz mode driven for 1000 s at dt = 10 ms: float32 coefficients carry a
    relative error ~6e-8, i.e. a frequency error, so the phase error grows with time."""
    model = one_mode(1.0)
    dt_s = 0.01
    errors = {}
    for n in (1_000, 100_000):
        t = np.arange(n + 1) * dt_s
        acc = np.zeros((n + 1, 3))
        acc[:, 2] = np.sin(2 * np.pi * 0.37 * t)
        q64 = np.asarray(jaxflex.simulate(model, acc, dt_s).q)[:, 0]
        q32 = np.asarray(jaxflex.simulate(model, acc, dt_s, dtype="float32").q, dtype=float)[:, 0]
        errors[n] = np.abs(q32 - q64).max() / np.abs(q64).max()
        if n == 1_000:
            expected = -piecewise_linear_response(t, acc[:, 2], dt_s, 2 * np.pi, 0.0)
            np.testing.assert_allclose(q64, expected, atol=1e-11 * np.abs(expected).max())
    assert errors[1_000] < 1e-5
    assert errors[100_000] > 10 * errors[1_000]


def test_step_sampling_misses_the_settle_time_analyze_move_does_not():
    """A 6.7 Hz mode (omega dt = 0.42, zeta 5 %) after a short pulse: read at the 10 ms steps,
    the deviation drops below the 5 % threshold ~65 ms too early, because an oscillation
    peak between two samples still crosses it. jaxflex.analyze_move certifies the gaps between
    samples and finds the true last crossing. Truth: the closed-form response (independent of
    jaxflex) evaluated 64 times finer than dt."""
    dt_s, zeta, omega = 0.01, 0.05, 0.4217 / 0.01
    model = one_mode(omega / (2 * np.pi), zeta)
    acc = np.zeros((5, 3))
    acc[1:4, 2] = [1.0, 2.0, 1.0]
    n_rest = 1200  # e^{-zeta omega t} < 1e-10 at the end: nothing crosses afterwards
    full = np.concatenate([acc, np.zeros((n_rest, 3))])
    t_dense = dt_s / 64 * np.arange(64 * (len(full) - 1) + 1)
    dense = np.abs(piecewise_linear_response(t_dense, full[:, 2], dt_s, omega, zeta))
    threshold_m = 0.05 * dense.max()
    truth = settle_from_samples(t_dense, dense, threshold_m)
    exact = jaxflex.analyze_move(model, acc, dt_s, threshold_m).settle_time_s
    # the dense truth itself is read with linear interpolation: within one fine step
    assert abs(exact - truth) <= dt_s / 64
    sampled_dev = np.asarray(jaxflex.simulate(model, full, dt_s).deviation)
    sampled = settle_from_samples(dt_s * np.arange(len(full)), sampled_dev, threshold_m)
    assert sampled < truth - 0.03  # measured: 65 ms early (the period is 149 ms)
    # ... because a peak between samples after the sampled "settle" exceeds the threshold
    late = t_dense > sampled + dt_s
    assert dense[late].max() > threshold_m


def _dense_freq_hz(result, first: int, count: int) -> np.ndarray:
    """Independent dense generalised eigen solve of the same K, M (one BLAS thread: OpenBLAS
    threads make a 300x300 eigh ~50x slower on the shared 2-core machine)."""
    with threadpool_limits(limits=1, user_api="blas"):
        values = scipy.linalg.eigh(
            result.K_free.toarray(), result.M_free.toarray(), eigvals_only=True
        )
    return np.sqrt(values[first : first + count]) / (2 * np.pi)


def _pinned_plate(points, allow_rigid_modes):
    part = fem.rectangular_plate(0.3, 0.2, 1e-3, "steel", 0.03)
    supports = [fem.PointSupport(x, y) for x, y in points]
    return fem.modal_analysis(part, supports, 6, allow_rigid_modes=allow_rigid_modes)


@pytest.mark.parametrize(
    "points",
    [[(0.05, 0.1), (0.25, 0.1)], [(0.05, 0.1), (0.15, 0.1), (0.25, 0.1)]],
    ids=["two pins", "three collinear pins"],
)
def test_rigid_mode_is_detected_where_a_naive_solve_fails(points):
    """A plate pinned on one line can rotate about it: K is singular (cond ~1e17). fem's
    shift-invert solve about a negative shift (K - sigma M positive definite) reports exactly
    one rigid-body mode and elastic frequencies equal to a dense generalised eigen solve;
    the naive routes fail: the layout is rejected without allow_rigid_modes, a factorisation
    of K returns garbage silently, and Lanczos for the smallest eigenvalues without a shift
    does not converge."""
    with pytest.raises(jaxflex.InputError, match="allow_rigid_modes"):
        _pinned_plate(points, allow_rigid_modes=False)
    result = _pinned_plate(points, allow_rigid_modes=True)
    assert result.rigid_freq_hz.size == 1 and result.rigid_freq_hz[0] < 0.01
    dense = _dense_freq_hz(result, 1, 6)
    # both solve the same matrices: agreement to round-off of the eigenvalues
    np.testing.assert_allclose(result.freq_hz, dense, rtol=1e-8)
    b = np.ones(result.K_free.shape[0])
    x = scipy.sparse.linalg.splu(result.K_free.tocsc()).solve(b)
    assert not np.abs(result.K_free @ x - b).max() <= 1e-6 * np.abs(b).max()  # no solution exists
    with pytest.raises(scipy.sparse.linalg.ArpackNoConvergence):
        scipy.sparse.linalg.eigsh(result.K_free, k=4, M=result.M_free, which="SM", maxiter=200)


def test_near_collinear_pins_give_an_accurate_soft_mode():
    """Three pins 1 mm off one line hold the plate, barely: the lowest mode (16 Hz, a third of
    the next) is elastic and K is ill-conditioned (~4e6). The layout is rejected unless
    allowed; once allowed, no mode is reported rigid and all six match the dense solve."""
    points = [(0.05, 0.1), (0.15, 0.101), (0.25, 0.1)]
    with pytest.raises(jaxflex.InputError, match="collinear"):
        _pinned_plate(points, allow_rigid_modes=False)
    result = _pinned_plate(points, allow_rigid_modes=True)
    assert result.rigid_freq_hz.size == 0
    dense = _dense_freq_hz(result, 0, 6)
    np.testing.assert_allclose(result.freq_hz, dense, rtol=1e-8)
    assert result.freq_hz[0] < 0.4 * result.freq_hz[1]
