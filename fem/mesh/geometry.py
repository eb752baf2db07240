"""The shapes of parts: where a point lies on them and how they are meshed (metres).

Three kinds, each answering the same questions for fem.parts.Part:

* :class:`Rectangle`: the built-in parts, a footprint [0, w] x [0, h] with an optional
  surface z(x, y), meshed on a tensor grid refined around the cups (fem.mesh.meshing) whose
  nodes follow the cups' rims (fem.mesh.rim);
* :class:`GivenMesh`: a part read from a mesh file or a Nastran deck, its mesh used as is;
* :class:`CadSurface`: a CAD sheet body, meshed by gmsh (fem.mesh.cad) when it is analysed,
  refined around the cups.

Points on a part: (x, y) is the surface point above (or below) that footprint point, (x, y,
z) the nearest surface point (its projection along the normal). ``place`` also tells how far
a point lies off the part; ``disc_problem`` whether a contact disc fits on it.
"""

from __future__ import annotations

import os

import numpy as np

from fem.mesh import meshing
from fem.mesh.cad import meshed
from fem.mesh.mesh_io import SheetMesh
from fem.mesh.meshes import PlateMesh, ShellMesh, SurfaceMesh
from fem.mesh.rim import Rim, conforming_grid
from fem.mesh.surface_index import SurfaceIndex
from jaxflex.errors import InputError

AREA_SAMPLES = 400  # midpoint rule per side for the area of a built-in curved surface
RIM_ITERATIONS = 40  # fixed-point steps of a rim on a curved surface (to rounding)


def principal_span_m(points: np.ndarray) -> float:
    """The second largest extent (m) of points (N, 3) along their principal axes: the
    smaller side of a sheet, whatever its orientation and depth."""
    centred = points - points.mean(axis=0)
    _, _, vt = np.linalg.svd(centred, full_matrices=False)
    extents = np.sort(np.ptp(centred @ vt.T, axis=0))[::-1]
    return float(extents[1])


