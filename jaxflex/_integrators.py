"""Classical time integrators of the modal equations, kept to show where they fail.

Both integrate q_i'' + 2 zeta_i w_i q_i' + w_i^2 q_i = f_i(t), f = -Gamma . a, from rest, with
the forces sampled at the steps (they see the samples, not the piecewise-linear input):

* Newmark average acceleration (beta = 1/4, gamma = 1/2, the trapezoidal rule): unconditionally
  stable, but its period is too long by (w h)^2 / 12 relative to first order, so phase errors
  grow with time and with w h.
* Central difference (explicit): exact enough for small w h, unstable for w h > 2
  (h > 2 / w_max): the error grows exponentially.

jaxflex's exact recursion (jaxflex.simulate) has neither limit. Both return the modal
coordinates (n+1, M) at the samples; they are jitted ``lax.scan`` loops so that their speed is
measured on the same footing.
"""

from __future__ import annotations

from functools import partial

import jax
import jax.numpy as jnp

from jaxflex._engine import modal_forces
from jaxflex.model import ModalModel


@partial(jax.jit, static_argnames=("beta", "gamma"))
def newmark_modal(model: ModalModel, acc, dt_s, beta: float = 0.25, gamma: float = 0.5):
    """Newmark-beta on each mode: modal coordinates q (n+1, M) at t_k = k dt."""
    omega = model.omega_rad_s
    damping = 2.0 * model.zeta * omega
    stiffness = omega**2
    force = modal_forces(model, acc)
    k_eff = stiffness + gamma / (beta * dt_s) * damping + 1.0 / (beta * dt_s**2)

    def step(state, f_next):
        q, v, a = state
        rhs = (
            f_next
            + q / (beta * dt_s**2)
            + v / (beta * dt_s)
            + (0.5 / beta - 1.0) * a
            + damping * (gamma / (beta * dt_s) * q + (gamma / beta - 1.0) * v)
            + damping * dt_s * (0.5 * gamma / beta - 1.0) * a
        )
        q_next = rhs / k_eff
        a_next = (q_next - q) / (beta * dt_s**2) - v / (beta * dt_s) - (0.5 / beta - 1.0) * a
        v_next = v + dt_s * ((1.0 - gamma) * a + gamma * a_next)
        return (q_next, v_next, a_next), q_next

    zeros = jnp.zeros_like(omega)
    _, qs = jax.lax.scan(step, (zeros, zeros, force[0]), force[1:])
    return jnp.concatenate([zeros[None], qs], axis=0)


@jax.jit
def central_difference_modal(model: ModalModel, acc, dt_s):
    """Explicit central difference on each mode: q (n+1, M); unstable if w h > 2."""
    omega = model.omega_rad_s
    sigma_h = model.zeta * omega * dt_s
    force = modal_forces(model, acc)
    q0 = jnp.zeros_like(omega)
    q_prev = q0 + 0.5 * dt_s**2 * force[0]  # q_{-1} from rest with q''(0) = f_0

    def step(state, f):
        q_before, q = state
        q_next = (dt_s**2 * f - (omega**2 * dt_s**2 - 2.0) * q - (1.0 - sigma_h) * q_before) / (
            1.0 + sigma_h
        )
        return (q, q_next), q_next

    _, qs = jax.lax.scan(step, (q_prev, q0), force[:-1])
    return jnp.concatenate([q0[None], qs], axis=0)
