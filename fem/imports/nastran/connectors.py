"""Connectors between the shell surfaces of a Nastran deck: CFAST fasteners (PFAST) and CWELD
spot welds (PWELD), as element matrices on the grids of the shells they join (basic axes,
the deck's units).

Each connector joins two surface patches at a point: its grid GS (or XS, YS, ZS) projected
onto patch A and patch B gives its end points PA and PB, on the shell facet
(fem.imports.nastran.shells) that holds the projection; an end point moves as the facet's grids do,
translations and rotations weighted by the point's barycentric coordinates (Nastran derives
the end's rotations from the patch's translations; the two agree where the patch bends
smoothly). The patches, as Nastran names them:

* CFAST TYPE PROP: the shells of properties IDA and IDB; TYPE ELEM: the elements IDA, IDB;
* CWELD ELPAT: element SHIDA and the elements sharing a grid with it (SHIDB likewise);
  ELEMID: the elements SHIDA, SHIDB; PARTPAT: the shells of properties PIDA, PIDB. GRIDID
  and ALIGN are refused by name.

The connector between PA and PB:

* CFAST: six springs KT1-KT3, KR1-KR3 of PFAST at the middle of PA-PB, rigidly tied to both
  ends (as CBUSH), x along PA-PB (patch A's normal where they coincide); MFLAG 1 takes
  MCID's axes as they are, otherwise y and z are MCID's y and z turned normal to x, and an
  unequal pair (KT2, KT3 or KR2, KR3) without MCID is refused. Its MASS, half at each end.
* CWELD: a shear-flexible round beam of diameter D and material MID (shear factor 0.9 of a
  circle) whose stiffness has Nastran's effective length: (tA + tB) / 2 for TYPE SPOT with
  the patch formats, else the distance PA-PB within LDMIN D ... LDMAX D (0.2, 5); it sits
  between the ends on rigid arms along its axis. Its mass (a cylinder of D) is left out.
"""

from __future__ import annotations

import numpy as np

from fem.elements.beam import local_matrices, to_global
from fem.elements.offsets import offset_transform
from fem.imports.nastran.bdf import BulkData, Card
from fem.imports.nastran.coords import DeckGeometry
from fem.imports.nastran.materials import Materials
from jaxflex.errors import InputError

CONNECTOR_CARDS = ("CFAST", "CWELD")
ROUND_SHEAR_FACTOR = 0.9  # Cowper's 6 (1 + nu) / (7 + 6 nu) of a solid circle at nu ~ 0.3
WELD_LENGTH_RANGE = (0.2, 5.0)  # Nastran's bounds of the weld's length over its diameter


class Patches:
    """The shell facets of the deck model by element id and by property id, and the
    projection of a point onto a set of them."""

    def __init__(self, facets, nodes: np.ndarray, grid_ids: np.ndarray) -> None:
        self.f, self.nodes, self.grid_ids = facets, nodes, grid_ids
        eids = np.array([e.card.integer(0, "EID") for e in facets.elements])
        self.facet_eid = eids[facets.element]
        self.corners = self.nodes[facets.triangles]
        self.thickness = facets.t_mean

    def of_elements(self, eids) -> np.ndarray:
        return np.flatnonzero(np.isin(self.facet_eid, list(eids)))

    def of_property(self, pid: int) -> np.ndarray:
        return np.flatnonzero(self.f.pid == pid)

    def around(self, eid: int) -> np.ndarray:
        """The facets of element ``eid`` and of the elements sharing a grid with it."""
        own = self.of_elements([eid])
        grids = np.unique(self.f.triangles[own])
        return np.flatnonzero(np.isin(self.f.triangles, grids).any(axis=1))

    def project(self, point: np.ndarray, rows: np.ndarray):
        """(facet row, barycentric weights (3,), projected point) of ``point`` on the facets
        ``rows``: the facet holding its projection nearest to it (else the nearest facet,
        the weights clipped to it)."""
        xyz = self.corners[rows]
        e1, e2 = xyz[:, 1] - xyz[:, 0], xyz[:, 2] - xyz[:, 0]
        rel = point - xyz[:, 0]
        gram = np.stack(
            [
                np.stack([np.einsum("fi,fi->f", e1, e1), np.einsum("fi,fi->f", e1, e2)], -1),
                np.stack([np.einsum("fi,fi->f", e2, e1), np.einsum("fi,fi->f", e2, e2)], -1),
            ],
            -2,
        )
        rhs = np.stack([np.einsum("fi,fi->f", e1, rel), np.einsum("fi,fi->f", e2, rel)], -1)
        st = np.linalg.solve(gram, rhs[..., None])[..., 0]
        weights = np.column_stack([1 - st.sum(axis=1), st])
        clipped = np.clip(weights, 0.0, None)
        clipped /= clipped.sum(axis=1, keepdims=True)
        projected = np.einsum("fk,fki->fi", clipped, xyz)
        outside = np.clip(-weights, 0.0, None).sum(axis=1)
        distance = np.linalg.norm(projected - point, axis=1)
        best = int(np.lexsort((distance, outside > 1e-9))[0])
        return int(rows[best]), clipped[best], projected[best]

    def normal(self, row: int) -> np.ndarray:
        xyz = self.corners[row]
        n = np.cross(xyz[1] - xyz[0], xyz[2] - xyz[0])
        return n / np.linalg.norm(n)


