"""The response during the move as a linear map of the samples, for the clearance limit.

With per-mode forces f_k = -Gamma . a_k, the state at sample k is
x_k = sum_i (Phi^{k-1-i} G0 [i < k] + Phi^{k-i} G1 [1 <= i <= k]) f_i, and at t_k + tau
(first-order hold) q = [Phi(tau) x_k]_q + J0_q(tau) f_k + (tau J0_q - J1_q)(tau) (f_{k+1} - f_k)
/ dt. :class:`MoveResponse` tabulates these coefficients at every dt / substeps during the
move, so that the deviation there is |shapes_p q(t)| with q linear in the samples: the exact
route bounds it with tangent-plane rows, the gradient route with a soft maximum.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from jaxflex.discretize import foh_coefficients, propagators
from jaxflex.model import ModalModel

SUBSTEPS = 8


@dataclass(frozen=True)
class ClearancePeak:
    """Deviation ``u`` (C,) at ``point`` and fine time index ``index`` (t = index dt / S)."""

    index: int
    point: int
    u: np.ndarray
    value: float  # |u| / limit


class MoveResponse:
    """q(t_j) (T, M) = sum_i G[j, :, i] f_i at t_j = j dt / substeps, j = 0 .. n substeps."""

    def __init__(
        self, model: ModalModel, components, n_steps: int, dt: float, substeps: int = SUBSTEPS
    ):
        omega, zeta = 2 * np.pi * np.asarray(model.freq_hz), np.asarray(model.zeta)
        m, n = omega.size, n_steps
        powers = propagators(omega, zeta, dt * np.arange(n + 1)[:, None], np).phi  # (n+1,M,2,2)
        _, g0, g1 = foh_coefficients(omega, zeta, dt, np)
        c0 = np.einsum("lmab,mb->lma", powers, g0)  # Phi^l G0, (n+1, M, 2)
        c1 = np.einsum("lmab,mb->lma", powers, g1)
        k, i = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
        lag = k - i  # the state at sample k from the force at sample i
        state = np.where((lag >= 1)[..., None, None], c0[np.clip(lag - 1, 0, n)], 0.0)
        state += np.where(((lag >= 0) & (i >= 1))[..., None, None], c1[np.clip(lag, 0, n)], 0.0)
        tau = dt * np.arange(substeps) / substeps
        sub = propagators(omega, zeta, tau[:, None], np)  # (S, M, ...)
        ramp = (tau[:, None] * sub.j0[..., 0] - sub.j1[..., 0]) / dt  # (S, M)
        q = np.einsum("sma,kima->ksmi", sub.phi[:, :, 0, :], state[:n])  # (n, S, M, n+1)
        steps = np.arange(n)
        q[steps, :, :, steps] += sub.j0[..., 0] - ramp
        q[steps, :, :, steps + 1] += ramp
        at_end = state[n, :, :, 0].T[None]  # (1, M, n+1): q at t_n
        self.coef = np.concatenate([q.reshape(n * substeps, m, n + 1), at_end], axis=0)
        self.gamma = np.asarray(model.gamma)
        self.shapes = np.asarray(model.shapes)[:, list(components), :]  # (K, C, M)
        self.dt, self.substeps = dt, substeps

    def sample_map(self, axes) -> np.ndarray:
        """(T, M, n+1, d): q(t_j) = sum over samples and moving ``axes`` of map * a."""
        return -np.einsum("tmi,mc->tmic", self.coef, self.gamma[:, list(axes)])

    def modal(self, acc: np.ndarray) -> np.ndarray:
        """q (T, M) for samples ``acc`` (n+1, 3)."""
        return np.einsum("tmi,im->tm", self.coef, -acc @ self.gamma.T)

    def peaks(self, acc: np.ndarray, limit_m: float, tol: float = 1e-6, most: int = 40):
        """Local maxima in time of max_p |u_p| above ``limit_m`` (worst first)."""
        u = np.einsum("pcm,tm->tpc", self.shapes, self.modal(acc))
        size = np.linalg.norm(u, axis=-1) / limit_m
        d, worst = size.max(axis=1), size.argmax(axis=1)
        padded = np.concatenate([[-np.inf], d, [-np.inf]])
        local = (d >= padded[:-2]) & (d >= padded[2:]) & (d > 1.0 + tol)
        found = [
            ClearancePeak(int(j), int(worst[j]), u[j, worst[j]], float(d[j]))
            for j in np.flatnonzero(local)
        ]
        return sorted(found, key=lambda pk: -pk.value)[:most]

    def row(self, peak: ClearancePeak, axes) -> np.ndarray:
        """(n+1, d) coefficients r with sum r * a = c . u_p(t), c = u / |u| (a tangent cut)."""
        along = (peak.u / np.linalg.norm(peak.u)) @ self.shapes[peak.point]  # (M,)
        return np.einsum("m,mic->ic", along, self.sample_map(axes)[peak.index])
