"""A rest-to-rest move of n steps as LP variables and rows: exact kinematics and limits.

Per moving axis the variables are the samples a_0..a_n, v_0..v_n and x_0..x_n, tied by the
exact recursions of the piecewise-linear acceleration (jaxflex._profile):

    v_{k+1} = v_k + dt (a_k + a_{k+1}) / 2,    x_{k+1} = x_k + dt v_k + dt^2 (2 a_k + a_{k+1}) / 6

with a_0 = a_n = 0, v_0 = v_n = 0, x_0 = 0, x_n = distance. Limits:

* |a_k| <= amax and |a_{k+1} - a_k| <= jmax dt are exact (acceleration is linear on a step);
* velocity, quadratic on a step, lies in the convex hull of its Bernstein coefficients
  (v_k, v_k + a_k dt / 2, v_{k+1}), so |v_k| <= vmax and |v_k + a_k dt / 2| <= vmax make the
  limit hold at every instant. The price is at most jmax dt^2 / 2 of velocity where the
  acceleration crosses zero (5 mm/s at jmax 100 m/s^3, dt 10 ms).
* path-norm limits |v|, |a|, |jerk| <= limit act on the same points (the hull argument holds
  for vectors, the norm being convex) through the polyhedral inner approximation of
  optim.polytope, generated lazily as cutting planes (:func:`path_cuts`).

Via points (:class:`ViaRow`): at sample k_j the position equals the via point and the
velocity and acceleration are 0 (a stop), or each axis lies within a tolerance of it (a
blend). These rows are exact; the choice of k_j is not part of the LP (optim.cell_rows).

Axes that do not move (zero distance and no via point off the axis) stay at rest and are not
variables. Limits are used at their exact values (a margin would make the kinematic floor
infeasible whenever ruckig's corners fall on the grid); the solvers run with a 1e-9
feasibility tolerance and the limits check allows 1e-9 relative.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from optim.limits import Limits
from optim.lp import LPBuilder
from optim.options import MOVE_ATOL_M as MOVE_ATOL_M  # home: the light checks
from optim.options import clean_distance as clean_distance
from optim.polytope import ball_normals, support, worst_normals


@dataclass(frozen=True)
class MoveLayout:
    """Variable indices of a move: a, v, x are (d, n+1) for the d moving ``axes``."""

    n_steps: int
    dt_s: float
    axes: tuple[int, ...]
    a: np.ndarray
    v: np.ndarray
    x: np.ndarray

    def acceleration(self, solution: np.ndarray) -> np.ndarray:
        """(n+1, 3) samples from an LP solution vector (zero on axes that do not move)."""
        acc = np.zeros((self.n_steps + 1, 3))
        acc[:, list(self.axes)] = solution[self.a].T
        return acc


@dataclass(frozen=True)
class ViaRow:
    """A via point at sample ``k``: ``offset_m`` (3,) from the start, ``mode`` "stop" or
    "blend" (within ``tolerance_m`` per axis)."""

    k: int
    offset_m: np.ndarray
    mode: str
    tolerance_m: float


def via_step(fraction: float, n_steps: int) -> int:
    """The sample of an n-step move at which a via point at ``fraction`` of the move is
    passed: rounded to a sample, kept inside the move."""
    return int(np.clip(round(fraction * n_steps), 1, n_steps - 1))


def moving_axes(distance_m: np.ndarray, via: Sequence[ViaRow] = ()) -> tuple[int, ...]:
    """Axes whose distance, or a via point's offset, exceeds MOVE_ATOL_M."""
    reach = np.abs(np.asarray(distance_m, dtype=np.float64))
    for row in via:
        reach = np.maximum(reach, np.abs(row.offset_m))
    return tuple(int(c) for c in np.flatnonzero(reach > MOVE_ATOL_M))


def add_move(
    builder: LPBuilder,
    n_steps: int,
    dt_s: float,
    distance_m: np.ndarray,
    limits: Limits,
    via: Sequence[ViaRow] = (),
) -> MoveLayout:
    """Add the variables and rows of an n-step move to ``builder`` (module docstring)."""
    axes = moving_axes(distance_m, via)
    n, h = n_steps, dt_s
    a_idx, v_idx, x_idx = [], [], []
    for c in axes:
        amax, vmax = float(limits.amax[c]), float(limits.vmax[c])
        if limits.apath is not None:
            amax = min(amax, limits.apath)
        if limits.vpath is not None:
            vmax = min(vmax, limits.vpath)
        a = builder.variables(n + 1, -amax, amax)
        v = builder.variables(n + 1, -vmax, vmax)
        x = builder.variables(n + 1)
        builder.set_bounds([a[0], a[-1], v[0], v[-1], x[0]], 0.0, 0.0)
        builder.set_bounds([x[-1]], distance_m[c], distance_m[c])
        k = np.arange(n)
        ones = np.ones(n)
        builder.rows(  # v_{k+1} - v_k - h/2 (a_k + a_{k+1}) = 0
            np.column_stack([v[k + 1], v[k], a[k], a[k + 1]]),
            np.column_stack([ones, -ones, -h / 2 * ones, -h / 2 * ones]),
            0.0,
            0.0,
        )
        builder.rows(  # x_{k+1} - x_k - h v_k - h^2/3 a_k - h^2/6 a_{k+1} = 0
            np.column_stack([x[k + 1], x[k], v[k], a[k], a[k + 1]]),
            np.column_stack([ones, -ones, -h * ones, -h * h / 3 * ones, -h * h / 6 * ones]),
            0.0,
            0.0,
        )
        jump = float(limits.jmax[c]) * h
        if limits.jpath is not None:
            jump = min(jump, limits.jpath * h)
        builder.rows(np.column_stack([a[k + 1], a[k]]), np.column_stack([ones, -ones]), -jump, jump)
        builder.rows(  # Bernstein middle coefficient of the velocity on step k
            np.column_stack([v[k], a[k]]), np.column_stack([ones, h / 2 * ones]), -vmax, vmax
        )
        for row in via:
            target = float(row.offset_m[c])
            if row.mode == "stop":
                builder.set_bounds([x[row.k]], target, target)
                builder.set_bounds([v[row.k], a[row.k]], 0.0, 0.0)
            else:
                tol = row.tolerance_m
                builder.set_bounds([x[row.k]], target - tol, target + tol)
        a_idx.append(a)
        v_idx.append(v)
        x_idx.append(x)
    return MoveLayout(n, dt_s, axes, np.array(a_idx), np.array(v_idx), np.array(x_idx))


