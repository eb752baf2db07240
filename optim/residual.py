"""The residual vibration after a move, as a linear function of the acceleration samples.

The modal state at the end of an n-step move is linear in the samples (first-order hold):

    x_end = sum_k Phi^{n-1-k} (G0 f_k + G1 f_{k+1}),   f_k = -Gamma . a_k,   Phi^j = Phi(j dt),

so jaxflex.response.end_state_map gives the matrix exactly (it equals ``jax.jacfwd`` of
the core's end state through the scan, in closed form because its shape changes with n and
a jitted Jacobian would recompile for every n tried). After the move the
part vibrates freely, u_p(t_n + tau) = sum_i phi_i(p) (P11_i(tau) q_i + P12_i(tau) qd_i), again
linear in the end state. :class:`ResidualModel` samples that response densely to find the
(point, time) pairs where it exceeds the threshold: those become the LP's rows. The largest
point at every sample comes from the pruned blocked evaluation (jaxflex._deviation), so
all-node models cost little more than their few blocks near the maximum.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from jaxflex.model import ModalModel
from jaxflex.response import (
    amplitudes,
    component_blocks,
    envelope_horizon,
    free_rows,
    max_norms,
    once_per_array,
    point_displacements,
)

SAMPLES_PER_PERIOD = 16  # dense check: time step 1 / (16 f_max)
REFINE_SAMPLES = 33  # sub-samples over two grid steps around every candidate peak
PEAK_SLACK = 0.03  # a sampled peak can hide (2 pi / 16)^2 / 8 = 1.9 % between samples
CHUNK = 1024
HORIZON_CAP_S = 120.0


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
        self.omega = np.asarray(model.omega_rad_s)
        self.sigma = np.asarray(model.zeta) * self.omega
        self.shapes, self.blocks = component_blocks(model, components)  # shapes (K, C, M)
        self.n_points = self.shapes.shape[0]
        # (K, M) the shapes' norms, computed once for the models sharing the shapes (a grid's)
        self.weights = once_per_array(self.shapes, "norms", lambda a: np.linalg.norm(a, axis=1))
        self.step_s = 1.0 / (SAMPLES_PER_PERIOD * np.max(np.asarray(model.freq_hz)))

    # -- closed-form free response -------------------------------------------------------
    def propagator_rows(self, tau: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """P11, P12 (T, M): q_i(tau) = P11 q_i + P12 qd_i for the free decay."""
        return free_rows(self.model, tau)

    def modal(self, x_end: np.ndarray, tau: np.ndarray) -> np.ndarray:
        """(T, M) modal coordinates at times ``tau`` after the move."""
        p11, p12 = self.propagator_rows(tau)
        return p11 * x_end[:, 0] + p12 * x_end[:, 1]

    def displacement(self, x_end: np.ndarray, tau: np.ndarray, points=slice(None)) -> np.ndarray:
        """(T, P, C) displacement of ``points`` (default every point) at times ``tau``."""
        return point_displacements(self.shapes[points], self.modal(x_end, tau))

    def deviation(self, x_end: np.ndarray, tau: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(d (T,) m, point (T,)): the largest |u_p| at times ``tau`` and where it is."""
        return max_norms(self.blocks, self.modal(x_end, tau))

    def amplitudes(self, x_end: np.ndarray) -> np.ndarray:
        """R_i (M,): amplitude of each mode's free decay from ``x_end``."""
        return amplitudes(self.model, x_end)

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
        horizon = envelope_horizon(self.weights, self.amplitudes(x_end), self.sigma, limit_m)
        return min(horizon, HORIZON_CAP_S)

    # -- finding exceedances -------------------------------------------------------------
    def _refine(self, x_end, tau0, tau1, point: int, limit_m) -> Peak:
        """Largest deviation of ``point`` over [tau0, tau1] (REFINE_SAMPLES samples)."""
        tau = np.linspace(max(0.0, tau0), tau1, REFINE_SAMPLES)
        u = self.displacement(x_end, tau, [point])[:, 0]  # (T, C)
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
            d, worst = self.deviation(x_end, tau)
            d = d / limit_m
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
        d, worst = self.deviation(x_end, fine)
        j = int(np.argmax(d))
        p = worst[j]
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
