"""Polyhedral inner approximations of the Euclidean ball, for norm limits in linear programs.

With unit normals c_f, the polytope {u : c_f . u <= rho r for all f} lies inside the ball
|u| <= r exactly when rho <= 1 / max_vertex |v| of {c_f . v <= 1}. That polytope is the polar
of conv{c_f}, so its vertices are n / b for the facets n . x <= b of the hull of the normals:
rho = min_facets b. Then |u| <= r holds whenever every row c_f . u <= rho r does, and
conversely any u with |u| > r violates at least one row (cutting-plane generation is exact).
"""

from __future__ import annotations

import functools

import numpy as np

POLYGON_SIDES = 32
SPHERE_NORMALS = 400
PATCH = {1: 1, 2: 3, 3: 12}


@functools.lru_cache(maxsize=8)
def ball_normals(dim: int) -> tuple[np.ndarray, float]:
    """(normals (F, dim), rho) for a ball in ``dim`` = 1, 2 or 3 dimensions.

    1-D: (+1, -1), rho = 1 (exact). 2-D: a regular polygon, rho = cos(pi / F).
    3-D: a Fibonacci sphere of unit normals, rho from the hull (about 0.99 for 400 normals).
    """
    if dim == 1:
        normals, rho = np.array([[1.0], [-1.0]]), 1.0
    elif dim == 2:
        angle = 2 * np.pi * np.arange(POLYGON_SIDES) / POLYGON_SIDES
        normals = np.column_stack([np.cos(angle), np.sin(angle)])
        rho = float(np.cos(np.pi / POLYGON_SIDES))
    elif dim == 3:
        from scipy.spatial import ConvexHull  # ~0.2 s: only for limits on 3-D norms

        i = np.arange(SPHERE_NORMALS) + 0.5
        polar = np.arccos(1 - 2 * i / SPHERE_NORMALS)
        azimuth = np.pi * (1 + 5**0.5) * i
        normals = np.column_stack(
            [np.cos(azimuth) * np.sin(polar), np.sin(azimuth) * np.sin(polar), np.cos(polar)]
        )
        hull = ConvexHull(normals)
        rho = float(np.min(-hull.equations[:, -1]))  # facet offsets b of n . x <= b
    else:
        raise ValueError(f"dim: must be 1, 2 or 3, got {dim}")
    normals.setflags(write=False)
    return normals, rho


def support(vectors: np.ndarray, dim: int) -> np.ndarray:
    """max_f c_f . u over the normals for vectors (..., dim): the polytope 'norm' / rho."""
    normals, _ = ball_normals(dim)
    if dim == 1:
        return np.abs(vectors[..., 0])
    return np.max(vectors @ normals.T, axis=-1)


def worst_normals(vector: np.ndarray, dim: int) -> np.ndarray:
    """The normals with the largest c_f . u: the facets a cutting-plane method adds for a
    vector u outside the polytope. Several at once (PATCH[dim]), because an LP pushed against
    one facet slides to its neighbours: with the single worst facet per round, 3-D path limits
    took more than 30 rounds."""
    normals, _ = ball_normals(dim)
    order = np.argsort(-(normals @ vector))
    return normals[order[: PATCH[dim]]]
