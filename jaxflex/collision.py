"""Collision checking with the deforming part: the smallest distance to the cell's obstacles.

The model is in cell coordinates at the start of the move (jaxflex.cell.Cell.posed): point
p_k of the part is at

    p_k(t) = x_k + g_k + s(t) + u_k(t)

with x_k the model's point, g_k its static deflection under gravity (mode displacement,
sum_i phi_i(k) Gamma_i . g / omega_i^2; the deviation u of jaxflex is relative to the part at
rest), s(t) the rigid path of the move (exact, jaxflex.profile) and u_k(t) the vibration
(exact, jaxflex.engine). :func:`min_distance` finds min over t >= 0, points and obstacles of
the distance (signed: negative inside a box or half-space) to within ``atol``, with where
and when, by the branch and bound of jaxflex.peaks: a point moves at most at speed
L = |s'| + sum_i |phi_i(k)| sup |q_i'| (the energy bound during the move, omega_i R_i
e^{-sigma_i tau} after it), so on [a, b] its distance is at least
(d(a) + d(b)) / 2 - L (b - a) / 2; after the move it is at least d_rest - E_k(tau) (the
envelope of jaxflex.decay), so beyond a horizon nothing can come closer.

Monitored points are what is checked: the part's surface between them, and its thickness,
are not (use all nodes, or a margin of the point spacing's sagitta).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np
from threadpoolctl import threadpool_limits

from jaxflex.cell import Cell
from jaxflex.decay import amplitudes
from jaxflex.engine import (
    derivative_bounds,
    free_states,
    modal_forces,
    modal_states,
    states_between,
)
from jaxflex.peaks import SAMPLES_PER_PERIOD, SearchState, certified_max, settling_windows
from jaxflex.profile import as_move, kinematics_at


@dataclass(frozen=True)
class Clearance:
    """The smallest distance found, ``distance_m`` (m; negative: inside an obstacle), at
    ``time_s`` (s from the start; inf: the part at rest after settling), between point
    ``point`` and obstacle ``obstacle`` (``obstacle_name``); the true minimum is at least
    ``bound_m``."""

    distance_m: float
    time_s: float
    point: int
    obstacle: int
    obstacle_name: str
    bound_m: float
    evaluations: int

    def as_dict(self) -> dict:
        return asdict(self)


def gravity_offset(model, gravity_m_s2) -> np.ndarray:
    """(K, 3) static deflection of the points under gravity ``gravity_m_s2`` (3,), m."""
    g = np.asarray(gravity_m_s2, dtype=np.float64)
    q = (np.asarray(model.gamma) @ g) / np.asarray(model.omega) ** 2
    return np.einsum("kcm,m->kc", np.asarray(model.shapes), q)


def distances(obstacles, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(distance (N,), obstacle index (N,), closest obstacle point (N, 3)) of points (N, 3):
    the nearest obstacle of ``obstacles``."""
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


