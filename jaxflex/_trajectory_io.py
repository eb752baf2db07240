"""Trajectory files: CSV with one row per sample, SI units in the column names.

Columns: t_s, ax_m_s2, ay_m_s2, az_m_s2, vx_m_s, vy_m_s, vz_m_s, x_m, y_m, z_m, jx_m_s3,
jy_m_s3, jz_m_s3. Velocity and position are the exact integrals of the piecewise-linear
acceleration (jaxflex._profile); the jerk is constant on each step, (a_{k+1} - a_k) / dt_s
on [t_k, t_{k+1}) in row k, and 0 in the last row (at rest after the move). Times are the
decimal multiples of the step (jaxflex._grid: 0.82, not 0.8200000000000001); every value is
written as the shortest decimal that reads back as the same float. Reading needs t and the
acceleration only.

A move that turns the part (a turn about a fixed axis, jaxflex._pose) adds the turn's
columns after these: turn_angle_rad, turn_rate_rad_s, turn_acc_rad_s2 (the angle and its
exact integrals, like the translation's); straight moves' files are unchanged.
"""

from __future__ import annotations

import io
import os
from pathlib import Path

import numpy as np

from jaxflex._atomic import write_text_atomic
from jaxflex._grid import grid_times
from jaxflex._inputs import read_text
from jaxflex._profile import Move, as_move, integrate
from jaxflex.errors import InputError

COLUMNS = (
    "t_s",
    "ax_m_s2",
    "ay_m_s2",
    "az_m_s2",
    "vx_m_s",
    "vy_m_s",
    "vz_m_s",
    "x_m",
    "y_m",
    "z_m",
    "jx_m_s3",
    "jy_m_s3",
    "jz_m_s3",
)
TURN_COLUMNS = ("turn_angle_rad", "turn_rate_rad_s", "turn_acc_rad_s2")


def write_trajectory_csv(path: str | os.PathLike, move: Move, turn_acc_rad_s2=None) -> None:
    """Write a :class:`~jaxflex._profile.Move` with velocity, position and jerk (module
    docstring), and with ``turn_acc_rad_s2`` ((n+1,) rad/s^2, a turn about a fixed axis) the
    turn's angle, rate and angular acceleration."""
    move = as_move(move, name="move")
    acc, dt_s = move.acc, move.dt_s
    vel, pos = integrate(move)
    jerk = np.vstack([np.diff(acc, axis=0) / dt_s, np.zeros((1, 3))])
    t = grid_times(acc.shape[0] - 1, dt_s)
    columns = [t, acc, vel, pos, jerk]
    names = list(COLUMNS)
    if turn_acc_rad_s2 is not None:
        alpha = np.zeros_like(acc)
        alpha[:, 0] = turn_acc_rad_s2
        rate, angle = integrate(alpha, dt_s)
        columns += [angle[:, 0], rate[:, 0], alpha[:, 0]]
        names += TURN_COLUMNS
    table = np.column_stack(columns) + 0.0  # + 0.0: no "-0.0" cells
    lines = [",".join(names)]
    lines += [",".join(map(repr, row)) for row in table.tolist()]
    write_text_atomic(path, "\n".join(lines) + "\n")


def read_trajectory_csv(path: str | os.PathLike) -> Move:
    """Read a trajectory CSV as a checked :class:`~jaxflex._profile.Move` (samples (n+1, 3)
    m/s^2 and the step, s). Only t and a are used."""
    path, header, table = _read_table(path)
    cols = [header.index(c) for c in COLUMNS[:4]]
    t, acc = table[:, cols[0]], table[:, cols[1:]]
    if len(t) < 2:
        raise InputError(f"{str(path)!r}: needs at least two samples")
    steps = np.diff(t)
    dt_s = float(np.mean(steps))
    if dt_s <= 0 or np.max(np.abs(steps - dt_s)) > 1e-9 * max(1.0, t[-1]):
        raise InputError(f"{str(path)!r}: samples must be equally spaced in t_s")
    return as_move(acc, _written_step(t, dt_s), name=f"{str(path)!r}: acceleration")


def read_turn_csv(path: str | os.PathLike) -> np.ndarray | None:
    """The turn's angular acceleration samples ((n+1,) rad/s^2, column turn_acc_rad_s2) of a
    trajectory CSV, or None for a move that does not turn (no turn columns)."""
    path, header, table = _read_table(path)
    if TURN_COLUMNS[-1] not in header:
        return None
    return table[:, header.index(TURN_COLUMNS[-1])].copy()


def _read_table(path: str | os.PathLike) -> tuple[Path, list[str], np.ndarray]:
    """(path, column names, values (rows, columns)) of a trajectory CSV with at least t and
    a, every value finite; InputError naming the file otherwise."""
    path = Path(path)
    text = read_text("trajectory", path)
    header = text.split("\n", 1)[0].strip().split(",")
    missing = [c for c in COLUMNS[:4] if c not in header]
    if missing:
        raise InputError(f"{str(path)!r}: missing columns {missing} (expected {list(COLUMNS)})")
    try:
        table = np.loadtxt(io.StringIO(text), delimiter=",", skiprows=1, ndmin=2)
    except ValueError as exc:
        raise InputError(f"{str(path)!r}: malformed numbers ({exc})") from exc
    bad = np.flatnonzero(~np.isfinite(table).all(axis=1))
    if bad.size:
        raise InputError(
            f"{str(path)!r}: row {int(bad[0]) + 1} holds a value that is not finite (inf or "
            "nan, or a number beyond 1e308)"
        )
    return path, header, table


def _written_step(t: np.ndarray, mean_step_s: float) -> float:
    """The step a file was written with: the shortest decimal near the mean step whose grid
    reproduces the times exactly (a file of write_trajectory_csv), else the mean step."""
    n = len(t) - 1
    for digits in range(1, 18):
        candidate = float(f"{mean_step_s:.{digits}g}")
        if np.array_equal(grid_times(n, candidate), t - t[0]):
            return candidate
    return mean_step_s
