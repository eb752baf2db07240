"""The surface an animation draws: the part's own mesh, its two skins, and a lighter copy.

A model from the FE carries the mesh's triangles over its points (jaxflex ModalModel.surface,
the model file's ``surface`` group). A model without them (modal results of other solvers,
R1, a voxel-reduced point set) is drawn from its points alone: triangulated in its plane
where the points lie in one (Delaunay, the triangles longer than the mesh's spacing dropped:
holes and notches stay open), else as a point cloud; :attr:`Surface.kind` and
:attr:`Surface.note` say which.

A sheet is drawn as its two skins, each half the thickness off the mid-surface along the
node's normal at rest (the area-weighted normal of its triangles), closed along the
boundary by the sheet's edge: the surface jaxflex._collision certifies the distance of (its
ball of half the thickness about each mid-surface point; exact where a skin faces the
obstacle). :func:`reduced` thins a surface for the browser page by clustering its points on
a grid, keeping one real point per cluster (so every value drawn is the engine's at a point).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# A point set counts as lying in one plane when its thinnest extent (the smallest singular
# value of the centred points) is below this share of its largest: a sheet-metal part
# (curved panels of a few per cent rise included) is triangulated in its plane.
FLAT_SHARE = 0.05
# Delaunay triangles with an edge longer than this many times the points' median nearest
# neighbour distance span a hole or a notch of the outline, not the part: dropped.
LONG_EDGE = 2.5


@dataclass(frozen=True)
class Surface:
    """Points drawn and their triangles. ``node`` (V,) the model point each vertex is at,
    ``side`` (V,) -1, 0, +1: the lower skin, the mid-surface, the upper skin (half the
    thickness along the node's normal), ``triangles`` (T, 3) vertex indices (empty for a
    point cloud), ``kind`` "mesh" (the FE's), "triangulated" (from the points) or "points",
    ``note`` the sentence that says so."""

    node: np.ndarray
    side: np.ndarray
    triangles: np.ndarray
    kind: str
    note: str

    @property
    def n_vertices(self) -> int:
        return len(self.node)


def mid_surface(model) -> Surface:
    """The mid-surface of ``model``'s points (module docstring)."""
    points = np.asarray(model.points)
    nodes = np.arange(len(points))
    zeros = np.zeros(len(points), dtype=np.int64)
    if model.surface is not None:
        note = f"the FE mesh: {len(points)} nodes, {len(model.surface)} triangles"
        return Surface(nodes, zeros, np.asarray(model.surface), "mesh", note)
    triangles = plane_triangulation(points)
    if triangles is None:
        note = (
            f"{len(points)} points, drawn as a point cloud: the model carries no mesh (modal "
            "results or a point selection) and its points do not lie in one plane"
        )
        return Surface(nodes, zeros, np.zeros((0, 3), dtype=np.int64), "points", note)
    note = (
        f"{len(points)} points triangulated in their plane ({len(triangles)} triangles): the "
        "model carries no mesh (modal results or a point selection)"
    )
    return Surface(nodes, zeros, triangles, "triangulated", note)


def plane_triangulation(points: np.ndarray) -> np.ndarray | None:
    """(T, 3) Delaunay triangles of ``points`` (K, 3) in their best-fit plane, those with an
    edge longer than LONG_EDGE times the typical spacing dropped; None where the points do
    not lie in one plane (FLAT_SHARE) or are too few."""
    from scipy.spatial import Delaunay, QhullError, cKDTree

    if len(points) < 3:
        return None
    centred = points - points.mean(axis=0)
    _, sizes, axes = np.linalg.svd(centred, full_matrices=False)
    if sizes[1] <= 0 or sizes[2] > FLAT_SHARE * sizes[0]:
        return None
    flat = centred @ axes[:2].T
    try:
        triangles = Delaunay(flat).simplices.astype(np.int64)
    except QhullError:
        return None
    spacing = np.median(cKDTree(flat).query(flat, k=2)[0][:, 1])
    corners = flat[triangles]
    edges = np.linalg.norm(corners - np.roll(corners, 1, axis=1), axis=2).max(axis=1)
    kept = triangles[edges <= LONG_EDGE * spacing]
    return kept if len(kept) else None


def node_normals(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """(K, 3) unit normals at ``points`` (K, 3): the area-weighted sum of the normals of the
    ``triangles`` (T, 3) at each (their orientation as the mesh gives it); a point of no
    triangle gets the points' best-fit plane normal."""
    corners = points[triangles]
    area_normals = 0.5 * np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    summed = np.zeros_like(points)
    for j in range(3):
        np.add.at(summed, triangles[:, j], area_normals)
    length = np.linalg.norm(summed, axis=1)
    plane = np.linalg.svd(points - points.mean(axis=0), full_matrices=False)[2][-1]
    return np.where(length[:, None] > 0, summed / np.where(length > 0, length, 1)[:, None], plane)


def boundary_edges(triangles: np.ndarray) -> np.ndarray:
    """(E, 2) the edges of ``triangles`` that only one triangle has, in its orientation."""
    edges = np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]])
    key = np.sort(edges, axis=1)
    _, inverse, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    return edges[counts[inverse.ravel()] == 1]


