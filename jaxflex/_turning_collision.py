"""The smallest distance to the cell's obstacles of a part that turns (jaxflex._collision's).

The model is posed in cell coordinates at the identity orientation (jaxflex._cell); the
gripper turns about the pivot c (model frame, m) along the jaxflex._pose.PosePath while the
pivot moves by s(t) (the exact path of the world acceleration samples, jaxflex._profile).
Point k of the part's mid-surface is at

    X_k(t) = c + s(t) + R(t) (x_k - c + u_k(t)),
    u_k = Phi_k q + D_k (a_O - g_b) + D_rot,k b                                       (1)

with q the total modal state of jaxflex._turning (from the sag at the start pose, gravity
turned with the part), a_O - g_b the frame origin's acceleration less gravity and b the
coefficients of the rotational loads (jaxflex._rotation_residual): u is the whole elastic
displacement, the sag at the current pose included (the mode-acceleration split, exact at
rest). Between samples q is exact for the sampled forcing (jaxflex._engine.states_between),
a_O - g_b and b are linear (the forcing's first-order hold) and R(t) = R_k exp([phi]_x) with
phi = w_k tau + alpha_k tau^2 / 2 + (alpha_k+1 - alpha_k) tau^3 / (6 dt) (body components):
exact for a turn about a fixed axis (jaxflex._pose.fixed_axis_path), the only paths there
are. After the move the part rests in its final pose and vibrates freely about its sag there.

The search is jaxflex._collision's (the same blocks, branch and bound and settling windows,
both skins h / 2 off the mid-surface); only the speed bound gains the rotation:
|X_k'| <= |s'| + |w| (|x_k - c| + sup |u_k|) + sup |u_k'|, and a block's members stay within
|x_p - x_c| + sum_j |psi_j(p) - psi_j(c)| |c_j| of its centre (R keeps lengths).
"""

from __future__ import annotations

import math

import numpy as np
from threadpoolctl import threadpool_limits

from jaxflex._cell import Cell
from jaxflex._collision import Clearance, PartBlocks, _Motion, distances, search_clearance
from jaxflex._decay import amplitudes
from jaxflex._engine import derivative_bounds, free_states, states_between
from jaxflex._pose import PosePath
from jaxflex._profile import kinematics_at, samples_at
from jaxflex._rotation import LEVI_CIVITA, require_rotation
from jaxflex._rotation_residual import turning_coordinates, turning_shapes, warn_missing_static
from jaxflex._turning import Turn, turning_motion


def rotations_between(path: PosePath, t_s: np.ndarray) -> np.ndarray:
    """(T, 3, 3) the orientation (body to world) at times ``t_s`` (T,) s within the move
    (module docstring: exact for a turn about a fixed axis)."""
    n, dt = path.n_steps, path.dt_s
    t = np.asarray(t_s, dtype=np.float64)
    k = np.clip(np.floor(t / dt).astype(int), 0, n - 1)
    tau = (t - k * dt)[:, None]
    w, alpha = np.asarray(path.omega_rad_s), np.asarray(path.alpha_rad_s2)
    phi = w[k] * tau + alpha[k] * tau**2 / 2 + (alpha[k + 1] - alpha[k]) * tau**3 / (6 * dt)
    angle = np.linalg.norm(phi, axis=1)
    unit = phi / np.where(angle > 0, angle, 1.0)[:, None]
    skew = -np.einsum("kij,tk->tij", LEVI_CIVITA, unit)  # [n]_x
    sin, cos = np.sin(angle)[:, None, None], np.cos(angle)[:, None, None]
    turn = np.eye(3) + sin * skew + (1.0 - cos) * (skew @ skew)  # Rodrigues
    return np.asarray(path.rotation)[k] @ turn


def turning_part_blocks(model) -> PartBlocks:
    """The jaxflex._collision.PartBlocks of the turning shapes (built once per model)."""
    cache = model.__dict__.setdefault("_turning_collision_blocks", {})
    if "blocks" not in cache:
        cache["blocks"] = PartBlocks(np.asarray(model.points), turning_shapes(model))
    return cache["blocks"]


