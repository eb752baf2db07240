"""Mesh files read by meshio in a child process (jaxflex.isolated), so that a damaged file
cannot take the reading process down: the parts of fem.mesh.mesh_io and the obstacles of
optim.cell_file read their files here."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from jaxflex.errors import InputError
from jaxflex.isolated import isolated


@isolated("mesh", "meshio")
def read_cells(path: str | os.PathLike) -> tuple[np.ndarray, list[tuple[str, np.ndarray]]]:
    """(points (N, d) as read, [(meshio cell type, connectivity (C, k) int64)]) of a mesh
    file, read by meshio in a child process (jaxflex.isolated: a damaged binary file cannot
    take this process down); InputError naming the file when meshio cannot read it."""
    import meshio  # ~0.1 s: only where a mesh is read

    try:
        data = meshio.read(path)
    # meshio raises many types (ReadError, KeyError, ValueError...) and, when no reader
    # accepts the file, calls sys.exit(1)
    except ValueError as exc:
        if "at least one array" not in str(exc):  # numpy's words for meshio's empty block
            raise InputError(f"mesh: cannot read {str(path)!r} ({exc})") from None
        raise InputError(f"mesh: {str(path)!r} holds an empty block of cells or nodes") from None
    except (Exception, SystemExit) as exc:
        raise InputError(
            f"mesh: cannot read {str(path)!r} ({type(exc).__name__}: {exc}); give a mesh file "
            "meshio reads (gmsh .msh, .vtu/.vtk, .stl, .obj, Abaqus .inp, ...)"
        ) from None
    if Path(path).suffix.lower() == ".msh":
        _check_gmsh_nodes(path)
    blocks = [(block.type, np.asarray(block.data)) for block in data.cells]
    return np.asarray(data.points), blocks


def _check_gmsh_nodes(path: str | os.PathLike) -> None:
    """InputError if gmsh itself refuses the .msh file meshio read for one of its nodes:
    meshio maps an element's reference to node tag 0 (or below) onto the last node (a
    negative index wraps), so a damaged file would be read as a different mesh; gmsh names the
    wrong node. Other complaints of gmsh (its own reading of what meshio wrote) are not this
    check's; skipped where gmsh's library cannot be loaded."""
    try:
        import gmsh
    except OSError:
        return
    gmsh.initialize(readConfigFiles=False, interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.open(str(path))
    except Exception as exc:  # gmsh raises plain Exceptions with its message
        if "node" in str(exc).lower():  # what meshio let through; other complaints are gmsh's
            raise InputError(f"mesh: {str(path)!r} is damaged: gmsh refuses it ({exc})") from None
    finally:
        gmsh.finalize()
