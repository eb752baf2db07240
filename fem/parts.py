"""Parts: geometry (metres), material, thickness and the finite-element formulation.

Built-in parts are rectangular in their xy footprint [0, width] x [0, height] (m): a flat
plate, or a doubly curved panel z(x, y) (fender-like). User parts come from mesh files via
meshio (:func:`read_mesh`). A part is meshed when it is analysed, so the mesh can be refined
around the cups of the gripper.

Formulations (``element``):
    "morley"   Kirchhoff plate, ElementTriMorley (flat parts, default; converges from below).
    "argyris"  Kirchhoff plate, ElementTriArgyris (flat parts, accurate reference).
    "hex2"     one-layer thin solid of 27-node hexahedra, full integration (curved parts).
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import matplotlib.tri as mtri
import numpy as np

from fem import meshing
from fem.materials import Material, resolve_material
from fem.mesh import PlateMesh, SurfaceMesh
from fem.mesh_io import load_part_mesh
from jaxflex.errors import InputError
from jaxflex.validation import check_positive

PLATE_ELEMENTS = ("morley", "argyris")
ELEMENTS = (*PLATE_ELEMENTS, "hex2")
# Default element size: fine enough for <= 0.5 % on the first plate modes (see docs/fem.md).
DEFAULT_SIZE_M = {"morley": 0.015, "argyris": 0.05, "hex2": 0.025}
DEFAULT_SIZE_PER_SPAN = {"morley": 60, "argyris": 20, "hex2": 30}
# Element size inside a cup as a fraction of its radius (quadratic solids have mid-nodes).
CUP_FINE_FRACTION = {"morley": 0.25, "argyris": 0.25, "hex2": 1 / 3}


class _Rectangle:
    """Footprint [0, w] x [0, h]; optional surface z(x, y) = ``height_fn``."""

    def __init__(self, width_m: float, height_m: float, surface=None, description=None):
        self.width_m, self.height_m = width_m, height_m
        self.surface = surface  # callable (x, y) -> (z, dz/dx, dz/dy), or None for flat
        self.description = description or {}

    def contains_xy(self, xy: np.ndarray) -> np.ndarray:
        tol = 1e-9 * max(self.width_m, self.height_m)
        x, y = xy[:, 0], xy[:, 1]
        return (x >= -tol) & (x <= self.width_m + tol) & (y >= -tol) & (y <= self.height_m + tol)

    def map(self, uv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Points (n, 3) and unit normals (n, 3) of the surface above footprint points uv."""
        if self.surface is None:
            z, zx, zy = (np.zeros(len(uv)),) * 3
        else:
            z, zx, zy = self.surface(uv[:, 0], uv[:, 1])
        normals = np.column_stack([-zx, -zy, np.ones(len(uv))])
        normals /= np.linalg.norm(normals, axis=1, keepdims=True)
        return np.column_stack([uv, z]), normals

    def surface_point(self, xy: np.ndarray) -> np.ndarray:
        return self.map(np.atleast_2d(xy))[0]

    def plate_mesh(self, size_m: float, cups, fine_fraction: float) -> PlateMesh:
        x, y = meshing.cup_grid(self.width_m, self.height_m, size_m, cups, fine_fraction)
        nodes, quads = meshing.grid_quads(x, y)
        return PlateMesh(nodes, meshing.split_quads(quads, nodes))

    def surface_mesh(self, size_m: float, cups, fine_fraction: float) -> SurfaceMesh:
        x, y = meshing.cup_grid(self.width_m, self.height_m, size_m, cups, fine_fraction)
        uv, quads = meshing.grid_quads(x, y)
        points, normals = self.map(uv)
        return SurfaceMesh(points, quads, normals, params=uv, exact=self.map)

    def span_m(self) -> float:
        return min(self.width_m, self.height_m)


class _GivenMesh:
    """A part defined by a mesh: flat triangles (plate) or a quad mid-surface (thin solid)."""

    def __init__(self, mesh: PlateMesh | SurfaceMesh, description: dict):
        self.mesh = mesh
        self.description = description
        if isinstance(mesh, PlateMesh):
            xy, tris = mesh.nodes_xy, mesh.triangles
            self._z = np.full(len(xy), mesh.z0)
        else:
            xy, tris = mesh.nodes[:, :2], meshing.split_quads(mesh.quads, mesh.nodes[:, :2])
            self._z = mesh.nodes[:, 2]
        self._tri = mtri.Triangulation(xy[:, 0], xy[:, 1], tris)
        self._finder = self._tri.get_trifinder()
        self._xy, self._tris = xy, tris

    def contains_xy(self, xy: np.ndarray) -> np.ndarray:
        return self._finder(xy[:, 0], xy[:, 1]) >= 0

    def surface_point(self, xy: np.ndarray) -> np.ndarray:
        xy = np.atleast_2d(xy)
        tri = self._finder(xy[:, 0], xy[:, 1])
        out = np.column_stack([xy, np.zeros(len(xy))])
        for k, t in enumerate(tri):
            if t < 0:
                continue
            a, b, c = self._tris[t]
            mat = np.column_stack([self._xy[b] - self._xy[a], self._xy[c] - self._xy[a]])
            l1, l2 = np.linalg.solve(mat, xy[k] - self._xy[a])
            out[k, 2] = (1 - l1 - l2) * self._z[a] + l1 * self._z[b] + l2 * self._z[c]
        return out

    def plate_mesh(self, size_m, cups, fine_fraction) -> PlateMesh:
        return self.mesh

    def surface_mesh(self, size_m, cups, fine_fraction) -> SurfaceMesh:
        return self.mesh

    def span_m(self) -> float:
        extent = self._xy.max(axis=0) - self._xy.min(axis=0)
        return float(extent.min())


