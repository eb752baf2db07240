"""Solid elements of a Nastran deck (CHEXA, CPENTA, CTETRA with PSOLID and an isotropic
MAT1): isoparametric elements of three DOFs per grid (the translations; a grid that only
solids reach has its rotations held by AUTOSPC, as in Nastran), consistent mass, the deck's
units.

* CTETRA: 4 grids (linear) or 10 (quadratic; mid-side grids G5-G10 on edges 1-2, 2-3, 3-1,
  1-4, 2-4, 3-4);
* CPENTA: 6 or 15 (G7-G9 on the triangle 1-2-3's edges, G10-G12 on 1-4, 2-5, 3-6, G13-G15 on
  the triangle 4-5-6's);
* CHEXA: 8 or 20 (G9-G12 on the face 1-2-3-4's edges, G13-G16 on 1-5 ... 4-8, G17-G20 on the
  face 5-6-7-8's). The 8-grid brick has Wilson's incompatible bending modes (1 - xi^2 per
  direction, condensed, their derivatives from the centre's Jacobian as Taylor's form that
  passes the patch test): a full-integration trilinear brick locks in bending, and Nastran's
  CHEXA has its own cure (reduced shear integration with bubble functions).

An element gives all its mid-side grids or none (a partial set is refused), its grids in
either order Nastran takes (a mirrored order has det J < 0 throughout: the same element; det
J of both signs, an element turned inside out in part, is refused). Quadrature: Gauss
points on the brick, the collapsed (Duffy) brick on the tetrahedron and the wedge's
triangle, exact for the stiffness and mass of straight-sided elements. Shape functions'
derivatives come from the complex step (exact for these polynomials).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fem.imports.nastran.bdf import BulkData, Card
from fem.imports.nastran.materials import Materials
from jaxflex.errors import InputError

SOLID_CARDS = ("CHEXA", "CPENTA", "CTETRA")
CORNERS = {"CTETRA": 4, "CPENTA": 6, "CHEXA": 8}
FULL = {"CTETRA": 10, "CPENTA": 15, "CHEXA": 20}
STEP = 1e-30  # complex step


def _hex_nodes() -> np.ndarray:
    corners = np.array(
        [[-1, -1, -1], [1, -1, -1], [1, 1, -1], [-1, 1, -1],
         [-1, -1, 1], [1, -1, 1], [1, 1, 1], [-1, 1, 1]], dtype=float
    )  # fmt: skip
    edges = [(0, 1), (1, 2), (2, 3), (3, 0), (0, 4), (1, 5), (2, 6), (3, 7),
             (4, 5), (5, 6), (6, 7), (7, 4)]  # fmt: skip
    return np.vstack([corners, [(corners[a] + corners[b]) / 2 for a, b in edges]])


HEX_NODES = _hex_nodes()


def hex_shapes(p: np.ndarray, n: int) -> np.ndarray:
    """(P, n) brick shape functions at natural points ``p`` (P, 3) in [-1, 1]^3."""
    x, y, z = (p[:, k][:, None] for k in range(3))
    xi, eta, zeta = (HEX_NODES[:n, k][None] for k in range(3))
    if n == 8:
        return (1 + x * xi) * (1 + y * eta) * (1 + z * zeta) / 8
    corner = (1 + x * xi) * (1 + y * eta) * (1 + z * zeta) * (x * xi + y * eta + z * zeta - 2) / 8
    mid = np.where(
        xi == 0,
        (1 - x**2) * (1 + y * eta) * (1 + z * zeta),
        np.where(eta == 0, (1 + x * xi) * (1 - y**2) * (1 + z * zeta),
                 (1 + x * xi) * (1 + y * eta) * (1 - z**2)),
    ) / 4  # fmt: skip
    return np.where(np.arange(n) < 8, corner, mid)


def tet_shapes(p: np.ndarray, n: int) -> np.ndarray:
    """(P, n) tetrahedron shape functions at points (r, s, t) of the unit tetrahedron."""
    lam = np.column_stack([1 - p.sum(axis=1), p[:, 0], p[:, 1], p[:, 2]])
    if n == 4:
        return lam
    edges = [(0, 1), (1, 2), (2, 0), (0, 3), (1, 3), (2, 3)]
    mids = [4 * lam[:, a] * lam[:, b] for a, b in edges]
    return np.column_stack([lam * (2 * lam - 1), *mids])


def wedge_shapes(p: np.ndarray, n: int) -> np.ndarray:
    """(P, n) wedge shape functions at points (r, s, zeta): (r, s) in the unit triangle."""
    lam = np.column_stack([1 - p[:, 0] - p[:, 1], p[:, 0], p[:, 1]])
    z = p[:, 2][:, None]
    bottom, top = (1 - z) / 2, (1 + z) / 2
    if n == 6:
        return np.hstack([lam * bottom, lam * top])
    bubble = 1 - z**2
    corners = [lam * ((2 * lam - 1) * (1 - z) - bubble) / 2,
               lam * ((2 * lam - 1) * (1 + z) - bubble) / 2]  # fmt: skip
    tri = [(0, 1), (1, 2), (2, 0)]
    low = np.column_stack([2 * lam[:, a] * lam[:, b] * (1 - z[:, 0]) for a, b in tri])
    high = np.column_stack([2 * lam[:, a] * lam[:, b] * (1 + z[:, 0]) for a, b in tri])
    return np.hstack([corners[0], corners[1], low, lam * bubble, high])


SHAPES = {"CHEXA": hex_shapes, "CTETRA": tet_shapes, "CPENTA": wedge_shapes}
# CPENTA's Nastran order: G7-G9 (1-2, 2-3, 3-1), G10-G12 (1-4, 2-5, 3-6), G13-G15 (4-5, ...):
# wedge_shapes orders them low triangle, vertical, high triangle as well


def _gauss(n: int) -> tuple[np.ndarray, np.ndarray]:
    x, w = np.polynomial.legendre.leggauss(n)
    return x, w


def quadrature(kind: str, order: int) -> tuple[np.ndarray, np.ndarray]:
    """(points (P, 3), weights (P,)) of ``order`` Gauss points per direction on the
    element's natural domain (collapsed bricks for the tetrahedron and the triangle)."""
    x, w = _gauss(order)
    grid = np.stack(np.meshgrid(x, x, x, indexing="ij"), -1).reshape(-1, 3)
    weight = np.einsum("i,j,k->ijk", w, w, w).ravel()
    if kind == "CHEXA":
        return grid, weight
    u = (grid + 1) / 2  # [0, 1]^3, weights / 8
    weight = weight / 8
    if kind == "CTETRA":  # x = u, y = v (1 - u), z = w (1 - u) (1 - v)
        points = np.column_stack(
            [u[:, 0], u[:, 1] * (1 - u[:, 0]), u[:, 2] * (1 - u[:, 0]) * (1 - u[:, 1])]
        )
        return points, weight * (1 - u[:, 0]) ** 2 * (1 - u[:, 1])
    points = np.column_stack([u[:, 0], u[:, 1] * (1 - u[:, 0]), grid[:, 2]])  # the wedge
    return points, weight * 2 * (1 - u[:, 0])


