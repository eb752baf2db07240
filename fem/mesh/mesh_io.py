"""Reading part meshes (meshio; coordinates in metres, ``scale`` converts, e.g. 1e-3 for mm).

Nothing the file holds is lost: every cell block of every supported type is merged (gmsh
writes one block per surface, many tools one per type), quadratic cells are split into
linear ones through their mid-side nodes (so the nodes the mesher placed on the curved
surface are kept), nodes closer than ``WELD_RELATIVE`` x the part's size are welded into
one, and the cells are oriented consistently. What was read is reported: cells per type,
welded nodes, connected pieces, non-manifold edges, repaired orientations.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import breadth_first_order, connected_components
from scipy.spatial import cKDTree

from fem.choices import CAD_SUFFIXES as CAD_SUFFIXES  # their home: the light names
from fem.choices import FORMATS_HELP as FORMATS_HELP
from fem.mesh.meshes import PlateMesh, ShellMesh, SurfaceMesh
from fem.mesh.meshfile import read_cells
from fem.mesh.meshing import split_quads
from fem.mesh.plan import plan_of_cells
from jaxflex.errors import InputError
from jaxflex.files import check_input_file
from jaxflex.runtime import Need, require

MAX_EXTENT_M = 20.0  # a sheet-metal part larger than this is almost surely in millimetres
MIN_EXTENT_M = 1e-3  # ... and one smaller than this is in another unit (or no part at all)
WELD_RELATIVE = 1e-6  # nodes closer than this x the part's extent are one node
FLAT_RELATIVE = 1e-6  # a part whose z spread is below this x its extent is flat
# meshio cell type -> (corner count, sub-cells through the mid-side nodes as local indices;
# quad8's centre "c" is added at the serendipity centre)
TRIANGLE_SPLIT = [[0, 3, 5], [3, 1, 4], [5, 4, 2], [3, 4, 5]]
QUAD_SPLIT = [[0, 4, 8, 7], [4, 1, 5, 8], [8, 5, 2, 6], [7, 8, 6, 3]]
SHELL_CELLS = ("triangle", "triangle6", "triangle7", "quad", "quad8", "quad9")
SOLID_CELLS = ("hexahedron",)
SKIPPED_CELLS = ("vertex", "line", "line3")  # gmsh's physical points and curves
# merging, welding and orienting cells (fem.mesh.mesh_io, 2-core machine: 444 204 triangles of a
# CAD sheet in 4.4 s, and ~1 kB each at the peak)
MESH_S_PER_CELL = 1e-5
MESH_BYTES_PER_CELL = 1e3


@dataclass(frozen=True, eq=False)
class SheetMesh:
    """A sheet part's mid-surface as read: nodes (N, 3) m, linear triangles (T, 3) and quads
    (Q, 4) oriented consistently per connected piece; ``report`` what was read and repaired;
    ``thickness_m`` the thickness measured in a one-layer hexahedral mesh (else None)."""

    nodes: np.ndarray
    triangles: np.ndarray
    quads: np.ndarray
    report: dict = field(default_factory=dict)
    thickness_m: float | None = None

    @property
    def extent_m(self) -> float:
        return float(np.ptp(self.nodes, axis=0).max())

    @property
    def is_flat(self) -> bool:
        """True if the part lies in a plane z = const (within FLAT_RELATIVE of its size)."""
        return bool(np.ptp(self.nodes[:, 2]) <= FLAT_RELATIVE * max(self.extent_m, 1e-300))

    def all_triangles(self) -> np.ndarray:
        """(T + 2 Q, 3) triangles: the quads cut along their shorter diagonal."""
        if not len(self.quads):
            return self.triangles
        return np.concatenate([self.triangles, split_quads(self.quads, self.nodes)])

    @property
    def area_m2(self) -> float:
        tris = self.nodes[self.all_triangles()]
        return float(
            0.5
            * np.linalg.norm(
                np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]), axis=1
            ).sum()
        )

    def plate_mesh(self) -> PlateMesh:
        """The flat part as a Kirchhoff plate mesh (counter-clockwise triangles in xy)."""
        tris = self.all_triangles()
        xy = self.nodes[:, :2]
        a, b, c = (xy[tris[:, k]] for k in range(3))
        cross = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (
            c[:, 0] - a[:, 0]
        )
        tris = np.where((cross < 0)[:, None], tris[:, [0, 2, 1]], tris)
        return PlateMesh(xy.copy(), tris, float(self.nodes[:, 2].mean()))

    def shell_mesh(self) -> ShellMesh:
        return ShellMesh(self.nodes, self.all_triangles())

    def surface_mesh(self, source: str) -> SurfaceMesh:
        """The quad mid-surface to extrude into the thin solid (quads only)."""
        if len(self.triangles):
            raise InputError(
                f"element: the thin solid (hex2) is extruded from quadrilaterals; {source} has "
                f"{len(self.triangles)} triangles (use the shell, element='shell')"
            )
        return surface_from_quads(self.nodes, self.quads, source)


def read_sheet(path: str | os.PathLike, scale: float = 1.0) -> SheetMesh:
    """The sheet mid-surface of a mesh file (every block merged; see the module)."""
    if check_input_file("mesh", path).stat().st_size == 0:
        raise InputError(f"mesh: {str(path)!r} is empty (0 bytes)")
    if Path(path).suffix.lower() in CAD_SUFFIXES:
        raise InputError(
            f"mesh: {str(path)!r} is a CAD file, not a mesh; mesh its sheet body with gmsh: "
            "fem.read_cad(path, thickness, mesh_size=...) / jaxflex model --cad FILE "
            "--thickness T --mesh-size H"
        )
    raw, blocks = read_cells(path)
    cells = sum(len(c) for kind, c in blocks if kind in SHELL_CELLS + SOLID_CELLS)
    require(*sheet_needs(str(path), cells))
    points = check_points(raw, str(path)) * scale
    if points.shape[1] == 2:
        points = np.column_stack([points, np.zeros(len(points))])
    return sheet_from_cells(points, blocks, str(path))


def sheet_needs(source: str, cells: int) -> list[Need]:
    """What making a part of a mesh of ``cells`` cells takes at least: merging, welding and
    orienting them (MESH_S_PER_CELL, MESH_BYTES_PER_CELL), and the cheapest analysis of
    that many cells (a Morley plate, one mode: fem.mesh.plan)."""
    sheet = Need(
        f"merging, welding and orienting the {cells:,} cells of {source!r}",
        MESH_BYTES_PER_CELL * cells,
        MESH_S_PER_CELL * cells,
        "give a coarser mesh",
    )
    return [sheet, plan_of_cells("morley", cells, 1, None).need(f"analysing {source!r}")]


def check_points(points: np.ndarray, source: str) -> np.ndarray:
    """Node coordinates (N, 2 or 3) as float64, checked: at least one node, finite (the
    first bad one named)."""
    try:
        points = np.asarray(points, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(f"mesh: {source!r}: node coordinates are not numbers ({exc})") from None
    if points.size == 0:
        raise InputError(f"mesh: {source!r} holds no nodes")
    if points.ndim != 2 or points.shape[1] not in (2, 3):
        raise InputError(
            f"mesh: {source!r}: node coordinates of shape {points.shape}; expected (N, 2) or (N, 3)"
        )
    bad = np.flatnonzero(~np.isfinite(points).all(axis=1))
    if bad.size:
        raise InputError(
            f"mesh: {source!r}: node {int(bad[0])} of {len(points)} has coordinates "
            f"{points[bad[0]].tolist()} ({bad.size} such node(s)); every coordinate must be "
            "finite"
        )
    return points


def check_connectivity(blocks, n_nodes: int, source: str) -> list[tuple[str, np.ndarray]]:
    """The cell blocks [(meshio type, (C, k))] as int64 arrays, checked before any use: whole
    numbers, every index a node of the mesh (0 ... n_nodes - 1; a negative index would wrap
    around in numpy), the first bad cell named."""
    checked = []
    for kind, cells in blocks:
        cells = np.asarray(cells)
        if cells.size and not np.issubdtype(cells.dtype, np.integer):
            raise InputError(
                f"mesh: {source!r}: the {kind} cells hold {cells.dtype} node numbers, not integers"
            )
        cells = cells.astype(np.int64, copy=False)
        cells = cells.reshape(len(cells), -1) if cells.size else cells.reshape(0, 0)
        bad = np.flatnonzero(((cells < 0) | (cells >= n_nodes)).any(axis=1))
        if bad.size:
            row = cells[bad[0]]
            index = int(row[(row < 0) | (row >= n_nodes)][0])
            raise InputError(
                f"mesh: {source!r}: {kind} cell {int(bad[0])} refers to node {index}, but the "
                f"mesh has {n_nodes} nodes (0 ... {n_nodes - 1}); {bad.size} cell(s) refer to "
                "nodes it lacks"
            )
        checked.append((kind, cells))
    return checked


def check_extent(
    extent_m: float, source: str, field: str = "mesh", max_extent_m: float = MAX_EXTENT_M
) -> None:
    """Refuse a part whose largest extent (m) is no sheet-metal part's: above ``max_extent_m``
    (coordinates in millimetres read as metres; a file whose unit was stated passes inf) or
    below MIN_EXTENT_M."""
    if extent_m > max_extent_m:
        raise InputError(
            f"{field}: {source!r} spans {extent_m:g} m; coordinates must be in metres (pass "
            "scale=1e-3 / --scale 1e-3 for a mesh in millimetres)"
        )
    if not extent_m >= MIN_EXTENT_M:
        raise InputError(
            f"{field}: {source!r} spans {extent_m:g} m; a sheet part spans at least "
            f"{MIN_EXTENT_M * 1e3:g} mm: check the file's unit (scale, --scale)"
        )


def sheet_from_cells(
    points: np.ndarray, blocks, source: str, *, weld: bool = True, max_extent_m=MAX_EXTENT_M
) -> SheetMesh:
    """A SheetMesh from points (N, 3) m and cell blocks [(meshio type, (C, k))]: merged,
    split into linear cells, welded (unless ``weld`` is False: nodes that are distinct by
    identity, as Nastran grids, stay distinct), oriented (see the module); a part larger
    than ``max_extent_m`` is refused (a file whose unit was stated passes inf)."""
    blocks = check_connectivity(blocks, len(points), source)
    extent = float(np.ptp(points, axis=0).max()) if len(points) else 0.0
    counts: dict[str, int] = {}
    skipped: dict[str, int] = {}
    for kind, cells in blocks:
        target = counts if kind in SHELL_CELLS + SOLID_CELLS else skipped
        target[kind] = target.get(kind, 0) + len(cells)
    unsupported = {k: v for k, v in skipped.items() if k not in SKIPPED_CELLS}
    counts = {k: v for k, v in counts.items() if v}
    if not counts and not any(skipped.values()):
        raise InputError(f"mesh: {source!r} holds no cells (nodes only, or empty cell blocks)")
    if not counts or unsupported:
        raise InputError(
            f"mesh: {source!r} has cells {sorted(unsupported or skipped) or 'none'}; supported "
            "are triangles and quadrilaterals (tri3, tri6, tri7, quad4, quad8, quad9: a "
            "mid-surface) or one layer of hexahedra (a volume mesh of a thicker part: export "
            "its mid-surface)"
        )
    check_extent(extent, source, max_extent_m=max_extent_m)
    if "hexahedron" in counts:
        if len(counts) > 1:
            raise InputError(
                f"mesh: {source!r} mixes hexahedra with surface cells {sorted(counts)}; give "
                "either a mid-surface or one layer of hexahedra"
            )
        hexes = np.concatenate([c for k, c in blocks if k == "hexahedron"])
        nodes, quads, thickness = _mid_surface_of_hexes(points, hexes)
        report = {"source": source, "cells": counts, "skipped_cells": skipped}
        sheet = _assemble(nodes, np.empty((0, 3), dtype=np.int64), quads, report, source, weld)
        return SheetMesh(sheet.nodes, sheet.triangles, sheet.quads, sheet.report, thickness)
    points = points.copy()
    tris, quads = [], []
    for kind, cells in blocks:
        if kind == "triangle":
            tris.append(cells)
        elif kind in ("triangle6", "triangle7"):
            tris.append(cells[:, TRIANGLE_SPLIT].reshape(-1, 3))
        elif kind == "quad":
            quads.append(cells)
        elif kind in ("quad8", "quad9"):
            if kind == "quad8":  # serendipity centre: -1/4 corners + 1/2 mid-sides
                centre = -0.25 * points[cells[:, :4]].sum(axis=1) + 0.5 * points[cells[:, 4:8]].sum(
                    axis=1
                )
                ids = len(points) + np.arange(len(cells))
                points = np.concatenate([points, centre])
                cells = np.column_stack([cells, ids])
            quads.append(cells[:, QUAD_SPLIT].reshape(-1, 4))
    report = {"source": source, "cells": counts, "skipped_cells": skipped}
    return _assemble(
        points,
        np.concatenate(tris) if tris else np.empty((0, 3), dtype=np.int64),
        np.concatenate(quads) if quads else np.empty((0, 4), dtype=np.int64),
        report,
        source,
        weld,
    )


def _assemble(points, tris, quads, report: dict, source: str, weld: bool) -> SheetMesh:
    """Weld, compact, check and orient the linear cells."""
    used = np.unique(np.concatenate([tris.ravel(), quads.ravel()]))
    extent = float(np.ptp(points[used], axis=0).max())
    if weld:
        rep, welded = _weld(points, WELD_RELATIVE * extent)
    else:
        rep, welded = np.arange(len(points)), 0
    tris, quads = rep[tris], rep[quads]
    used, inverse = np.unique(np.concatenate([tris.ravel(), quads.ravel()]), return_inverse=True)
    nodes = points[used]
    tris = inverse[: tris.size].reshape(-1, 3)
    quads = inverse[tris.size :].reshape(-1, 4)
    collapsed = sum(
        int((np.sort(c, axis=1)[:, 1:] == np.sort(c, axis=1)[:, :-1]).any(axis=1).sum())
        for c in (tris, quads)
    )
    if collapsed:
        raise InputError(
            f"mesh: {source!r} has {collapsed} cell(s) with repeated nodes (after welding "
            f"nodes closer than {WELD_RELATIVE:g} x the part's size); degenerate cells"
        )
    _check_areas(nodes, tris, quads, source)
    tris, quads, orientation = orient_cells(tris, quads)
    report = {
        **report,
        "welded_nodes": int(welded),
        "n_nodes": len(nodes),
        "linear_cells": {"triangle": len(tris), "quad": len(quads)},
        **orientation,
    }
    return SheetMesh(nodes, tris, quads, report)


def _weld(points: np.ndarray, tolerance_m: float) -> tuple[np.ndarray, int]:
    """Representative (lowest) index of every point among those within ``tolerance_m`` of
    each other (transitively), and how many points were merged away."""
    pairs = cKDTree(points).query_pairs(tolerance_m, output_type="ndarray")
    if not len(pairs):
        return np.arange(len(points)), 0
    graph = sp.coo_matrix((np.ones(len(pairs)), pairs.T), shape=(len(points),) * 2)
    count, labels = connected_components(graph, directed=False)
    first = np.full(count, len(points))
    np.minimum.at(first, labels, np.arange(len(points)))
    rep = first[labels]
    return rep, int(len(points) - count)


def _check_areas(nodes, tris, quads, source) -> None:
    scale = np.ptp(nodes, axis=0).max() ** 2
    for kind, cells in (("triangles", tris), ("quads", quads)):
        if not len(cells):
            continue
        a, b, c = (nodes[cells[:, k]] for k in range(3))
        d = nodes[cells[:, -1]]
        area = np.linalg.norm(np.cross(c - a, d - b if cells.shape[1] == 4 else b - a), axis=1)
        if (area <= 1e-14 * scale).any():
            raise InputError(f"mesh: {source!r} has degenerate (zero-area) {kind}")


def orient_cells(tris: np.ndarray, quads: np.ndarray):
    """Triangles and quads re-ordered so that neighbours across every edge shared by two
    cells traverse it in opposite directions (per connected piece the first cell keeps its
    own); and a report: connected pieces, non-manifold edges (three or more cells), flipped
    cells, orientable (False for a Moebius-like surface: some pair stays inconsistent)."""
    cells = [*tris.tolist(), *quads.tolist()]
    n_cells = len(cells)
    owner, a, b = [], [], []
    for c, cell in enumerate(cells):
        k = len(cell)
        for i in range(k):
            owner.append(c)
            a.append(cell[i])
            b.append(cell[(i + 1) % k])
    owner, a, b = np.array(owner), np.array(a), np.array(b)
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    forward = a < b
    key = lo.astype(np.int64) * (max(hi.max(initial=0), lo.max(initial=0)) + 1) + hi
    order = np.argsort(key, kind="stable")
    key_s = key[order]
    starts = np.flatnonzero(np.r_[True, key_s[1:] != key_s[:-1]])
    sizes = np.diff(np.r_[starts, key_s.size])
    nonmanifold = int((sizes > 2).sum())
    pair = starts[sizes == 2]
    c1, c2 = owner[order[pair]], owner[order[pair + 1]]
    same = forward[order[pair]] == forward[order[pair + 1]]
    graph = sp.coo_matrix(
        (np.ones(2 * c1.size), (np.r_[c1, c2], np.r_[c2, c1])), shape=(n_cells, n_cells)
    ).tocsr()
    link = np.r_[c1 * n_cells + c2, c2 * n_cells + c1]
    link_order = np.argsort(link)
    link, link_same = link[link_order], np.r_[same, same][link_order]
    n_components, labels = connected_components(graph, directed=False)
    flip = np.zeros(n_cells, dtype=bool)
    for piece in range(n_components):
        seed = int(np.flatnonzero(labels == piece)[0])
        visit, pred = breadth_first_order(graph, seed, directed=False)
        tree = visit[1:]
        # whether each cell runs along its shared edge with its parent the same way
        relation = link_same[np.searchsorted(link, pred[tree] * n_cells + tree)]
        position = {int(c): i for i, c in enumerate(tree)}
        flips = [False] * len(tree)
        for i, c in enumerate(tree.tolist()):
            parent = int(pred[c])
            flips[i] = relation[i] ^ (flips[position[parent]] if parent != seed else False)
        flip[tree] = flips
    consistent = (same ^ flip[c1] ^ flip[c2]) == 0
    n_tri = len(tris)
    tris = np.where(flip[:n_tri, None], tris[:, ::-1], tris)
    quads = np.where(flip[n_tri:, None], quads[:, ::-1], quads)
    pieces = _pieces(tris, quads)
    report = {
        "pieces": pieces,
        "nonmanifold_edges": nonmanifold,
        "flipped_cells": int(flip.sum()),
        "orientable": bool(consistent.all()),
    }
    return tris, quads, report


def _pieces(tris: np.ndarray, quads: np.ndarray) -> int:
    """Connected pieces of the surface (cells sharing a node are connected)."""
    edges = [
        np.stack([c[:, k], c[:, (k + 1) % c.shape[1]]])
        for c in (tris, quads)
        for k in range(c.shape[1])
    ]
    edges = np.concatenate(edges, axis=1) if edges else np.empty((2, 0), dtype=np.int64)
    used = np.unique(edges)
    n = int(used.max()) + 1 if used.size else 0
    graph = sp.coo_matrix((np.ones(edges.shape[1]), edges), shape=(n, n))
    _, labels = connected_components(graph, directed=False)
    return int(np.unique(labels[used]).size)


def surface_from_quads(nodes: np.ndarray, quads: np.ndarray, path) -> SurfaceMesh:
    """Quad mid-surface with area-weighted node normals, consistently oriented."""
    _, quads, _ = orient_cells(np.empty((0, 3), dtype=np.int64), quads)
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
            "cancel); give a smooth, orientable sheet, or use the shell (element='shell')"
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
    """Mid-surface nodes and quads of a one-layer hexahedral mesh and its mean thickness (m)."""
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
    return mid, quads, float(thickness.mean())