def add_tv_objective(builder: LPBuilder, layout: MoveLayout, limits: Limits, weight: float):
    """Add ``weight`` * sum_k,c |a_{k+1,c} - a_{k,c}| / (jmax_c dt) to the objective (total
    variation of the acceleration, which favours few jerk switches)."""
    for i, c in enumerate(layout.axes):
        a = layout.a[i]
        t = builder.variables(layout.n_steps, 0.0, np.inf, weight / (limits.jmax[c] * layout.dt_s))
        ones = np.ones(layout.n_steps)
        cols = np.column_stack([t, a[1:], a[:-1]])
        builder.rows(cols, np.column_stack([ones, -ones, ones]), 0.0, np.inf)
        builder.rows(cols, np.column_stack([ones, ones, -ones]), 0.0, np.inf)


def add_jerk_tv_objective(builder: LPBuilder, layout: MoveLayout, limits: Limits, weight: float):
    """Add ``weight`` * sum_k,c |j_{k+1,c} - j_{k,c}| / (2 jmax_c) to the objective (total
    variation of the jerk, j_k = (a_{k+1} - a_k) / dt: few and small jerk changes, no
    chattering between the jerk limits)."""
    n = layout.n_steps
    if n < 2:
        return
    for i, c in enumerate(layout.axes):
        a = layout.a[i]
        scale = weight / (2.0 * limits.jmax[c] * layout.dt_s)
        t = builder.variables(n - 1, 0.0, np.inf, scale)
        ones = np.ones(n - 1)
        cols = np.column_stack([t, a[2:], a[1:-1], a[:-2]])
        builder.rows(cols, np.column_stack([ones, -ones, 2 * ones, -ones]), 0.0, np.inf)
        builder.rows(cols, np.column_stack([ones, ones, -2 * ones, ones]), 0.0, np.inf)


def _path_quantities(layout: MoveLayout, sol: np.ndarray, limits: Limits):
    """(name, values (m, d), columns (m, terms, d), weights, limit) of every norm-limited
    quantity at the points where the LP bounds it."""
    a, v = sol[layout.a].T, sol[layout.v].T  # (n+1, d)
    n, h = layout.n_steps, layout.dt_s
    k = np.arange(n)
    out = []
    if limits.apath is not None:
        out.append((a, layout.a.T[:, None, :], (1.0,), limits.apath))
    if limits.jpath is not None:
        cols = np.stack([layout.a.T[k + 1], layout.a.T[k]], axis=1)
        out.append(((a[k + 1] - a[k]) / h, cols, (1.0 / h, -1.0 / h), limits.jpath))
    if limits.vpath is not None:
        out.append((v, layout.v.T[:, None, :], (1.0,), limits.vpath))
        cols = np.stack([layout.v.T[k], layout.a.T[k]], axis=1)
        out.append((v[k] + 0.5 * h * a[k], cols, (1.0, 0.5 * h), limits.vpath))
    return out


def path_cuts(
    layout: MoveLayout, sol: np.ndarray, limits: Limits, tol: float = 1e-9
) -> list[tuple[np.ndarray, np.ndarray, float]]:
    """Cutting planes (columns, coefficients, upper bound) for every path-norm limit the LP
    solution ``sol`` breaks in the polyhedral sense. Empty for single-axis moves, where the
    norm limits are plain bounds already."""
    d = len(layout.axes)
    if d < 2 or not limits.has_path_limits():
        return []
    _, rho = ball_normals(d)
    cuts = []
    for values, cols, weights, limit in _path_quantities(layout, sol, limits):
        bound = rho * limit
        for i in np.flatnonzero(support(values, d) > bound * (1 + tol)):
            for normal in worst_normals(values[i], d):
                coef = np.concatenate([w * normal for w in weights])
                cuts.append((cols[i].ravel(), coef, bound))
    return cuts


def add_cuts(builder: LPBuilder, cuts) -> None:
    for cols, coef, bound in cuts:
        builder.rows(cols[None], coef[None], -np.inf, bound)
