"""The animation as a ParaView series: ``part.pvd`` over ``part_NNNN.vtu`` (meshio's VTU,
binary, zlib), ``cell.vtu`` and ``path.vtu`` (optim.animate).

Each frame's VTU holds the part's surface (optim.animate_surface: both skins of the FE mesh)
with its points at their **rigid pose** (the part undeformed, moved along the path and
turned) and the point data

* ``displacement`` (m, 3 components): from the rigid pose to where the engine puts the
  point (the sag under gravity and the vibration); ParaView's Warp By Vector with scale
  factor 1 shows the part as it is, larger factors exaggerate the bending;
* ``deviation_m``: the deviation |u| about the sag of the current pose (what the threshold
  limits);
* ``von_mises_pa``: von Mises at the model's stress point nearest to the surface point
  (with the stress the model carries; weight included);
* ``distance_m``: the point's distance to the nearest obstacle (its ball of half the
  thickness about the mid-surface point, as the certificate counts it; with a cell);
* ``node``: the model point (FE node) the surface point belongs to;

The frame's time is in ``part.pvd`` (its ``timestep``). Values are float64: the exact values
of the frames.
``cell.vtu``: the obstacles' surfaces (cell data ``obstacle``: the index in the cell file);
``path.vtu``: the path of the part frame's origin (a polyline, point data ``time_s``) and the
via points (vertices, ``time_s`` NaN).
"""

from __future__ import annotations

from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

from jaxflex.files import SetWriter, atomic_path
from optim.animate_frames import Frames, Scene
from optim.animate_surface import Surface, obstacle_surfaces
from optim.result_files import CELL_FILE as CELL_FILE  # their home: the light names
from optim.result_files import PATH_FILE as PATH_FILE
from optim.result_files import SERIES as SERIES


def frame_name(index: int) -> str:
    return f"part_{index:04d}.vtu"


def vertex_positions(frames: Frames, surface: Surface, offsets: np.ndarray, f: int) -> np.ndarray:
    """(V, 3) the rigid pose of the surface's vertices at frame ``f``: their node's rigid
    position plus the skin's offset ``offsets`` (V, 3, at rest) turned with the part."""
    return frames.rigid[f, surface.node] + offsets @ frames.rotation[f].T


def skin_offsets(surface: Surface, normals: np.ndarray, half_m: float | None) -> np.ndarray:
    """(V, 3) each vertex's offset from its node at rest: half the thickness along the node's
    normal ``normals`` (K, 3), towards its side."""
    return surface.side[:, None] * (half_m or 0.0) * normals[surface.node]


def stress_nearest(scene: Scene, surface: Surface, offsets: np.ndarray) -> np.ndarray | None:
    """(V,) the model's stress point nearest to each vertex at rest, or None."""
    from scipy.spatial import cKDTree

    if scene.model.stress is None:
        return None
    rest = np.asarray(scene.model.points)[surface.node] + offsets
    return cKDTree(np.asarray(scene.model.stress.points_m)).query(rest)[1]


def _cells(surface: Surface):
    if len(surface.triangles):
        return [("triangle", surface.triangles.astype(np.int32))]
    return [("vertex", np.arange(surface.n_vertices, dtype=np.int32)[:, None])]


def write_series(
    files: SetWriter, scene: Scene, frames: Frames, surface: Surface, normals: np.ndarray
) -> list[str]:
    """Add the frames' VTU files and ``part.pvd`` to ``files``; the names written."""
    import meshio  # ~0.1 s: only when writing

    offsets = skin_offsets(surface, normals, scene.half_thickness_m)
    nearest = stress_nearest(scene, surface, offsets)
    cells = _cells(surface)
    names = []
    for f in range(len(frames.t_s)):
        data = {
            "displacement": frames.displacement[f, surface.node],
            "deviation_m": frames.deviation_m[f, surface.node],
            "node": surface.node.astype(np.int32),
        }
        if nearest is not None:
            data["von_mises_pa"] = frames.von_mises_pa[f, nearest]
        if frames.distance_m is not None:
            data["distance_m"] = frames.distance_m[f, surface.node]
        mesh = meshio.Mesh(
            vertex_positions(frames, surface, offsets, f),
            cells,
            point_data=data,
        )
        names.append(frame_name(f))
        files.add(names[-1], lambda p, mesh=mesh: _write_vtu(p, mesh))
    files.add_text(SERIES, _pvd(frames.t_s, names))
    return [*names, SERIES]


def _write_vtu(path: Path, mesh) -> None:
    import meshio

    with atomic_path(path, suffix=".vtu") as tmp:
        meshio.write(tmp, mesh, file_format="vtu")


def _pvd(t_s: np.ndarray, names: list[str]) -> str:
    """The ParaView collection of the frame files at their times."""
    rows = "\n".join(
        f'    <DataSet timestep="{t!r}" part="0" file={quoteattr(name)}/>'
        for t, name in zip(t_s.tolist(), names, strict=True)
    )
    return (
        '<?xml version="1.0"?>\n'
        '<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">\n'
        f"  <Collection>\n{rows}\n  </Collection>\n</VTKFile>\n"
    )


def write_cell(files: SetWriter, scene: Scene, frames: Frames) -> list[str]:
    """Add ``path.vtu`` and, with obstacles, ``cell.vtu`` to ``files``; the names."""
    import meshio

    origin = frames.origin_m
    points = np.concatenate([origin, scene.via_m])
    lines = np.column_stack([np.arange(len(origin) - 1), np.arange(1, len(origin))])
    cells = [("line", lines.astype(np.int32))]
    if len(scene.via_m):
        via = len(origin) + np.arange(len(scene.via_m), dtype=np.int32)
        cells.append(("vertex", via[:, None]))
    times = np.concatenate([frames.t_s, np.full(len(scene.via_m), np.nan)])
    path_mesh = meshio.Mesh(points, cells, point_data={"time_s": times})
    files.add(PATH_FILE, lambda p: _write_vtu(p, path_mesh))
    if not scene.obstacles:
        return [PATH_FILE]
    vertices, triangles, owner = obstacle_surfaces(scene.obstacles, scene_bounds(frames))
    cell_mesh = meshio.Mesh(
        vertices,
        [("triangle", triangles.astype(np.int32))],
        cell_data={"obstacle": [owner.astype(np.int32)]},
    )
    files.add(CELL_FILE, lambda p: _write_vtu(p, cell_mesh))
    return [PATH_FILE, CELL_FILE]


def scene_bounds(frames: Frames) -> np.ndarray:
    """(2, 3) the lower and upper corner of the box the part sweeps (its rigid pose), m."""
    return np.stack([frames.rigid.min(axis=(0, 1)), frames.rigid.max(axis=(0, 1))])
