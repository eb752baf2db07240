"""Time-optimal jerk-limited motion (ruckig), input-shaped variants, and their grid versions.

Ruckig gives the continuous time-optimal rest-to-rest motion under per-axis limits, axes
synchronised to finish together. Its acceleration is piecewise linear with corners anywhere
in time; read exactly from its profiles (phase durations and accelerations), it can be
shifted and summed for input shaping. A continuous move becomes a grid move (samples a_k on
t_k = k dt, linear in between) by the closest grid profile in the L1 sense that meets the
limits and the boundary conditions exactly (a small LP, :func:`fit_to_grid`).

Every grid move is itself a jerk-limited motion, so it cannot beat ruckig: its duration is at
least ceil(T_ruckig / dt) steps, the kinematic floor.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from ruckig import InputParameter, Result, Ruckig, Synchronization, Trajectory

from jaxflex.errors import InputError
from jaxflex.response import as_move, enforce_end_state
from optim.kinematics import add_cuts, add_move, clean_distance, path_cuts
from optim.limits import Limits
from optim.lp import LPBuilder, solve_lp
from optim.shapers import Shaper

MAX_CUT_ROUNDS = 30
# Grid moves exist at ceil(T / dt) or one step more in every case tried (hundreds of random
# moves and limits); a few more are allowed before this is treated as a failure.
MAX_EXTRA_STEPS = 4


@dataclass(frozen=True)
class ContinuousMove:
    """A continuous piecewise-linear acceleration: per axis the knot times (s) and values
    (m/s^2); zero outside [0, duration_s]."""

    duration_s: float
    knots: tuple[tuple[np.ndarray, np.ndarray], ...]

    def acceleration(self, t: np.ndarray) -> np.ndarray:
        """(T, 3) acceleration at times ``t`` (T,) s."""
        t = np.asarray(t, dtype=np.float64)
        return np.column_stack([np.interp(t, kt, ka, left=0.0, right=0.0) for kt, ka in self.knots])


def _ruckig_limits(distance: np.ndarray, limits: Limits):
    """Per-axis limits handed to ruckig. With path-norm limits the move runs on the straight
    line (phase synchronisation) with each axis limited to min(limit_c, path limit |u_c|),
    which keeps the norms within their limits."""
    v, a, j = limits.vmax.copy(), limits.amax.copy(), limits.jmax.copy()
    if not limits.has_path_limits():
        return v, a, j, Synchronization.Time
    unit = np.abs(distance) / np.linalg.norm(distance)
    for values, path in ((v, limits.vpath), (a, limits.apath), (j, limits.jpath)):
        if path is not None:
            moving = unit > 0
            values[moving] = np.minimum(values[moving], path * unit[moving])
    return v, a, j, Synchronization.Phase


def time_optimal_move(
    distance_m, limits: Limits, minimum_duration_s: float | None = None
) -> ContinuousMove:
    """Ruckig's time-optimal rest-to-rest motion over ``distance_m`` (3,) m; with
    ``minimum_duration_s`` the motion is stretched to last at least that long."""
    distance = np.asarray(distance_m, dtype=np.float64).reshape(3)
    v, a, j, sync = _ruckig_limits(distance, limits)
    inp = InputParameter(3)
    inp.current_position = [0.0, 0.0, 0.0]
    inp.target_position = distance.tolist()
    inp.max_velocity, inp.max_acceleration, inp.max_jerk = v.tolist(), a.tolist(), j.tolist()
    inp.synchronization = sync
    if minimum_duration_s is not None:
        inp.minimum_duration = float(minimum_duration_s)
    traj = Trajectory(3)
    try:
        result = Ruckig(3).calculate(inp, traj)
    except (ValueError, RuntimeError) as exc:  # ruckig's own errors (e.g. result codes < -100)
        raise InputError(
            f"limits: ruckig cannot plan the move over {distance.tolist()} m with vmax "
            f"{v.tolist()}, amax {a.tolist()}, jmax {j.tolist()} ({exc})"
        ) from exc
    if result not in (Result.Working, Result.Finished) or not math.isfinite(traj.duration):
        raise InputError(f"limits: ruckig found no motion for distance {distance.tolist()} m")
    knots = []
    for profile in traj.profiles[0]:
        times = np.concatenate([[0.0], np.cumsum(profile.t)])
        knots.append((times, np.asarray(profile.a, dtype=np.float64)))
    return ContinuousMove(float(traj.duration), tuple(knots))


def shaped_acceleration(move: ContinuousMove, shaper: Shaper) -> Callable:
    """a_s(t) = sum_j A_j a(t - t_j): the move convolved with the shaper's impulses."""

    def acc(t):
        t = np.asarray(t, dtype=np.float64)
        out = np.zeros((t.size, 3))
        for amp, delay in zip(shaper.amplitudes, shaper.times_s, strict=True):
            out += amp * move.acceleration(t - delay)
        return out

    return acc


