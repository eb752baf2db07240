"""The preprint's direct convolution: a reference path, and a way to use a user's R1 matrix.

The acceleration is a sum of hat functions a(t) = sum_k a_k h_k(t) (h_k = 1 at t_k, linear to
0 at t_{k-1} and t_{k+1}; preprint eq. 1-2). The response to the hat at t_1 with unit
amplitude along one axis, sampled at t_j, is the unit response R1 (K points x 3 components x
N steps). By time invariance the hat at t_k gives R1 shifted by k - 1 steps, so (eq. 4)

    u(t_j) = sum_k a_k R1(t_{j - k + 1}).

This costs O(n^2 K) per profile, against O(n M + n K M) for the modal recursion; jaxflex
keeps it to check the recursion and to benchmark against. R1 files use the preprint's
Table 2 layout: a CSV with one row per point and, per time step, the x, y, z displacement in
m (3 N columns), optionally a header row.
"""

from __future__ import annotations

import csv
import io
import os
import warnings
from pathlib import Path

import numpy as np

from jaxflex._atomic import write_text_atomic
from jaxflex._budget import Need, require
from jaxflex._inputs import check_text_file
from jaxflex._scalars import check_positive
from jaxflex._simulate import simulate
from jaxflex._validation import check_acc
from jaxflex.errors import InputError
from jaxflex.model import ModalModel


def unit_response(model: ModalModel, dt_s: float, n_steps: int) -> np.ndarray:
    """R1 for a unit hat at t_1 along x, y and z: (3 axes, n_steps + 1, K, 3) in m per m/s^2.

    Computed exactly with the modal recursion; R1[:, 0] is zero.
    """
    dt_s = check_positive("dt_s", dt_s)
    if int(n_steps) < 2:
        raise InputError(f"n_steps: must be >= 2, got {n_steps}")
    out = np.empty((3, int(n_steps) + 1, model.n_points, 3))
    for axis in range(3):
        acc = np.zeros((int(n_steps) + 1, 3))
        acc[1, axis] = 1.0
        out[axis] = np.asarray(simulate(model, acc, dt_s, displacement=True).displacement)
    return out


def convolve_unit_response(r1: np.ndarray, acc, axes: tuple[int, ...] = (0, 1, 2)) -> np.ndarray:
    """Displacements u(t_j), (n+1, K, 3) in m, by direct superposition of shifted unit responses.

    ``r1``: (A, N+1, K, 3) unit responses for the acceleration ``axes`` (A of them, 0 = x,
    1 = y, 2 = z), N >= n. ``acc``: (n+1, 3) samples in m/s^2 with a_0 = 0 (the hat at t_0
    lies half before the start and is not represented by R1); the other axes must be zero.
    """
    acc = check_acc(acc)
    r1 = np.asarray(r1, dtype=np.float64)
    axes = tuple(int(a) for a in axes)
    if not axes or len(set(axes)) != len(axes) or any(a not in (0, 1, 2) for a in axes):
        raise InputError(f"axes: distinct values among 0, 1, 2 required, got {axes}")
    if r1.ndim != 4 or r1.shape[3] != 3 or r1.shape[0] != len(axes):
        raise InputError(f"r1: expected shape ({len(axes)} axes, N+1, K, 3), got {r1.shape}")
    n_r1 = r1.shape[1]
    n = acc.shape[0] - 1
    if n_r1 < n + 1:
        raise InputError(f"r1: covers {n_r1 - 1} steps, the profile needs {n}")
    if np.any(acc[0] != 0):
        raise InputError("acc: the first sample must be 0 for the hat-function convolution")
    others = [a for a in range(3) if a not in axes]
    if np.any(acc[:, others] != 0):
        raise InputError(f"acc: r1 holds axes {axes} only, but axes {others} are non-zero")
    acc = acc[:, axes]
    out = np.zeros((n + 1, r1.shape[2], 3))
    for k in range(1, n + 1):
        weights = acc[k]
        if not weights.any():
            continue
        # Hat k: u(t_j) += a_k R1(t_{j-k+1}) for j >= k - 1.
        out[k - 1 :] += np.tensordot(weights, r1[:, : n + 2 - k], axes=(0, 0))
    return out


def deviation_from_displacement(displacement: np.ndarray) -> np.ndarray:
    """d_j = max_p |u_p(t_j)| for (T, K, 3) displacements: (T,) in m."""
    return np.sqrt(np.max(np.einsum("tkc,tkc->tk", displacement, displacement), axis=1))


