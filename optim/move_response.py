"""The response during the move as a linear map of the samples, for the clearance limit.

The modal coordinates during the move are linear in the modal forces at the samples
(jaxflex.response.state_map). :class:`MoveResponse` holds that map at every dt / substeps during
the move, so that the deviation there is |shapes_p q(t)| with q linear in the samples: the exact
route bounds it with tangent-plane rows, the gradient route with a soft maximum. The largest
point at every time comes from the pruned blocked evaluation (jaxflex._deviation). Where the
model has a static residual D (u = Phi q + D a), the coordinates are q followed by the base
acceleration a(t), linear in the samples as well (jaxflex.response.response_shapes).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from jaxflex.model import ModalModel
from jaxflex.response import (
    component_blocks,
    max_norms,
    modal_forces,
    point_displacements,
    state_map,
)

SUBSTEPS = 8


@dataclass(frozen=True)
class ClearancePeak:
    """Deviation ``u`` (C,) at ``point`` and fine time index ``index`` (t = index dt / S)."""

    index: int
    point: int
    u: np.ndarray
    value: float  # |u| / limit


class MoveResponse:
    """q(t_j) (T, M) = sum_i G[j, :, i] f_i at t_j = j dt / substeps, j = 0 .. n substeps,
    and a(t_j) (T, 3) = sum_i H[j, i] a_i where the model has a static residual."""

    def __init__(
        self, model: ModalModel, components, n_steps: int, dt_s: float, substeps: int = SUBSTEPS
    ):
        self.model = model
        self.coef = state_map(model, n_steps, dt_s, substeps)
        self.gamma = np.asarray(model.gamma)
        # shapes (K, C, M'), M' = M or M + 3 (the static residual's columns)
        self.shapes, self.blocks = component_blocks(model, components, moving=True)
        self.with_acc = self.shapes.shape[2] > model.n_modes
        self.hold = _interpolation(n_steps, substeps) if self.with_acc else None
        self.dt_s, self.substeps = dt_s, substeps

    def sample_map(self, axes, index: int | slice = slice(None)) -> np.ndarray:
        """(T, M', n+1, d): the coordinates at t_j = sum over samples and moving ``axes`` of
        map * a; with an integer ``index`` only that time's (M', n+1, d)."""
        axes = list(axes)
        modal = -np.einsum("...mi,mc->...mic", self.coef[index], self.gamma[:, axes])
        if not self.with_acc:
            return modal
        # a_c(t_j) = sum_i H[j, i] a_{i, c}: coordinate M + c sees axis c only
        acc = np.einsum("...i,cd->...cid", self.hold[index], np.eye(3)[:, axes])
        return np.concatenate([modal, acc], axis=-3)

    @property
    def rest(self) -> np.ndarray:
        """(T, M') the coordinates with every sample zero: none for a straight move (the
        affine map's constant; optim.turn_clearance: the turn's own)."""
        return np.zeros((self.coef.shape[0], self.shapes.shape[2]))

    def modal(self, acc: np.ndarray) -> np.ndarray:
        """The coordinates (T, M') for samples ``acc`` (n+1, 3): q, then a where the model has
        a static residual."""
        q = np.einsum("tmi,im->tm", self.coef, modal_forces(self.model, acc, np))
        return np.concatenate([q, self.hold @ acc], axis=1) if self.with_acc else q

    def peaks(self, acc: np.ndarray, limit_m: float, tol: float = 1e-6, most: int = 40):
        """Local maxima in time of max_p |u_p| above ``limit_m`` (worst first)."""
        return clearance_peaks(self.blocks, self.shapes, self.modal(acc), limit_m, tol, most)

    def row(self, peak: ClearancePeak, axes) -> np.ndarray:
        """(n+1, d) coefficients r with sum r * a = c . u_p(t), c = u / |u| (a tangent cut)."""
        along = (peak.u / np.linalg.norm(peak.u)) @ self.shapes[peak.point]  # (M,)
        return np.einsum("m,mic->ic", along, self.sample_map(axes, peak.index))

    def offset(self, peak: ClearancePeak) -> float:
        """The part of the cut's c . u_p(t) that does not depend on the samples, m: none for
        a straight move (optim.turn_clearance: the turn's own deviation)."""
        return 0.0


def clearance_peaks(blocks, shapes, coords: np.ndarray, limit_m: float, tol: float, most: int):
    """The local maxima in time of max_p |u_p| above ``limit_m`` (worst first, at most
    ``most``), u_p = shapes_p coords of the coordinates ``coords`` (T, M') and their
    ``blocks`` (jaxflex.response.max_norms)."""
    d, worst = max_norms(blocks, coords)
    d = d / limit_m
    padded = np.concatenate([[-np.inf], d, [-np.inf]])
    local = np.flatnonzero((d >= padded[:-2]) & (d >= padded[2:]) & (d > 1.0 + tol))
    u = point_displacements(shapes[worst[local]], coords[local])  # (J, J, C)
    found = [
        ClearancePeak(int(j), int(worst[j]), u[i, i], float(d[j])) for i, j in enumerate(local)
    ]
    return sorted(found, key=lambda pk: -pk.value)[:most]


def _interpolation(n_steps: int, substeps: int) -> np.ndarray:
    """(n S + 1, n+1) H with a(t_j) = sum_i H[j, i] a_i at t_j = j dt / S (linear in between)."""
    j = np.arange(n_steps * substeps + 1)
    k = np.minimum(j // substeps, n_steps - 1)
    w = j / substeps - k
    hold = np.zeros((j.size, n_steps + 1))
    hold[j, k] = 1.0 - w
    hold[j, k + 1] += w
    return hold


# The bound below holds for the continuous response; the clearance is checked at samples
# every dt / SUBSTEPS, between which the deviation can exceed it. The bound is therefore
# applied to this multiple of the clearance: it refuses only requests that even a deviation
# this much larger than allowed could not meet.
SAMPLING_ALLOWANCE = 2.0


def shortest_clearance_move_s(
    model: ModalModel, components, distance_m: np.ndarray, clearance_m: float
) -> tuple[float, int]:
    """(T_min s, mode): no move over ``distance_m`` (3,) m shorter than T_min keeps the
    deviation at every point within SAMPLING_ALLOWANCE * ``clearance_m``; 0 when the bound
    says nothing.

    Integrating q'' + 2 zeta w q' + w^2 q = -Gamma . a twice over a rest-to-rest move of
    duration T gives q(T) + 2 zeta w int q + w^2 int int q = -Gamma . D, so
    |Gamma . D| <= max|q| (1 + 2 zeta w T + w^2 T^2 / 2). When the shapes at the points have
    full column rank, q = pinv(Phi) u bounds max|q_i| <= |row_i pinv(Phi)|_1 max|u|, and the
    quadratic in T gives the shortest T for each mode."""
    shapes = np.asarray(model.shapes)[:, list(components), :]
    phi = shapes.reshape(-1, shapes.shape[-1])  # (K C, M)
    singular = np.linalg.svd(phi, compute_uv=False)
    if singular.size < phi.shape[1] or singular[-1] <= 1e-9 * singular[0]:
        return 0.0, -1  # a mode hardly seen at the points: q is not bounded by u
    gain = np.abs(np.linalg.pinv(phi)).sum(axis=1)  # (M,) max|q_i| per unit max|u|
    force = np.abs(np.asarray(model.gamma) @ np.asarray(distance_m, dtype=np.float64))
    ratio = force / (gain * SAMPLING_ALLOWANCE * clearance_m)  # >= 1 + 2 z w T + w^2 T^2 / 2
    omega, zeta = np.asarray(model.omega_rad_s), np.asarray(model.zeta)
    need = np.maximum(ratio - 1.0, 0.0)
    t_min = (np.sqrt((2 * zeta * omega) ** 2 + 2 * omega**2 * need) - 2 * zeta * omega) / omega**2
    mode = int(np.argmax(t_min))
    return float(t_min[mode]), mode
