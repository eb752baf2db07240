"""Where points lie on a triangulated surface in space (mesh-defined parts).

Cups and monitored points are given in the part's coordinates, m: (x, y) is the surface
point above or below it (the top-most where several layers overlap; facets seen edge-on,
such as a vertical flange, have no footprint), (x, y, z) the nearest surface point (its
projection along the surface normal). Points off the part are measured: how far outside the
footprint, or how far beyond the boundary along the surface. Discs are checked against the
boundary and against folds (edges where the facets turn by more than ``FOLD_ANGLE_DEG``).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

FOLD_ANGLE_DEG = 30.0  # a suction cup cannot seal across a sharper crease


def _closest_on_segments(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Closest points (..., 3) to p on the segments a-b (broadcast)."""
    d = b - a
    t = np.einsum("...k,...k->...", p - a, d) / np.maximum(
        np.einsum("...k,...k->...", d, d), 1e-300
    )
    return a + np.clip(t, 0.0, 1.0)[..., None] * d


def closest_on_triangles(p: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """Closest points (K, 3) on triangles tri (K, 3, 3) to points p (K, 3)."""
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    n = np.cross(b - a, c - a)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    q = p - np.einsum("kd,kd->k", p - a, n)[:, None] * n
    # barycentric coordinates of the projection
    v0, v1, v2 = b - a, c - a, q - a
    d00, d01, d11 = (np.einsum("kd,kd->k", x, y) for x, y in ((v0, v0), (v0, v1), (v1, v1)))
    d20, d21 = np.einsum("kd,kd->k", v2, v0), np.einsum("kd,kd->k", v2, v1)
    den = d00 * d11 - d01**2
    s = (d11 * d20 - d01 * d21) / den
    t = (d00 * d21 - d01 * d20) / den
    inside = (s >= 0) & (t >= 0) & (s + t <= 1)
    on_edges = np.stack(
        [_closest_on_segments(p, x, y) for x, y in ((a, b), (b, c), (c, a))], axis=1
    )  # (K, 3, 3)
    best = np.argmin(np.linalg.norm(on_edges - p[:, None], axis=2), axis=1)
    return np.where(inside[:, None], q, on_edges[np.arange(len(p)), best])


class SurfaceIndex:
    """Queries on a surface of ``triangles`` (E, 3) over ``nodes`` (N, 3), m."""

    def __init__(self, nodes: np.ndarray, triangles: np.ndarray) -> None:
        self.nodes = np.asarray(nodes, dtype=float)
        self.triangles = np.asarray(triangles, dtype=np.int64)
        corners = self.nodes[self.triangles]  # (E, 3, 3)
        self._corners = corners
        cross = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
        self.areas = 0.5 * np.linalg.norm(cross, axis=1)
        self.normals = cross / np.maximum(2 * self.areas, 1e-300)[:, None]
        centroids = corners.mean(axis=1)
        self._tree = cKDTree(centroids)
        self._reach = float(np.linalg.norm(corners - centroids[:, None], axis=2).max())
        self.extent_m = float(np.ptp(self.nodes, axis=0).max())
        # the footprint: facets not seen edge-on from above
        flat_enough = np.abs(self.normals[:, 2]) > 1e-6
        self._up = np.flatnonzero(flat_enough)
        if self._up.size:
            c2 = centroids[self._up, :2]
            self._tree2 = cKDTree(c2)
            self._reach2 = float(
                np.linalg.norm(corners[self._up, :, :2] - c2[:, None], axis=2).max()
            )
        pairs = np.sort(
            np.stack([self.triangles, np.roll(self.triangles, -1, axis=1)], 2).reshape(-1, 2),
            axis=1,
        )
        edges, inverse, count = np.unique(pairs, axis=0, return_inverse=True, return_counts=True)
        owner = np.repeat(np.arange(len(self.triangles)), 3)
        self.boundary_edges = edges[count == 1]
        self.nonmanifold_edges = edges[count > 2]
        interior = np.flatnonzero(count == 2)
        order = np.argsort(inverse, kind="stable")
        first = np.searchsorted(inverse[order], interior)
        t1, t2 = owner[order[first]], owner[order[first + 1]]
        cos = np.abs(np.einsum("kd,kd->k", self.normals[t1], self.normals[t2]))
        folded = cos < np.cos(np.radians(FOLD_ANGLE_DEG))
        self.fold_edges = np.concatenate([edges[interior[folded]], self.nonmanifold_edges])

    def above(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Surface points (K, 3) above or below footprint points xy (K, 2), the top-most
        where several facets overlap, and a mask (K,) of the points that have one."""
        xy = np.atleast_2d(np.asarray(xy, dtype=float))
        out = np.full((len(xy), 3), np.nan)
        found = np.zeros(len(xy), dtype=bool)
        if not self._up.size:
            return out, found
        tol = 1e-9
        for k, candidates in enumerate(self._tree2.query_ball_point(xy, self._reach2 * (1 + tol))):
            if not candidates:
                continue
            tris = self._corners[self._up[np.asarray(candidates)]]  # (C, 3, 3)
            a, b, c = tris[:, 0, :2], tris[:, 1, :2], tris[:, 2, :2]
            v0, v1, v2 = b - a, c - a, xy[k] - a
            den = v0[:, 0] * v1[:, 1] - v0[:, 1] * v1[:, 0]
            s = (v2[:, 0] * v1[:, 1] - v2[:, 1] * v1[:, 0]) / den
            t = (v0[:, 0] * v2[:, 1] - v0[:, 1] * v2[:, 0]) / den
            hit = (s >= -tol) & (t >= -tol) & (s + t <= 1 + tol)
            if not hit.any():
                continue
            z = (1 - s - t) * tris[:, 0, 2] + s * tris[:, 1, 2] + t * tris[:, 2, 2]
            out[k] = [*xy[k], z[hit].max()]
            found[k] = True
        return out, found

    def footprint_distance(self, xy: np.ndarray) -> np.ndarray:
        """(K,) distance (m) of footprint points from the part's footprint (0 on it)."""
        xy = np.atleast_2d(np.asarray(xy, dtype=float))
        _, found = self.above(xy)
        out = np.zeros(len(xy))
        if found.all():
            return out
        if not self._up.size:
            return np.where(found, 0.0, np.inf)
        miss = np.flatnonzero(~found)
        count = min(64, self._up.size)
        _, idx = self._tree2.query(xy[miss], k=count)
        idx = np.atleast_2d(idx).reshape(len(miss), count)
        tris = self._corners[self._up[idx]][..., :2]  # (K, C, 3, 2)
        p = xy[miss][:, None, :]  # (K, 1, 2)
        dist = np.min(
            [
                np.linalg.norm(_closest_on_segments(p, tris[:, :, i], tris[:, :, j]) - p, axis=-1)
                for i, j in ((0, 1), (1, 2), (2, 0))
            ],
            axis=0,
        )
        out[miss] = dist.min(axis=1)
        return out

    def nearest(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Nearest surface points (K, 3) to points (K, 3) and their facets (K,)."""
        points = np.atleast_2d(np.asarray(points, dtype=float))
        d0, _ = self._tree.query(points)
        out = np.empty_like(points)
        facet = np.empty(len(points), dtype=np.int64)
        for k, p in enumerate(points):
            cand = np.asarray(self._tree.query_ball_point(p, d0[k] + self._reach * (1 + 1e-9)))
            q = closest_on_triangles(np.repeat(p[None], cand.size, 0), self._corners[cand])
            best = int(np.argmin(np.linalg.norm(q - p, axis=1)))
            out[k], facet[k] = q[best], cand[best]
        return out, facet

    def project(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Nearest surface points (K, 3) of points (K, 3) and how far (m) each point lies
        beyond the surface's boundary, measured along the surface (0 when the offset is
        along the normal of the facet it lands on)."""
        q, facet = self.nearest(points)
        offset = np.atleast_2d(points) - q
        along = (
            offset
            - np.einsum("kd,kd->k", offset, self.normals[facet])[:, None] * (self.normals[facet])
        )
        return q, np.linalg.norm(along, axis=1)

    def edge_distance(self, centre: np.ndarray, edges: np.ndarray) -> tuple[float, np.ndarray]:
        """Smallest distance (m) from ``centre`` (3,) to the segments ``edges`` (B, 2) and the
        nearest point on them (inf and NaN without edges)."""
        if len(edges) == 0:
            return np.inf, np.full(3, np.nan)
        a, b = self.nodes[edges[:, 0]], self.nodes[edges[:, 1]]
        q = _closest_on_segments(centre[None], a, b)
        d = np.linalg.norm(q - centre, axis=1)
        i = int(np.argmin(d))
        return float(d[i]), q[i]
