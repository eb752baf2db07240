"""Shear panels of a Nastran deck (CSHEAR with PSHEAR) as element matrices on their four
grids (basic axes, the deck's units).

A shear panel carries in-plane shear only, at a constant shear flow: its strain energy is
G t A gamma^2 / 2 with gamma the panel's mean shear strain, which for a parallelogram is the
shear strain of the bilinear quadrilateral at its centre (the sides' relative sliding over
their distance), A the area there. Its mass, (RHO t + NSM) A, is lumped to the corners in
equal quarters on the three translations, as Nastran's default lumped mass does. Edge
extension (PSHEAR F1, F2) is refused: the panels of such decks carry part of the edge
members' load, which this model would leave out.
"""

from __future__ import annotations

import numpy as np

from fem.imports.nastran.bdf import BulkData, Card
from fem.imports.nastran.coords import DeckGeometry
from fem.imports.nastran.materials import Materials
from jaxflex.errors import InputError

CENTRE_DERIVATIVES = np.array([[-1.0, 1.0, 1.0, -1.0], [-1.0, -1.0, 1.0, 1.0]]) / 4


def shear_gradient(xyz: np.ndarray) -> tuple[np.ndarray, float]:
    """(12,) d gamma / d u of the panel's mean shear strain with respect to the corners'
    translations (basic) and the panel's area (at its centre) for corners ``xyz`` (4, 3)."""
    normal = np.cross(xyz[2] - xyz[0], xyz[3] - xyz[1])
    e3 = normal / np.linalg.norm(normal)
    e1 = xyz[1] - xyz[0]
    e1 = e1 - (e1 @ e3) * e3
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(e3, e1)
    local = (xyz - xyz.mean(axis=0)) @ np.stack([e1, e2]).T  # (4, 2)
    jacobian = CENTRE_DERIVATIVES @ local  # (2, 2): d(x, y) / d(xi, eta)
    area = 4 * float(np.linalg.det(jacobian))
    dn = np.linalg.solve(jacobian, CENTRE_DERIVATIVES)  # (2, 4): dN/dx, dN/dy
    gradient = dn[1][:, None] * e1 + dn[0][:, None] * e2  # gamma = u_,y + v_,x
    return gradient.ravel(), area


def shear_panels(bulk: BulkData, geometry: DeckGeometry, materials: Materials, out) -> None:
    """Every CSHEAR of the deck into ``out`` (fem.imports.nastran.points.PointMatrices)."""
    properties = bulk.by_id("PSHEAR")
    for card in bulk.named("CSHEAR"):
        pid = card.integer(1, "PID", card.integer(0, "EID"))
        prop = bulk.referenced(properties, pid, ("PSHEAR",), card, (1, "PID"))
        grids = []
        for k in range(4):
            gid = card.required(card.integer(2 + k, f"G{k + 1}"), 2 + k, f"G{k + 1}")
            if gid not in bulk.grids:
                raise InputError(
                    f"deck: {card.where(2 + k, f'G{k + 1}')}: grid {gid} is not in the deck"
                )
            grids.append(gid)
        _panel(card, prop, grids, geometry, materials, out)


def _panel(card: Card, prop: Card, grids, geometry, materials: Materials, out) -> None:
    for index, label in ((4, "F1"), (5, "F2")):
        if prop.real(index, label, 0.0):
            raise InputError(
                f"deck: {prop.where(index, label)}: edge extension of shear panels is not "
                "modelled (give 0 or model the edges as rods)"
            )
    material = materials.any(prop.integer(1, "MID"), prop, 1, "MID", ("MAT1",))
    thickness = prop.required(prop.real(2, "T"), 2, "T")
    gradient, area = shear_gradient(np.array([geometry.positions[g] for g in grids]))
    if area <= 0:
        raise InputError(f"deck: {card.where(None)}: its corners do not make a convex panel")
    translations = (6 * np.arange(4)[:, None] + np.arange(3)).ravel()
    k = np.zeros((24, 24))
    k[np.ix_(translations, translations)] = (
        material.g * thickness * area * np.outer(gradient, gradient)
    )
    m = np.zeros((24, 24))
    mass = (material.rho * thickness + prop.real(3, "NSM", 0.0)) * area
    m[translations, translations] = mass / 4
    out.add(card, grids, stiffness=k, mass=m)
