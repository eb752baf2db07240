"""Sheet parts the import and shell tests generate themselves (no data files).

* A circular cylindrical panel (radius RADIUS_M, chord CHORD_M along x, depth DEPTH_M along
  y, crowned at x = CHORD_M / 2): nodes on the exact surface, as meshes of every cell type
  (tri3, tri6, quad4, quad8, quad9, mixed, several blocks) and as STEP and IGES files
  written by gmsh's OpenCASCADE kernel.
* A folded L-bracket of quadrilaterals: a base [0, base] x [0, width] in the plane z = 0 and
  a flange along the edge x = 0, turned up by the fold angle (90 degrees: vertical).
* The 3-D inertia of a faceted sheet (:func:`sheet_moments`): a facet of area A, corners
  x_a and unit normal n, thickness h, density rho has the mass rho h A, the first moment
  rho h A (x_1 + x_2 + x_3) / 3 and the second moment int rho r r^T dV = rho h A / 12
  (sum_a x_a x_a^T + s s^T), s = sum_a x_a (exact for a triangle), plus its fibres'
  rho h^3 / 12 A n n^T (r = x + zeta n, zeta in [-h/2, h/2]).
"""

from __future__ import annotations

import os
from contextlib import contextmanager

import gmsh
import numpy as np

RADIUS_M, CHORD_M, DEPTH_M = 1.0, 0.6, 0.4
HALF_ANGLE = np.arcsin(CHORD_M / 2 / RADIUS_M)