@dataclass(frozen=True, eq=False)
class Part:
    """A thin part: geometry (m), material, thickness (m), formulation and mesh size (m).

    Create it with :func:`rectangular_plate`, :func:`curved_panel` or :func:`read_mesh`.
    ``mesh_size_m`` None means the default for the element (see ``DEFAULT_SIZE_M``); it is
    ignored for parts read from a mesh file (their mesh is used as is). ``cup_fine_fraction``
    (element size inside a cup band as a fraction of the cup radius) None means the default
    for the element (``CUP_FINE_FRACTION``); fem.sizing scales it with the base size so that
    a refinement sequence refines the whole mesh.
    """

    name: str
    element: str
    material: Material
    thickness_m: float
    mesh_size_m: float | None
    geometry: Any
    cup_fine_fraction: float | None = None

    @property
    def kind(self) -> str:
        """ "plate" (Kirchhoff, transverse deflection only) or "solid" (3-D displacement)."""
        return "plate" if self.element in PLATE_ELEMENTS else "solid"

    @property
    def element_size_m(self) -> float:
        """Base element size used for meshing (m)."""
        if self.mesh_size_m is not None:
            return self.mesh_size_m
        span = self.geometry.span_m()
        return min(DEFAULT_SIZE_M[self.element], span / DEFAULT_SIZE_PER_SPAN[self.element])

    def contains_xy(self, xy) -> np.ndarray:
        """(N,) True where footprint points xy (N, 2) m lie on the part."""
        return self.geometry.contains_xy(np.atleast_2d(np.asarray(xy, dtype=float)))

    def surface_point(self, xy) -> np.ndarray:
        """(N, 3) mid-surface points above footprint points xy (N, 2) m."""
        return self.geometry.surface_point(np.atleast_2d(np.asarray(xy, dtype=float)))

    def mesh(self, cups=()) -> PlateMesh | SurfaceMesh:
        """The mesh used for analysis, refined around ``cups`` (built-in parts)."""
        fine = self.cup_fine_fraction or CUP_FINE_FRACTION[self.element]
        if self.kind == "plate":
            return self.geometry.plate_mesh(self.element_size_m, cups, fine)
        return self.geometry.surface_mesh(self.element_size_m, cups, fine)

    def describe(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "element": self.element,
            "thickness_m": self.thickness_m,
            "mesh_size_m": None if isinstance(self.geometry, _GivenMesh) else self.element_size_m,
            **({"cup_fine_fraction": self.cup_fine_fraction} if self.cup_fine_fraction else {}),
            **self.geometry.description,
        }


def _check_common(thickness: float, element: str, mesh_size, allowed) -> None:
    check_positive("thickness", thickness)
    if element not in allowed:
        raise InputError(f"element: must be one of {list(allowed)}, got {element!r}")
    if mesh_size is not None:
        check_positive("mesh_size", mesh_size)


def rectangular_plate(
    width: float = 1.5,
    height: float = 0.8,
    thickness: float = 1e-3,
    material: str | Material | Mapping[str, Any] = "steel",
    mesh_size: float | None = None,
    *,
    element: str = "morley",
) -> Part:
    """A flat width x height (m) plate of ``thickness`` (m) on [0, width] x [0, height].

    ``element`` "morley" (default) or "argyris" (Kirchhoff plate), or "hex2" (the same flat
    part as a one-layer thin solid, for cross-checks). ``mesh_size`` is the base element size
    in m (default: 15 mm or span/60 for Morley, 50 mm or span/20 for Argyris, 25 mm or span/30
    for hex2, whichever is smaller); the mesh is refined around the cups.
    """
    description = {"shape": "flat rectangle"}
    return _rectangular_part(
        "rectangular plate",
        (width, height),
        thickness,
        material,
        mesh_size,
        element,
        ELEMENTS,
        None,
        description,
    )


def _rectangular_part(
    name, size, thickness, material, mesh_size, element, allowed, surface, description
) -> Part:
    width, height = (check_positive(n, v) for n, v in zip(("width", "height"), size, strict=True))
    _check_common(thickness, element, mesh_size, allowed)
    geometry = _Rectangle(
        width, height, surface, description={**description, "width_m": width, "height_m": height}
    )
    return Part(
        name,
        element,
        resolve_material(material),
        float(thickness),
        None if mesh_size is None else float(mesh_size),
        geometry,
    )


