"""The deviation during a move that turns the part, every dt / 8, affine in the translation
samples: the clearance limit (``clearance_m``) of a turning move.

The deviation of a turning move is measured about the static equilibrium at the current pose
(jaxflex._turning): at a point p,

    u_p(t) = Phi_p (q(t) - Omega^-2 Gamma g_b(t)) + D_p a_O(t) + D_rot,p b(t),

q the turning engine's modal state (exact between the samples for its sampled forcing,
jaxflex.response.states_between) and the inputs g_b, a_O, b linear between the samples: the
definition the turning cell's families use (optim.turn_cell.TurnMotion); at the samples it is
jaxflex.simulate_turning's deviation. It is checked at the exact samples every
dt / 8, as a straight move's clearance (optim.move_response).

For a FIXED turn schedule (optim.turn.TurnSchedule: the angular acceleration samples of an
n-step move) the world translation samples a_k enter only through the body-frame samples
R_k^T a_k: in the modal forces -Gamma . R_k^T a_k and in a_O (the pivot's rigid terms, gravity,
the Euler and centrifugal loads and the start's sag do not depend on them). So

    u_p(t_j) = S_p(t_j)[R^T a] + u_p,turn(t_j),

S the straight move's response every dt / 8 (optim.move_response.MoveResponse: q linear in
the modal forces, a linear between the samples) of the turned samples, and u_turn the
deviation of the turn alone (the translation at rest). A peak's tangent cut c . u_p(t_j) <=
limit (c = u / |u| at the peak) is the LP row

    sum_k (R_k r_k) . a_k <= limit - c . u_p,turn(t_j),     r the straight cut's coefficients,

exact for the schedule (it cuts off no move that meets the clearance with it), and a valid
cut for every schedule (|u| <= limit implies c . u <= limit): the pooled peaks of a length
serve all its schedules, each building its rows with its own constant.
"""

from __future__ import annotations

import numpy as np

from jaxflex.response import (
    Move,
    Turn,
    as_move,
    gravity_coordinates,
    max_norms,
    turning_blocks,
    turning_coordinates,
    turning_shapes,
)
from optim.move_response import SUBSTEPS, ClearancePeak, MoveResponse, clearance_peaks
from optim.turn_cell import TurnMotion


def turning_move_coordinates(
    model, turn: Turn, substeps: int = SUBSTEPS
) -> tuple[np.ndarray, np.ndarray]:
    """(t (T,) s, coordinates (T, M'') of jaxflex.response.turning_shapes) every dt_s /
    ``substeps`` during the turning move ``turn`` (a jaxflex.response.Turn): the deviation
    about the current pose's sag (module docstring)."""
    times = turn.dt_s / substeps * np.arange(turn.path.n_steps * substeps + 1)
    inputs = TurnMotion(model, turn, times, np.zeros(0)).inputs
    gravity = inputs.gravity_body_m_s2
    sagging = inputs.q - gravity_coordinates(model, gravity)
    return times, turning_coordinates(model, sagging, inputs.base + gravity, inputs.coefficients)


def turning_move_deviation(
    model, spec, angular_acc: np.ndarray, move: Move
) -> tuple[np.ndarray, np.ndarray]:
    """(t (T,) s, d (T,) m): the largest deviation over the model's points every dt_s / 8
    during the turning move (the translation ``move``, a Move, with the turn ``angular_acc``;
    :func:`turning_move_coordinates`)."""
    t, coords = turning_move_coordinates(model, spec.with_move(angular_acc, move))
    return t, max_norms(turning_blocks(model), coords)[0]


class TurnMoveResponse:
    """The nominal model's deviation every dt / 8 during an n-step move with the turn
    ``angular_acc`` (n+1,) rad/s^2 of ``spec`` (an optim.turn.TurnSpec), as an affine map of
    the translation samples (module docstring); ``straight`` the straight move's response
    of the same length (its maps are shared by every schedule of the length)."""

    def __init__(self, straight: MoveResponse, spec, angular_acc: np.ndarray) -> None:
        model = straight.model
        self.straight = straight
        self.rotation = np.asarray(spec.path(angular_acc, straight.dt_s).rotation)  # (n+1, 3, 3)
        self.shapes = turning_shapes(model)  # (K, 3, M''): the straight move's M' columns first
        self.blocks = turning_blocks(model)
        self.n_linear = straight.shapes.shape[2]
        zero = as_move(np.zeros((self.rotation.shape[0], 3)), straight.dt_s)
        turn = spec.with_move(angular_acc, zero)
        self.rest = turning_move_coordinates(model, turn, straight.substeps)[1]  # the turn alone

    def modal(self, acc: np.ndarray) -> np.ndarray:
        """The coordinates (T, M'') for the world samples ``acc`` (n+1, 3)."""
        coords = self.rest.copy()
        body = np.einsum("kji,kj->ki", self.rotation, acc)  # R_k^T a_k
        coords[:, : self.n_linear] += self.straight.modal(body)
        return coords

    def peaks(self, acc: np.ndarray, limit_m: float, tol: float = 1e-6, most: int = 40):
        """Local maxima in time of max_p |u_p| above ``limit_m`` (worst first)."""
        return clearance_peaks(self.blocks, self.shapes, self.modal(acc), limit_m, tol, most)

    def sample_map(self, axes, index: int | slice = slice(None)) -> np.ndarray:
        """(T, M'', n+1, d): the coordinates at t_j are sum over samples and the moving world
        ``axes`` of map * a plus :attr:`rest` (with an integer ``index`` only that time's
        (M'', n+1, d)): the straight map of the body samples R_k^T a_k, zero for the
        rotational coordinates (the turn's own, in :attr:`rest`)."""
        body = self.straight.sample_map((0, 1, 2), index)  # (..., M', n+1, 3)
        world = np.einsum("...mkd,kcd->...mkc", body, self.rotation)[..., list(axes)]
        pad = [(0, 0)] * world.ndim
        pad[-3] = (0, self.shapes.shape[2] - self.n_linear)
        return np.pad(world, pad)

    def row(self, peak: ClearancePeak, axes) -> np.ndarray:
        """(n+1, d) coefficients r with sum r * a = c . u_p(t) - :meth:`offset`, c = u / |u|,
        on the moving ``axes`` of the world samples."""
        along = (peak.u / np.linalg.norm(peak.u)) @ self.shapes[peak.point]  # (M'',)
        return np.einsum("m,mkd->kd", along, self.sample_map(axes, peak.index))

    def offset(self, peak: ClearancePeak) -> float:
        """c . u_p,turn(t), m: the cut's part from the turn alone."""
        c = peak.u / np.linalg.norm(peak.u)
        return float(c @ (self.shapes[peak.point] @ self.rest[peak.index]))
