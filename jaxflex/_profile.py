"""Moves: acceleration samples, checked once, their exact kinematics, a jerk-limited move.

A move is a (n+1, 3) array of acceleration samples a_k (m/s^2) at t_k = k dt_s, linear in
between (docs/design.md). Velocity is then piecewise quadratic and position piecewise cubic,
both linear in the samples:

    v_{k+1} = v_k + dt_s (a_k + a_{k+1}) / 2
    x_{k+1} = x_k + dt_s v_k + dt_s^2 (2 a_k + a_{k+1}) / 6

User input is checked once, where it enters (:func:`as_move`); a :class:`Move` carries that
check with it, so the layers below trust it instead of checking the same array again.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from jaxflex._grid import grid_time
from jaxflex._scalars import check_positive
from jaxflex._validation import check_acc
from jaxflex.errors import InputError


@dataclass(frozen=True, eq=False)
class Move:
    """Checked acceleration samples ``acc`` ((n+1, 3) float64, read-only, m/s^2) at step
    ``dt_s`` (s). Made by :func:`as_move`."""

    acc: np.ndarray
    dt_s: float

    @property
    def n_steps(self) -> int:
        return self.acc.shape[0] - 1

    @property
    def duration_s(self) -> float:
        """n dt_s: the transfer time, s (jaxflex._grid: 82 steps of 0.01 s last 0.82 s)."""
        return grid_time(self.n_steps, self.dt_s)

    @property
    def at_rest(self) -> bool:
        """True if the move starts and ends at rest (a_0 = a_n = 0)."""
        return not (self.acc[0].any() or self.acc[-1].any())


def as_move(
    acc,
    dt_s: float | None = None,
    *,
    at_rest: bool = False,
    name: str = "acc",
    dt_name: str = "dt_s",
) -> Move:
    """``acc`` ((n+1, 3) m/s^2, n >= 1, finite; with ``at_rest`` also a_0 = a_n = 0) at step
    ``dt_s`` (s, > 0) as a checked :class:`Move`: the door where raw samples become a move. A
    Move passes through without a second check (``dt_s`` may then be left out; if given it
    must be the move's step). Raises InputError naming the field (``name``, ``dt_name``)."""
    if isinstance(acc, Move):
        if dt_s is not None and not math.isclose(acc.dt_s, float(dt_s), rel_tol=1e-12):
            raise InputError(f"{dt_name}: {dt_s} s, but the move is sampled every {acc.dt_s} s")
        if at_rest and not acc.at_rest:
            check_acc(acc.acc, name=name, rest_at_ends=True)  # raises with the details
        return acc
    if dt_s is None:
        raise InputError(f"{dt_name}: raw samples {name!r} need their step (s), or pass a Move")
    checked = check_acc(acc, name=name, rest_at_ends=at_rest).astype(np.float64)
    checked.setflags(write=False)
    return Move(checked, check_positive(dt_name, dt_s))


def integrate(acc, dt_s: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Exact velocity (m/s) and position (m) at the samples of a :class:`Move` (or of raw
    samples ``acc`` at step ``dt_s`` s), from rest at the origin: two (n+1, 3) arrays."""
    move = as_move(acc, dt_s)
    acc, dt_s = move.acc, move.dt_s
    dv = 0.5 * dt_s * (acc[:-1] + acc[1:])
    vel = np.concatenate([np.zeros((1, 3)), np.cumsum(dv, axis=0)])
    dx = dt_s * vel[:-1] + dt_s**2 * (2.0 * acc[:-1] + acc[1:]) / 6.0
    pos = np.concatenate([np.zeros((1, 3)), np.cumsum(dx, axis=0)])
    return vel, pos


def samples_at(values, dt_s: float, t_s, outside: float | None = None) -> np.ndarray:
    """(T, F) the samples ``values`` ((n+1, F) at step ``dt_s`` s) at times ``t_s`` (T,) s:
    linear between samples; before the start and after the end held at the end samples, or
    ``outside`` where given."""
    values = np.asarray(values, dtype=np.float64)
    t = np.asarray(t_s, dtype=np.float64)
    grid = dt_s * np.arange(values.shape[0])
    columns = range(values.shape[1])
    return np.column_stack([np.interp(t, grid, values[:, c], outside, outside) for c in columns])


def acceleration_at(move: Move, t_s) -> np.ndarray:
    """(T, 3) acceleration (m/s^2) of ``move`` at times ``t_s`` (T,) s: linear between
    samples, 0 before the start and after the end."""
    return samples_at(move.acc, move.dt_s, t_s, outside=0.0)


def kinematics_at(move: Move, t_s) -> tuple[np.ndarray, np.ndarray]:
    """Exact (position (T, 3) m, velocity (T, 3) m/s) of ``move`` (from rest at the origin)
    at times ``t_s`` (T,) s; held after the end."""
    acc, dt_s = move.acc, move.dt_s
    vel, pos = integrate(move)
    n = acc.shape[0] - 1
    t = np.asarray(t_s, dtype=np.float64)
    k = np.clip(np.floor(t / dt_s).astype(np.int64), 0, n - 1)
    tau = np.clip(t - k * dt_s, 0.0, dt_s)[:, None]
    jerk = (acc[k + 1] - acc[k]) / dt_s
    position = pos[k] + vel[k] * tau + acc[k] * tau**2 / 2 + jerk * tau**3 / 6
    velocity = vel[k] + acc[k] * tau + jerk * tau**2 / 2
    return position, velocity


def position_weights(n_steps: int, dt_s: float, t_s) -> np.ndarray:
    """(T, n+1) weights W with position(t) = W @ a (per axis) for an n-step move from rest at
    the origin, at times ``t_s`` (T,) s (held after the end): the exact integral of the
    piecewise-linear acceleration, linear in the samples (:func:`kinematics_at`'s formulas
    applied to the unit samples, all at once)."""
    unit = np.eye(n_steps + 1)
    vel = np.concatenate(
        [np.zeros((1, n_steps + 1)), np.cumsum(0.5 * dt_s * (unit[:-1] + unit[1:]), axis=0)]
    )
    dx = dt_s * vel[:-1] + dt_s**2 * (2.0 * unit[:-1] + unit[1:]) / 6.0
    pos = np.concatenate([np.zeros((1, n_steps + 1)), np.cumsum(dx, axis=0)])
    t = np.atleast_1d(np.asarray(t_s, dtype=np.float64))
    k = np.clip(np.floor(t / dt_s).astype(np.int64), 0, n_steps - 1)
    tau = np.clip(t - k * dt_s, 0.0, dt_s)[:, None]
    jerk = (unit[k + 1] - unit[k]) / dt_s
    return pos[k] + vel[k] * tau + unit[k] * tau**2 / 2 + jerk * tau**3 / 6


def axis_limits(name: str, value, n_axes: int = 3) -> np.ndarray:
    """A per-axis limit given as a scalar or n_axes values, each finite and > 0."""
    arr = np.broadcast_to(np.asarray(value, dtype=np.float64), (n_axes,)).copy()
    for i, v in enumerate(arr):
        check_positive(f"{name}[{'xyz'[i]}]", float(v))
    return arr


def path_limit(direction: np.ndarray, per_axis: np.ndarray) -> float:
    """Largest scalar s with |direction_i| s <= per_axis_i on every axis (unit direction;
    components below 1e-12 move less than 1e-12 of the path and do not bind)."""
    moving = np.abs(direction) > 1e-12
    return float(np.min(per_axis[moving] / np.abs(direction[moving])))


def jerk_limited_move(distance_m, vmax, amax, jmax, dt_s: float) -> Move:
    """Shortest straight-line move with a symmetric trapezoidal acceleration whose corners lie
    on the dt grid, within per-axis |v| <= vmax (m/s), |a| <= amax (m/s^2), |jerk| <= jmax
    (m/s^3): a :class:`Move` of (n+1, 3) samples at step ``dt_s`` (s) that ends exactly at
    ``distance_m`` (3,) m, at rest.

    Corners on the grid make the piecewise-linear samples represent the profile exactly; the
    price is at most a few steps over the continuous time-optimal motion (see optim issue
    baselines for the ruckig duration).
    """
    dist = np.asarray(distance_m, dtype=np.float64).reshape(-1)
    if dist.shape != (3,) or not np.isfinite(dist).all():
        raise InputError(f"distance_m: expected 3 finite values (x, y, z) in m, got {distance_m!r}")
    length = float(np.linalg.norm(dist))
    if length == 0:
        raise InputError("distance_m: the move has zero length")
    dt_s = check_positive("dt_s", dt_s)
    direction = dist / length
    v_lim = path_limit(direction, axis_limits("vmax", vmax))
    a_lim = path_limit(direction, axis_limits("amax", amax))
    j_lim = path_limit(direction, axis_limits("jmax", jmax))

    nj_max = max(1, int(np.ceil(a_lim / (j_lim * dt_s)))) + 1
    na_max = max(0, int(np.ceil(v_lim / (a_lim * dt_s)))) + 1
    nj, na = np.meshgrid(np.arange(1, nj_max + 1), np.arange(0, na_max + 1), indexing="ij")
    peak_acc = np.minimum(a_lim, j_lim * nj * dt_s)
    # Steps of one acceleration phase plus cruise, needed by the velocity and acceleration caps.
    need = np.maximum(length / (dt_s * v_lim), length / (dt_s**2 * (nj + na) * peak_acc))
    nv = np.maximum(0, np.ceil(need * (1 - 1e-12)) - (2 * nj + na)).astype(np.int64)
    total = 2 * (2 * nj + na) + nv
    best = np.unravel_index(np.lexsort((peak_acc.ravel(), total.ravel()))[0], total.shape)
    n_j, n_a, n_v = int(nj[best]), int(na[best]), int(nv[best])
    accel = length / (dt_s**2 * (n_j + n_a) * (2 * n_j + n_a + n_v))
    ramp = accel * np.arange(n_j + 1) / n_j
    phase = np.concatenate([ramp, np.full(n_a, accel), ramp[::-1][1:]])  # 2 n_j + n_a + 1
    profile = np.concatenate([phase, np.zeros(n_v), -phase[1:]])
    acc = np.outer(profile, direction)
    acc.setflags(write=False)
    return Move(acc, dt_s)


def end_weights(n_steps: int, dt_s: float) -> np.ndarray:
    """(2, n+1) weights w with v_n = w[0] . a and x_n = w[1] . a for one axis starting at
    rest at 0: v_n = dt sum_k c_k a_k (trapezoid, c = 1/2 at the ends) and
    x_n = int_0^T (T - t) a(t) dt = dt^2 sum_k (n - k) a_k for interior samples (hat
    functions are symmetric) and dt^2 (n/2 - 1/6) resp. dt^2 / 6 for the end samples."""
    k = np.arange(n_steps + 1, dtype=np.float64)
    w_v = np.full(n_steps + 1, dt_s)
    w_v[[0, -1]] = 0.5 * dt_s
    w_x = dt_s**2 * (n_steps - k)
    w_x[0] = dt_s**2 * (n_steps / 2.0 - 1.0 / 6.0)
    w_x[-1] = dt_s**2 / 6.0
    return np.stack([w_v, w_x])


def enforce_end_state(move: Move, distance_m) -> Move:
    """The closest move (least-squares change of the interior samples of ``move``) that
    starts and ends at rest (a_0 = a_n = 0, v_n = 0) and arrives exactly at ``distance_m``
    (3,) m.

    Used to remove the ~1e-9 residue a solver leaves on the end conditions; the change is of
    that size, far inside the margin the optimiser keeps below every limit."""
    acc, dt_s = np.array(move.acc), move.dt_s
    acc[[0, -1]] = 0.0
    n = acc.shape[0] - 1
    if n < 2:
        raise InputError("acc: a move needs at least 3 samples (n >= 2)")
    w = end_weights(n, dt_s)[:, 1:-1]  # (2, n-1)
    gram_inv = np.linalg.inv(w @ w.T)
    dist = np.asarray(distance_m, dtype=np.float64).reshape(3)
    residual = w @ acc[1:-1] - np.stack([np.zeros(3), dist])  # (2, 3): v_n, x_n - d
    acc[1:-1] -= w.T @ (gram_inv @ residual)
    acc.setflags(write=False)
    return Move(acc, dt_s)
