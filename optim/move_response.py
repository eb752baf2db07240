"""The response during the move as a linear map of the samples, for the clearance limit.

The modal coordinates during the move are linear in the modal forces at the samples
(jaxflex.engine.state_map). :class:`MoveResponse` holds that map at every dt / substeps during
the move, so that the deviation there is |shapes_p q(t)| with q linear in the samples: the exact
route bounds it with tangent-plane rows, the gradient route with a soft maximum. The largest
point at every time comes from the pruned blocked evaluation (jaxflex.deviation).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from jaxflex.deviation import block_model, max_norms, point_displacements
from jaxflex.engine import modal_forces, state_map
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
        self, model: ModalModel, components, n_steps: int, dt_s: float, substeps: int = SUBSTEPS
    ):
        self.model = model
        self.coef = state_map(model, n_steps, dt_s, substeps)
        self.gamma = np.asarray(model.gamma)
        self.shapes = np.asarray(model.shapes)[:, list(components), :]  # (K, C, M)
        self.blocks = block_model(self.shapes, model.points)
        self.dt_s, self.substeps = dt_s, substeps

    def sample_map(self, axes) -> np.ndarray:
        """(T, M, n+1, d): q(t_j) = sum over samples and moving ``axes`` of map * a."""
        return -np.einsum("tmi,mc->tmic", self.coef, self.gamma[:, list(axes)])

    def modal(self, acc: np.ndarray) -> np.ndarray:
        """q (T, M) for samples ``acc`` (n+1, 3)."""
        return np.einsum("tmi,im->tm", self.coef, modal_forces(self.model, acc, np))

    def peaks(self, acc: np.ndarray, limit_m: float, tol: float = 1e-6, most: int = 40):
        """Local maxima in time of max_p |u_p| above ``limit_m`` (worst first)."""
        q = self.modal(acc)
        d, worst = max_norms(self.blocks, q)
        d = d / limit_m
        padded = np.concatenate([[-np.inf], d, [-np.inf]])
        local = np.flatnonzero((d >= padded[:-2]) & (d >= padded[2:]) & (d > 1.0 + tol))
        u = point_displacements(self.shapes[worst[local]], q[local])  # (J, J, C)
        found = [
            ClearancePeak(int(j), int(worst[j]), u[i, i], float(d[j])) for i, j in enumerate(local)
        ]
        return sorted(found, key=lambda pk: -pk.value)[:most]

    def row(self, peak: ClearancePeak, axes) -> np.ndarray:
        """(n+1, d) coefficients r with sum r * a = c . u_p(t), c = u / |u| (a tangent cut)."""
        along = (peak.u / np.linalg.norm(peak.u)) @ self.shapes[peak.point]  # (M,)
        return np.einsum("m,mic->ic", along, self.sample_map(axes)[peak.index])