class Rectangle:
    """Footprint [0, w] x [0, h]; optional surface z(x, y) = ``surface`` (callable (x, y) ->
    (z, dz/dx, dz/dy)), None for a flat part."""

    given_mesh = False

    def __init__(self, width_m: float, height_m: float, surface=None, description=None):
        self.width_m, self.height_m = width_m, height_m
        self.surface = surface
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

    def _footprint_of(self, points: np.ndarray) -> np.ndarray:
        """Footprint (n, 2) of the surface points nearest to points (n, 3) (Gauss-Newton on
        the graph surface; a few steps converge for panels flatter than 45 degrees)."""
        uv = points[:, :2].copy()
        if self.surface is None:
            return uv
        for _ in range(8):
            z, zx, zy = self.surface(*np.clip(uv, 0, [self.width_m, self.height_m]).T)
            r = points - np.column_stack([uv, z])
            jac = np.stack(
                [np.column_stack([np.ones_like(zx), 0 * zx, zx]),
                 np.column_stack([0 * zy, np.ones_like(zy), zy])],
                axis=2,
            )  # fmt: skip
            normal = np.einsum("nki,nkj->nij", jac, jac)
            uv += np.linalg.solve(normal, np.einsum("nki,nk->ni", jac, r)[..., None])[..., 0]
        return uv

    def place(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Surface points (n, 3) of points (n, 2|3) and their distance off the part (m)."""
        uv = points if points.shape[1] == 2 else self._footprint_of(points)
        clipped = np.clip(uv, 0, [self.width_m, self.height_m])
        off = np.linalg.norm(uv - clipped, axis=1)
        off[self.contains_xy(uv)] = 0.0
        return self.map(clipped)[0], off

    def surface_point(self, points: np.ndarray) -> np.ndarray:
        return self.place(points)[0]

    def disc_problem(self, centre: np.ndarray, radius: float) -> str | None:
        # the rim in the footprint around the surface point's footprint
        angle = np.linspace(0, 2 * np.pi, 48, endpoint=False)
        rim = centre[None, :2] + radius * np.column_stack([np.cos(angle), np.sin(angle)])
        if not self.contains_xy(rim).all():
            return "overhangs the edge of the part"
        return None

    def bounds_m(self) -> tuple[np.ndarray, np.ndarray]:
        u = np.linspace(0, 1, 51)
        uv = np.stack(np.meshgrid(u * self.width_m, u * self.height_m), -1).reshape(-1, 2)
        points = self.map(uv)[0]
        return points.min(axis=0), points.max(axis=0)

    def area_m2(self) -> float:
        if self.surface is None:
            return self.width_m * self.height_m
        u = (np.arange(AREA_SAMPLES) + 0.5) / AREA_SAMPLES
        uv = np.stack(np.meshgrid(u * self.width_m, u * self.height_m), -1).reshape(-1, 2)
        _, zx, zy = self.surface(uv[:, 0], uv[:, 1])
        cell = self.width_m * self.height_m / AREA_SAMPLES**2
        return float(np.sqrt(1 + zx**2 + zy**2).sum() * cell)

    def _grid(self, size_m: float, cups, fine_fraction: float):
        """(footprint nodes (N, 2), quads (Q, 4), rims) of the tensor grid refined around
        ``cups`` (contact discs or cups: x, y, radius and z or None) whose nodes follow
        their rims (fem.mesh.rim)."""
        x, y = meshing.cup_grid(self.width_m, self.height_m, size_m, cups, fine_fraction)
        fine = meshing.cup_bands(cups, size_m, fine_fraction)[2]
        points = [[d.x, d.y] if getattr(d, "z", None) is None else [d.x, d.y, d.z] for d in cups]
        centres = np.array([self.place(np.array([p], dtype=float))[0][0] for p in points])
        radii = [float(d.radius) for d in cups]
        discs = [(c[:2], r, fine) for c, r in zip(centres, radii, strict=True)]

        def rim_radius(k: int, theta: np.ndarray) -> np.ndarray:
            return self._rim_radius(centres[k], radii[k], theta)

        uv, quads, followed = conforming_grid(x, y, discs, rim_radius)
        return uv, quads, tuple(Rim(centres[k], radii[k]) for k in followed)

    def _rim_radius(self, centre: np.ndarray, radius_m: float, theta: np.ndarray) -> np.ndarray:
        """(n,) footprint distance from ``centre``'s footprint, along the angles ``theta``,
        of the surface points at 3-D distance ``radius_m`` from the surface point ``centre``
        (a fixed point: the distance grows nearly in proportion along a ray)."""
        rho = np.full(len(theta), float(radius_m))
        if self.surface is None:
            return rho
        ray = np.column_stack([np.cos(theta), np.sin(theta)])
        for _ in range(RIM_ITERATIONS):
            points = self.map(centre[None, :2] + rho[:, None] * ray)[0]
            rho = rho * radius_m / np.linalg.norm(points - centre, axis=1)
        return rho

    def plate_mesh(self, size_m: float, cups, fine_fraction: float) -> PlateMesh:
        nodes, quads, rims = self._grid(size_m, cups, fine_fraction)
        return PlateMesh(nodes, meshing.split_quads(quads, nodes), rims=rims)

    def surface_mesh(self, size_m: float, cups, fine_fraction: float) -> SurfaceMesh:
        uv, quads, rims = self._grid(size_m, cups, fine_fraction)
        points, normals = self.map(uv)
        return SurfaceMesh(points, quads, normals, params=uv, exact=self.map, rims=rims)

    def shell_mesh(self, size_m: float, cups, fine_fraction: float) -> ShellMesh:
        uv, quads, rims = self._grid(size_m, cups, fine_fraction)
        return ShellMesh(self.map(uv)[0], meshing.split_quads(quads, uv), rims=rims)

    def span_m(self) -> float:
        return min(self.width_m, self.height_m)


class _MeshQueries:
    """Point location on a triangulated surface (``self.index``: a SurfaceIndex)."""

    index: SurfaceIndex

    def contains_xy(self, xy: np.ndarray) -> np.ndarray:
        return self.index.above(xy)[1]

    def place(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        if points.shape[1] == 3:
            return self.index.project(points)
        on, found = self.index.above(points)
        off = self.index.footprint_distance(points)
        tol = 1e-9 * self.index.extent_m
        return on, np.where(found, 0.0, np.maximum(off, tol * 2))

    def surface_point(self, points: np.ndarray) -> np.ndarray:
        return self.place(points)[0]

    def disc_problem(self, centre: np.ndarray, radius: float) -> str | None:
        gap, _ = self.index.edge_distance(centre, self.index.boundary_edges)
        if gap < radius * (1 - 1e-9):
            return f"overhangs the edge of the part by {1e3 * (radius - gap):.3g} mm"
        crease, _ = self.index.edge_distance(centre, self.index.fold_edges)
        if crease < radius * (1 - 1e-9):
            return (
                f"reaches over a fold of the part {1e3 * crease:.3g} mm from its centre (a cup "
                "cannot seal across it)"
            )
        return None

    def bounds_m(self) -> tuple[np.ndarray, np.ndarray]:
        return self.index.nodes.min(axis=0), self.index.nodes.max(axis=0)

    def area_m2(self) -> float:
        return float(self.index.areas.sum())

    def span_m(self) -> float:
        return principal_span_m(self.index.nodes)


class GivenMesh(_MeshQueries):
    """A part defined by a mesh (``sheet``, a fem.mesh.mesh_io.SheetMesh), used as is."""

    given_mesh = True

    def __init__(self, sheet: SheetMesh, description: dict):
        self.sheet = sheet
        self.description = description
        self.index = SurfaceIndex(sheet.nodes, sheet.all_triangles())

    def plate_mesh(self, size_m, cups, fine_fraction) -> PlateMesh:
        return self.sheet.plate_mesh()

    def surface_mesh(self, size_m, cups, fine_fraction) -> SurfaceMesh:
        return self.sheet.surface_mesh(self.description.get("path", "the mesh"))

    def shell_mesh(self, size_m, cups, fine_fraction) -> ShellMesh:
        return self.sheet.shell_mesh()


class CadSurface(_MeshQueries):
    """A CAD sheet body (fem.mesh.cad), meshed at the part's element size when analysed, refined
    around the cups; ``base`` (a SheetMesh at that size without refinement) answers where
    points lie."""

    given_mesh = False

    def __init__(self, path: str | os.PathLike, scale: float, base: SheetMesh, description):
        self.path, self.scale, self.base = str(path), scale, base
        self.description = description
        self.index = SurfaceIndex(base.nodes, base.all_triangles())

    def _sheet(self, size_m: float, cups, fine_fraction: float, quads: bool) -> SheetMesh:
        discs = []
        for cup in cups:
            point = [cup.x, cup.y] if cup.z is None else [cup.x, cup.y, cup.z]
            centre = self.surface_point(np.array([point], dtype=float))[0]
            discs.append((centre, cup.radius, min(size_m, fine_fraction * cup.radius)))
        return meshed(self.path, size_m, scale=self.scale, discs=discs, quads=quads)

    def plate_mesh(self, size_m, cups, fine_fraction) -> PlateMesh:
        return self._sheet(size_m, cups, fine_fraction, False).plate_mesh()

    def surface_mesh(self, size_m, cups, fine_fraction) -> SurfaceMesh:
        return self._sheet(size_m, cups, fine_fraction, True).surface_mesh(self.path)

    def shell_mesh(self, size_m, cups, fine_fraction) -> ShellMesh:
        return self._sheet(size_m, cups, fine_fraction, False).shell_mesh()


def check_sheet_element(sheet: SheetMesh, element: str, source: str) -> None:
    """Refuse a formulation the mesh cannot carry (a plate needs a flat part in a plane
    z = const; the thin solid quadrilaterals)."""
    if element in ("morley", "argyris") and not sheet.is_flat:
        spread = float(np.ptp(sheet.nodes[:, 2]))
        raise InputError(
            f"element: {element!r} is a flat plate in a plane z = const; {source} spans "
            f"{spread:.3g} m in z (curved, folded or tilted): use element='shell' (the default "
            "for such parts)"
        )
    if element == "hex2":
        sheet.surface_mesh(source)