class _TurningMotion(_Motion):
    """Point positions of a turning part over the move and the settling (module docstring);
    the bounds of jaxflex._collision._Motion with the rotation's share of the speed."""

    def __init__(self, model, obstacles, turn: Turn, half_thickness_m: float) -> None:
        path = turn.path
        self.model, self.obstacles, self.path = model, obstacles, path
        self.move, self.dt_s = turn.move, path.dt_s
        self.half = float(half_thickness_m)
        self.pivot = turn.pivot_m
        self.modes = np.asarray(model.shapes)
        self.shapes = turning_shapes(model)  # (K, 3, M'): q, then a_O - g_b, then b
        self.base = np.asarray(model.points)
        self.arm = np.linalg.norm(self.base - self.pivot, axis=1)  # (K,) |x_k - c|
        motion = turning_motion(model, turn)
        self.inputs = inputs = motion.inputs
        self.states, self.force = motion.states, motion.force
        rotation = np.asarray(path.rotation)
        gravity = inputs.gravity_body_m_s2  # body
        self.n_steps, self.t_end = path.n_steps, path.n_steps * path.dt_s
        omega, zeta = np.asarray(model.omega_rad_s), np.asarray(model.zeta)
        self.omega, self.sigma = omega, zeta * omega
        self.weights = model.shape_norms
        self.moving_weights = np.linalg.norm(self.shapes, axis=1)  # (K, M')
        dt = path.dt_s
        step_force = np.maximum(np.abs(self.force[:-1]), np.abs(self.force[1:]))
        radius = np.hypot(self.states[:-1, :, 1], omega * self.states[:-1, :, 0])
        size = (radius + dt * step_force) / omega
        speed = derivative_bounds(model, self.states, self.force, dt)[0]
        extra = turning_coordinates(model, inputs.q, inputs.base, inputs.coefficients)
        extra = extra[:, model.n_modes :]  # (n+1, M' - M) the linear coordinates
        self.coordinate_speed = np.hstack([speed, np.abs(np.diff(extra, axis=0)) / dt])
        self.coordinate_size = np.hstack([size, np.maximum(np.abs(extra[:-1]), np.abs(extra[1:]))])
        pos, vel = kinematics_at(self.move, dt * np.arange(self.n_steps + 1))
        speed_path = np.linalg.norm(vel, axis=1)
        acc_norm = np.linalg.norm(self.move.acc, axis=1)
        self.path_speed = np.maximum(speed_path[:-1], speed_path[1:]) + dt * np.maximum(
            acc_norm[:-1], acc_norm[1:]
        )
        w = np.linalg.norm(path.omega_rad_s, axis=1)
        alpha = np.linalg.norm(path.alpha_rad_s2, axis=1)
        self.rate = np.maximum(w[:-1], w[1:]) + dt * np.maximum(alpha[:-1], alpha[1:])  # (n,)
        self.end = pos[-1]
        self.end_rotation = rotation[-1]
        self.end_state = motion.end_state  # the deviation state about the final pose's sag
        self.amplitude = amplitudes(model, motion.end_state)
        self.rest = self.base - self.pivot + self._sag_shapes() @ (-gravity[-1])

    def _sag_shapes(self) -> np.ndarray:
        """(K, 3, 3) the points' displacement per unit a_O - g_b at rest (the sag's map)."""
        if self.model.static_shapes is not None:
            return np.asarray(self.model.static_shapes)
        omega = self.omega
        return -np.asarray(self.model.shapes) @ (np.asarray(self.model.gamma) / omega[:, None] ** 2)

    def _world(self, local: np.ndarray, path: np.ndarray, rotation: np.ndarray) -> np.ndarray:
        """(T, I, 3) world positions of body vectors ``local`` (T, I, 3) from the pivot."""
        return self.pivot + path[:, None] + np.einsum("tab,tib->tia", rotation, local)

    def _skins(self, points: np.ndarray) -> np.ndarray:
        d, _, _ = distances(self.obstacles, points.reshape(-1, 3))
        return self.half - d.reshape(points.shape[:2]).T

    def coordinates(self, t: np.ndarray) -> np.ndarray:
        q = states_between(self.model, self.states, self.force, self.dt_s, t, np)[..., 0]
        base = samples_at(self.inputs.base, self.dt_s, t)
        b = samples_at(self.inputs.coefficients, self.dt_s, t)
        return turning_coordinates(self.model, q, base, b)

    def during(self, t: np.ndarray, items: np.ndarray) -> np.ndarray:
        u = np.einsum("kcm,tm->tkc", self.shapes[items], self.coordinates(t))
        local = (self.base[items] - self.pivot)[None] + u
        path = kinematics_at(self.move, t)[0]
        return self._skins(self._world(local, path, rotations_between(self.path, t)))

    def during_bound(self, a, b, va, vb, items):
        k = self._steps(a, b)
        speed = self.moving_weights[items] @ self.coordinate_speed[k].T + self.path_speed[k]
        reach = self.arm[items, None] + self.moving_weights[items] @ self.coordinate_size[k].T
        return 0.5 * (va + vb) + 0.5 * (speed + self.rate[k] * reach) * (b - a)

    def _after_local(self, t: np.ndarray, items: np.ndarray) -> np.ndarray:
        p = free_states(self.model, self.end_state, t - self.t_end, np)[..., 0]
        return self.rest[items][None] + np.einsum("kcm,tm->tkc", self.modes[items], p)

    def after(self, t: np.ndarray, items: np.ndarray) -> np.ndarray:
        local = self._after_local(t, items)
        rotation = np.broadcast_to(self.end_rotation, (len(t), 3, 3))
        return self._skins(self._world(local, np.broadcast_to(self.end, (len(t), 3)), rotation))

    def at_rest(self, items: np.ndarray) -> np.ndarray:
        local = self.rest[items][None]
        world = self._world(local, self.end[None], self.end_rotation[None])
        return self._skins(world)[:, 0]

    def positions(self, t_s: np.ndarray, items: np.ndarray) -> np.ndarray:
        """(T, I, 3) the mid-surface points ``items`` at times ``t_s`` (T,) s during the move
        and after it (inf: at rest in the final pose): equation (1)."""
        t = np.asarray(t_s, dtype=np.float64)
        rest = np.isinf(t)
        during = ~rest & (t <= self.t_end)
        after = ~rest & ~during
        local = np.empty((len(t), len(items), 3))
        if during.any():
            u = np.einsum("kcm,tm->tkc", self.shapes[items], self.coordinates(t[during]))
            local[during] = (self.base[items] - self.pivot)[None] + u
        if after.any():
            local[after] = self._after_local(t[after], items)
        local[rest] = self.rest[items]
        t_path = np.where(during, t, self.t_end)
        path = kinematics_at(self.move, t_path)[0]
        return self._world(local, path, rotations_between(self.path, t_path))

    def position(self, point: int, time_s: float) -> np.ndarray:
        return self.positions(np.array([time_s]), np.array([point]))[0, 0]


