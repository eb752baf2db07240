"""Structured meshes of rectangular footprints, refined around the cups.

The footprint [0, width] x [0, height] (m) is meshed on a tensor grid whose spacing is the
base size away from the cups and ``fine`` inside bands around each cup, growing smoothly in
between; triangles (plate) split each grid cell, quadrilaterals (thin solid) are the cells.
"""

from __future__ import annotations

import numpy as np

from jaxflex.errors import InputError

GROWTH = 0.3  # element size may grow by 30 % of the distance covered (smooth grading)
COUNT_SAMPLES = 20_000  # samples of the spacing for a count (relative error ~1e-6)


def graded_coordinates(
    length_m: float, size_m: float, bands: list[tuple[float, float]], fine_m: float
) -> np.ndarray:
    """Node coordinates on [0, length_m]: spacing ``fine_m`` inside the ``bands`` (lo, hi),
    ``size_m`` far from them, growing linearly with distance in between. Sorted, (n+1,)."""
    if size_m <= 0 or fine_m <= 0:
        raise InputError(f"mesh_size: must be > 0 m, got {size_m}, {fine_m}")
    samples = max(2000, int(40 * length_m / min(size_m, fine_m)))
    s = np.linspace(0.0, length_m, samples + 1)
    target = np.full_like(s, size_m)
    for lo, hi in bands:
        distance = np.maximum(np.maximum(lo - s, s - hi), 0.0)
        target = np.minimum(target, fine_m + GROWTH * distance)
    density = 1.0 / target
    cumulative = np.concatenate([[0.0], np.cumsum(0.5 * (density[1:] + density[:-1]) * np.diff(s))])
    n = max(1, int(np.ceil(cumulative[-1] - 1e-9)))
    coords = np.interp(np.linspace(0.0, cumulative[-1], n + 1), cumulative, s)
    coords[0], coords[-1] = 0.0, length_m
    return coords


def graded_count(
    length_m: float, size_m: float, bands: list[tuple[float, float]], fine_m: float
) -> float:
    """The number of intervals :func:`graded_coordinates` makes (the integral of 1 / spacing
    over [0, length_m], at most ``COUNT_SAMPLES`` samples: for a plan, without the nodes)."""
    s = np.linspace(0.0, length_m, COUNT_SAMPLES + 1)
    target = np.full_like(s, size_m)
    for lo, hi in bands:
        distance = np.maximum(np.maximum(lo - s, s - hi), 0.0)
        target = np.minimum(target, fine_m + GROWTH * distance)
    density = 1.0 / target
    return max(1.0, float(np.sum(0.5 * (density[1:] + density[:-1]) * np.diff(s))))


def cup_bands(cups, size_m: float, fine_fraction: float):
    """(bands along x, bands along y, fine spacing m) of a tensor grid refined around
    ``cups``: inside a band of the cup diameter, the spacing is min(size, fine_fraction *
    radius)."""
    bands_x, bands_y, fines = [], [], []
    for cup in cups:
        margin = cup.radius
        bands_x.append((cup.x - margin, cup.x + margin))
        bands_y.append((cup.y - margin, cup.y + margin))
        fines.append(min(size_m, fine_fraction * cup.radius))
    return bands_x, bands_y, min(fines, default=size_m)


def cup_grid(
    width_m: float, height_m: float, size_m: float, cups, fine_fraction: float = 0.25
) -> tuple[np.ndarray, np.ndarray]:
    """Grid lines (x, y) of a width x height footprint, refined around ``cups`` (bands of
    :func:`cup_bands`)."""
    bands_x, bands_y, fine = cup_bands(cups, size_m, fine_fraction)
    return (
        graded_coordinates(width_m, size_m, bands_x, fine),
        graded_coordinates(height_m, size_m, bands_y, fine),
    )


def grid_quads(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Footprint nodes (N, 2) and counter-clockwise quads (E, 4) of the tensor grid x by y.
    Node (i, j) has index i * len(y) + j."""
    xx, yy = np.meshgrid(x, y, indexing="ij")
    nodes = np.column_stack([xx.ravel(), yy.ravel()])
    idx = np.arange(nodes.shape[0]).reshape(len(x), len(y))
    quads = np.column_stack(
        [
            idx[:-1, :-1].ravel(),
            idx[1:, :-1].ravel(),
            idx[1:, 1:].ravel(),
            idx[:-1, 1:].ravel(),
        ]
    )
    return nodes, quads


def split_quads(quads: np.ndarray, nodes_xy: np.ndarray) -> np.ndarray:
    """Triangles (2E, 3), counter-clockwise, from quads (E, 4): each quad is cut along its
    shorter diagonal."""
    a, b, c, d = quads.T
    diag_ac = np.linalg.norm(nodes_xy[a] - nodes_xy[c], axis=1)
    diag_bd = np.linalg.norm(nodes_xy[b] - nodes_xy[d], axis=1)
    use_ac = diag_ac <= diag_bd
    first = np.where(use_ac[:, None], np.column_stack([a, b, c]), np.column_stack([a, b, d]))
    second = np.where(use_ac[:, None], np.column_stack([a, c, d]), np.column_stack([b, c, d]))
    return np.concatenate([first, second])