def _end_map(weights: np.ndarray) -> np.ndarray:
    """(6, 18) the end point's six DOFs from its facet's three grids' six DOFs."""
    return np.hstack([w * np.eye(6) for w in weights])


def _axes(axis: np.ndarray, fallback: np.ndarray, reference: np.ndarray | None) -> np.ndarray:
    """(3, 3) rows x, y, z: x along ``axis`` (``fallback`` where it is zero), y the
    ``reference`` direction (or the basic axis least along x) turned normal to x."""
    length = np.linalg.norm(axis)
    x = axis / length if length > 1e-12 * max(np.linalg.norm(fallback), 1.0) else fallback
    v = reference if reference is not None else np.eye(3)[int(np.argmin(np.abs(x)))]
    y = v - (v @ x) * x
    if np.linalg.norm(y) < 1e-9:
        y = np.eye(3)[int(np.argmin(np.abs(x)))] - x * x[int(np.argmin(np.abs(x)))]
    y /= np.linalg.norm(y)
    return np.stack([x, y, np.cross(x, y)])


def _station(card: Card, bulk: BulkData, geometry: DeckGeometry, gs_index: int, xs_index=None):
    """The connector's location: grid GS, else (CFAST) XS, YS, ZS in basic."""
    gs = card.integer(gs_index, "GS")
    if gs:
        if gs not in bulk.grids:
            raise InputError(f"deck: {card.where(gs_index, 'GS')}: grid {gs} is not in the deck")
        return geometry.positions[gs]
    xyz = [] if xs_index is None else [card.real(xs_index + k, "XYZ"[k] + "S") for k in range(3)]
    if len(xyz) < 3 or any(v is None for v in xyz):
        card.required(None, gs_index, "GS")
    return np.array(xyz, dtype=float)


def _patch_rows(card: Card, patches: Patches, kind: str, ident: int, index: int, label: str):
    rows = (
        patches.of_property(ident)
        if kind == "property"
        else patches.around(ident)
        if kind == "around"
        else patches.of_elements([ident])
    )
    if not len(rows):
        what = "no shell of property" if kind == "property" else "no shell element"
        raise InputError(f"deck: {card.where(index, label)}: {what} {ident} in the deck model")
    return rows


def _ends(card, patches: Patches, point, patch_a, patch_b):
    """Per end (facet row, weights, point) of a connector at ``point`` between patches
    ((kind, id, field index, label) each)."""
    return [
        patches.project(point, _patch_rows(card, patches, *patch)) for patch in (patch_a, patch_b)
    ]


def _on_grids(patches: Patches, ends, k: np.ndarray, m: np.ndarray):
    """(grid ids (6,), stiffness, mass (36, 36)) of an element (12, 12) between the ends."""
    t = np.zeros((12, 36))
    grids = []
    for side, (row, weights, _) in enumerate(ends):
        t[6 * side : 6 * side + 6, 18 * side : 18 * side + 18] = _end_map(weights)
        grids.extend(int(g) for g in patches.grid_ids[patches.f.triangles[row]])
    return grids, t.T @ k @ t, t.T @ m @ t


def _springs(ends, axes: np.ndarray, k: np.ndarray, masses: float) -> tuple:
    """(12, 12) stiffness and mass of six springs ``k`` in ``axes`` at the middle of the
    ends, rigidly tied to them; ``masses`` at each end."""
    (_, _, pa), (_, _, pb) = ends
    middle = (pa + pb) / 2
    turn = np.kron(np.eye(2), axes)
    b = np.hstack(
        [-turn @ offset_transform((middle - pa)[None, None])[0],
         turn @ offset_transform((middle - pb)[None, None])[0]]
    )  # fmt: skip
    m = np.zeros((12, 12))
    m[[0, 1, 2, 6, 7, 8], [0, 1, 2, 6, 7, 8]] = masses
    return b.T @ (k[:, None] * b), m


