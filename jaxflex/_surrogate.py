"""Smooth, differentiable upper bounds for gradient-based optimisers: the soft maximum and,
built on it, a bound of the cycle time.

The soft maximum (:func:`soft_max`, the one the core and the optimiser's gradient route
share) of values v_r with weights w_r in {0, 1} at sharpness s,

    S = (1 / s) log sum_r w_r exp(s v_r),    max_r v_r <= S <= max_r v_r + log(R) / s,

(the maxima over the R rows with w_r = 1) is smooth, and an upper bound of the maximum
whose excess is at most log(R) / s.

The exact cycle time jumps by about half a period whenever an oscillation peak crosses the
threshold, so it cannot be optimised directly. After the move, each point's deviation is
bounded by its free-decay envelope

    |u_p(t_n + tau)| <= E_p(tau) = sum_i |phi_i(p)| R_i e^{-sigma_i tau},

(R_i the amplitude of mode i at t_n, sigma_i = zeta_i omega_i). The surrogate is the time at
which the soft maximum over points of log E_p reaches the threshold,

    F(tau) = (1 / s) log sum_p E_p(tau)^s   (>= max_p log E_p(tau)),   F(tau_env) = log threshold,

extended to negative tau (a residual already below the threshold) and passed through a
softplus of width w (default: dt_s):  T_smooth = t_n + w softplus(tau_env / w).

Bound: T_smooth >= exact cycle time, always (every step over-estimates). It is tight when one
mode dominates the residual (then the envelope touches the true peaks); with several modes the
over-estimate is the phase slack of the envelope plus at most log(K) / (s sigma_min) from the
soft maximum (K points, s = ``sharpness``). The gradient is exact for this smooth function
(implicit function theorem at the root), so it matches finite differences.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from jaxflex._simulate import end_state
from jaxflex.model import ModalModel

_NEWTON_STEPS = 40


def soft_max(values, sharpness, weights=None):
    """Soft maximum (module docstring) of ``values`` (any shape, the rows to bound, in any
    unit) at ``sharpness`` (in the inverse of that unit), over every element whose
    ``weights`` (broadcast to ``values``' shape, 0 or 1; default all 1) is 1. Traceable."""
    return jax.nn.logsumexp(sharpness * values, b=weights) / sharpness


def _envelope_terms(model: ModalModel, x_end, threshold_m):
    """Point weights |phi_i(p)| (K, M), amplitudes R_i (M,) and decay rates sigma_i (M,),
    with floors that only ever raise the envelope (so the bound is kept)."""
    omega = model.omega_rad_s
    sigma = model.zeta * omega
    omega_d = omega * jnp.sqrt(1.0 - model.zeta**2)
    weights = jnp.linalg.norm(model.shapes, axis=1)  # (K, M)
    weights = jnp.maximum(weights, 1e-30 * jax.lax.stop_gradient(jnp.max(weights)))
    # Smooth |.|: sqrt(R^2 + eps^2) >= R with eps small enough to add < 1e-9 threshold.
    eps = 1e-9 * threshold_m / jax.lax.stop_gradient(jnp.max(jnp.sum(weights, axis=1)))
    q0, v0 = x_end[:, 0], x_end[:, 1]
    amplitude = jnp.sqrt(q0**2 + ((v0 + sigma * q0) / omega_d) ** 2 + eps**2)
    return weights, amplitude, sigma


def envelope_time(model: ModalModel, x_end, threshold_m, *, sharpness: float = 50.0):
    """Smooth root tau (s, may be negative) of soft-max_p log E_p(tau) = log threshold_m for the
    free decay from modal state ``x_end`` (M, 2). Differentiable in x_end and the model.

    G(tau) = soft-max_p log E_p(tau) - log threshold is convex and decreasing in tau (a
    log-sum-exp of functions linear in tau), so Newton's method started left of the root
    climbs to it monotonically without overshooting.
    """
    weights, amplitude, sigma = _envelope_terms(model, x_end, threshold_m)
    log_threshold = jnp.log(threshold_m)

    def excess(tau):
        envelope = weights @ (amplitude * jnp.exp(-sigma * tau))  # (K,)
        return soft_max(jnp.log(envelope), sharpness) - log_threshold

    excess_and_slope = jax.value_and_grad(excess)
    sigma_pos = jnp.maximum(jax.lax.stop_gradient(sigma), 1e-9)
    g0 = jax.lax.stop_gradient(excess(0.0))
    # The root lies between g0 / sigma_max and g0 / sigma_min; start at the left end.
    # (clamped where exp(-sigma tau) would overflow; Newton then steps in from the right).
    start = jnp.minimum(g0 / jnp.max(sigma_pos), g0 / jnp.min(sigma_pos))
    start = jnp.maximum(start, -600.0 / jnp.max(sigma_pos))

    def newton(_, tau):
        g, slope = excess_and_slope(tau)
        return jax.lax.stop_gradient(tau - g / slope)

    tau0 = jax.lax.fori_loop(0, _NEWTON_STEPS, newton, jax.lax.stop_gradient(start))
    # One more Newton step with gradients: at the root its derivative is the implicit one.
    g, slope = excess_and_slope(tau0)
    return tau0 - g / slope


def cycle_time_smooth(
    model: ModalModel,
    acc,
    dt_s,
    threshold_m,
    *,
    sharpness: float = 50.0,
    width_s=None,
):
    """Smooth upper bound of the exact cycle time (s) of the move ``acc`` ((n+1, 3) m/s^2)
    at step ``dt_s`` (s) against ``threshold_m`` (m); see the module docstring. Traceable, so
    jax.grad gives its gradient with respect to the samples and the model."""
    acc = jnp.asarray(acc)
    n_steps = acc.shape[0] - 1
    width = dt_s if width_s is None else width_s
    tau = envelope_time(model, end_state(model, acc, dt_s), threshold_m, sharpness=sharpness)
    return n_steps * dt_s + width * jax.nn.softplus(tau / width)
