"""Collision checking with the deforming part: the smallest distance to the cell's obstacles.

The model is in cell coordinates at the start of the move (jaxflex._cell.Cell.posed): point
p_k of the part's mid-surface is at

    p_k(t) = x_k + g_k + s(t) + u_k(t)

with x_k the model's point, g_k its exact static deflection under gravity (the model's
static displacement, jaxflex.model: the part hangs at rest in gravity before the move, and
the deviation u of jaxflex is relative to that), s(t) the rigid path of the move (exact,
jaxflex._profile) and u_k(t) = sum_i phi_i(k) q_i(t) + D_k a(t) the vibration with the static
residual (exact, jaxflex._engine and jaxflex._deviation.response_shapes). The part is a sheet
of thickness h: its two skins lie within h / 2 of the mid-surface, so the part at p_k keeps
at least dist(p_k) - h / 2 from an obstacle (exact where the skin's normal faces the
obstacle). :func:`min_distance` reports that, the distance of the skins.

It finds min over t >= 0, points and obstacles of the distance (signed: negative inside a
box or half-space) to within ``atol``, with where and when, by the branch and bound of
jaxflex._peaks: a point moves at most at speed L = |s'| + sum_i |phi_i(k)| sup |q_i'| +
|D_k| |a'| (the energy bound during the move, omega_i R_i e^{-sigma_i tau} after it), so on
[a, b] its distance is at least (d(a) + d(b)) / 2 - L (b - a) / 2; after the move it is at
least d_rest - E_k(tau) (the envelope of jaxflex._decay), so beyond a horizon nothing can come
closer.

Every point of the model is checked (models at every FE node are the default of fem:
``jaxflex model --points``). During the move the points are first taken a block at a time
(:class:`PartBlocks`: spatially compact groups; a block's centre point is evaluated exactly
and bounds every member, d_p >= d_c - |X_p - X_c| - sum_i |phi_i(p) - phi_i(c)| |q_i|, the
distance being 1-Lipschitz), and only the members of blocks that could come closer than the
best distance found are searched point by point, so the cost grows with the part near the
obstacles, not with the mesh.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from jaxflex._blocks import kd_order
from jaxflex._budget import check_time
from jaxflex._cell import Cell
from jaxflex._decay import amplitudes
from jaxflex._deviation import response_shapes, with_acceleration
from jaxflex._engine import (
    derivative_bounds,
    free_states,
    modal_forces,
    modal_states,
    states_at,
    states_between,
)
from jaxflex._peaks import (
    SAMPLES_PER_PERIOD,
    SearchState,
    certified_max,
    one_blas_thread,
    settling_windows,
)
from jaxflex._profile import Move, acceleration_at, as_move, kinematics_at

BLOCK_POINTS = 32
COARSE_STRIDE = 8  # close_approaches: the block centres at every 8th time first
BLOCK_CHUNK = 4096  # (time, block) pairs per evaluation of the distance
# what a run out of its time budget (jaxflex._budget) was doing, and what to do about it
CHECKING = "checking the part's distance to the cell's obstacles"
SIMPLER_CELL = "simplify the obstacles (fewer triangles or boxes) or raise --max-time"


@dataclass(frozen=True)
class Clearance:
    """The smallest distance found, ``distance_m`` (m, from the part's skins; negative:
    inside an obstacle), at ``time_s`` (s from the start; inf: the part at rest after
    settling), between point ``point`` and obstacle ``obstacle`` (``obstacle_name``); the
    true minimum is at least ``bound_m``. ``half_thickness_m``: the share of the part's
    thickness taken off the mid-surface's distance; ``position_m`` (3,): where that point of
    the mid-surface is then (m, the witness of the minimum; the point's start is the model's
    ``points[point]``)."""

    distance_m: float
    time_s: float
    point: int
    obstacle: int
    obstacle_name: str
    bound_m: float
    evaluations: int
    half_thickness_m: float = 0.0
    position_m: tuple[float, float, float] | None = None

    def as_dict(self) -> dict:
        return asdict(self)


def gravity_offset(model, gravity_m_s2) -> np.ndarray:
    """(K, 3) static deflection of the points under gravity ``gravity_m_s2`` (3,), m: the
    model's exact static displacement under the base acceleration -g (jaxflex.model)."""
    return model.static_displacement(-np.asarray(gravity_m_s2, dtype=np.float64))