def turning_positions_at(model, turn: Turn, t_s, *, points=None) -> np.ndarray:
    """(T, P, 3) exact mid-surface positions (m, cell coordinates) of ``points`` (indices;
    default all) of the turning part at times ``t_s`` (T,) s of the turning move ``turn``
    (jaxflex._turning.Turn) and after it (inf: at rest in the final pose): equation (1) of the
    module docstring, the positions the search of :func:`turning_min_distance` evaluates
    (jaxflex._collision.positions_at of a straight move)."""
    require_rotation(model)
    motion = _TurningMotion(model, (), turn, 0.0)
    items = np.arange(model.n_points) if points is None else np.asarray(points, dtype=np.int64)
    return motion.positions(t_s, items)


def turning_min_distance(
    model,
    obstacles,
    turn: Turn,
    *,
    half_thickness_m: float = 0.0,
    atol: float = 1e-5,
    limit_m: float | None = None,
) -> Clearance:
    """The smallest distance (m) between the turning part (every point of ``model``, posed in
    cell coordinates, its skins ``half_thickness_m`` off the mid-surface) and ``obstacles``
    (or a jaxflex._cell.Cell's) over the turning move ``turn`` (jaxflex._turning.Turn: the
    part turns about the pivot while the pivot moves with the world accelerations, at rest at
    both ends, rate 0 at the end) and the settling after it, to within ``atol`` m;
    ``limit_m`` as jaxflex._collision.min_distance (module docstring)."""
    rotation = require_rotation(model)
    if model.static_shapes is not None and rotation.static_shapes is None:
        warn_missing_static("clearance")
    if isinstance(obstacles, Cell):
        obstacles = obstacles.obstacles
    obstacles = tuple(obstacles)
    if not obstacles:
        return Clearance(math.inf, math.nan, -1, -1, "", math.inf, 0, half_thickness_m)
    with threadpool_limits(limits=1, user_api="blas"):
        motion = _TurningMotion(model, obstacles, turn, half_thickness_m)
        return search_clearance(motion, turning_part_blocks(model), atol, limit_m)
