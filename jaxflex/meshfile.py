"""Mesh files read by meshio in a child process (jaxflex.isolated), so that a damaged file
cannot take the reading process down: the parts of fem.mesh_io and the obstacles of
jaxflex.cell read their files here."""

from __future__ import annotations

import os

import meshio
import numpy as np

from jaxflex.errors import InputError
from jaxflex.isolated import isolated


@isolated("mesh", "meshio")
def read_cells(path: str | os.PathLike) -> tuple[np.ndarray, list[tuple[str, np.ndarray]]]:
    """(points (N, d) as read, [(meshio cell type, connectivity (C, k) int64)]) of a mesh
    file, read by meshio in a child process (jaxflex.isolated: a damaged binary file cannot
    take this process down); InputError naming the file when meshio cannot read it."""
    try:
        data = meshio.read(path)
    # meshio raises many types (ReadError, KeyError, ValueError...) and, when no reader
    # accepts the file, calls sys.exit(1)
    except (Exception, SystemExit) as exc:
        raise InputError(
            f"mesh: cannot read {str(path)!r} ({type(exc).__name__}: {exc}); give a mesh file "
            "meshio reads (gmsh .msh, .vtu/.vtk, .stl, .obj, Abaqus .inp, ...)"
        ) from None
    blocks = [(block.type, np.asarray(block.data)) for block in data.cells]
    return np.asarray(data.points), blocks