def _arc(coord: np.ndarray, centre: float, radius: float | None):
    """Circular profile through (centre, 0) curving down with ``radius`` (None/inf: flat)."""
    if radius is None or math.isinf(radius):
        return np.zeros_like(coord), np.zeros_like(coord)
    d = coord - centre
    root = np.sqrt(radius**2 - d**2)
    return root - radius, -d / root


def curved_panel(
    width: float = 1.5,
    height: float = 0.8,
    thickness: float = 1e-3,
    material: str | Material | Mapping[str, Any] = "steel",
    mesh_size: float | None = None,
    *,
    radius_x: float | None = 2.5,
    radius_y: float | None = 1.2,
    element: str = "hex2",
) -> Part:
    """A doubly curved, fender-like panel over the footprint [0, width] x [0, height] (m).

    The surface is z(x, y) = c(x; radius_x) + c(y; radius_y), where c is a circular arc of the
    given radius (m) through the footprint centre, crowned upwards (z = 0 at the centre, lower
    at the edges); principal radii of curvature radius_x (along x) and radius_y (along y) at
    the crown. ``radius_x=None`` gives a circular cylindrical panel (axis along x). Modelled as
    a one-layer 27-node hexahedral thin solid of ``thickness`` m along the surface normal.
    """
    check_positive("width", width)
    check_positive("height", height)
    for name, r, half in (("radius_x", radius_x, width / 2), ("radius_y", radius_y, height / 2)):
        if r is not None and not math.isinf(r):
            check_positive(name, r)
            if r <= half * 1.05:
                raise InputError(
                    f"{name}: must exceed half the span ({half:g} m) by 5 %, got {r:g} m"
                )
    if radius_x is None and radius_y is None:
        raise InputError(
            "curved_panel: give radius_x and/or radius_y (use rectangular_plate for a flat part)"
        )
    cx, cy = width / 2, height / 2

    def surface(x, y):
        zx, dzx = _arc(x, cx, radius_x)
        zy, dzy = _arc(y, cy, radius_y)
        return zx + zy, dzx, dzy

    description = {
        "shape": "doubly curved panel" if radius_x and radius_y else "cylindrical panel",
        "radius_x_m": radius_x,
        "radius_y_m": radius_y,
    }
    return _rectangular_part(
        "curved panel",
        (width, height),
        thickness,
        material,
        mesh_size,
        element,
        ("hex2",),
        surface,
        description,
    )


def read_mesh(
    path: str | os.PathLike,
    thickness: float | None = None,
    material: str | Material | Mapping[str, Any] = "steel",
    *,
    element: str | None = None,
    scale: float = 1.0,
) -> Part:
    """A part from a mesh file (any format meshio reads), coordinates in m (times ``scale``).

    - triangles in a plane z = const: a Kirchhoff plate ("morley" default, or "argyris");
    - quadrilaterals: the mid-surface of a curved part, extruded along the node normals into
      a one-layer thin solid of ``thickness`` m ("hex2");
    - hexahedra: a one-layer thin solid; its mid-surface is extracted and re-extruded, the
      thickness is measured from the mesh (``thickness`` must be None or agree within 5 %).
    """
    scale = check_positive("scale", scale)
    mesh, measured, cell_type = load_part_mesh(path, scale)
    if isinstance(mesh, PlateMesh):
        element = element or "morley"
        allowed = PLATE_ELEMENTS
    else:
        element = element or "hex2"
        allowed = ("hex2",)
    if measured is not None:
        if thickness is not None and abs(thickness - measured) > 0.05 * measured:
            raise InputError(
                f"thickness: {thickness:g} m differs from the {measured:.4g} m measured in the "
                f"hexahedral mesh {str(path)!r}; omit thickness to use the mesh's"
            )
        thickness = measured if thickness is None else thickness
    if thickness is None:
        raise InputError(f"thickness: required for a {cell_type} mesh (sheet thickness in m)")
    _check_common(thickness, element, None, allowed)
    description = {"shape": "mesh file", "path": str(path), "cell_type": cell_type, "scale": scale}
    return part_from_mesh(
        mesh, thickness, material, element, os.path.basename(str(path)), description
    )


def part_from_mesh(
    mesh: PlateMesh | SurfaceMesh,
    thickness: float,
    material: str | Material | Mapping[str, Any],
    element: str,
    name: str,
    description: dict,
) -> Part:
    """A part whose mesh is given (used as is): a flat PlateMesh for a Kirchhoff plate
    ("morley", "argyris") or a quad SurfaceMesh for the thin solid ("hex2"); thickness in m."""
    allowed = PLATE_ELEMENTS if isinstance(mesh, PlateMesh) else ("hex2",)
    _check_common(thickness, element, None, allowed)
    return Part(
        name,
        element,
        resolve_material(material),
        float(thickness),
        None,
        _GivenMesh(mesh, description),
    )
