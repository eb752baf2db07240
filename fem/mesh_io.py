"""Reading part meshes with meshio (coordinates in metres; ``scale`` converts, e.g. 1e-3 for mm)."""

from __future__ import annotations

import os

import meshio
import numpy as np

from fem.mesh import PlateMesh, SurfaceMesh
from jaxflex.errors import InputError

MAX_EXTENT_M = 20.0  # a sheet-metal part larger than this is almost surely in millimetres


def load_part_mesh(path: str | os.PathLike, scale: float = 1.0):
    """(mesh, measured thickness or None, cell type) from a mesh file.

    Triangles -> PlateMesh (must be flat in a plane z = const); quads -> SurfaceMesh;
    hexahedra -> SurfaceMesh of the mid-surface plus the measured thickness.
    """
    if not os.path.isfile(path):
        raise InputError(f"mesh: file {str(path)!r} does not exist")
    try:
        data = meshio.read(path)
    # meshio raises many types (ReadError, KeyError, ValueError...) and, when no reader
    # accepts the file, calls sys.exit(1)
    except (Exception, SystemExit) as exc:
        raise InputError(
            f"mesh: cannot read {str(path)!r} ({type(exc).__name__}: {exc}); give a mesh file "
            "meshio understands (.msh, .vtu, .vtk, .xdmf, .inp, .med, ...)"
        ) from exc
    points = np.asarray(data.points, dtype=float) * scale
    if points.ndim != 2 or points.shape[0] == 0 or not np.isfinite(points).all():
        raise InputError(f"mesh: {str(path)!r} has no valid points")
    if points.shape[1] == 2:
        points = np.column_stack([points, np.zeros(len(points))])
    extent = float(np.ptp(points, axis=0).max())
    if extent > MAX_EXTENT_M:
        raise InputError(
            f"mesh: {str(path)!r} spans {extent:g} m; coordinates must be in metres "
            "(pass scale=1e-3 / --scale 1e-3 for a mesh in millimetres)"
        )
    blocks = {block.type: np.asarray(block.data) for block in data.cells}
    if "hexahedron" in blocks:
        return (*_mid_surface_of_hexes(points, blocks["hexahedron"]), "hexahedron")
    if "quad" in blocks:
        nodes, quads = _compact(points, blocks["quad"])
        return surface_from_quads(nodes, quads, path), None, "quad"
    if "triangle" in blocks:
        nodes, tris = _compact(points, blocks["triangle"])
        z = nodes[:, 2]
        if np.ptp(z) > 1e-6 * max(extent, 1e-12):
            raise InputError(
                f"mesh: the triangle mesh {str(path)!r} is not flat in a plane z = const "
                f"(z spans {np.ptp(z):.3g} m); flat parts are plates in the xy plane, curved "
                "parts need a quad (surface) or hexahedral mesh"
            )
        xy = nodes[:, :2]
        a, b, c = tris.T
        cross = (xy[b, 0] - xy[a, 0]) * (xy[c, 1] - xy[a, 1]) - (xy[b, 1] - xy[a, 1]) * (
            xy[c, 0] - xy[a, 0]
        )
        if (np.abs(cross) <= 1e-14 * extent**2).any():
            raise InputError(f"mesh: {str(path)!r} has degenerate (zero-area) triangles")
        tris = np.where((cross < 0)[:, None], tris[:, [0, 2, 1]], tris)
        return PlateMesh(xy, tris, float(z.mean())), None, "triangle"
    raise InputError(
        f"mesh: {str(path)!r} has cells {sorted(blocks) or 'none'}; supported are triangle "
        "(flat plate), quad (mid-surface) and hexahedron (one-layer solid)"
    )


