"""The animation as a ParaView series: ``part.xdmf`` over ``part.h5`` (XDMF 3 with its
data in HDF5, gzip-compressed), ``cell.vtu`` and ``path.vtu`` (meshio's VTU; optim.animate).

``part.xdmf`` is a temporal collection with one grid per frame (its ``Time`` the frame's
time, written exactly: ``repr`` of the float). Every frame has the part's surface
(optim.animate_surface: both skins of the FE mesh) with its points at their **rigid pose**
(the part undeformed, moved along the path and turned: the frame's own ``Geometry``) and
the point data

* ``displacement`` (m, 3 components): from the rigid pose to where the engine puts the
  point (the sag under gravity and the vibration); ParaView's Warp By Vector with scale
  factor 1 shows the part as it is, larger factors exaggerate the bending;
* ``deviation_m``: the deviation |u| about the sag of the current pose (what the threshold
  limits);
* ``von_mises_pa``: von Mises at the model's stress point nearest to the surface point
  (with the stress the model carries; weight included);
* ``distance_m``: the point's distance to the nearest obstacle (its ball of half the
  thickness about the mid-surface point, as the certificate counts it; with a cell);
* ``node``: the model point (FE node) the surface point belongs to.

Values are float64: the exact values of the frames. What stays the same is written once
(the triangles ``/topology`` and ``/node``, which every frame's grid names); each frame's
arrays are datasets ``/NAME/NNNN`` of ``part.h5``. Each node's two skin points are side by
side (optim.animate_surface.skins), so gzip stores its values, the same on both skins,
about once: for the README's press scene 174 MB of VTU files became 47 MB.
meshio's ``meshio.xdmf.TimeSeriesReader`` reads the triangles, the times and the point
data (not a frame's own geometry: it gives the first frame's points for all);
ParaView's XDMF readers read all of it.

``cell.vtu``: the obstacles' surfaces (cell data ``obstacle``: the index in the cell file);
``path.vtu``: the path of the part frame's origin (a polyline, point data ``time_s``) and the
via points (vertices, ``time_s`` NaN).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from jaxflex.files import SetWriter, atomic_path
from optim.animate_frames import Frames, Scene
from optim.animate_surface import Surface, obstacle_surfaces
from optim.result_files import CELL_FILE as CELL_FILE  # their home: the light names
from optim.result_files import PATH_FILE as PATH_FILE
from optim.result_files import SERIES as SERIES
from optim.result_files import SERIES_DATA as SERIES_DATA

# gzip at level 4 (HDF5's deflate filter, which every HDF5 build has): each node's values
# stored about once (the skins side by side); shuffling the bytes first compresses the
# skins' pairs worse (measured on the press scene: 72 MB against 47 MB)
COMPRESSION = {"compression": "gzip", "compression_opts": 4}


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


def frame_fields(
    frames: Frames, surface: Surface, nearest: np.ndarray | None, f: int
) -> dict[str, np.ndarray]:
    """The point data of frame ``f`` (module docstring) at the surface's vertices, float64;
    ``nearest`` (V,): each vertex's stress point (stress_nearest)."""
    data = {
        "displacement": frames.displacement[f, surface.node],
        "deviation_m": frames.deviation_m[f, surface.node],
    }
    if nearest is not None:
        data["von_mises_pa"] = frames.von_mises_pa[f, nearest]
    if frames.distance_m is not None:
        data["distance_m"] = frames.distance_m[f, surface.node]
    return {name: np.asarray(value, dtype=np.float64) for name, value in data.items()}


def write_series(
    files: SetWriter, scene: Scene, frames: Frames, surface: Surface, normals: np.ndarray
) -> list[str]:
    """Add ``part.h5`` and ``part.xdmf`` to ``files`` (module docstring); the names."""
    offsets = skin_offsets(surface, normals, scene.half_thickness_m)
    nearest = stress_nearest(scene, surface, offsets)
    grids: list[str] = []

    def write_data(path: Path) -> None:
        import h5py  # only when writing

        with atomic_path(path, suffix=".h5") as tmp, h5py.File(tmp, "w") as h5:
            topology = _cells(surface)[0][1]
            h5.create_dataset("topology", data=topology, **COMPRESSION)
            h5.create_dataset("node", data=surface.node.astype(np.int32), **COMPRESSION)
            for f, t in enumerate(frames.t_s.tolist()):
                data = {"geometry": vertex_positions(frames, surface, offsets, f)}
                data.update(frame_fields(frames, surface, nearest, f))
                for name, value in data.items():
                    h5.create_dataset(f"{name}/{f:04d}", data=value, **COMPRESSION)
                grids.append(_grid(f, t, topology.shape, data))

    files.add(SERIES_DATA, write_data)
    files.add_text(SERIES, _xdmf(grids))
    return [SERIES_DATA, SERIES]


def _item(shape: tuple[int, ...], path: str, number: str = "Float", precision: int = 8) -> str:
    """An XDMF DataItem of the dataset ``path`` of part.h5."""
    dims = " ".join(map(str, shape))
    return (
        f'<DataItem Dimensions="{dims}" NumberType="{number}" Precision="{precision}" '
        f'Format="HDF">{SERIES_DATA}:{path}</DataItem>'
    )


def _grid(f: int, t_s: float, topology: tuple[int, int], arrays: dict[str, np.ndarray]) -> str:
    """Frame ``f``'s grid of part.xdmf at time ``t_s``: the shared cells (``topology``: their
    count, corners), its geometry and point data (``arrays``: name -> the array written as
    ``/name/f``) and the shared ``node``."""
    cells, corners = topology
    cell_type = "Triangle" if corners == 3 else "Polyvertex"
    n = len(arrays["geometry"])
    rows = [
        f'  <Grid Name="frame_{f:04d}" GridType="Uniform">',
        f'    <Time Value="{t_s!r}"/>',
        f'    <Topology TopologyType="{cell_type}" NumberOfElements="{cells}" '
        f'NodesPerElement="{corners}">{_item(topology, "/topology", "Int", 4)}</Topology>',
        f'    <Geometry GeometryType="XYZ">{_item((n, 3), f"/geometry/{f:04d}")}</Geometry>',
    ]
    for name, value in arrays.items():
        if name != "geometry":
            rank = "Vector" if value.ndim == 2 else "Scalar"
            rows.append(
                f'    <Attribute Name="{name}" AttributeType="{rank}" Center="Node">'
                f"{_item(value.shape, f'/{name}/{f:04d}')}</Attribute>"
            )
    rows.append(
        '    <Attribute Name="node" AttributeType="Scalar" Center="Node">'
        f"{_item((n,), '/node', 'Int', 4)}</Attribute>"
    )
    return "\n".join([*rows, "  </Grid>"])


def _xdmf(grids: list[str]) -> str:
    """part.xdmf: the frames' grids as one temporal collection."""
    body = "\n".join(grids)
    return (
        '<?xml version="1.0"?>\n<Xdmf Version="3.0">\n<Domain>\n'
        f'<Grid Name="part" GridType="Collection" CollectionType="Temporal">\n{body}\n'
        "</Grid>\n</Domain>\n</Xdmf>\n"
    )


def _write_vtu(path: Path, mesh) -> None:
    import meshio

    with atomic_path(path, suffix=".vtu") as tmp:
        meshio.write(tmp, mesh, file_format="vtu")


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
