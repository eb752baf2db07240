"""Viewing: mode shapes and transient responses as VTU/XDMF (meshio; ParaView opens them) and
a quick matplotlib picture of the part, its supports and the first mode shapes.

Files are written atomically (temporary file beside the target, then renamed). Fields are
displacements in m (mode shapes: m per kg^0.5, mass-normalised), at the reporting nodes
(plate vertices, or the mid-surface of a thin solid with quadratic quad9 cells).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from fem.choices import VIEW_SUFFIXES as FORMATS
from fem.modal import ModalResult
from fem.system import surface_triangles
from fem.transient import TransientResult
from jaxflex.errors import InputError
from jaxflex.files import atomic_path


def _atomic_path(path: str | os.PathLike):
    """A new file with the same suffix beside ``path``, renamed onto it on success."""
    target = Path(path)
    if target.suffix.lower() not in FORMATS:
        raise InputError(f"export path {str(path)!r}: use one of the suffixes {list(FORMATS)}")
    return atomic_path(target, suffix=target.suffix)


def _write(path, points, cells, point_data, field_data=None) -> None:
    import meshio  # ~0.1 s: only when writing (as in export_transient)

    with _atomic_path(path) as tmp:
        if Path(tmp).suffix.lower() in (".xdmf", ".xmf"):
            # meshio's static XDMF writer needs h5py; one step of a time series does not
            with meshio.xdmf.TimeSeriesWriter(tmp, data_format="XML") as writer:
                writer.write_points_cells(points, cells)
                writer.write_data(0.0, point_data=point_data)
        else:
            mesh = meshio.Mesh(points, cells, point_data=point_data, field_data=field_data or {})
            meshio.write(tmp, mesh)


def export_modes(result: ModalResult, path: str | os.PathLike, n_modes: int | None = None) -> None:
    """Write the first ``n_modes`` (default all) mode shapes to ``path`` (.vtu/.vtk/.xdmf):
    point data "mode_01", ... (N, 3) in m/kg^0.5, field data "freq_hz"."""
    n = result.n_modes if n_modes is None else min(int(n_modes), result.n_modes)
    shapes = result.node_shapes()
    data = {f"mode_{i + 1:02d}": shapes[:, :, i] for i in range(n)}
    _write(
        path,
        result.system.nodes,
        [(result.system.cell_type, result.system.cells)],
        data,
        {"freq_hz": np.asarray(result.freq_hz[:n])},
    )


def export_transient(
    result: ModalResult, transient: TransientResult, path: str | os.PathLike
) -> None:
    """Write a transient response as an XDMF time series (``path`` .xdmf, XML data): field
    "displacement" (K, 3) in m per output time. On the mesh cells if it was computed at every
    node, else as a point cloud of the monitored points."""
    if Path(path).suffix.lower() not in (".xdmf", ".xmf"):
        raise InputError(f"export_transient: path {str(path)!r} must end in .xdmf")
    full = len(transient.node_indices) == len(result.system.nodes) and np.array_equal(
        transient.node_indices, np.arange(len(result.system.nodes))
    )
    if full:
        cells = [(result.system.cell_type, result.system.cells)]
    else:
        cells = [("vertex", np.arange(len(transient.points))[:, None])]
    import meshio

    with _atomic_path(path) as tmp, meshio.xdmf.TimeSeriesWriter(tmp, data_format="XML") as w:
        w.write_points_cells(transient.points, cells)
        for t, u in zip(transient.t_s, transient.displacement_m, strict=True):
            w.write_data(float(t), point_data={"displacement": u})


def _outline_supports(ax, supports) -> None:
    """The supports on a mode map: each cup's disc as a black outline, each other held
    point as a black cross (the map's colours stay readable under them)."""
    angle = np.linspace(0, 2 * np.pi, 65)
    for support in supports:
        disc = support.contact_disc
        if disc is not None:
            ax.plot(disc.x + disc.radius * np.cos(angle), disc.y + disc.radius * np.sin(angle),
                    color="k", lw=0.9)  # fmt: skip
        elif support.anchor_xy is not None:
            ax.plot(*support.anchor_xy, "k+", ms=7, mew=1.2)


def plot_part(result: ModalResult, path: str | os.PathLike, n_modes: int = 4) -> None:
    """PNG: the part's footprint with its supports, and contour plots of the normal (z)
    displacement of the first ``n_modes`` modes with the supports outlined on them."""
    import matplotlib.tri as mtri  # matplotlib: only when drawing

    from jaxflex.plots import plt, save_figure

    nodes = result.system.nodes
    tri = mtri.Triangulation(
        nodes[:, 0], nodes[:, 1], surface_triangles(result.system.cells, result.system.cell_type)
    )
    n = min(int(n_modes), result.n_modes)
    cols = min(3, n + 1)
    rows = int(np.ceil((n + 1) / cols))
    aspect = np.ptp(nodes[:, 1]) / max(np.ptp(nodes[:, 0]), 1e-12)
    fig, axes = plt.subplots(
        rows, cols, figsize=(4.2 * cols, 4.2 * rows * aspect + 0.8), squeeze=False
    )
    ax = axes.flat[0]
    ax.triplot(tri, lw=0.15, color="0.6")
    captions = [c for s in result.supports if (c := s.draw(ax)) is not None]
    title = f"{result.part.name}: {len(result.supports)} support(s)"
    if captions:
        title += " (" + ", ".join(captions) + ")"
    ax.set_title(title, fontsize=9)
    shapes = result.node_shapes()
    for i in range(n):
        ax = axes.flat[i + 1]
        w = shapes[:, 2, i]
        level = np.abs(w).max() or 1.0
        ax.tricontourf(tri, w, levels=np.linspace(-level, level, 21), cmap="RdBu_r")
        _outline_supports(ax, result.supports)
        ax.set_title(f"mode {i + 1}: {result.freq_hz[i]:.2f} Hz (u_z)", fontsize=9)
    for ax in axes.flat:
        ax.set_aspect("equal")
        ax.set_xlabel("x [m]", fontsize=8)
        ax.set_ylabel("y [m]", fontsize=8)
        ax.tick_params(labelsize=7)
    for ax in list(axes.flat)[n + 1 :]:
        ax.set_visible(False)
    fig.tight_layout()
    save_figure(fig, path)
