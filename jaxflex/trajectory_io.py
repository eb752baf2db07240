"""Trajectory files: CSV with one row per sample, SI units in the column names.

Columns: t_s, ax_m_s2, ay_m_s2, az_m_s2, vx_m_s, vy_m_s, vz_m_s, x_m, y_m, z_m. Velocity and
position are the exact integrals of the piecewise-linear acceleration (jaxflex.profile).
"""

from __future__ import annotations

import io
import os
from pathlib import Path

import numpy as np

from jaxflex.atomic import write_text_atomic
from jaxflex.errors import InputError
from jaxflex.profile import integrate

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
)


def write_trajectory_csv(path: str | os.PathLike, acc, dt_s: float) -> None:
    """Write samples ``acc`` ((n+1, 3) m/s^2 at step ``dt_s`` s) with velocity and position."""
    vel, pos = integrate(acc, dt_s)
    acc = np.asarray(acc, dtype=np.float64)
    t = dt_s * np.arange(acc.shape[0])
    table = np.column_stack([t, acc, vel, pos])
    buf = io.StringIO()
    np.savetxt(buf, table, delimiter=",", header=",".join(COLUMNS), comments="", fmt="%.17g")
    write_text_atomic(path, buf.getvalue())


def read_trajectory_csv(path: str | os.PathLike) -> tuple[np.ndarray, float]:
    """Read a trajectory CSV: returns (acc (n+1, 3) m/s^2, dt s). Only t and a are used."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"trajectory file {str(path)!r} does not exist")
    with path.open(encoding="utf-8") as handle:
        header = handle.readline().strip().split(",")
    missing = [c for c in COLUMNS[:4] if c not in header]
    if missing:
        raise InputError(f"{str(path)!r}: missing columns {missing} (expected {list(COLUMNS)})")
    try:
        table = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    except ValueError as exc:
        raise InputError(f"{str(path)!r}: malformed numbers ({exc})") from exc
    cols = [header.index(c) for c in COLUMNS[:4]]
    t, acc = table[:, cols[0]], table[:, cols[1:]]
    if len(t) < 2:
        raise InputError(f"{str(path)!r}: needs at least two samples")
    steps = np.diff(t)
    dt_s = float(np.mean(steps))
    if dt_s <= 0 or np.max(np.abs(steps - dt_s)) > 1e-9 * max(1.0, t[-1]):
        raise InputError(f"{str(path)!r}: samples must be equally spaced in t_s")
    return acc, dt_s