def positions_at(model, move: Move, t_s, gravity_m_s2, points=None, coords=None):
    """(T, P, 3) exact mid-surface positions (m) of ``points`` (indices; default all) of
    ``model`` (posed in the cell) at times ``t_s`` (T,) s of ``move`` (from rest) and after
    it, hanging at rest in ``gravity_m_s2`` before it (module docstring). ``coords``: the
    displacement coordinates at ``t_s`` when known (:func:`displacement_coordinates`)."""
    t = np.asarray(t_s, dtype=np.float64)
    points = slice(None) if points is None else points
    if coords is None:
        coords = displacement_coordinates(model, move, t)
    base = np.asarray(model.points)[points] + gravity_offset(model, gravity_m_s2)[points]
    u = np.einsum("kcm,tm->tkc", response_shapes(model)[points], coords)
    return base[None] + kinematics_at(move, t)[0][:, None] + u


def displacement_coordinates(model, move: Move, t_s) -> np.ndarray:
    """(T, M') the coordinates of the displacement shapes (jaxflex._deviation.response_shapes:
    q, then the base acceleration) at times ``t_s`` (T,) s of ``move`` and after."""
    t = np.asarray(t_s, dtype=np.float64)
    q = states_at(model, move, t)[..., 0]
    return with_acceleration(model, q, acceleration_at(move, t))