def shape_derivatives(kind: str, points: np.ndarray, n: int) -> np.ndarray:
    """(P, 3, n) dN / d(natural coordinates) by the complex step."""
    out = np.empty((len(points), 3, n))
    for k in range(3):
        shifted = points.astype(complex)
        shifted[:, k] += 1j * STEP
        out[:, k] = SHAPES[kind](shifted, n).imag / STEP
    return out


@dataclass
class SolidElements:
    """Solids of one kind and grid count: ``cards``, ``grids`` (E, n) ids, their Young's
    modulus, Poisson's ratio and density (E,) in the deck's units."""

    kind: str
    cards: list[Card]
    grids: np.ndarray
    e: np.ndarray
    nu: np.ndarray
    rho: np.ndarray


def _isotropic(e: float, nu: float) -> np.ndarray:
    lam, mu = e * nu / ((1 + nu) * (1 - 2 * nu)), e / (2 * (1 + nu))
    d = np.zeros((6, 6))
    d[:3, :3] = lam
    d[np.arange(6), np.arange(6)] += np.r_[np.full(3, 2 * mu), np.full(3, mu)]
    return d


def strain_matrix(dn: np.ndarray) -> np.ndarray:
    """(P, 6, 3 n) strains (xx, yy, zz, xy, yz, zx) from node translations, ``dn`` (P, 3, n)
    the shape functions' physical derivatives."""
    p, _, n = dn.shape
    b = np.zeros((p, 6, n, 3))
    for i in range(3):
        b[:, i, :, i] = dn[:, i]
    for row, (i, j) in zip((3, 4, 5), ((0, 1), (1, 2), (2, 0)), strict=True):
        b[:, row, :, i] = dn[:, j]
        b[:, row, :, j] = dn[:, i]
    return b.reshape(p, 6, 3 * n)


def incompatible_strains(xyz: np.ndarray, points: np.ndarray, dets: np.ndarray) -> np.ndarray:
    """(P, 6, 9) strains of Wilson's incompatible modes 1 - xi_k^2 (per direction and
    displacement component) of a brick at corners ``xyz`` (8, 3): their derivatives through
    the centre's Jacobian, times det J0 / det J (Taylor: the patch test holds)."""
    j0 = shape_derivatives("CHEXA", np.zeros((1, 3)), 8)[0] @ xyz
    dp = np.zeros((len(points), 3, 3))  # d(1 - x_k^2) / d natural: -2 x_k on the diagonal
    dp[:, np.arange(3), np.arange(3)] = -2 * points
    physical = np.linalg.solve(j0, dp) * (np.linalg.det(j0) / dets)[:, None, None]
    return strain_matrix(physical)