def _compact(points: np.ndarray, cells: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    used, inverse = np.unique(cells, return_inverse=True)
    return points[used], inverse.reshape(cells.shape)


def orient_quads(quads: np.ndarray) -> np.ndarray:
    """Quads re-ordered so that neighbours traverse their shared edge in opposite directions
    (one orientation per connected piece, the first quad of each piece keeps its own)."""
    quads = quads.copy()
    edge_owner: dict[tuple[int, int], list[int]] = {}
    for e, quad in enumerate(quads):
        for k in range(4):
            a, b = int(quad[k]), int(quad[(k + 1) % 4])
            edge_owner.setdefault((min(a, b), max(a, b)), []).append(e)
    done = np.zeros(len(quads), dtype=bool)
    for seed in range(len(quads)):
        if done[seed]:
            continue
        done[seed] = True
        stack = [seed]
        while stack:
            e = stack.pop()
            quad = quads[e]
            for k in range(4):
                a, b = int(quad[k]), int(quad[(k + 1) % 4])
                for other in edge_owner[(min(a, b), max(a, b))]:
                    if done[other]:
                        continue
                    o = list(quads[other])
                    i = o.index(a)
                    if o[(i + 1) % 4] == b:  # same direction: flip the neighbour
                        quads[other] = quads[other][::-1]
                    done[other] = True
                    stack.append(other)
    return quads


def surface_from_quads(nodes: np.ndarray, quads: np.ndarray, path) -> SurfaceMesh:
    """Quad mid-surface with area-weighted node normals, consistently oriented."""
    quads = orient_quads(quads)
    a, b, c, d = (nodes[quads[:, k]] for k in range(4))
    quad_normals = np.cross(c - a, d - b)
    area = np.linalg.norm(quad_normals, axis=1)
    if (area <= 1e-14 * np.ptp(nodes, axis=0).max() ** 2).any():
        raise InputError(f"mesh: {str(path)!r} has degenerate (zero-area) quads")
    normals = np.zeros_like(nodes)
    for k in range(4):
        np.add.at(normals, quads[:, k], quad_normals)
    length = np.linalg.norm(normals, axis=1)
    unit_quad = quad_normals / area[:, None]
    if (length <= 1e-12 * area.max()).any() or (
        np.einsum("ekd,ed->ek", (normals / np.maximum(length, 1e-300)[:, None])[quads], unit_quad)
        < 0.2
    ).any():
        raise InputError(
            f"mesh: the surface of {str(path)!r} folds over or is not orientable (node normals "
            "cancel); give a smooth, orientable sheet"
        )
    return SurfaceMesh(nodes, quads, normals / length[:, None])


# meshio/VTK hexahedron: 0-3 one face, 4-7 the opposite face, i and i+4 joined by an edge.
_FAMILIES = {
    # pairs of nodes joined along one edge direction, listed as a quad around the mid-plane
    "c": [(0, 4), (1, 5), (2, 6), (3, 7)],
    "a": [(0, 1), (3, 2), (7, 6), (4, 5)],
    "b": [(0, 3), (4, 7), (5, 6), (1, 2)],
}


def _mid_surface_of_hexes(points: np.ndarray, hexes: np.ndarray):
    """Mid-surface quads of a one-layer hexahedral mesh and its mean thickness (m)."""
    pairs_per_hex = np.empty((len(hexes), 4, 2), dtype=np.int64)
    thickness = np.empty(len(hexes))
    for e, cell in enumerate(hexes):
        best = None
        for family in _FAMILIES.values():
            lengths = [np.linalg.norm(points[cell[i]] - points[cell[j]]) for i, j in family]
            if best is None or np.mean(lengths) < best[0]:
                best = (np.mean(lengths), family)
        thickness[e] = best[0]
        pairs_per_hex[e] = [[cell[i], cell[j]] for i, j in best[1]]
    sorted_pairs = np.sort(pairs_per_hex.reshape(-1, 2), axis=1)
    unique_pairs, inverse = np.unique(sorted_pairs, axis=0, return_inverse=True)
    mid = 0.5 * (points[unique_pairs[:, 0]] + points[unique_pairs[:, 1]])
    quads = inverse.reshape(-1, 4)
    if np.ptp(thickness) > 0.05 * thickness.mean():
        raise InputError(
            f"mesh: hexahedral mesh thickness varies from {thickness.min():.4g} to "
            f"{thickness.max():.4g} m; a uniform one-layer sheet is required"
        )
    return surface_from_quads(mid, quads, "hexahedral mesh"), float(thickness.mean())
