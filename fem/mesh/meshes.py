"""The meshes a part is analysed on: a flat triangle mesh (plate elements), a quad
mid-surface (extruded into a one-layer thin solid) and a triangulated mid-surface in space
(shell elements). Built by fem.parts, read from files by fem.mesh.mesh_io, assembled by
fem.elements.plate, fem.elements.solid and fem.elements.shell; coordinates in m."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from fem.mesh.rim import Rim


@dataclass(frozen=True, eq=False)
class PlateMesh:
    """A flat triangle mesh in the plane z = z0: nodes_xy (N, 2) m, triangles (E, 3);
    ``rims``: the cups' rims its nodes follow (fem.mesh.rim)."""

    nodes_xy: np.ndarray
    triangles: np.ndarray
    z0: float = 0.0
    rims: tuple[Rim, ...] = ()


@dataclass(frozen=True, eq=False)
class SurfaceMesh:
    """A quadrilateral mid-surface to extrude into a one-layer thin solid.

    nodes (N, 3) m, quads (E, 4) counter-clockwise seen from the normal side, normals (N, 3)
    unit. ``exact(uv) -> (points, normals)`` maps footprint coordinates ``params`` (N, 2)
    exactly onto the surface (built-in parts), so mid-side nodes lie on the true surface.
    ``rims``: the cups' rims its nodes follow (fem.mesh.rim).
    """

    nodes: np.ndarray
    quads: np.ndarray
    normals: np.ndarray
    params: np.ndarray | None = None
    exact: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]] | None = None
    rims: tuple[Rim, ...] = ()


@dataclass(frozen=True, eq=False)
class ShellMesh:
    """A triangulated mid-surface in space: nodes (N, 3) m, triangles (E, 3), oriented
    consistently within each connected piece where the surface is orientable (the shell's
    stiffness does not depend on it; reported normals do). Flat, curved or folded.
    ``rims``: the cups' rims its nodes follow (fem.mesh.rim)."""

    nodes: np.ndarray
    triangles: np.ndarray
    rims: tuple[Rim, ...] = ()
