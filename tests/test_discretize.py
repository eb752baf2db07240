"""Exact discretisation against an independent matrix exponential and closed forms."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import scipy.linalg

from jaxflex._discretize import foh_coefficients, propagators


def reference(omega: float, zeta: float, h: float):
    """Phi, J0, J1 from scipy's expm of the augmented system [[A, B, 0], [0, 0, 1], [0, 0, 0]]:
    its exponential holds int e^{A(h-s)} B ds = J0 and int e^{A(h-s)} B s ds = h J0 - J1."""
    aug = np.zeros((4, 4))
    aug[:2, :2] = [[0.0, 1.0], [-(omega**2), -2 * zeta * omega]]
    aug[1, 2] = 1.0
    aug[2, 3] = 1.0
    e = scipy.linalg.expm(aug * h)
    j0 = e[:2, 2]
    return e[:2, :2], j0, h * j0 - e[:2, 3]


def scaled(omega: float, h: float, phi, j0, j1):
    """Dimensionless forms of O(1) size: state (omega q, q'), forces scaled by 1/omega."""
    d = np.diag([omega, 1.0])
    return (
        d @ phi @ np.linalg.inv(d),
        omega * (d @ j0),
        omega * (d @ j1) / h,
    )


FREQS_HZ = [0.5, 3.0, 30.0, 300.0, 2000.0]
ZETAS = [0.0, 0.02, 0.3, 0.9]
STEPS_S = [1e-5, 1e-3, 0.0099, 0.01, 0.025, 0.3]


@pytest.mark.parametrize("freq_hz", FREQS_HZ)
@pytest.mark.parametrize("zeta", ZETAS)
@pytest.mark.parametrize("h", STEPS_S)
def test_propagators_match_matrix_exponential(freq_hz, zeta, h):
    omega = 2 * np.pi * freq_hz
    ours = scaled(omega, h, *propagators(omega, zeta, h, np))
    ref = scaled(omega, h, *reference(omega, zeta, h))
    # expm (scaling and squaring) is backward stable to ~1e-15 of the norm of omega*h*A; its
    # forward error grows with that norm (up to ~4e4 here), so allow 1e-10 in O(1) units.
    for a, b in zip(ours, ref, strict=True):
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-10)


def test_numpy_arrays_mixing_both_branches_match_matrix_exponential():
    """NumPy evaluates the closed form and the series each on its own entries only: a (T, M)
    array with omega h on both sides of the switch (and h = 0) gives every entry the
    independent matrix exponential's value, the shapes broadcast as documented."""
    omega = 2 * np.pi * np.array([0.5, 7.0, 41.0, 2000.0])
    zeta = np.array([0.0, 0.02, 0.3, 0.9])
    h = np.array([0.0, 1e-6, 2e-4, 1.25e-3, 0.01])[:, None]  # omega h from 0 to 126
    prop = propagators(omega[None], zeta[None], h, np)
    assert prop.phi.shape == (5, 4, 2, 2) and prop.j0.shape == prop.j1.shape == (5, 4, 2)
    for t in range(h.shape[0]):
        for m in range(omega.size):
            if h[t, 0] == 0.0:
                np.testing.assert_array_equal(prop.phi[t, m], np.eye(2))
                np.testing.assert_array_equal(prop.j0[t, m], 0.0)
                continue
            ours = scaled(omega[m], h[t, 0], prop.phi[t, m], prop.j0[t, m], prop.j1[t, m])
            ref = scaled(omega[m], h[t, 0], *reference(omega[m], zeta[m], h[t, 0]))
            for a, b in zip(ours, ref, strict=True):  # tolerance as for the scalars above
                np.testing.assert_allclose(a, b, rtol=0, atol=1e-10)


def test_numpy_and_jax_agree():
    omega = 2 * np.pi * np.array([0.5, 7.0, 2000.0])
    zeta = np.array([0.0, 0.05, 0.5])
    for h in (1e-4, 0.01):
        for a, b in zip(propagators(omega, zeta, h, np), propagators(omega, zeta, h), strict=True):
            # XLA and numpy transcendental functions differ by a few ulp, amplified by cancellation
            np.testing.assert_allclose(np.asarray(b), a, rtol=1e-12, atol=1e-300)


def test_series_and_closed_form_meet_continuously():
    omega, zeta = 2 * np.pi * 10.0, 0.03
    h_switch = 0.1 / omega
    below = propagators(omega, zeta, h_switch * (1 - 1e-9), np)
    above = propagators(omega, zeta, h_switch * (1 + 1e-9), np)
    for a, b in zip(below, above, strict=True):
        # values differ by the 2e-9 relative change of h (derivatives are O(1/h)), nothing more
        np.testing.assert_allclose(a, b, rtol=1e-8, atol=0)


def test_high_frequency_mode_at_coarse_step_is_bounded_and_exact():
    """A 2 kHz mode at dt = 10 ms: |eigenvalues of Phi| = e^{-zeta omega dt} <= 1 exactly."""
    omega, zeta, dt_s = 2 * np.pi * 2000.0, 0.02, 0.01
    phi, g0, g1 = foh_coefficients(omega, zeta, dt_s, np)
    radius = np.max(np.abs(np.linalg.eigvals(phi)))
    assert radius == pytest.approx(np.exp(-zeta * omega * dt_s), rel=1e-12)
    # A constant unit force held forever converges to the static deflection 1/omega^2.
    x = np.zeros(2)
    for _ in range(200):
        x = phi @ x + g0 + g1
    assert x[0] == pytest.approx(1 / omega**2, rel=1e-12)
    assert abs(x[1]) < 1e-12 / omega


@pytest.mark.parametrize("argnum", [0, 1, 2])
def test_gradients_match_finite_differences(argnum):
    args = [2 * np.pi * 12.0, 0.04, 0.01]

    def total(omega, zeta, dt_s):
        phi, g0, g1 = foh_coefficients(omega, zeta, dt_s)
        weights = jnp.array([1.0, 0.3])
        return jnp.sum(phi @ weights) + 50 * (omega**2) * jnp.sum(g0 + 2 * g1)

    grad = jax.grad(total, argnums=argnum)(*map(jnp.asarray, args))
    step = 1e-6 * args[argnum]
    plus, minus = list(args), list(args)
    plus[argnum] += step
    minus[argnum] -= step
    fd = (total(*plus) - total(*minus)) / (2 * step)
    # central differences: truncation O(step^2) ~ 1e-12 relative, round-off ~ eps / 1e-6
    assert float(grad) == pytest.approx(float(fd), rel=1e-7)


def test_gradient_is_finite_across_the_series_switch():
    def f(h):
        return jnp.sum(propagators(2 * np.pi * 10.0, 0.02, h).j1)

    for h in (1e-6, 0.1 / (2 * np.pi * 10.0), 0.01):
        assert np.isfinite(float(jax.grad(f)(jnp.asarray(h))))
