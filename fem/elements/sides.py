"""The nodes of a side of a part's boundary (edge supports of the surface formulations).

``side`` names a side of the bounding box of the mesh vertices in the footprint: "x0" (x =
x_min), "x1", "y0", "y1", or "all" for the whole boundary. Per node, the unit tangent(s) of
the boundary there: one on a smooth boundary, two at a sharp corner (a simple support holds
the displacement along both edges that meet there).
"""

from __future__ import annotations

import numpy as np

from jaxflex.errors import InputError

SHARP_CORNER_COS = np.cos(np.radians(30.0))


def side_nodes(
    points: np.ndarray,
    edge_ends: np.ndarray,
    side: str,
    *,
    n_vertices: int | None = None,
    mid_nodes: np.ndarray | None = None,
) -> tuple[np.ndarray, list[list[np.ndarray]]]:
    """(nodes, tangents per node) on ``side``.

    points (N, 3) m; edge_ends (B, 2) the vertex indices of the boundary edges; ``mid_nodes``
    (B,) the index of each edge's mid-node (quadratic meshes) or None; ``n_vertices`` the
    number of vertices among ``points`` (default all) for the bounding box.
    """
    ends = np.asarray(edge_ends)
    mids = None if mid_nodes is None else np.asarray(mid_nodes)
    if side != "all":
        axis = 0 if side[0] == "x" else 1
        coord = points[: n_vertices or len(points), axis]
        target = coord.min() if side[1] == "0" else coord.max()
        tol = 1e-6 * np.ptp(points, axis=0).max()
        on_side = (np.abs(points[ends, axis] - target) <= tol).all(axis=1)
        ends = ends[on_side]
        mids = None if mids is None else mids[on_side]
        if ends.size == 0:
            raise InputError(f"edge support side {side!r}: no boundary edge of the part lies there")
    vec = points[ends[:, 1]] - points[ends[:, 0]]
    vec /= np.linalg.norm(vec, axis=1, keepdims=True)
    per_node: dict[int, list[np.ndarray]] = {}
    for e, (a, b) in enumerate(ends):
        members = (int(a), int(b)) if mids is None else (int(a), int(b), int(mids[e]))
        for k in members:
            per_node.setdefault(k, []).append(vec[e])
    nodes, tangents = [], []
    for k, vecs in per_node.items():
        ref = vecs[0]
        aligned = [v if v @ ref >= 0 else -v for v in vecs]
        if min(abs(v @ ref) for v in aligned) < SHARP_CORNER_COS:
            held = [ref, *(v for v in aligned if abs(v @ ref) < SHARP_CORNER_COS)][:2]
        else:
            mean = np.sum(aligned, axis=0)
            held = [mean / np.linalg.norm(mean)]
        nodes.append(k)
        tangents.append(held)
    return np.array(nodes, dtype=np.int64), tangents
