"""The residual vibration after a move, as a linear function of the acceleration samples.

The modal state at the end of an n-step move is linear in the samples (first-order hold):

    x_end = sum_k Phi^{n-1-k} (G0 f_k + G1 f_{k+1}),   f_k = -Gamma . a_k,   Phi^j = Phi(j dt),

so :func:`end_state_map` gives the matrix exactly (it equals ``jax.jacfwd`` of
``jaxflex.end_state`` through the scan; computed here in closed form because its shape
changes with n and a jitted Jacobian would recompile for every n tried). After the move the
part vibrates freely, u_p(t_n + tau) = sum_i phi_i(p) (P11_i(tau) q_i + P12_i(tau) qd_i), again
linear in the end state. :class:`ResidualModel` samples that response densely to find the
(point, time) pairs where it exceeds the threshold: those become the LP's rows.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from jaxflex.discretize import foh_coefficients, propagators
from jaxflex.model import ModalModel

SAMPLES_PER_PERIOD = 16  # dense check: time step 1 / (16 f_max)
REFINE_SAMPLES = 33  # sub-samples over two grid steps around every candidate peak
PEAK_SLACK = 0.03  # a sampled peak can hide (2 pi / 16)^2 / 8 = 1.9 % between samples
CHUNK = 1024
HORIZON_CAP_S = 120.0


def end_state_map(model: ModalModel, n_steps: int, dt: float) -> np.ndarray:
    """(M, 2, n+1, 3) matrix E with x_end[i, :] = sum_{k, c} E[i, :, k, c] a[k, c]."""
    omega = 2.0 * np.pi * np.asarray(model.freq_hz)
    zeta = np.asarray(model.zeta)
    powers = propagators(omega, zeta, dt * np.arange(n_steps + 1)[:, None], np).phi
    _, g0, g1 = foh_coefficients(omega, zeta, dt, np)  # (M, 2)
    k = np.arange(n_steps)
    coef = np.zeros((n_steps + 1, omega.size, 2))
    coef[:-1] += np.einsum("kmij,mj->kmi", powers[n_steps - 1 - k], g0)
    coef[1:] += np.einsum("kmij,mj->kmi", powers[n_steps - 1 - k], g1)
    gamma = np.asarray(model.gamma)  # (M, 3)
    return -np.einsum("kmi,mc->mikc", coef, gamma)


@dataclass(frozen=True)
class Peak:
    """A sampled exceedance: deviation vector ``u`` (3,) m at ``point`` and ``tau_s`` after
    the move; ``value`` is its size relative to the limit (> 1 means violated)."""

    tau_s: float
    point: int
    u: np.ndarray
    value: float


class ResidualModel:
    """Free decay of one modal model after a move, evaluated for many end states.

    ``components`` are the displacement components the shapes actually use (a flat part
    moving in z has only u_z): norms are taken over those only.
    """

    def __init__(self, model: ModalModel, components: tuple[int, ...]) -> None:
        self.model = model
        self.components = components
        self.omega = 2.0 * np.pi * np.asarray(model.freq_hz)
        self.zeta = np.asarray(model.zeta)
        self.sigma = self.zeta * self.omega
        shapes = np.asarray(model.shapes)[:, list(components), :]  # (K, C, M)
        self.shapes = shapes
        self.n_points = shapes.shape[0]
        self.by_row = np.transpose(shapes, (2, 1, 0)).reshape(self.omega.size, -1)  # (M, C K)
        self.weights = np.linalg.norm(shapes, axis=1)  # (K, M)
        self.step_s = 1.0 / (SAMPLES_PER_PERIOD * np.max(np.asarray(model.freq_hz)))

    # -- closed-form free response -------------------------------------------------------
    def propagator_rows(self, tau: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """P11, P12 (T, M): q_i(tau) = P11 q_i + P12 qd_i for the free decay (0 <= zeta < 1),
        q(tau) = e^{-sigma tau} (q0 cos(w_d tau) + (qd0 + sigma q0) sin(w_d tau) / w_d)."""
        tau = np.asarray(tau, dtype=np.float64)[:, None]
        omega_d = self.omega * np.sqrt(1.0 - self.zeta**2)
        decay = np.exp(-self.sigma * tau)
        sin_over = np.sin(omega_d * tau) / omega_d
        return decay * (np.cos(omega_d * tau) + self.sigma * sin_over), decay * sin_over

    def displacement(self, x_end: np.ndarray, tau: np.ndarray) -> np.ndarray:
        """(T, K, C) displacement of every point at times ``tau`` after the move."""
        p11, p12 = self.propagator_rows(tau)
        q = p11 * x_end[:, 0] + p12 * x_end[:, 1]
        u = (q @ self.by_row).reshape(len(tau), len(self.components), self.n_points)
        return np.transpose(u, (0, 2, 1))

    def amplitudes(self, x_end: np.ndarray) -> np.ndarray:
        """R_i (M,): amplitude of each mode's free decay from ``x_end``."""
        omega_d = self.omega * np.sqrt(1.0 - self.zeta**2)
        q0, v0 = x_end[:, 0], x_end[:, 1]
        return np.hypot(q0, (v0 + self.sigma * q0) / omega_d)

    def sampling_step(self, x_end: np.ndarray, limit_m: float) -> float:
        """1/16 of the period of the highest mode that matters: modes are dropped from the
        top while their summed largest contribution max_p |phi_i(p)| R_i stays below
        1e-3 of ``limit_m`` (their sampling error is then below that too)."""
        contribution = self.weights.max(axis=0) * self.amplitudes(x_end)  # (M,)
        order = np.argsort(self.omega)[::-1]
        dropped = np.cumsum(contribution[order]) <= 1e-3 * limit_m
        kept = order[~dropped]
        top = self.omega[kept].max() if kept.size else self.omega.min()
        return 2.0 * np.pi / (SAMPLES_PER_PERIOD * top)

    def envelope_horizon(self, x_end: np.ndarray, limit_m: float) -> float:
        """Smallest tau after which the envelope sum_i |phi_i(p)| R_i e^{-sigma_i tau} stays
        below ``limit_m`` at every point (so |u_p| does too), capped at HORIZON_CAP_S."""
        amplitude = self.amplitudes(x_end)

        def peak(tau):
            return np.max(self.weights @ (amplitude * np.exp(-self.sigma * tau)))

        if peak(0.0) <= limit_m:
            return 0.0
        lo, hi = 0.0, HORIZON_CAP_S
        if peak(hi) > limit_m:
            return hi
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if peak(mid) > limit_m else (lo, mid)
        return hi

    # -- finding exceedances -------------------------------------------------------------
    def _refine(self, x_end, tau0, tau1, point: int, limit_m) -> Peak:
        """Largest deviation of ``point`` over [tau0, tau1] (REFINE_SAMPLES samples)."""
        tau = np.linspace(max(0.0, tau0), tau1, REFINE_SAMPLES)
        u = self.displacement(x_end, tau)[:, point]  # (T, C)
        values = np.linalg.norm(u, axis=-1) / limit_m
        j = int(np.argmax(values))
        return Peak(float(tau[j]), point, u[j], float(values[j]))

    def exceedances(
        self,
        x_end: np.ndarray,
        limit_m: float,
        *,
        max_peaks: int = 40,
        tol: float = 1e-6,
    ) -> list[Peak]:
        """Peaks of the free response where the deviation exceeds ``limit_m`` (values in
        units of the limit), worst first, at most ``max_peaks``. Sampled at 1/16 of the
        shortest period up to the envelope horizon, every candidate peak refined."""
        horizon = self.envelope_horizon(x_end, limit_m)
        if horizon == 0.0:
            return []
        h = self.sampling_step(x_end, limit_m)
        n_samples = int(np.ceil(horizon / h)) + 2
        peaks: list[Peak] = []
        for start in range(0, n_samples, CHUNK):
            first = max(0, start - 1)
            tau = h * np.arange(first, min(n_samples, start + CHUNK) + 1)
            u = self.displacement(x_end, tau)
            size = np.linalg.norm(u, axis=-1) / limit_m  # (T, K)
            d, worst = size.max(axis=1), size.argmax(axis=1)
            if first == 0:  # tau = 0 is a boundary: a maximum there if d decreases
                d = np.concatenate([[-np.inf], d])
                worst = np.concatenate([[0], worst])
                tau = np.concatenate([[0.0], tau])
            local = (d[1:-1] >= d[:-2]) & (d[1:-1] >= d[2:]) & (d[1:-1] > 1.0 - PEAK_SLACK)
            for j in np.flatnonzero(local) + 1:
                peak = self._refine(x_end, tau[j - 1], tau[j + 1], int(worst[j]), limit_m)
                if peak.value > 1.0 + tol:
                    peaks.append(peak)
        peaks.sort(key=lambda pk: -pk.value)
        return peaks[:max_peaks]

    def worst_near(self, x_end: np.ndarray, tau_s: float, limit_m: float) -> Peak:
        """The largest deviation (any point) within half the longest period before
        ``tau_s``: where a certification found the last exceedance."""
        span = 0.5 / np.min(np.asarray(self.model.freq_hz))
        step = self.step_s / 4
        fine = np.arange(max(0.0, tau_s - span), tau_s + step, step)
        values = np.linalg.norm(self.displacement(x_end, fine), axis=-1)
        j, p = np.unravel_index(np.argmax(values), values.shape)
        lo, hi = fine[max(0, j - 1)], fine[min(len(fine) - 1, j + 1)]
        return self._refine(x_end, lo, hi, int(p), limit_m)

    # -- rows ------------------------------------------------------------------------------
    def row(self, peak: Peak) -> np.ndarray:
        """(M, 2) coefficients r with r . x_end = c . u_p(tau), c = u / |u| the peak's
        direction: the tangent plane of the ball |u_p(tau)| <= limit at the peak, a valid
        linear cut (every feasible end state satisfies it). Generated lazily at the worst
        peaks, these cuts converge to the exact norm constraint (a second-order cone)."""
        normal = peak.u / np.linalg.norm(peak.u)
        p11, p12 = self.propagator_rows(np.array([peak.tau_s]))
        along = normal @ self.shapes[peak.point]  # (M,)
        return np.stack([along * p11[0], along * p12[0]], axis=-1)