def element_matrices(kind: str, xyz: np.ndarray, e: float, nu: float, rho: float):
    """(K, M) (3 n, 3 n) of one solid with grids at ``xyz`` (n, 3), in either order Nastran
    takes (det J of one sign throughout: a mirrored order is the same element); None for an
    element flat or turned inside out in part (det J of both signs)."""
    n = len(xyz)
    order = 3 if n > CORNERS[kind] or kind != "CHEXA" else 2
    points, weights = quadrature(kind, order)
    dn = shape_derivatives(kind, points, n)
    jac = dn @ xyz  # (P, 3, 3)
    dets = np.linalg.det(jac)
    if not (np.all(dets > 0) or np.all(dets < 0)):  # flat, or turned inside out in part
        return None
    dx = np.linalg.solve(jac, dn)
    b = strain_matrix(dx)
    d = _isotropic(e, nu)
    dv = weights * np.abs(dets)  # grids in mirrored order (det J < 0 throughout): the same
    k = np.einsum("p,pai,ab,pbj->ij", dv, b, d, b)
    if kind == "CHEXA" and n == 8:
        ba = incompatible_strains(xyz, points, dets)
        k_ua = np.einsum("p,pai,ab,pbj->ij", dv, b, d, ba)
        k_aa = np.einsum("p,pai,ab,pbj->ij", dv, ba, d, ba)
        k = k - k_ua @ np.linalg.solve(k_aa, k_ua.T)
    mass_points, mass_weights = quadrature(kind, 4)
    shapes = SHAPES[kind](mass_points, n)
    mass_det = np.abs(np.linalg.det(shape_derivatives(kind, mass_points, n) @ xyz))
    scalar = np.einsum("p,pi,pj->ij", rho * mass_weights * mass_det, shapes, shapes)
    return k, np.kron(scalar, np.eye(3))


def read_solids(bulk: BulkData, materials: Materials) -> list[SolidElements]:
    """The deck's solids grouped by kind and grid count, checked (module docstring)."""
    properties = bulk.by_id("PSOLID")
    groups: dict[tuple[str, int], list] = {}
    for card in bulk.named(*SOLID_CARDS):
        corners, full = CORNERS[card.name], FULL[card.name]
        grids = [card.integer(2 + k, f"G{k + 1}") for k in range(full)]
        for k in range(corners):
            card.required(grids[k], 2 + k, f"G{k + 1}")
        given = [g for g in grids[corners:] if g]
        if given and len(given) != full - corners:
            raise InputError(
                f"deck: {card.where(None)}: {len(given)} of its {full - corners} mid-side grids "
                "are given; a solid takes all or none"
            )
        grids = grids[: full if given else corners]
        for k, gid in enumerate(grids):
            if gid not in bulk.grids:
                raise InputError(
                    f"deck: {card.where(2 + k, f'G{k + 1}')}: grid {gid} is not in the deck"
                )
        pid = card.integer(1, "PID", card.integer(0, "EID"))
        prop = bulk.referenced(properties, pid, ("PSOLID",), card, (1, "PID"))
        material = materials.any(prop.integer(1, "MID"), prop, 1, "MID", ("MAT1",))
        groups.setdefault((card.name, len(grids)), []).append((card, grids, material))
    out = []
    for (kind, _), members in groups.items():
        out.append(
            SolidElements(
                kind,
                [c for c, _, _ in members],
                np.array([g for _, g, _ in members], dtype=np.int64),
                np.array([m.e for _, _, m in members]),
                np.array([m.nu for _, _, m in members]),
                np.array([m.rho for _, _, m in members]),
            )
        )
    return out


def solid_chunk(group: SolidElements, nodes: np.ndarray, index: dict, chunk: np.ndarray):
    """(K, M) (C, 3 n, 3 n) of the elements ``chunk`` of ``group`` at ``nodes`` (deck
    units); an element flat or turned inside out in part is refused by name."""
    n = group.grids.shape[1]
    k_out, m_out = np.zeros((len(chunk), 3 * n, 3 * n)), np.zeros((len(chunk), 3 * n, 3 * n))
    for row, e in enumerate(chunk):
        xyz = nodes[[index[int(g)] for g in group.grids[e]]]
        matrices = element_matrices(group.kind, xyz, group.e[e], group.nu[e], group.rho[e])
        if matrices is None:
            raise InputError(
                f"deck: {group.cards[e].where(None)}: its volume is flat or turned inside out "
                "in part (check the order of its grids and their positions)"
            )
        k_out[row], m_out[row] = matrices
    return k_out, m_out
