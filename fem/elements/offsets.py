"""Rigid offsets: the motion of a point rigidly attached to a node with six DOFs.

A point at r from a node moves by u + theta x r = u - S(r) theta (S the cross-product
matrix) and turns by theta: offset elements (CBAR/CBEAM/shell offsets), the dependent grids
of a rigid element and masses away from their grid (CONM2) all use this map.
"""

from __future__ import annotations

import numpy as np


def skew(r: np.ndarray) -> np.ndarray:
    """(..., 3, 3) S with S t = r x t."""
    r = np.asarray(r, dtype=float)
    zero = np.zeros(r.shape[:-1])
    x, y, z = r[..., 0], r[..., 1], r[..., 2]
    return np.stack(
        [np.stack([zero, -z, y], -1), np.stack([z, zero, -x], -1), np.stack([-y, x, zero], -1)],
        -2,
    )


def offset_transform(offsets: np.ndarray) -> np.ndarray:
    """(E, 6 n, 6 n) T with the motion of points offset by ``offsets`` (E, n, 3) from n
    nodes (u + theta x r, theta) = T (nodal u, theta), all in global axes."""
    n_el, n = offsets.shape[:2]
    t = np.zeros((n_el, n, 6, n, 6))
    for a in range(n):
        t[:, a, :, a, :] = np.eye(6)
        t[:, a, :3, a, 3:] = -skew(offsets[:, a])
    return t.reshape(n_el, 6 * n, 6 * n)