def write_unit_response_csv(
    path: str | os.PathLike, r1_axis: np.ndarray, dt_s: float | None = None
) -> None:
    """Write one axis' R1 ((N+1, K, 3)) in the Table 2 layout, atomically, with a header.

    The header names the component and step (``x_0, y_0, z_0, x_1, ...``); with ``dt_s`` it
    also states the time of each step (``x_0@0s, ..., x_1@0.01s``) so that a reader can
    check the time step it is told.
    """
    r1_axis = np.asarray(r1_axis, dtype=np.float64)
    n_t, n_points, _ = r1_axis.shape
    if dt_s is None:
        header = [f"{c}_{j}" for j in range(n_t) for c in "xyz"]
    else:
        dt_s = check_positive("dt_s", dt_s)
        header = [f"{c}_{j}@{j * dt_s:.12g}s" for j in range(n_t) for c in "xyz"]
    buf = io.StringIO()
    writer = csv.writer(buf)
    writer.writerow(header)
    table = np.transpose(r1_axis, (1, 0, 2)).reshape(n_points, 3 * n_t)
    for row in table:
        writer.writerow([repr(float(v)) for v in row])
    write_text_atomic(path, buf.getvalue())


# reading an R1 table: about 8 characters per value or more ("1.25e-05,"), held as the
# parser's rows, the table and its transpose
MIN_CHARS_PER_VALUE = 8
MAX_R1_M = 1e6  # m per m/s^2: far above any mode's static deflection, 1 / omega^2
READ_COPIES = 3


def read_unit_response_csv(path: str | os.PathLike) -> np.ndarray:
    """Read an R1 CSV in the Table 2 layout (K rows, x/y/z per time step; an optional header
    row is skipped) as (N+1, K, 3). Raises InputError with the line for malformed files.

    Well-formed files are parsed by numpy's C reader (a preprint-size R1, 66 308 rows of
    3 003 values, in well under a minute); a file it rejects is read again line by line to
    say where it is broken.
    """
    path = check_text_file("R1 file", path)
    values = path.stat().st_size / MIN_CHARS_PER_VALUE
    require(
        Need(
            f"reading the R1 file {str(path)!r} (about {values:,.0f} values)",
            READ_COPIES * 8.0 * values,
            0.0,
            "give the R1 of fewer points or steps",
        )
    )
    with path.open(newline="", encoding="utf-8") as handle:
        first = next(csv.reader(handle), [])
    try:
        header = 1 if first and any(_not_a_number(cell) for cell in first) else 0
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # an empty file warns; let the slow path say so
            table = np.loadtxt(path, delimiter=",", skiprows=header, ndmin=2, dtype=np.float64)
    except (ValueError, UserWarning):
        table = _read_table_by_line(path)
    if table.size == 0:
        raise InputError(f"{str(path)!r}: no data rows")
    width = table.shape[1]
    if width % 3:
        raise InputError(
            f"{str(path)!r}: {width} columns is not a multiple of 3 (x, y, z per step)"
        )
    if not np.isfinite(table).all():
        raise InputError(f"{str(path)!r}: contains non-finite values")
    if np.abs(table).max() > MAX_R1_M:
        row = int(np.argmax(np.abs(table).max(axis=1)))
        raise InputError(
            f"{str(path)!r}: data row {row + 1} holds {np.abs(table[row]).max():.3g} m per m/s^2; "
            f"a unit response stays below {MAX_R1_M:g} (a 0.01 Hz mode deflects 253 m per "
            "m/s^2)"
        )
    return np.transpose(table.reshape(len(table), width // 3, 3), (1, 0, 2))


def _not_a_number(cell: str) -> bool:
    try:
        float(cell)
    except ValueError:
        return True
    return False


def _read_table_by_line(path: Path) -> np.ndarray:
    rows: list[list[float]] = []
    lines: list[int] = []
    bad_line = None
    with path.open(newline="", encoding="utf-8") as handle:
        for line_no, row in enumerate(csv.reader(handle), start=1):
            if not row or all(not cell.strip() for cell in row):
                continue
            if bad_line is not None:  # a broken line followed by data: not a cut-off end
                raise InputError(f"{str(path)!r} line {bad_line}: non-numeric value")
            try:
                rows.append([float(cell) for cell in row])
                lines.append(line_no)
            except ValueError:
                if line_no == 1 and not rows:
                    continue  # header
                bad_line = line_no
    if bad_line is not None:
        raise InputError(
            f"{str(path)!r} line {bad_line}: non-numeric value at the end of the file; the file "
            "looks truncated"
        )
    if not rows:
        raise InputError(f"{str(path)!r}: no data rows")
    widths = np.array([len(r) for r in rows])
    if np.ptp(widths):
        common = int(np.bincount(widths).argmax())
        odd = int(np.argmax(widths != common))
        truncated = odd == len(rows) - 1 and widths[odd] < common
        raise InputError(
            f"{str(path)!r}: rows have different lengths {sorted(set(widths.tolist()))}: line "
            f"{lines[odd]} has {widths[odd]} values, the others {common}"
            + ("; the file looks truncated" if truncated else "")
        )
    return np.asarray(rows)
