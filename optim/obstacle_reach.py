"""Obstacles the part cannot come near, left out of the distance before it is measured.

A cell with ``--min-distance`` certifies the distance of every point to every obstacle piece
(a box, a half-space, a mesh's triangle) at every sample a search tries: thousands of far
obstacles cost as much as thousands of near ones. Before any of it, every piece that no
point of the part can come within the limit of is left out:

* **Where the pivot can be.** A rest-to-rest move of at most ``max_duration_s`` T along the
  path (start, via points, end) within the per-axis speed limit vmax_i travels at most
  vmax_i T along axis i, of which the path itself needs L_i (the sum of its segments' spans):
  the pivot stays within the path's bounding box widened by (vmax_i T - L_i) / 2 per axis.
* **How far a point can deviate.** Mode i's forcing is at most F_i = sum_j |Gamma_ij| amax_j;
  its energy radius sqrt(q'^2 + omega^2 q^2) grows at most by |f| per second (damping only
  takes energy), so |q_i| <= F_i T / omega_i during and after the move. With the static
  residual (|D_p a| <= |static_shapes_p| |a| + sum_i |phi_i(p)| F_i / omega_i^2) and the
  sag (|static_shapes_p| |g|), every point stays within r = max_p sum_i |phi_i(p)| F_i
  (T / omega_i + 1 / omega_i^2) + |static_shapes_p| (|amax| + |g|) of where its pivot puts it.
* **Left out**: a piece whose distance to the part's points at the start, moved over that
  box and widened by r, exceeds the limit (plus SKIN_M for the sheet's half thickness): no
  move can bring it within the limit, so no constraint row or certificate needs it. The
  obstacle nearest the part at rest stays (the distance reported is measured to the pieces
  kept; each left out is farther than the least distance stated in the note).

Turning moves keep every obstacle (a turn moves the points about the pivot; their plan,
optim.budget, counts every piece).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from jaxflex.geometry import Box, HalfSpace, TriangleMesh
from jaxflex.model import ModalModel
from jaxflex.runtime import step
from optim.cell_setup import posed_in
from optim.limits import Limits

SKIN_M = 0.05  # more than half of any sheet's thickness: distances are to the skins


def pivot_box(cell, limits: Limits, max_duration_s: float) -> tuple[np.ndarray, np.ndarray]:
    """(low (3,), high (3,)) m: where the pivot can be during any move along ``cell``'s path
    within ``limits`` and ``max_duration_s`` (module docstring)."""
    stops = np.array(
        [cell.start_m, *(v.position_m for v in cell.via), cell.end_m], dtype=np.float64
    )
    span = np.abs(np.diff(stops, axis=0)).sum(axis=0)
    spare = np.maximum(0.0, np.asarray(limits.vmax, dtype=np.float64) * max_duration_s - span)
    return stops.min(axis=0) - spare / 2, stops.max(axis=0) + spare / 2


def deviation_bound_m(
    model: ModalModel, amax_m_s2: np.ndarray, duration_s: float, gravity_m_s2
) -> float:
    """The largest distance (m) any point of ``model`` (posed in the cell: shapes and
    participation factors in its axes) can be from where the rigid motion puts it, during
    and after a move of at most ``duration_s`` within the per-axis accelerations
    ``amax_m_s2`` (3,), sag under ``gravity_m_s2`` included (module docstring)."""
    amax = np.asarray(amax_m_s2, dtype=np.float64)
    phi = np.linalg.norm(np.asarray(model.shapes), axis=1)  # (K, M)
    force = np.abs(np.asarray(model.gamma)) @ amax  # (M,)
    omega = np.asarray(model.omega_rad_s)
    bound = phi @ (force * (duration_s / omega + 1.0 / omega**2))
    if model.static_shapes is not None:
        static = np.linalg.norm(np.asarray(model.static_shapes), axis=(1, 2))  # >= spectral
        bound = bound + static * (np.linalg.norm(amax) + np.linalg.norm(gravity_m_s2))
    return float(bound.max())


def _box_gap(low: np.ndarray, high: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Distances (N,) between the box [low, high] and boxes [lo, hi] (N, 3)."""
    gap = np.maximum(0.0, np.maximum(lo - high, low - hi))
    return np.linalg.norm(gap, axis=-1)


