"""The response engine: the one place that advances modal states.

A move is acceleration samples a_k (m/s^2) at t_k = k dt_s, k = 0..n, linear in between
(first-order hold). Per mode i the forcing is f_i(t) = -Gamma_i . a(t) and the state
x_i = (q_i, q_i') follows the exact step (jaxflex._discretize)

    x_{k+1} = Phi x_k + G0 f_k + G1 f_{k+1}.

Everything that needs modal states asks this module: at the samples (:func:`modal_states`,
JAX ``lax.scan`` or a NumPy loop), between samples (:func:`states_between`), after the move
(:func:`free_states`), or as linear maps of the samples (:func:`end_state_map`,
:func:`state_map`). ``xp`` selects the backend: ``jax.numpy`` (traceable: jit, grad, vmap)
or ``numpy`` (no compilation, for code that sees a new move length at every call).

``hold="zero"`` gives the zero-order-hold variant (each sample held over its step, as a
co-simulation host that cannot interpolate inputs does): x_{k+1} = Phi x_k + J0 f_k.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import jax
import jax.numpy as jnp
import numpy as np

from jaxflex._discretize import Propagators, foh_coefficients, propagators, substep_state
from jaxflex.errors import InputError

if TYPE_CHECKING:
    from jaxflex._profile import Move

HOLDS = ("linear", "zero")
# Moves are padded to a multiple of this many steps where a jitted function would otherwise
# compile once per move length (sweeps, sizing curves): one compilation per 128 steps.
PAD_STEPS = 128
POWER_TERMS_KEPT = 4  # (length, step) pairs of _power_terms kept per model
SAMPLE_STATES_KEPT = 2  # moves whose sample states states_at keeps per model (n M 32 bytes)


def modal_forces(model, acc, xp: Any = jnp):
    """f_k = -Gamma . a_k: (n+1, M) modal forces in kg^0.5 m/s^2 for samples (n+1, 3)."""
    return -(xp.asarray(acc) @ xp.asarray(model.gamma).T)


def step_matrices(model, dt_s, *, hold: str = "linear", xp: Any = jnp):
    """(Phi (M, 2, 2), G0 (M, 2), G1 (M, 2)) of one step of ``dt_s`` s for ``hold``."""
    if hold not in HOLDS:
        raise InputError(f"hold: must be one of {list(HOLDS)}, got {hold!r}")
    phi, g0, g1 = foh_coefficients(model.omega_rad_s, model.zeta, dt_s, xp)
    if hold == "zero":
        return phi, g0 + g1, xp.zeros_like(g1)
    return phi, g0, g1


def modal_states(model, acc, dt_s, *, x0=None, hold: str = "linear", xp: Any = jnp):
    """Modal states at every sample: (n+1, M, 2) with [..., 0] = q (kg^0.5 m) and [..., 1] = q'.

    ``x0`` (M, 2) is the state at t_0 (default: at rest). With ``xp=jax.numpy`` the recursion
    is a ``lax.scan`` (traceable); with ``xp=numpy`` a loop over the steps (~3 us per step for
    40 modes, and nothing to compile).
    """
    return forced_states(model, modal_forces(model, acc, xp), dt_s, x0=x0, hold=hold, xp=xp)


def forced_states(model, force, dt_s, *, x0=None, hold: str = "linear", xp: Any = jnp):
    """:func:`modal_states` for given modal forces ``force`` (n+1, M) in kg^0.5 m/s^2 at the
    samples (linear in between): the recursion of any forcing (the turning response uses it)."""
    phi, g0, g1 = step_matrices(model, dt_s, hold=hold, xp=xp)
    force = xp.asarray(force)
    drive = g0[None] * force[:-1, :, None] + g1[None] * force[1:, :, None]  # (n, M, 2)
    p11, p12, p21, p22 = phi[:, 0, 0], phi[:, 0, 1], phi[:, 1, 0], phi[:, 1, 1]
    n_steps, n_modes = drive.shape[0], drive.shape[1]
    x0 = xp.zeros((n_modes, 2), drive.dtype) if x0 is None else xp.asarray(x0, drive.dtype)
    if xp is np:
        states = np.empty((n_steps + 1, n_modes, 2))
        states[0] = x0
        q, v = x0[:, 0].copy(), x0[:, 1].copy()
        for k in range(n_steps):
            q, v = p11 * q + p12 * v + drive[k, :, 0], p21 * q + p22 * v + drive[k, :, 1]
            states[k + 1, :, 0], states[k + 1, :, 1] = q, v
        return states

    def step(x, b):
        q, v = x[:, 0], x[:, 1]
        x_next = jnp.stack([p11 * q + p12 * v + b[:, 0], p21 * q + p22 * v + b[:, 1]], axis=-1)
        return x_next, x_next

    _, xs = jax.lax.scan(step, x0, drive)
    return jnp.concatenate([x0[None], xs], axis=0)


def states_between(model, states, force, dt_s, t_s, xp: Any = np):
    """Exact states (T, M, 2) at times ``t_s`` (T,) during the move, 0 <= t <= n dt_s, from
    the states at the samples (n+1, M, 2) and the modal forces (n+1, M) (linear between)."""
    n_steps = states.shape[0] - 1
    t_s = xp.asarray(t_s)
    k = xp.clip(xp.floor(t_s / dt_s).astype(int), 0, n_steps - 1)
    tau = t_s - k * dt_s
    prop = propagators(model.omega_rad_s, model.zeta, tau[:, None], xp)
    slope = (force[k + 1] - force[k]) / dt_s
    return substep_state(prop, tau[:, None], states[k], force[k], slope, xp)


def derivative_bounds(model, states, force, dt_s: float) -> tuple[np.ndarray, ...]:
    """Bounds (n, M) of sup |q'|, |q''| and |q'''| over each step of a move, from the states
    at the samples (n+1, M, 2) and the modal forces (n+1, M). NumPy.

    Two bounds, the smaller taken: (a) the energy radius r = sqrt(q'^2 + omega^2 q^2) grows by
    at most |f| per second; (b) within a step the force is linear, f = f_k + s t, so q is the
    particular solution q_p = f / omega^2 - 2 zeta s / omega^3 (q_p' = s / omega^2, q_p'' = 0)
    plus a free vibration whose energy radius r_h does not grow (zeta >= 0): |q''| <= (1 + 2
    zeta) omega r_h, |q'''| <= (1 + 2 zeta (1 + 2 zeta)) omega^2 r_h. (b) is what keeps stiff
    modes cheap: their response is quasi-static and r_h only the vibration the move excites,
    while (a) grows with omega dt. r_h carries an allowance for the rounding of the
    subtraction of q_p."""
    omega, zeta = np.asarray(model.omega_rad_s), np.asarray(model.zeta)
    q, v = states[:-1, :, 0], states[:-1, :, 1]
    step_force = np.maximum(np.abs(force[:-1]), np.abs(force[1:]))
    slope = np.diff(force, axis=0) / dt_s
    vel = np.hypot(v, omega * q) + dt_s * step_force
    qdd = step_force + (1.0 + 2.0 * zeta) * omega * vel
    qddd = np.abs(slope) + 2 * zeta * omega * qdd + omega**2 * vel
    q_free = q - force[:-1] / omega**2 + 2 * zeta * slope / omega**3
    v_free = v - slope / omega**2
    scale = (
        omega * np.abs(q)
        + np.abs(force[:-1]) / omega
        + (1 + 2 * zeta) * np.abs(slope) / omega**2
        + np.abs(v)
    )
    free = np.hypot(v_free, omega * q_free) + 8 * np.finfo(float).eps * scale
    return (
        np.minimum(vel, np.abs(slope) / omega**2 + free),
        np.minimum(qdd, (1 + 2 * zeta) * omega * free),
        np.minimum(qddd, (1 + 2 * zeta * (1 + 2 * zeta)) * omega**2 * free),
    )


def free_propagators(model, tau_s, xp: Any = jnp) -> Propagators:
    """Propagators of the free vibration after times ``tau_s`` (T,): entries (T, M, ...)."""
    return propagators(
        model.omega_rad_s[None, :], model.zeta[None, :], xp.asarray(tau_s)[:, None], xp
    )


def free_states(model, x_start, tau_s, xp: Any = jnp):
    """Free vibration (base at rest) from state ``x_start`` (M, 2) after times ``tau_s`` (T,) s:
    (T, M, 2)."""
    phi = free_propagators(model, tau_s, xp).phi
    return xp.einsum("tmij,mj->tmi", phi, x_start)


def states_at(model, move: Move, t_s) -> np.ndarray:
    """Exact states (T, M, 2) at any times ``t_s`` (T,) >= 0 s, during ``move`` (a
    jaxflex._profile.Move, at rest at the end) and after it (free vibration). NumPy."""
    t_s = np.asarray(t_s, dtype=np.float64)
    dt_s = move.dt_s
    states, force = _sample_states(model, move.acc, dt_s)
    t_end = move.n_steps * dt_s
    during = t_s < t_end
    out = np.empty((t_s.size, model.n_modes, 2))
    out[during] = states_between(model, states, force, dt_s, t_s[during], np)
    out[~during] = free_states(model, states[-1], t_s[~during] - t_end, np)
    return out


def _sample_states(model, acc: np.ndarray, dt_s: float) -> tuple[np.ndarray, np.ndarray]:
    """(states (n+1, M, 2), modal forces (n+1, M)) at the samples of the move ``acc`` ((n+1,
    3) float64, NumPy); of a concrete model kept for the last few moves (the optimiser's
    rows and certificates evaluate one move at one time after another: the recursion over
    the move once, not once per row)."""
    cache = model.__dict__.setdefault("_sample_states", {})
    key = (dt_s, acc.shape, acc.tobytes())
    if key not in cache:
        while len(cache) >= SAMPLE_STATES_KEPT:
            del cache[next(iter(cache))]
        cache[key] = (modal_states(model, acc, dt_s, xp=np), modal_forces(model, acc, np))
    return cache[key]


def _power_terms(model, n_steps: int, dt_s: float):
    """Phi^l G0 and Phi^l G1 for l = 0..n: two (n+1, M, 2) arrays (Phi^l = Phi(l dt_s)); of
    a concrete model kept for the last few lengths and steps (the optimiser asks for the
    same ones for every row it adds)."""
    cache = model.__dict__.setdefault("_power_terms", {})
    key = (int(n_steps), float(dt_s))
    if key not in cache:
        while len(cache) >= POWER_TERMS_KEPT:
            del cache[next(iter(cache))]
        cache[key] = _compute_power_terms(model, n_steps, dt_s)
    return cache[key]


def _compute_power_terms(model, n_steps: int, dt_s: float):
    powers = propagators(
        model.omega_rad_s, model.zeta, dt_s * np.arange(n_steps + 1)[:, None], np
    ).phi
    _, g0, g1 = step_matrices(model, dt_s, xp=np)
    return np.einsum("lmab,mb->lma", powers, g0), np.einsum("lmab,mb->lma", powers, g1)


def end_state_map(model, n_steps: int, dt_s: float) -> np.ndarray:
    """(M, 2, n+1, 3) matrix E with x_end[i, :] = sum_{k, c} E[i, :, k, c] a[k, c]: the state
    at t_n, which is linear in the samples (it equals ``jax.jacfwd`` of the recursion)."""
    return _end_map(model, _power_terms(model, n_steps, dt_s), n_steps)


def _end_map(model, terms, n_steps: int) -> np.ndarray:
    """:func:`end_state_map` of ``n_steps`` steps from the :func:`_power_terms` ``terms`` of
    at least that many steps."""
    c0, c1 = terms
    lag = n_steps - 1 - np.arange(n_steps)
    coef = np.zeros((n_steps + 1, model.n_modes, 2))
    coef[:-1] += c0[lag]
    coef[1:] += c1[lag]
    return -np.einsum("kmi,mc->mikc", coef, np.asarray(model.gamma))


def state_map(model, n_steps: int, dt_s: float, substeps: int) -> np.ndarray:
    """(n S + 1, M, n+1) map C with q(t_j) = sum_i C[j, :, i] f_i at t_j = j dt_s / S during the
    move (S = ``substeps``), f the modal forces at the samples (first-order hold)."""
    n, m = n_steps, model.n_modes
    c0, c1 = _power_terms(model, n, dt_s)
    k, i = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
    lag = k - i  # the state at sample k from the force at sample i
    state = np.where((lag >= 1)[..., None, None], c0[np.clip(lag - 1, 0, n)], 0.0)
    state += np.where(((lag >= 0) & (i >= 1))[..., None, None], c1[np.clip(lag, 0, n)], 0.0)
    tau = dt_s * np.arange(substeps) / substeps
    sub = propagators(model.omega_rad_s, model.zeta, tau[:, None], np)  # (S, M, ...)
    ramp = (tau[:, None] * sub.j0[..., 0] - sub.j1[..., 0]) / dt_s  # (S, M)
    q = np.einsum("sma,kima->ksmi", sub.phi[:, :, 0, :], state[:n])  # (n, S, M, n+1)
    steps = np.arange(n)
    q[steps, :, :, steps] += sub.j0[..., 0] - ramp
    q[steps, :, :, steps + 1] += ramp
    at_end = state[n, :, :, 0].T[None]  # (1, M, n+1): q at t_n
    return np.concatenate([q.reshape(n * substeps, m, n + 1), at_end], axis=0)


def state_maps_at(model, n_steps: int, dt_s: float, t_s) -> np.ndarray:
    """(T, M, 2, n+1, 3) map X with x(t)[i, :] = sum_{k, c} X[t, i, :, k, c] a[k, c]: the
    modal state (q, q') at any times ``t_s`` (T,) >= 0 s of an n-step move (samples a, first-
    order hold) and of the free vibration after it, as a linear function of the samples.
    NumPy; cost O(T n M) (for the few times where the optimiser adds rows)."""
    t_s = np.atleast_1d(np.asarray(t_s, dtype=np.float64))
    gamma = np.asarray(model.gamma)
    out = np.zeros((t_s.size, model.n_modes, 2, n_steps + 1, 3))
    terms = _power_terms(model, n_steps, dt_s)  # every shorter move's map is a part of them
    end = _end_map(model, terms, n_steps)
    t_end = n_steps * dt_s
    for j, t in enumerate(t_s):
        if t >= t_end:
            phi = free_propagators(model, np.array([t - t_end]), np).phi[0]  # (M, 2, 2)
            out[j] = np.einsum("mab,mbkc->makc", phi, end)
            continue
        k = min(int(np.floor(t / dt_s)), n_steps - 1)
        tau = t - k * dt_s
        out[j, :, :, : k + 1] = _end_map(model, terms, k) if k > 0 else 0.0
        prop = propagators(model.omega_rad_s, model.zeta, tau, np)  # entries (M, ...)
        out[j] = np.einsum("mab,mbkc->makc", prop.phi, out[j])
        ramp = (tau * prop.j0 - prop.j1) / dt_s  # (M, 2), per unit slope of the force
        here = prop.j0 - ramp  # coefficient of f_k
        out[j, :, :, k] -= here[:, :, None] * gamma[:, None, :]
        out[j, :, :, k + 1] -= ramp[:, :, None] * gamma[:, None, :]
    return out


def padded_steps(n_steps: int, block: int = PAD_STEPS) -> int:
    """``n_steps`` rounded up to a whole number of ``block`` steps (at least one block)."""
    return block * max(1, -(-int(n_steps) // block))


def rest_padded(acc, n_steps: int) -> np.ndarray:
    """(n_steps + 1, 3): the move ``acc`` ((n+1, 3), n <= n_steps) followed by rest."""
    acc = np.asarray(acc, dtype=np.float64)
    if acc.shape[0] > n_steps + 1:
        raise InputError(f"n_steps: {n_steps} is shorter than the move ({acc.shape[0] - 1} steps)")
    return np.concatenate([acc, np.zeros((n_steps + 1 - acc.shape[0], acc.shape[1]))])


def upsample(acc, factor: int, xp: Any = jnp):
    """The same piecewise-linear profile sampled ``factor`` times finer: (n+1, ...) samples
    (e.g. (n+1, 3) accelerations, (n+1,) angular accelerations) -> (n factor + 1, ...).

    Simulating it at dt / factor gives the exact response at the finer times."""
    acc = xp.asarray(acc)
    if int(factor) != factor or factor < 1:
        raise InputError(f"factor: must be an integer >= 1, got {factor}")
    factor = int(factor)
    frac = xp.arange(factor, dtype=acc.dtype).reshape((factor,) + (1,) * acc.ndim) / factor
    fine = (1.0 - frac) * acc[None, :-1] + frac * acc[None, 1:]  # (f, n, ...)
    fine = xp.moveaxis(fine, 0, 1).reshape((-1, *acc.shape[1:]))
    return xp.concatenate([fine, acc[-1:]], axis=0)
