"""Parts: geometry (metres), material, thickness and the finite-element formulation.

Built-in parts are rectangular in their xy footprint [0, width] x [0, height] (m): a flat
plate, or a doubly curved panel z(x, y) (fender-like). User parts come from mesh files via
meshio (:func:`read_mesh`) or from CAD sheet bodies via gmsh (:func:`read_cad`). Built-in
and CAD parts are meshed when they are analysed, so the mesh can be refined around the cups
of the gripper; a mesh file is used as is.

Formulations (``element``):
    "morley"   Kirchhoff plate, ElementTriMorley (flat parts, default; converges from below).
    "argyris"  Kirchhoff plate, ElementTriArgyris (flat parts, accurate reference).
    "shell"    flat-facet shell triangles, DKT + OPT (curved and folded parts from files).
    "hex2"     one-layer thin solid of 27-node hexahedra, full integration (curved parts).
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from fem.choices import ELEMENTS as ELEMENTS  # their home: the light names
from fem.choices import PLATE_ELEMENTS as PLATE_ELEMENTS
from fem.materials import Material, resolve_material
from fem.mesh.cad import cad_unit, meshed, read_cad_bounds
from fem.mesh.geometry import CadSurface, GivenMesh, Rectangle, check_sheet_element
from fem.mesh.mesh_io import SheetMesh, check_extent, read_sheet
from fem.mesh.meshes import PlateMesh, ShellMesh, SurfaceMesh
from fem.mesh.plan import cad_mesh_need, plan_of_cells, refined_cells
from fem.sanity import warn_units
from jaxflex.errors import InputError
from jaxflex.files import check_positive
from jaxflex.runtime import require

# Default element size: fine enough for <= 0.5 % on the first plate modes (see docs/fem.md).
DEFAULT_SIZE_M = {"morley": 0.015, "argyris": 0.05, "shell": 0.02, "hex2": 0.025}
DEFAULT_SIZE_PER_SPAN = {"morley": 60, "argyris": 20, "shell": 30, "hex2": 30}
# Element size inside a cup as a fraction of its radius (quadratic solids have mid-nodes; the
# shell's clamp is nodal, r/6 brings its first modes within ~1 % of the converged clamp;
# Morley at r/5 on the rim-following mesh: the built-in plate's first six modes within 0.5 %).
CUP_FINE_FRACTION = {"morley": 0.2, "argyris": 0.25, "shell": 1 / 6, "hex2": 1 / 3}


@dataclass(frozen=True, eq=False)
class Part:
    """A thin part: geometry (m), material, thickness (m), formulation and mesh size (m).

    Create it with :func:`rectangular_plate`, :func:`curved_panel`, :func:`read_mesh` or
    :func:`read_cad`. ``mesh_size_m`` None means the default for the element (see
    ``DEFAULT_SIZE_M``); it is ignored for parts read from a mesh file (their mesh is used as
    is). ``cup_fine_fraction`` (element size inside a cup band as a fraction of the cup
    radius) None means the default for the element (``CUP_FINE_FRACTION``); fem.sizing.run
    scales it with the base size so that a refinement sequence refines the whole mesh.
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
        """ "plate" (Kirchhoff, transverse deflection only), "shell" (6 DOFs per node) or
        "solid" (3-D displacement)."""
        if self.element in PLATE_ELEMENTS:
            return "plate"
        return "shell" if self.element == "shell" else "solid"

    @property
    def mesh_is_given(self) -> bool:
        """True for a part read from a mesh file (its mesh is used as is)."""
        return self.geometry.given_mesh

    @property
    def element_size_m(self) -> float:
        """Base element size used for meshing (m)."""
        if self.mesh_size_m is not None:
            return self.mesh_size_m
        span = self.geometry.span_m()
        return min(DEFAULT_SIZE_M[self.element], span / DEFAULT_SIZE_PER_SPAN[self.element])

    @property
    def span_m(self) -> float:
        """The smaller side of the part (m): its footprint's for built-in parts, the second
        principal extent for others."""
        return self.geometry.span_m()

    @property
    def area_m2(self) -> float:
        """Mid-surface area, m^2."""
        return self.geometry.area_m2()

    @property
    def mass_kg(self) -> float:
        """rho x thickness x area, kg."""
        return self.material.rho_kg_m3 * self.thickness_m * self.area_m2

    def bounds_m(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper corners (3,) of the part's bounding box, m."""
        return self.geometry.bounds_m()

    def contains_xy(self, xy) -> np.ndarray:
        """(N,) True where footprint points xy (N, 2) m lie on the part."""
        return self.geometry.contains_xy(np.atleast_2d(np.asarray(xy, dtype=float)))

    def surface_point(self, points) -> np.ndarray:
        """(N, 3) mid-surface points of points (N, 2) (above the footprint point) or (N, 3)
        (nearest surface point), m."""
        return self.geometry.surface_point(np.atleast_2d(np.asarray(points, dtype=float)))

    def place(self, points) -> tuple[np.ndarray, np.ndarray]:
        """Surface points (N, 3) of points (N, 2|3) m (see :meth:`surface_point`) and how
        far (m) each lies off the part (0 on it): outside the footprint, or beyond the
        boundary along the surface. A list may mix both kinds."""
        if isinstance(points, np.ndarray):
            rows = list(np.atleast_2d(points.astype(float)))
        else:
            rows = [np.asarray(p, dtype=float) for p in points]
        if not all(p.shape in ((2,), (3,)) for p in rows):
            raise InputError(f"points: each point is (x, y) or (x, y, z) in m, got {points!r}")
        on, off = np.empty((len(rows), 3)), np.empty(len(rows))
        for width in (2, 3):
            group = [i for i, p in enumerate(rows) if p.shape == (width,)]
            if group:
                on[group], off[group] = self.geometry.place(np.array([rows[i] for i in group]))
        return on, off

    def disc_problem(self, centre, radius_m: float) -> str | None:
        """Why a contact disc of ``radius_m`` around the surface point ``centre`` (3,) does
        not fit on the part (it overhangs an edge, reaches over a fold), or None."""
        return self.geometry.disc_problem(np.asarray(centre, dtype=float), radius_m)

    @property
    def fine_fraction(self) -> float:
        """Element size inside a cup band as a fraction of the cup radius."""
        return self.cup_fine_fraction or CUP_FINE_FRACTION[self.element]

    def mesh(self, cups=()) -> PlateMesh | SurfaceMesh | ShellMesh:
        """The mesh used for analysis, refined around ``cups`` (contact discs; built-in and
        CAD parts)."""
        fine = self.fine_fraction
        make = {
            "plate": self.geometry.plate_mesh,
            "shell": self.geometry.shell_mesh,
            "solid": self.geometry.surface_mesh,
        }[self.kind]
        return make(self.element_size_m, cups, fine)

    def describe(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "element": self.element,
            "thickness_m": self.thickness_m,
            "mesh_size_m": None if self.mesh_is_given else self.element_size_m,
            **({"cup_fine_fraction": self.cup_fine_fraction} if self.cup_fine_fraction else {}),
            **self.geometry.description,
        }

    def summary(self) -> str:
        """What the part is: source and cells read (mesh and CAD parts), area, mass,
        bounding box, thickness-to-span ratio, formulation."""
        lo, hi = self.bounds_m()
        box = ", ".join(
            f"{axis} {a:.4g} ... {b:.4g}" for axis, a, b in zip("xyz", lo, hi, strict=True)
        )
        lines = [f"{self.name}: {self.material.name}, thickness {1e3 * self.thickness_m:.4g} mm"]
        read = self.geometry.description.get("read")
        if read:
            lines.append(_describe_read(read))
        lines += [
            f"area {self.area_m2:.5g} m^2, mass {self.mass_kg:.5g} kg; bounding box {box} m",
            f"span {self.span_m:.4g} m, thickness/span 1/{self.span_m / self.thickness_m:.0f}; "
            f"element {self.element!r}",
        ]
        return "\n".join(lines)


def _describe_read(read: dict) -> str:
    cells = ", ".join(f"{n} {kind}" for kind, n in read["cells"].items())
    linear = read.get("linear_cells", {})
    text = f"read {read['source']}: {cells}"
    if linear:
        text += " -> " + ", ".join(f"{n} linear {k}" for k, n in linear.items() if n)
    notes = [f"{read['n_nodes']} nodes"] + ([read["unit"]] if read.get("unit") else [])
    if read.get("skipped_cells"):
        notes.append("skipped " + ", ".join(f"{n} {k}" for k, n in read["skipped_cells"].items()))
    if read.get("welded_nodes"):
        notes.append(f"{read['welded_nodes']} duplicate nodes welded")
    if read.get("flipped_cells"):
        notes.append(f"{read['flipped_cells']} cells re-oriented")
    if read.get("pieces", 1) > 1:
        notes.append(f"{read['pieces']} disconnected pieces (each needs its own cups)")
    if read.get("nonmanifold_edges"):
        notes.append(f"{read['nonmanifold_edges']} non-manifold edges (three or more cells)")
    if read.get("orientable") is False:
        notes.append("not orientable")
    return text + "; " + ", ".join(notes)


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
    geometry = Rectangle(
        width, height, surface, description={**description, "width_m": width, "height_m": height}
    )
    part = Part(
        name,
        element,
        resolve_material(material),
        float(thickness),
        None if mesh_size is None else float(mesh_size),
        geometry,
    )
    warn_units(part)
    return part


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
        ("hex2", "shell"),
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
    """A part from a mesh file (any format meshio reads; fem.mesh.mesh_io.FORMATS_HELP),
    coordinates in m (times ``scale``, e.g. 1e-3 for millimetres); ``thickness`` in m.

    Every cell block is read (tri3, tri6, tri7, quad4, quad8, quad9, mixed), quadratic cells
    are split through their mid-side nodes, duplicate nodes welded, cells oriented. The
    formulation (``element``) follows the part unless given:

    - flat in a plane z = const: a Kirchhoff plate ("morley"; or "argyris", "shell", and
      "hex2" from quadrilaterals);
    - curved, folded or tilted: the shell ("shell"; "hex2" from quadrilaterals);
    - one layer of hexahedra: the thin solid ("hex2", or "shell" on its mid-surface); the
      thickness is measured from the mesh (``thickness`` must be None or agree within 5 %).
    """
    scale = check_positive("scale", scale)
    sheet = read_sheet(path, scale)
    measured = sheet.thickness_m
    if measured is not None:
        if thickness is not None and abs(thickness - measured) > 0.05 * measured:
            raise InputError(
                f"thickness: {thickness:g} m differs from the {measured:.4g} m measured in the "
                f"hexahedral mesh {str(path)!r}; omit thickness to use the mesh's"
            )
        thickness = measured if thickness is None else thickness
    if thickness is None:
        raise InputError(f"thickness: required for a mesh of {str(path)!r} (sheet thickness in m)")
    if element is None:
        element = "hex2" if measured is not None else "morley" if sheet.is_flat else "shell"
    description = {"shape": "mesh file", "path": str(path), "scale": scale, "read": sheet.report}
    part = part_from_mesh(
        sheet, thickness, material, element, os.path.basename(str(path)), description
    )
    warn_units(part)
    return part


def part_from_mesh(
    sheet: SheetMesh,
    thickness: float,
    material: str | Material | Mapping[str, Any],
    element: str,
    name: str,
    description: dict,
) -> Part:
    """A part whose mesh is given (used as is; a fem.mesh.mesh_io.SheetMesh), thickness in m:
    a Kirchhoff plate ("morley", "argyris") if flat, the shell ("shell") or the thin solid
    ("hex2", quadrilaterals only)."""
    _check_common(thickness, element, None, ELEMENTS)
    check_sheet_element(sheet, element, repr(description.get("path", name)))
    return Part(
        name,
        element,
        resolve_material(material),
        float(thickness),
        None,
        GivenMesh(sheet, description),
    )


def read_cad(
    path: str | os.PathLike,
    thickness: float,
    material: str | Material | Mapping[str, Any] = "steel",
    mesh_size: float | None = None,
    *,
    element: str | None = None,
    scale: float = 1.0,
) -> Part:
    """A part from a CAD sheet body (STEP, IGES or BREP; fem.mesh.cad), meshed with gmsh when it
    is analysed: element size ``mesh_size`` m (default as for built-in parts of the
    formulation), refined around the cups. STEP and IGES coordinates are converted to metres
    from the unit the file states, then multiplied by ``scale``; ``thickness`` in m. The
    formulation follows the part unless given: flat in z = const "morley", else "shell"
    ("hex2" meshes quadrilaterals)."""
    scale = check_positive("scale", scale)
    _check_common(thickness, element or "shell", mesh_size, ELEMENTS)
    lo, hi, area = read_cad_bounds(path, scale, mesh_size)
    check_extent(float(np.max(hi - lo)), str(path), "cad")
    # where points lie, the area and the span come from a mesh at the element size (or 1/40
    # of the diagonal: the facets' area then differs from the surface's by < 1e-4 for
    # curvature radii down to the part's size)
    probe = float(mesh_size) if mesh_size is not None else float(np.linalg.norm(hi - lo)) / 40
    # before any meshing: the probe mesh, and an analysis at that size with the cheapest
    # formulation and one mode (the least any analysis of this part will need)
    cheapest = "morley" if element is None else element
    cells = refined_cells(area, probe, (), quads=cheapest == "hex2")
    analysis = plan_of_cells(cheapest, cells, 1, probe).need("the modal analysis of the sheet")
    require(cad_mesh_need(path, area, probe), analysis)
    base = meshed(path, probe, scale=scale)
    if element is None:
        element = "morley" if base.is_flat else "shell"
    check_sheet_element(base, "shell" if element == "hex2" else element, repr(str(path)))
    description = {"shape": "CAD sheet body", "path": str(path), "scale": scale}
    description["read"] = {**base.report, "unit": cad_unit(path)}
    part = Part(
        os.path.basename(str(path)),
        element,
        resolve_material(material),
        float(thickness),
        None if mesh_size is None else float(mesh_size),
        CadSurface(path, scale, base, description),
    )
    warn_units(part)
    return part