def fit_to_grid(
    reference: np.ndarray, dt_s: float, distance_m, limits: Limits, *, solver: str = "highs"
) -> np.ndarray | None:
    """The grid move of len(reference) - 1 steps closest to ``reference`` ((N+1, 3) samples)
    in the L1 norm that meets ``limits`` and the boundary conditions exactly, or None if
    no grid move of that length exists."""
    distance = np.asarray(distance_m, dtype=np.float64).reshape(3)
    n_steps = reference.shape[0] - 1
    builder = LPBuilder()
    layout = add_move(builder, n_steps, dt_s, distance, limits)
    for i, c in enumerate(layout.axes):
        a = layout.a[i]
        e = builder.variables(n_steps + 1, 0.0, np.inf, 1.0 / limits.amax[c])
        ones = np.ones(n_steps + 1)
        cols = np.column_stack([e, a])
        builder.rows(cols, np.column_stack([ones, -ones]), -reference[:, c], np.inf)
        builder.rows(cols, np.column_stack([ones, ones]), reference[:, c], np.inf)
    for _ in range(MAX_CUT_ROUNDS):
        sol = solve_lp(builder.program(), solver)
        if sol.status != "optimal":
            return None
        cuts = path_cuts(layout, sol.x, limits)
        if not cuts:
            return enforce_end_state(as_move(layout.acceleration(sol.x), dt_s), distance).acc
        add_cuts(builder, cuts)
    return None


def grid_steps(duration_s: float, dt_s: float) -> int:
    """ceil(duration / dt), tolerant to round-off in ruckig's duration."""
    return max(2, math.ceil(duration_s / dt_s - 1e-7))


@dataclass(frozen=True)
class GridMove:
    acc: np.ndarray  # (n+1, 3)
    continuous_duration_s: float  # of the continuous motion it samples


def kinematic_floor_move(
    distance_m, limits: Limits, dt_s: float, max_steps: int, *, solver: str = "highs"
) -> GridMove:
    """Ruckig's time-optimal motion on the grid: the fewest steps N >= ceil(T_ruckig / dt) at
    which the motion, stretched by ruckig to N dt, has a grid version within the limits."""
    distance = clean_distance(distance_m)
    floor = time_optimal_move(distance, limits)
    start = grid_steps(floor.duration_s, dt_s)
    for n_steps in range(start, min(max_steps, start + MAX_EXTRA_STEPS) + 1):
        stretched = time_optimal_move(distance, limits, minimum_duration_s=n_steps * dt_s)
        reference = stretched.acceleration(dt_s * np.arange(n_steps + 1))
        acc = fit_to_grid(reference, dt_s, distance, limits, solver=solver)
        if acc is not None:
            return GridMove(acc, floor.duration_s)
    if start <= max_steps:
        raise RuntimeError(
            f"no grid move found within {MAX_EXTRA_STEPS} steps of ruckig's duration "
            f"{floor.duration_s:.6g} s (distance {distance.tolist()} m, dt {dt_s} s)"
        )
    raise InputError(
        f"distance_m: the move needs at least {floor.duration_s:.3f} s at these limits "
        f"(time-optimal jerk-limited motion), more than the {max_steps} steps of "
        f"{dt_s:g} s allowed ({max_steps * dt_s:g} s: max_duration_s or the step budget); "
        "raise max_duration_s or the limits, or shorten the move"
    )


def shaped_grid_move(
    floor: ContinuousMove,
    shaper: Shaper,
    distance_m,
    limits: Limits,
    dt_s: float,
    *,
    extra_steps: int = 3,
    max_steps: int | None = None,
    solver: str = "highs",
) -> np.ndarray | None:
    """Grid version of the time-optimal move convolved with ``shaper`` (None if no grid move
    within ``extra_steps`` of its continuous length and at most ``max_steps`` long exists)."""
    acc_fn = shaped_acceleration(floor, shaper)
    start = grid_steps(floor.duration_s + shaper.duration_s, dt_s)
    last = start + extra_steps if max_steps is None else min(start + extra_steps, max_steps)
    for n_steps in range(start, last + 1):
        acc = fit_to_grid(
            acc_fn(dt_s * np.arange(n_steps + 1)), dt_s, distance_m, limits, solver=solver
        )
        if acc is not None:
            return acc
    return None