def panel_points(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Points (n, 3) of the panel at arc parameter u in [0, 1] (across the curvature) and v in
    [0, 1] (along the axis)."""
    theta = (2 * u - 1) * HALF_ANGLE
    x = CHORD_M / 2 + RADIUS_M * np.sin(theta)
    z = RADIUS_M * (np.cos(theta) - 1)
    return np.column_stack([x, v * DEPTH_M, z])


def _grid(nx: int, ny: int):
    u, v = np.meshgrid(np.linspace(0, 1, nx + 1), np.linspace(0, 1, ny + 1), indexing="ij")
    idx = np.arange(u.size).reshape(u.shape)
    return panel_points(u.ravel(), v.ravel()), idx


def _cells(idx: np.ndarray, step: int) -> list[np.ndarray]:
    """Quads of ``step`` x ``step`` grid cells as node blocks (step + 1) x (step + 1)."""
    blocks = []
    for i in range(0, idx.shape[0] - 1, step):
        for j in range(0, idx.shape[1] - 1, step):
            blocks.append(idx[i : i + step + 1, j : j + step + 1])
    return blocks


def panel_cells(kind: str, nx: int, ny: int) -> tuple[np.ndarray, list[tuple[str, np.ndarray]]]:
    """The panel as (points, cell blocks) of ``kind``: "triangle", "quad", "triangle6",
    "quad8", "quad9" (linear cells: nx x ny grid cells; quadratic: nx/2 x ny/2 cells whose
    mid-side nodes are the grid's), "mixed" (quads and triangles) or "blocks" (triangles in
    two cell blocks, one per half, as gmsh writes two surfaces)."""
    points, idx = _grid(nx, ny)
    if kind in ("triangle", "quad", "mixed", "blocks"):
        q = np.array([[b[0, 0], b[1, 0], b[1, 1], b[0, 1]] for b in _cells(idx, 1)])
        tris = np.concatenate([q[:, [0, 1, 2]], q[:, [0, 2, 3]]])
        if kind == "triangle":
            return points, [("triangle", tris)]
        if kind == "quad":
            return points, [("quad", q)]
        half = len(q) // 2
        if kind == "mixed":
            return points, [
                ("quad", q[:half]),
                ("triangle", np.concatenate([q[half:, [0, 1, 2]], q[half:, [0, 2, 3]]])),
            ]
        return points, [
            ("triangle", np.concatenate([q[:half, [0, 1, 2]], q[:half, [0, 2, 3]]])),
            ("triangle", np.concatenate([q[half:, [0, 1, 2]], q[half:, [0, 2, 3]]])),
        ]
    blocks = _cells(idx, 2)
    quad9 = np.array(
        [[b[0, 0], b[2, 0], b[2, 2], b[0, 2], b[1, 0], b[2, 1], b[1, 2], b[0, 1], b[1, 1]]
         for b in blocks]
    )  # fmt: skip
    if kind == "quad9":
        return points, [("quad9", quad9)]
    if kind == "quad8":
        return points, [("quad8", quad9[:, :8])]
    a, b, c, d, ab, bc, cd, da, centre = quad9.T
    tri6 = np.concatenate(
        [np.column_stack([a, b, c, ab, bc, centre]), np.column_stack([a, c, d, centre, cd, da])]
    )
    return points, [("triangle6", tri6)]


@contextmanager
def _gmsh():
    gmsh.initialize(readConfigFiles=False, interruptible=False)
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.option.setString("Geometry.OCCTargetUnit", "M")  # written in mm, read back in m
    try:
        yield
    finally:
        gmsh.finalize()


def _panel_surface(unit_m: float = 1.0) -> None:
    """The panel in the current gmsh model, coordinates in units of ``unit_m`` metres: the
    circular arc extruded along y (OpenCASCADE)."""
    occ = gmsh.model.occ
    ends = panel_points(np.array([0.0, 1.0]), np.zeros(2)) / unit_m
    start = occ.addPoint(*ends[0])
    centre = occ.addPoint(CHORD_M / 2 / unit_m, 0.0, -RADIUS_M / unit_m)
    end = occ.addPoint(*ends[1])
    arc = occ.addCircleArc(start, centre, end)
    occ.extrude([(1, arc)], 0, DEPTH_M / unit_m, 0)
    occ.synchronize()


def write_panel_step(path: str | os.PathLike) -> None:
    """The panel as a STEP surface (OpenCASCADE)."""
    with _gmsh():
        _panel_surface()
        gmsh.write(str(path))


def write_panel_iges(path: str | os.PathLike, unit: str = "MM", model_scale: int = 1) -> None:
    """The panel as an IGES surface written by gmsh, whose IGES writer states millimetres
    (units flag 2) for coordinates as they are: the panel is built in ``unit`` ("MM" or
    "IN") times ``model_scale`` (1 to 9), and the global section's units flag, name and
    model space scale (parameters 13 to 15) are set to say so."""
    unit_m = {"MM": 1e-3, "IN": 0.0254}[unit]
    gmsh.initialize(readConfigFiles=False, interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        _panel_surface(unit_m / model_scale)
        gmsh.write(str(path))
    finally:
        gmsh.finalize()
    with open(path, encoding="latin-1") as handle:
        text = handle.read()
    flag = {"MM": 2, "IN": 1}[unit]
    assert ",1.,2,2HMM," in text, "gmsh's IGES global section changed"
    stated = text.replace(",1.,2,2HMM,", f",{model_scale}.,{flag},2H{unit},", 1)
    with open(path, "w", encoding="latin-1") as handle:
        handle.write(stated)


def write_box_step(path: str | os.PathLike) -> None:
    """A solid box (a volume): what a sheet part must not be exported as."""
    with _gmsh():
        gmsh.model.occ.addBox(0, 0, 0, 0.3, 0.2, 0.001)
        gmsh.model.occ.synchronize()
        gmsh.write(str(path))


def bracket(
    fold_deg: float, size_m: float, base_m: float = 0.3, flange_m: float = 0.1, width_m=0.2
) -> tuple[np.ndarray, np.ndarray]:
    """Nodes (N, 3) and quads of the L-bracket (module docstring), elements of ``size_m``."""
    nb, nf, ny = (max(1, round(length / size_m)) for length in (base_m, flange_m, width_m))
    s = np.concatenate([np.linspace(-flange_m, 0, nf + 1)[:-1], np.linspace(0, base_m, nb + 1)])
    fold = np.radians(fold_deg)
    up = np.array([-np.cos(fold), 0.0, np.sin(fold)])  # the flange's direction from the fold
    ss, yy = np.meshgrid(s, np.linspace(0, width_m, ny + 1), indexing="ij")
    points = np.where(
        (ss < 0)[..., None], -ss[..., None] * up, np.stack([ss, 0 * ss, 0 * ss], axis=-1)
    )
    points[..., 1] = yy
    idx = np.arange(ss.size).reshape(ss.shape)
    quads = np.column_stack(
        [idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()]
    )
    return points.reshape(-1, 3), quads


def sheet_moments(nodes_m: np.ndarray, triangles: np.ndarray, rho_h: float, thickness_m: float):
    """(mass kg, first moment (3,) kg m, second moment (3, 3) kg m^2) of the faceted sheet
    (module docstring: exact for flat facets)."""
    corners = nodes_m[triangles]  # (E, 3, 3)
    twice = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    area = 0.5 * np.linalg.norm(twice, axis=1)
    normal = twice / (2 * area[:, None])
    total = corners.sum(axis=1)
    second = np.einsum("e,eai,eaj->ij", area, corners, corners) + np.einsum(
        "e,ei,ej->ij", area, total, total
    )
    fibres = thickness_m**2 / 12 * np.einsum("e,ei,ej->ij", area, normal, normal)
    return rho_h * area.sum(), rho_h * area @ total / 3, rho_h * (second / 12 + fibres)