def skins(mid: Surface) -> Surface:
    """The two skins of the sheet whose mid-surface is ``mid`` (sides -1 and +1), closed
    along its boundary edges by the sheet's edge; a point cloud stays one (both sides).
    Each mid-surface vertex i gives the vertices 2i (lower skin) and 2i + 1 (upper skin):
    side by side, so that the values of a node, the same on both skins, compress to one in
    the series' file (optim.animate_series)."""
    k = mid.n_vertices
    node = np.repeat(mid.node, 2)
    side = np.tile([-1, 1], k)
    tri = mid.triangles
    if not len(tri):
        return Surface(node, side, tri, mid.kind, mid.note)
    lower = 2 * tri[:, ::-1]  # the lower skin faces the other way
    upper = 2 * tri + 1
    edge = boundary_edges(tri)
    a, b = 2 * edge[:, 0], 2 * edge[:, 1]
    walls = np.concatenate([np.column_stack([b, a, a + 1]), np.column_stack([b, a + 1, b + 1])])
    triangles = np.concatenate([lower, upper, walls])
    return Surface(node, side, triangles, mid.kind, mid.note + "; both skins and the edge")


def reduced(points: np.ndarray, mid: Surface, max_vertices: int) -> Surface:
    """``mid`` with at most ``max_vertices`` vertices: its points (``points`` (K, 3) of the
    model, at rest) clustered on a grid whose cell grows until few enough clusters are left,
    each cluster drawn at its real point nearest the cluster's mean, the triangles mapped to
    those points (collapsed ones dropped). ``mid`` itself where it is small enough."""
    if mid.n_vertices <= max_vertices:
        return mid
    xyz = points[mid.node]
    span = np.ptp(xyz, axis=0)
    area = max(np.prod(np.sort(span)[1:]), 1e-12)
    cell = np.sqrt(area / max_vertices)
    while True:
        key = np.floor((xyz - xyz.min(axis=0)) / cell).astype(np.int64)
        _, cluster = np.unique(key, axis=0, return_inverse=True)
        cluster = cluster.ravel()
        if cluster.max() < max_vertices:
            break
        cell *= 1.15
    n = cluster.max() + 1
    mean = np.zeros((n, 3))
    np.add.at(mean, cluster, xyz)
    mean /= np.bincount(cluster, minlength=n)[:, None]
    gap = np.linalg.norm(xyz - mean[cluster], axis=1)
    order = np.lexsort((gap, cluster))  # per cluster, the nearest first
    first = order[np.r_[True, np.diff(cluster[order]) != 0]]  # (n,) vertex of each cluster
    tri = cluster[mid.triangles] if len(mid.triangles) else mid.triangles
    if len(tri):
        distinct = (tri[:, 0] != tri[:, 1]) & (tri[:, 1] != tri[:, 2]) & (tri[:, 0] != tri[:, 2])
        tri = tri[distinct]
        _, keep = np.unique(np.sort(tri, axis=1), axis=0, return_index=True)
        tri = tri[np.sort(keep)]
    note = f"{mid.note}; drawn at {n} of its points"
    return Surface(mid.node[first], mid.side[first], tri, mid.kind, note)


# the 12 triangles of a box's surface, corners numbered by the bits (x, y, z) of their index
BOX_TRIANGLES = np.array(
    [
        [0, 2, 3], [0, 3, 1], [4, 5, 7], [4, 7, 6], [0, 1, 5], [0, 5, 4],
        [2, 6, 7], [2, 7, 3], [0, 4, 6], [0, 6, 2], [1, 3, 7], [1, 7, 5],
    ]
)  # fmt: skip


def _plane_patch(normal, offset_m: float, corners: np.ndarray, margin: float):
    """(4 vertices, 2 triangles): the rectangle of the plane {x : normal . x = offset_m}
    covering the projections of ``corners`` (8, 3) and ``margin`` (m) around them."""
    n = np.asarray(normal, dtype=np.float64)
    a = np.cross(n, [1.0, 0.0, 0.0] if abs(n[0]) < 0.9 else [0.0, 1.0, 0.0])
    a /= np.linalg.norm(a)
    b = np.cross(n, a)
    u, w = corners @ a, corners @ b
    lo_u, hi_u, lo_w, hi_w = u.min() - margin, u.max() + margin, w.min() - margin, w.max() + margin
    square = np.array([[lo_u, lo_w], [hi_u, lo_w], [hi_u, hi_w], [lo_u, hi_w]])
    return offset_m * n + square @ np.stack([a, b]), np.array([[0, 1, 2], [0, 2, 3]])


def obstacle_surfaces(obstacles, bounds_m: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(vertices (V, 3) m, triangles (T, 3), obstacle index of each triangle (T,)) drawing
    ``obstacles`` (jaxflex.geometry Box, HalfSpace, TriangleMesh): a box's six faces, a
    mesh's triangles, a half-space's boundary plane as the rectangle under the box
    ``bounds_m`` (2, 3) (the lower and upper corner of what the part sweeps) and a tenth of
    its diagonal around."""
    vertices, triangles, owner = [np.zeros((0, 3))], [np.zeros((0, 3), np.int64)], [[]]
    count = 0
    corners = np.array([[bounds_m[i, 0], bounds_m[j, 1], bounds_m[k, 2]]
                        for i in (0, 1) for j in (0, 1) for k in (0, 1)])  # fmt: skip
    margin = 0.1 * max(float(np.linalg.norm(np.ptp(bounds_m, axis=0))), 1e-3)
    for j, obstacle in enumerate(obstacles):
        kind = type(obstacle).__name__
        if kind == "Box":
            bits = (np.arange(8)[:, None] >> np.arange(3)) & 1
            local = (bits - 0.5) * obstacle.size_m
            v, t = obstacle.centre_m + local @ obstacle.rotation.T, BOX_TRIANGLES
        elif kind == "HalfSpace":
            v, t = _plane_patch(obstacle.normal, obstacle.offset_m, corners, margin)
        else:
            v, t = np.asarray(obstacle.vertices), np.asarray(obstacle.triangles)
        vertices.append(v)
        triangles.append(t + count)
        owner.append([j] * len(t))
        count += len(v)
    return np.concatenate(vertices), np.concatenate(triangles), np.concatenate(owner).astype(int)