class _Motion:
    """Point positions of a posed model over a move and the settling (module docstring)."""

    def __init__(self, model, obstacles, move, gravity_m_s2) -> None:
        self.model, self.obstacles = model, obstacles
        self.acc, self.dt_s = move.acc, move.dt_s
        self.shapes = np.asarray(model.shapes)
        self.base = np.asarray(model.points) + gravity_offset(model, gravity_m_s2)
        self.states = modal_states(model, move.acc, move.dt_s, xp=np)
        self.force = modal_forces(model, move.acc, np)
        self.n_steps, self.t_end = move.n_steps, move.duration_s
        omega, zeta = np.asarray(model.omega), np.asarray(model.zeta)
        self.omega, self.sigma = omega, zeta * omega
        self.weights = model.shape_norms  # (K, M)
        # (n, M) sup |q'| per step
        self.modal_speed = derivative_bounds(model, self.states, self.force, move.dt_s)[0]
        pos, vel = kinematics_at(move.acc, move.dt_s, move.dt_s * np.arange(move.n_steps + 1))
        speed = np.linalg.norm(vel, axis=1)
        acc_norm = np.linalg.norm(move.acc, axis=1)
        self.path_speed = np.maximum(speed[:-1], speed[1:]) + move.dt_s * np.maximum(
            acc_norm[:-1], acc_norm[1:]
        )
        self.end = pos[-1]
        self.amplitude = amplitudes(model, self.states[-1])

    def _distance(self, u: np.ndarray, path: np.ndarray, items: np.ndarray) -> np.ndarray:
        """-(distance) (I, T) for displacements u (T, I, 3) and path positions (T, 3)."""
        points = self.base[items][None] + path[:, None] + u
        d, _, _ = distances(self.obstacles, points.reshape(-1, 3))
        return -d.reshape(points.shape[:2]).T

    def during(self, t: np.ndarray, items: np.ndarray) -> np.ndarray:
        states = states_between(self.model, self.states, self.force, self.dt_s, t, np)
        u = np.einsum("kcm,tm->tkc", self.shapes[items], states[..., 0])
        return self._distance(u, kinematics_at(self.acc, self.dt_s, t)[0], items)

    def during_bound(self, a, b, va, vb, items):
        k = np.clip(np.floor(0.5 * (a + b) / self.dt_s).astype(np.int64), 0, self.n_steps - 1)
        speed = self.weights[items] @ self.modal_speed[k].T + self.path_speed[k]  # (I, J)
        return 0.5 * (va + vb) + 0.5 * speed * (b - a)

    def after(self, t: np.ndarray, items: np.ndarray) -> np.ndarray:
        q = free_states(self.model, self.states[-1], t - self.t_end, np)[..., 0]
        u = np.einsum("kcm,tm->tkc", self.shapes[items], q)
        return self._distance(u, np.broadcast_to(self.end, (len(t), 3)), items)

    def envelope(self, items: np.ndarray, tau, power: int) -> np.ndarray:
        """(I, T) sum_i |phi_i(k)| omega_i^p R_i e^{-sigma_i tau}."""
        decay = self.amplitude[:, None] * np.exp(-np.outer(self.sigma, np.atleast_1d(tau)))
        return (self.weights[items] * self.omega**power) @ decay

    def after_bound(self, a, b, va, vb, items):
        speed = self.envelope(items, a - self.t_end, 1)
        return 0.5 * (va + vb) + 0.5 * speed * (b - a)

    def at_rest(self, items: np.ndarray) -> np.ndarray:
        """(I,) -(distance) of the points at rest at the end (gravity deflection only)."""
        d, _, _ = distances(self.obstacles, self.base[items] + self.end)
        return -d


def min_distance(
    model,
    obstacles,
    acc,
    dt_s: float,
    *,
    gravity_m_s2=(0.0, 0.0, -9.81),
    atol: float = 1e-5,
    limit_m: float | None = None,
) -> Clearance:
    """The smallest distance (m) between the monitored points of ``model`` (posed in cell
    coordinates) and ``obstacles`` (or a jaxflex.cell.Cell's) over the move ``acc`` ((n+1, 3)
    m/s^2 in cell coordinates at step ``dt_s`` s, at rest at both ends) and the settling
    after it, to within ``atol`` m (module docstring). With ``limit_m`` the search only
    decides whether the distance stays above it (``bound_m`` >= limit_m certifies; below it
    the minimum is located to ``atol``)."""
    if isinstance(obstacles, Cell):
        obstacles = obstacles.obstacles
    obstacles = tuple(obstacles)
    if not obstacles:
        return Clearance(math.inf, math.nan, -1, -1, "", math.inf, 0)
    move = as_move(acc, dt_s, at_rest=True)
    with threadpool_limits(limits=1, user_api="blas"):
        motion = _Motion(model, obstacles, move, gravity_m_s2)
        best = SearchState()

        def tolerance(value: float) -> float:
            return atol if limit_m is None else max(atol, -limit_m - value)

        items = np.arange(model.n_points)
        best.update(motion.at_rest(items)[:, None], np.array([math.inf]), items)
        grid = dt_s * np.arange(move.n_steps + 1)
        certified_max(motion.during, motion.during_bound, grid, items, tolerance, best)
        _settling(motion, best, tolerance)
    time_s, point = best.time, best.item
    if math.isinf(time_s):
        where = motion.base[[point]] + motion.end
    else:
        t = np.array([time_s])
        states = (
            states_between(model, motion.states, motion.force, dt_s, t, np)
            if time_s <= motion.t_end
            else free_states(model, motion.states[-1], t - motion.t_end, np)
        )
        path = kinematics_at(move.acc, dt_s, t)[0]
        where = motion.base[[point]] + path + np.asarray(model.shapes)[point] @ states[0, :, 0]
    _, which, _ = distances(obstacles, np.atleast_2d(where))
    obstacle = int(which[0])
    return Clearance(
        distance_m=-best.value,
        time_s=time_s,
        point=point,
        obstacle=obstacle,
        obstacle_name=getattr(obstacles[obstacle], "name", str(obstacle)),
        bound_m=min(-best.value - tolerance(best.value), -best.unresolved),
        evaluations=best.evaluations,
    )


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
