"""Free vibration after a move, in NumPy: amplitudes, envelope and its horizon.

After the move the base is at rest and each mode is a free damped oscillation
q_i(tau) = R_i e^{-sigma_i tau} cos(omega_d,i tau - theta_i), sigma_i = zeta_i omega_i, so
every point's deviation is bounded by the decreasing envelope

    |u_p(tau)| <= E_p(tau) = sum_i w_pi R_i e^{-sigma_i tau},   w_pi = |phi_i(p)|.

Once max_p E_p(tau) <= threshold nothing can exceed it again: that tau is the horizon. The
exact response itself is jaxflex._engine.free_states / :func:`free_rows`.
"""

from __future__ import annotations

import math

import numpy as np

from jaxflex._engine import free_propagators

HORIZON_REL_TOL = 1e-12


def amplitudes(model, x_end: np.ndarray) -> np.ndarray:
    """R_i (M,): amplitude of each mode's free decay from the state ``x_end`` (M, 2)."""
    omega, zeta = np.asarray(model.omega_rad_s), np.asarray(model.zeta)
    sigma = zeta * omega
    omega_d = omega * np.sqrt(1.0 - zeta**2)
    q0, v0 = x_end[:, 0], x_end[:, 1]
    return np.hypot(q0, (v0 + sigma * q0) / omega_d)


def free_rows(model, tau_s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """P11, P12 (T, M): q_i(tau) = P11 q_i + P12 q_i' for the free decay after ``tau_s`` (T,)."""
    phi = free_propagators(model, np.asarray(tau_s, dtype=np.float64), np).phi
    return phi[..., 0, 0], phi[..., 0, 1]


def envelope(weights: np.ndarray, amplitude: np.ndarray, sigma: np.ndarray, tau_s) -> np.ndarray:
    """E_p(tau) (K, T) >= |u_p(tau)| for point weights (K, M), amplitudes and decay rates (M,)."""
    tau = np.atleast_1d(np.asarray(tau_s, dtype=np.float64))
    return weights @ (amplitude[:, None] * np.exp(-np.outer(sigma, tau)))


def envelope_horizon(
    weights: np.ndarray,
    amplitude: np.ndarray,
    sigma: np.ndarray,
    threshold_m: float,
    groups: tuple[np.ndarray, np.ndarray] | None = None,
) -> float:
    """Smallest tau >= 0 (s) with max_p E_p(tau) <= ``threshold_m``; inf if undamped modes
    keep the envelope above it forever. Bisection to HORIZON_REL_TOL relative.

    ``groups`` = (members (G, b) point indices, K for none; group weights (G, M) >= those of
    the members) lets whole groups be ruled out by their envelope before their points are
    evaluated. Every E_p decreases in tau and the search only ever asks at later tau than the
    last one found above the threshold, so the groups below it there are dropped for good."""
    n_points = weights.shape[0]
    if groups is None:
        groups = (np.arange(n_points)[:, None], weights)
    members, group_weights = groups
    active = np.arange(members.shape[0])

    def peak(tau: float) -> float:
        nonlocal active
        bound = envelope(group_weights[active], amplitude, sigma, tau)[:, 0]
        over = active[bound > threshold_m]
        if over.size == 0:
            return float(bound.max())  # >= every point's envelope, <= the threshold
        idx = members[over].ravel()
        top = float(envelope(weights[idx[idx < n_points]], amplitude, sigma, tau).max())
        if top > threshold_m:
            active = over
        return top

    peak0 = peak(0.0)
    if peak0 <= threshold_m:
        return 0.0
    lasting = sigma <= 0
    if lasting.any() and (weights[:, lasting] @ amplitude[lasting]).max() >= threshold_m:
        return math.inf
    damped = (sigma > 0) & (amplitude > 0)
    lo, hi = 0.0, math.log(peak0 / threshold_m) / sigma[damped].min()
    while peak(hi) > threshold_m:  # undamped floor just below the threshold
        lo, hi = hi, 2.0 * hi
    for _ in range(200):
        if hi - lo <= HORIZON_REL_TOL * max(1.0, hi):
            break
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if peak(mid) > threshold_m else (lo, mid)
    return hi