def distances(obstacles, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(distance (N,), obstacle index (N,), closest obstacle point (N, 3)) of points (N, 3):
    the nearest obstacle of ``obstacles``."""
    check_time(CHECKING, SIMPLER_CELL)
    best = np.full(len(points), np.inf)
    which = np.zeros(len(points), dtype=np.int64)
    nearest = np.zeros_like(points)
    for j, obstacle in enumerate(obstacles):
        d, c = obstacle.closest(points)
        better = d < best
        best = np.where(better, d, best)
        which[better] = j
        nearest[better] = c[better]
    return best, which, nearest


class PartBlocks:
    """The points of a model in spatially compact blocks of BLOCK_POINTS (jaxflex._blocks'
    k-d order): ``members`` (nB, b) point indices (K for padding), ``centre`` (nB,) the
    member nearest the block's mean position, and per block the spread of its members about
    the centre: ``spread_shapes`` (nB, M') max_p |psi_j(p) - psi_j(c)| for the displacement
    shapes psi (jaxflex._deviation.response_shapes: the modes, then the static residual)."""

    def __init__(self, points: np.ndarray, shapes: np.ndarray) -> None:
        n_points = len(points)
        b = min(BLOCK_POINTS, n_points)
        order = np.asarray(kd_order(points, b))
        members = np.where(order < n_points, order, n_points).reshape(-1, b)
        real = members < n_points
        safe = np.where(real, members, 0)
        mean = np.sum(np.where(real[..., None], points[safe], 0.0), axis=1) / real.sum(1)[:, None]
        gap = np.linalg.norm(points[safe] - mean[:, None], axis=2)
        centre = safe[np.arange(len(members)), np.argmin(np.where(real, gap, np.inf), axis=1)]
        offset = np.linalg.norm(shapes[safe] - shapes[centre][:, None], axis=2)  # (nB, b, M')
        self.members, self.real, self.centre = members, real, centre
        self.spread_shapes = np.max(np.where(real[..., None], offset, 0.0), axis=1)

    def spread_positions(self, positions: np.ndarray) -> np.ndarray:
        """(nB,) max_p |X_p - X_c| of the members at rest ``positions`` (K, 3)."""
        return np.linalg.norm(self.extents(positions), axis=1)

    def extents(self, positions: np.ndarray) -> np.ndarray:
        """(nB, 3) max_p |X_p,k - X_c,k| per axis k of the members at rest ``positions``."""
        safe = np.where(self.real, self.members, 0)
        gap = np.abs(positions[safe] - positions[self.centre][:, None])  # (nB, b, 3)
        return np.max(np.where(self.real[..., None], gap, 0.0), axis=1)

    def points_of(self, blocks: np.ndarray) -> np.ndarray:
        """Sorted point indices of the members of ``blocks``."""
        members = self.members[blocks][self.real[blocks]]
        return np.sort(members)


def block_lower_bounds(obstacles, centres: np.ndarray, extents: np.ndarray, moving: np.ndarray):
    """(T, nB) a lower bound of the distance of every member of every block to the nearest
    obstacle, from the block centres' positions ``centres`` (T, nB, 3), the blocks' extents
    at rest about their centre ``extents`` (nB, 3) and the bound of how far a member's
    displacement differs from its centre's ``moving`` (T, nB). Each obstacle piece is
    convex, so its (signed) distance is a convex function with the unit vector g from its
    closest point as a subgradient at the centre: d(p) >= d(c) + g . (p - c) >= d(c) -
    sum_k |g_k| e_k - moving. Tight where a face lies parallel to the part (g across the
    sheet), where the 1-Lipschitz bound d(c) - |p - c| is not."""
    check_time(CHECKING, SIMPLER_CELL)
    flat = centres.reshape(-1, 3)
    spread = np.broadcast_to(extents[None], centres.shape).reshape(-1, 3)
    best = np.full(len(flat), np.inf)
    for obstacle in obstacles:
        d, closest = obstacle.closest(flat)
        gap = flat - closest
        norm = np.linalg.norm(gap, axis=1)
        direction = np.abs(gap) / np.where(norm > 0, norm, 1.0)[:, None]
        reach = np.where(
            norm > 0, np.sum(direction * spread, axis=1), np.linalg.norm(spread, axis=1)
        )
        best = np.minimum(best, d - reach)
    return best.reshape(centres.shape[:2]) - moving


@dataclass
class Approaches:
    """The points of a part that may come closer than a distance to the obstacles at some
    of the times ``t_s`` of a move (:func:`close_approaches`): ``points`` (P,) sorted and
    their skin distances ``distances`` (T, P) m where evaluated, inf elsewhere (every point
    of a block not evaluated provably keeps the distance there). Evaluated: at each time at
    least the closest point (exact), and at the times given to :meth:`fill` every point
    that may come closer."""

    points: np.ndarray
    distances: np.ndarray
    _motion: _Motion
    _coords: np.ndarray  # (T, M') displacement coordinates at the times
    _path: np.ndarray  # (T, 3) the rigid path at the times
    _close: np.ndarray  # (T, nB) the blocks that may come closer, per time

    def fill(self, indices) -> None:
        """Evaluate every point of every block that may come closer at the times
        ``indices`` (time indices)."""
        rows = np.zeros(len(self._close), dtype=bool)
        rows[np.asarray(indices, dtype=np.int64)] = True
        times, which = np.nonzero(self._close & rows[:, None])
        blocks = part_blocks(self._motion.model)
        for chunk in np.array_split(np.arange(len(times)), max(1, len(times) // BLOCK_CHUNK)):
            self._record(*_block_distances(self, blocks, times[chunk], which[chunk]))

    def _record(self, times, members, real, d) -> None:
        """Write the skin distances ``d`` (A, b) of the ``members`` (A, b; ``real``) at the
        time indices ``times`` (A,)."""
        rows = np.broadcast_to(times[:, None], members.shape)[real]
        self.distances[rows, np.searchsorted(self.points, members[real])] = d[real]


def close_approaches(
    model,
    obstacles,
    move,
    t_s,
    within_m,
    *,
    gravity_m_s2=(0.0, 0.0, -9.81),
    half_thickness_m: float = 0.0,
    stride: int = COARSE_STRIDE,
) -> Approaches:
    """The :class:`Approaches` of the points of ``model`` (posed in the cell, hanging in
    ``gravity_m_s2`` before the move) that may come closer than ``within_m`` (m, or one per
    time (T,)) to ``obstacles`` at some of the increasing times ``t_s`` (T,) s during and
    after ``move`` (a jaxflex.Move), their skins ``half_thickness_m`` off the mid-surface:
    at each time the closest point found exactly (its distance and every distance
    evaluated on the way); :meth:`Approaches.fill` adds every point that may come closer at
    chosen times.

    Two levels in time and in space: the block centres (:class:`PartBlocks`) are evaluated
    at every ``stride``-th time only, and between two of them a block's members move at most
    at the path speed plus the modes' (jaxflex._engine.derivative_bounds during the move, the
    decay envelope after it) weighted by the centre's shapes and the block's spread, so the
    block keeps (d_a + d_b) / 2 - L (b - a) / 2 (:func:`block_lower_bounds` at a and b).
    Only the blocks of the intervals where that reaches ``within_m`` get the block bound at
    each time; at each time the blocks whose bound reaches ``within_m`` are searched in the
    order of their bound until the next bound is above the closest point found. The closest
    point at each time, and every point at the filled times, are what evaluating every
    member of every block at every time gives."""
    t = np.asarray(t_s, dtype=np.float64)
    obstacles = tuple(obstacles)
    with one_blas_thread():
        motion = _Motion(model, obstacles, move, gravity_m_s2, half_thickness_m)
        blocks = part_blocks(model)
        coords = displacement_coordinates(model, move, t)
        extents = blocks.extents(motion.base)
        coarse = np.unique(np.r_[np.arange(0, len(t), stride), len(t) - 1])
        lower = _block_bounds(motion, blocks, extents, t[coarse], coords[coarse])  # (C, nB)
        speed = _interval_speeds(motion, blocks, t[coarse])  # (C - 1, nB)
        gap = np.diff(t[coarse])[:, None]
        within = np.broadcast_to(np.asarray(within_m, dtype=np.float64), t.shape)
        reach = np.maximum(within[coarse][:-1], within[coarse][1:])[:, None]
        flagged = 0.5 * (lower[:-1] + lower[1:]) - 0.5 * speed * gap <= reach
        candidate = np.zeros((len(t), len(blocks.centre)), dtype=bool)
        for j in np.flatnonzero(flagged.any(axis=1)):  # both ends of an interval belong to it
            candidate[coarse[j] : coarse[j + 1] + 1] |= flagged[j]
        times, which = np.nonzero(candidate)
        fine = np.full(candidate.shape, np.inf)
        if times.size:
            bounds = _block_bounds(motion, blocks, extents[which], t[times], coords[times], which)
            fine[times, which] = np.where(bounds <= within[times], bounds, np.inf)
        close = np.isfinite(fine)
        points = blocks.points_of(np.flatnonzero(close.any(axis=0)))
        path = kinematics_at(move, t)[0]
        found = Approaches(
            points, np.full((len(t), len(points)), np.inf), motion, coords, path, close
        )
        _smallest(found, blocks, fine, found._record)
        return found


def nearest_distances(
    model, obstacles, move, t_s, *, gravity_m_s2=(0.0, 0.0, -9.81), half_thickness_m: float = 0.0
) -> np.ndarray:
    """(T,) the smallest skin distance (m) of any point of ``model`` to ``obstacles`` at each
    time of ``t_s`` (T,) s during and after ``move`` (arguments as :func:`close_approaches`),
    exact: at each time the blocks (:class:`PartBlocks`) in the order of their bound, each
    block's members evaluated while its bound is below the smallest distance found (the
    other blocks cannot hold a closer point)."""
    t = np.asarray(t_s, dtype=np.float64)
    with one_blas_thread():
        motion = _Motion(model, tuple(obstacles), move, gravity_m_s2, half_thickness_m)
        blocks = part_blocks(model)
        coords = displacement_coordinates(model, move, t)
        lower = _block_bounds(motion, blocks, blocks.extents(motion.base), t, coords)
        path = kinematics_at(move, t)[0]
        frame = Approaches(np.zeros(0, np.int64), np.zeros((0, 0)), motion, coords, path, None)
        return _smallest(frame, blocks, lower)


def _smallest(frame: Approaches, blocks: PartBlocks, lower: np.ndarray, record=None):
    """(T,) the smallest skin distance at each time of the ``frame`` (its motion, times'
    coordinates and path), searching at each time the blocks in the order of their bounds
    ``lower`` (T, nB; inf: not a candidate) while the next bound is below the smallest found;
    ``record(times, members, real, distances)`` gets every evaluation."""
    order = np.argsort(lower, axis=1)
    best = np.full(len(lower), np.inf)
    rows = np.arange(len(lower))
    for rank in range(order.shape[1]):
        which = order[:, rank]
        times = rows[lower[rows, which] < best]
        if times.size == 0:
            break
        found = _block_distances(frame, blocks, times, which[times])
        best[times] = np.minimum(best[times], found[3].min(axis=1))
        if record is not None:
            record(*found)
    return best


def _block_distances(frame: Approaches, blocks: PartBlocks, times, which):
    """(times, members (A, b), real (A, b), skin distances (A, b), inf for padding) of every
    member of the blocks ``which`` (A,) at the time indices ``times`` (A,) of ``frame``."""
    motion = frame._motion
    members = blocks.members[which]
    real = blocks.real[which]
    safe = np.where(real, members, 0)
    u = np.einsum("abcm,am->abc", motion.shapes[safe], frame._coords[times])
    points = motion.base[safe] + frame._path[times][:, None] + u
    d, _, _ = distances(motion.obstacles, points.reshape(-1, 3))
    return times, members, real, np.where(real, d.reshape(real.shape) - motion.half, np.inf)


def _block_bounds(motion, blocks: PartBlocks, extents, t, coords, which=None) -> np.ndarray:
    """The block bounds of :func:`block_lower_bounds` (skins), (T, nB) at times ``t`` (T,)
    for every block, or (P,) for the (time, block) pairs ``t`` (P,), ``which`` (P,)."""
    centres = blocks.centre if which is None else blocks.centre[which]
    shapes = motion.shapes[centres]  # (B, 3, M')
    path = kinematics_at(motion.move, t)[0]
    if which is None:
        positions = (
            motion.base[centres][None] + path[:, None] + np.einsum("bcm,tm->tbc", shapes, coords)
        )
        moving = np.abs(coords) @ blocks.spread_shapes.T
        return block_lower_bounds(motion.obstacles, positions, extents, moving) - motion.half
    positions = motion.base[centres] + path + np.einsum("bcm,bm->bc", shapes, coords)
    moving = np.sum(np.abs(coords) * blocks.spread_shapes[which], axis=1)
    lower = block_lower_bounds(motion.obstacles, positions[None], extents, moving[None])
    return lower[0] - motion.half


def _interval_speeds(motion, blocks: PartBlocks, t: np.ndarray) -> np.ndarray:
    """(J, nB) the largest speed (m/s) of any member of each block over the intervals
    [t_j, t_j+1] of the increasing times ``t`` (J + 1,): the path's, plus each displacement
    coordinate's rate bound times the largest shape of a member (the centre's plus the
    block's spread); during the move per step (derivative_bounds, the jerk for the static
    residual's coordinates), after it the decay envelope omega_i R_i e^{-sigma_i tau} at the
    interval's start."""
    weights = np.linalg.norm(motion.shapes[blocks.centre], axis=1) + blocks.spread_shapes
    n, t_end = motion.n_steps, motion.t_end
    rates = np.zeros((len(t) - 1, weights.shape[1]))
    path = np.zeros(len(t) - 1)
    a, b = t[:-1], t[1:]
    during = a < t_end
    first = np.clip(np.floor(a / motion.dt_s + 1e-9).astype(np.int64), 0, n - 1)
    last = np.clip(
        np.ceil(np.minimum(b, t_end) / motion.dt_s - 1e-9).astype(np.int64) - 1, 0, n - 1
    )
    for j in np.flatnonzero(during):
        steps = slice(first[j], max(first[j], last[j]) + 1)
        rates[j] = motion.coordinate_speed[steps].max(axis=0)
        path[j] = motion.path_speed[steps].max()
    after = b > t_end
    if after.any():
        tau = np.maximum(a[after] - t_end, 0.0)
        decay = motion.amplitude[None] * np.exp(-np.outer(tau, motion.sigma))  # (J', M)
        modes = motion.omega * decay
        m = motion.model.n_modes
        rates[after, :m] = np.maximum(rates[after, :m], modes)
    return path[:, None] + rates @ weights.T