def _cfast(card: Card, bulk, geometry, patches: Patches, properties, out) -> None:
    kind = card.text(2)
    if kind not in ("PROP", "ELEM"):
        raise InputError(f"deck: {card.where(2, 'TYPE')}: {kind!r}; allowed: PROP, ELEM")
    pid = card.integer(1, "PID", card.integer(0, "EID"))
    prop = bulk.referenced(properties, pid, ("PFAST",), card, (1, "PID"))
    patch = "property" if kind == "PROP" else "elements"
    ida = card.required(card.integer(3, "IDA"), 3, "IDA")
    idb = card.required(card.integer(4, "IDB"), 4, "IDB")
    point = _station(card, bulk, geometry, 5, 8)
    ends = _ends(card, patches, point, (patch, ida, 3, "IDA"), (patch, idb, 4, "IDB"))
    k = np.array([prop.real(4 + i, label, 0.0) for i, label in enumerate(PFAST_K)])
    mcid, absolute = prop.integer(2, "MCID", -1), prop.integer(3, "MFLAG", 0) == 1
    frame = None
    if mcid is not None and mcid >= 0:
        frame = geometry.system(mcid, prop, 2, "MCID").frames(point[None])[0]
    elif k[1] != k[2] or k[4] != k[5]:
        raise InputError(
            f"deck: {prop.where(2, 'MCID')}: KT2 != KT3 or KR2 != KR3 need MCID (the "
            "fastener's y and z axes)"
        )
    if absolute:
        axes = frame
    else:
        fallback = patches.normal(ends[0][0])
        axes = _axes(ends[1][2] - ends[0][2], fallback, None if frame is None else frame[1])
    stiffness, mass = _springs(ends, axes, k, prop.real(10, "MASS", 0.0) / 2)
    grids, k_grids, m_grids = _on_grids(patches, ends, stiffness, mass)
    out.add(card, grids, stiffness=k_grids, mass=m_grids)


PFAST_K = ("KT1", "KT2", "KT3", "KR1", "KR2", "KR3")
WELD_PATCHES = {"ELPAT": "around", "ELEMID": "elements", "PARTPAT": "property"}


def _cweld(card: Card, bulk, geometry, patches: Patches, properties, materials, out) -> None:
    kind = card.text(3)
    if kind not in WELD_PATCHES:
        raise InputError(
            f"deck: {card.where(3, 'TYPE')}: {kind!r}; read: {', '.join(WELD_PATCHES)} (GRIDID "
            "and ALIGN are not)"
        )
    pid = card.integer(1, "PID", card.integer(0, "EID"))
    prop = bulk.referenced(properties, pid, ("PWELD",), card, (1, "PID"))
    material = materials.any(prop.integer(1, "MID"), prop, 1, "MID", ("MAT1",))
    diameter = prop.required(prop.real(2, "D"), 2, "D")
    point = _station(card, bulk, geometry, 2)
    patch = WELD_PATCHES[kind]
    ida = card.required(card.integer(8, "SHIDA"), 8, "SHIDA")
    idb = card.required(card.integer(9, "SHIDB"), 9, "SHIDB")
    ends = _ends(card, patches, point, (patch, ida, 8, "SHIDA"), (patch, idb, 9, "SHIDB"))
    (row_a, _, pa), (row_b, _, pb) = ends
    length = float(np.linalg.norm(pb - pa))
    if prop.text(7) == "SPOT":
        effective = (patches.thickness[row_a] + patches.thickness[row_b]) / 2
    else:
        low = prop.real(8, "LDMIN", WELD_LENGTH_RANGE[0])
        high = prop.real(9, "LDMAX", WELD_LENGTH_RANGE[1])
        effective = float(np.clip(length, low * diameter, high * diameter))
    axes = _axes(pb - pa, patches.normal(row_a), None)
    area, inertia = np.pi * diameter**2 / 4, np.pi * diameter**4 / 64
    shear = ROUND_SHEAR_FACTOR * area
    k, _ = local_matrices(
        np.array([effective]), material.e, material.g, area, inertia, inertia, 2 * inertia,
        0.0, 0.0, np.array([shear]), np.array([shear]),
    )  # fmt: skip
    arm = (length - effective) / 2 * axes[0]  # the beam's ends from PA, PB on its axis
    stiffness = to_global(k, axes[None], np.stack([arm, -arm])[None])[0]
    grids, k_grids, m_grids = _on_grids(patches, ends, stiffness, np.zeros((12, 12)))
    out.add(card, grids, stiffness=k_grids, mass=m_grids)


def connectors(bulk: BulkData, geometry: DeckGeometry, materials: Materials, patches, out):
    """Every CFAST and CWELD of the deck into ``out`` (fem.imports.nastran.points.PointMatrices)."""
    if not any(name in bulk.cards for name in CONNECTOR_CARDS):
        return
    fasteners = bulk.by_id("PFAST")
    for card in bulk.named("CFAST"):
        _cfast(card, bulk, geometry, patches, fasteners, out)
    welds = bulk.by_id("PWELD")
    for card in bulk.named("CWELD"):
        _cweld(card, bulk, geometry, patches, welds, materials, out)
