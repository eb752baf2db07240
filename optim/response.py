"""Deviation curves for reports and plots, in numpy (no JAX compilation per move length).

The states at the samples follow the exact first-order-hold recursion; between samples and
after the move the closed-form sub-step and free-decay propagators of jaxflex.discretize give
the exact response at any time (as in jaxflex.settle), so the curves are exact samples of
d(t) = max_p |u_p(t)|, not interpolations.
"""

from __future__ import annotations

import numpy as np

from jaxflex.discretize import foh_coefficients, propagators, substep_state
from jaxflex.model import ModalModel

SUBSTEPS = 8


def sample_states(model: ModalModel, acc: np.ndarray, dt: float) -> np.ndarray:
    """(n+1, M, 2) modal states at the samples (the recursion of jaxflex.modal_states)."""
    omega, zeta = 2 * np.pi * np.asarray(model.freq_hz), np.asarray(model.zeta)
    phi, g0, g1 = foh_coefficients(omega, zeta, dt, np)
    force = -acc @ np.asarray(model.gamma).T  # (n+1, M)
    states = np.zeros((acc.shape[0], omega.size, 2))
    for k in range(acc.shape[0] - 1):
        states[k + 1] = (
            np.einsum("mij,mj->mi", phi, states[k])
            + g0 * force[k][:, None]
            + g1 * force[k + 1][:, None]
        )
    return states


def deviation_curve(
    model: ModalModel, acc: np.ndarray, dt: float, until_s: float, substeps: int = SUBSTEPS
) -> tuple[np.ndarray, np.ndarray]:
    """(t (T,) s, d (T,) m): d(t) every dt / substeps from 0 to at least ``until_s``."""
    acc = np.asarray(acc, dtype=np.float64)
    n = acc.shape[0] - 1
    omega, zeta = 2 * np.pi * np.asarray(model.freq_hz), np.asarray(model.zeta)
    states = sample_states(model, acc, dt)
    force = -acc @ np.asarray(model.gamma).T
    h = dt / substeps
    t_move = h * np.arange(n * substeps)
    k = np.minimum((t_move / dt).astype(int), n - 1)
    tau = t_move - k * dt
    prop = propagators(omega, zeta, tau[:, None], np)
    slope = (force[k + 1] - force[k]) / dt
    q_move = substep_state(prop, tau[:, None], states[k], force[k], slope, np)[..., 0]
    t_free = n * dt + h * np.arange(max(1, int(np.ceil((until_s - n * dt) / h)) + 1))
    free = propagators(omega, zeta, (t_free - n * dt)[:, None], np).phi
    q_free = np.einsum("tmij,mj->tmi", free, states[-1])[..., 0]
    q = np.vstack([q_move, q_free])
    shapes = np.asarray(model.shapes)  # (K, 3, M)
    by_component = np.transpose(shapes, (2, 1, 0)).reshape(omega.size, -1)
    u = (q @ by_component).reshape(q.shape[0], 3, shapes.shape[0])
    return np.concatenate([t_move, t_free]), np.sqrt(np.max(np.sum(u * u, axis=1), axis=1))