def part_blocks(model) -> PartBlocks:
    """The :class:`PartBlocks` of a concrete model (built once per model: the shapes include
    its static residual, which depends on its frequencies)."""
    cache = model.__dict__.setdefault("_collision_blocks", {})
    if "blocks" not in cache:
        cache["blocks"] = PartBlocks(np.asarray(model.points), response_shapes(model))
    return cache["blocks"]


class _Motion:
    """Point positions of a posed model over a move and the settling (module docstring)."""

    def __init__(self, model, obstacles, move, gravity_m_s2, half_thickness_m: float) -> None:
        self.model, self.obstacles = model, obstacles
        self.move, self.dt_s = move, move.dt_s
        self.half = float(half_thickness_m)
        self.modes = np.asarray(model.shapes)  # (K, 3, M): after the move
        self.shapes = response_shapes(model)  # (K, 3, M'): during it
        self.base = np.asarray(model.points) + gravity_offset(model, gravity_m_s2)
        self.states = modal_states(model, move.acc, move.dt_s, xp=np)
        self.force = modal_forces(model, move.acc, np)
        self.n_steps, self.t_end = move.n_steps, move.duration_s
        omega, zeta = np.asarray(model.omega_rad_s), np.asarray(model.zeta)
        self.omega, self.sigma = omega, zeta * omega
        self.weights = model.shape_norms  # (K, M)
        self.moving_weights = np.linalg.norm(self.shapes, axis=1)  # (K, M')
        extra = self.shapes.shape[2] - model.n_modes  # 3 where there is a static residual
        step_force = np.maximum(np.abs(self.force[:-1]), np.abs(self.force[1:]))
        radius = np.hypot(self.states[:-1, :, 1], omega * self.states[:-1, :, 0])
        size = (radius + move.dt_s * step_force) / omega  # (n, M) sup |q| (energy radius)
        # (n, M) sup |q'| per step: the smaller of the energy radius and the free vibration
        # about the quasi-static response (stiff modes)
        speed = derivative_bounds(model, self.states, self.force, move.dt_s)[0]
        jerk = np.abs(np.diff(move.acc, axis=0)) / move.dt_s  # (n, 3) |a'| per step
        acc_size = np.maximum(np.abs(move.acc[:-1]), np.abs(move.acc[1:]))  # (n, 3) sup |a|
        self.coordinate_speed = np.hstack([speed, jerk[:, :extra]])  # (n, M')
        self.coordinate_size = np.hstack([size, acc_size[:, :extra]])  # (n, M') sup |c|
        pos, vel = kinematics_at(move, move.dt_s * np.arange(move.n_steps + 1))
        speed_path = np.linalg.norm(vel, axis=1)
        acc_norm = np.linalg.norm(move.acc, axis=1)
        self.path_speed = np.maximum(speed_path[:-1], speed_path[1:]) + move.dt_s * np.maximum(
            acc_norm[:-1], acc_norm[1:]
        )
        self.end = pos[-1]
        self.amplitude = amplitudes(model, self.states[-1])

    def _distance(self, u: np.ndarray, path: np.ndarray, items: np.ndarray) -> np.ndarray:
        """-(distance of the skins) (I, T) for displacements u (T, I, 3), path (T, 3)."""
        points = self.base[items][None] + path[:, None] + u
        d, _, _ = distances(self.obstacles, points.reshape(-1, 3))
        return self.half - d.reshape(points.shape[:2]).T

    def coordinates(self, t: np.ndarray) -> np.ndarray:
        """(T, M') the displacement coordinates during the move (q, then a)."""
        q = states_between(self.model, self.states, self.force, self.dt_s, t, np)[..., 0]
        return with_acceleration(self.model, q, acceleration_at(self.move, t))

    def during(self, t: np.ndarray, items: np.ndarray) -> np.ndarray:
        u = np.einsum("kcm,tm->tkc", self.shapes[items], self.coordinates(t))
        return self._distance(u, kinematics_at(self.move, t)[0], items)

    def _steps(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        return np.clip(np.floor(0.5 * (a + b) / self.dt_s).astype(np.int64), 0, self.n_steps - 1)

    def during_bound(self, a, b, va, vb, items):
        k = self._steps(a, b)
        speed = self.moving_weights[items] @ self.coordinate_speed[k].T + self.path_speed[k]
        return 0.5 * (va + vb) + 0.5 * speed * (b - a)

    def block_bound(self, blocks: PartBlocks, spread: np.ndarray, t: np.ndarray, values):
        """(nB, J) upper bound of -(distance) of every member of every block over the grid
        intervals [t_j, t_j+1], from the exact values of the block centres ``values``
        (nB, T) and the blocks' spread (``spread``: their rest positions, (nB,))."""
        k = self._steps(t[:-1], t[1:])
        centre = self.during_bound(t[:-1], t[1:], values[:, :-1], values[:, 1:], blocks.centre)
        members = blocks.spread_shapes @ self.coordinate_size[k].T  # (nB, J)
        return centre + spread[:, None] + members

    def after(self, t: np.ndarray, items: np.ndarray) -> np.ndarray:
        q = free_states(self.model, self.states[-1], t - self.t_end, np)[..., 0]
        u = np.einsum("kcm,tm->tkc", self.modes[items], q)
        return self._distance(u, np.broadcast_to(self.end, (len(t), 3)), items)

    def envelope(self, items: np.ndarray, tau, power: int) -> np.ndarray:
        """(I, T) sum_i |phi_i(k)| omega_i^p R_i e^{-sigma_i tau}."""
        decay = self.amplitude[:, None] * np.exp(-np.outer(self.sigma, np.atleast_1d(tau)))
        return (self.weights[items] * self.omega**power) @ decay

    def after_bound(self, a, b, va, vb, items):
        speed = self.envelope(items, a - self.t_end, 1)
        return 0.5 * (va + vb) + 0.5 * speed * (b - a)

    def at_rest(self, items: np.ndarray) -> np.ndarray:
        """(I,) -(distance of the skins) of the points at rest at the end (gravity sag)."""
        d, _, _ = distances(self.obstacles, self.base[items] + self.end)
        return self.half - d

    def position(self, point: int, time_s: float) -> np.ndarray:
        """(3,) the mid-surface point ``point`` at ``time_s`` (inf: at rest at the end)."""
        if math.isinf(time_s):
            return self.base[point] + self.end
        t = np.array([time_s])
        if time_s <= self.t_end:
            u = self.shapes[point] @ self.coordinates(t)[0]
        else:
            q = free_states(self.model, self.states[-1], t - self.t_end, np)[0, :, 0]
            u = self.modes[point] @ q
        return self.base[point] + kinematics_at(self.move, t)[0][0] + u


def part_half_thickness(model) -> float | None:
    """Half the part's thickness (m) as its model states it (meta: part.thickness_m, from
    fem), or None."""
    part = dict(model.meta).get("part") or {}
    thickness = part.get("thickness_m") if isinstance(part, dict) else None
    return None if thickness is None else 0.5 * float(thickness)


def min_distance(
    model,
    obstacles,
    move: Move,
    *,
    gravity_m_s2=(0.0, 0.0, -9.81),
    half_thickness_m: float = 0.0,
    atol: float = 1e-5,
    limit_m: float | None = None,
) -> Clearance:
    """The smallest distance (m) between the part (every point of ``model``, posed in cell
    coordinates, its skins ``half_thickness_m`` off the mid-surface) and ``obstacles`` (or a
    jaxflex._cell.Cell's) over ``move`` (in cell coordinates, at rest at both ends) and the
    settling after it, to within ``atol`` m (module docstring). With ``limit_m`` the search
    only decides whether the distance stays above it (``bound_m`` >= limit_m certifies; below
    it the minimum is located to ``atol``)."""
    if isinstance(obstacles, Cell):
        obstacles = obstacles.obstacles
    obstacles = tuple(obstacles)
    if not obstacles:
        return Clearance(math.inf, math.nan, -1, -1, "", math.inf, 0, half_thickness_m)
    move = as_move(move, at_rest=True)
    with one_blas_thread():
        motion = _Motion(model, obstacles, move, gravity_m_s2, half_thickness_m)
        return search_clearance(motion, part_blocks(model), atol, limit_m)


def search_clearance(motion, blocks: PartBlocks, atol: float, limit_m: float | None):
    """The :class:`Clearance` of the points of ``motion`` (a ``_Motion`` or one with the same
    methods: jaxflex._turning_collision) with ``blocks``: at rest at the end, during the move
    and over the settling (:func:`min_distance`'s search)."""
    obstacles = motion.obstacles
    best = SearchState()

    def tolerance(value: float) -> float:
        return atol if limit_m is None else max(atol, -limit_m - value)

    items = np.arange(len(motion.base))
    best.update(motion.at_rest(items)[:, None], np.array([math.inf]), items)
    _during(motion, blocks, best, tolerance)
    _settling(motion, best, tolerance)
    time_s, point = best.time, best.item
    position = motion.position(point, time_s)
    _, which, _ = distances(obstacles, position[None])
    obstacle = int(which[0])
    return Clearance(
        distance_m=-best.value,
        time_s=time_s,
        point=point,
        obstacle=obstacle,
        obstacle_name=getattr(obstacles[obstacle], "name", str(obstacle)),
        bound_m=min(-best.value - tolerance(best.value), -best.unresolved),
        evaluations=best.evaluations,
        half_thickness_m=motion.half,
        position_m=tuple(float(v) for v in position),
    )


def _during(motion: _Motion, blocks: PartBlocks, best: SearchState, tolerance) -> None:
    """The search during the move: the block centres on the sample grid, then the members of
    the blocks whose bound can beat the best value, point by point (module docstring)."""
    grid = motion.dt_s * np.arange(motion.n_steps + 1)
    centres = blocks.centre
    values = motion.during(grid, centres)
    best.evaluations += values.size
    best.update(values, grid, centres)
    spread = blocks.spread_positions(motion.base)
    bound = motion.block_bound(blocks, spread, grid, values)
    suspect = bound > best.value + tolerance(best.value)  # (nB, J)
    for first, last in _runs(suspect.any(axis=0)):  # only where a block's bound may beat it
        members = blocks.points_of(np.flatnonzero(suspect[:, first : last + 1].any(axis=1)))
        times = grid[first : last + 2]
        certified_max(motion.during, motion.during_bound, times, members, tolerance, best)


def _runs(flags: np.ndarray) -> list[tuple[int, int]]:
    """(first, last) index of every run of consecutive True in ``flags`` (J,)."""
    edges = np.diff(np.concatenate([[0], flags.astype(np.int8), [0]]))
    return list(zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1, strict=True))


def _settling(motion: _Motion, best: SearchState, tolerance) -> None:
    items = np.arange(motion.weights.shape[0])
    rest = motion.at_rest(items)

    def above(tau: float) -> np.ndarray:
        return rest + motion.envelope(items, tau, 0)[:, 0] > best.value + tolerance(best.value)

    sigma = motion.sigma[motion.amplitude > 0]
    step = 2 * np.pi / (SAMPLES_PER_PERIOD * motion.omega.max())
    for start, times in settling_windows(above, sigma, step, "min_distance"):
        alive = items[above(start)]
        if alive.size:
            certified_max(
                motion.after, motion.after_bound, motion.t_end + times, alive, tolerance, best
            )