def _lower_bounds(obstacle, low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """The least distance of each piece of ``obstacle`` (1 for a box or a half-space, one
    per triangle of a mesh) to the box [low, high]."""
    if isinstance(obstacle, Box):
        half = np.abs(obstacle.rotation) @ (obstacle.size_m / 2)
        return _box_gap(low, high, obstacle.centre_m - half, obstacle.centre_m + half)[None]
    if isinstance(obstacle, HalfSpace):
        centre, half = (low + high) / 2, (high - low) / 2
        nearest = obstacle.normal @ centre - np.abs(obstacle.normal) @ half
        return np.array([max(0.0, nearest - obstacle.offset_m)])
    corners = obstacle.vertices[obstacle.triangles]  # (F, 3, 3)
    return _box_gap(low, high, corners.min(axis=1), corners.max(axis=1))


def _nearest_at_rest(obstacles, points: np.ndarray) -> int:
    """The index of the obstacle nearest to the part's points at the start (by their
    closest-point distance from the point nearest the part's centre: cheap, one point)."""
    if len(obstacles) < 2:
        return 0
    centre = (points.min(axis=0) + points.max(axis=0)) / 2
    probe = points[np.argmin(np.linalg.norm(points - centre, axis=1))][None]
    return int(np.argmin([obstacle.closest(probe)[0][0] for obstacle in obstacles]))


@dataclasses.dataclass(frozen=True)
class Pruned:
    """The cell with the obstacles that can come within the limit (``cell``), how many
    pieces were left out (``dropped``) of how many (``total``), and the least distance
    (m) any piece left out can come to the part (``beyond_m``; inf if none)."""

    cell: object
    dropped: int
    total: int
    beyond_m: float

    def note(self, max_duration_s: float) -> str:
        """One line for the log: what was left out and why."""
        return (
            f"cell: {self.dropped:,} of {self.total:,} obstacle pieces are at least "
            f"{self.beyond_m:.4g} m from anywhere the part can be within {max_duration_s:g} s "
            "(--max-duration) at these limits: left out of the distance (its limit cannot bind "
            "there; the distance reported is to the others)"
        )


def reachable(
    cell, model: ModalModel, limits: Limits, max_duration_s: float, limit_m: float
) -> Pruned:
    """``cell`` without the obstacle pieces that no straight move of ``model`` (in its own
    frame; posed here) within ``limits`` and ``max_duration_s`` can bring within
    ``limit_m`` of the part (module docstring); the obstacle nearest the part at rest is
    always kept."""
    posed = posed_in(cell, model)
    points = np.asarray(posed.points)
    low, high = pivot_box(cell, limits, max_duration_s)
    reach = deviation_bound_m(posed, limits.amax, max_duration_s, cell.gravity_m_s2)
    region = (points.min(axis=0) + (low - cell.start_m) - reach,
              points.max(axis=0) + (high - cell.start_m) + reach)  # fmt: skip
    nearest = _nearest_at_rest(cell.obstacles, points)
    kept, dropped, total, beyond = [], 0, 0, np.inf
    for i, obstacle in enumerate(cell.obstacles):
        bounds = _lower_bounds(obstacle, *region)
        near = (bounds <= limit_m + SKIN_M) | (i == nearest)
        total += bounds.size
        dropped += int(bounds.size - near.sum())
        if (~near).any():
            beyond = min(beyond, float(bounds[~near].min()))
        if near.all():
            kept.append(obstacle)
        elif near.any():  # a mesh: the triangles that can come near
            kept.append(TriangleMesh(obstacle.vertices, obstacle.triangles[near], obstacle.name))
    if not dropped:
        return Pruned(cell, 0, total, np.inf)
    return Pruned(dataclasses.replace(cell, obstacles=tuple(kept)), dropped, total, beyond)


def reachable_cell(request):
    """The cell a straight move of ``request`` (an optim.request.Request) with
    ``min_distance_m`` measures its distance to: :func:`reachable`'s, the pieces left out
    said in a step line; the request's cell as it is otherwise (no limit, a turning move)."""
    cell = request.constraints.cell
    if cell is None or request.constraints.min_distance_m is None or request.turn is not None:
        return cell
    found = reachable(
        cell,
        request.model,
        request.limits,
        request.budget.max_duration_s,
        request.constraints.min_distance_m,
    )
    if found.dropped:
        step(found.note(request.budget.max_duration_s), enabled=request.search.progress)
    return found.cell
