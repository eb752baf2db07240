"""The shell elements of a Nastran deck as flat facets of our shell (fem.elements.shell_element).

Cards: CQUAD4, CTRIA3, CQUADR, CTRIAR, and the quadratic CQUAD8, CTRIA6 with their mid-side
grids. A quad is cut along its shorter diagonal (as fem.mesh.meshing.split_quads). A quadratic
element is cut into flat facets through its mid-side grids (:func:`polygon_triangles`):
the triangle at every corner between two mid-side grids, the rest of its boundary polygon
(corners and mid-side grids in order) by ears of the best shape, so a full CQUAD8 gives six
facets and a full CTRIA6 four, as a mesh of half the element size; an edge without its
mid-side grid is straight (as in Nastran's element) and stays one facet edge. Every facet
keeps the element's node order, so its normal is the element's (the positive z of
offsets, THETA and laminates). Per facet:

* the section (fem.imports.nastran.materials) at the facet's mean thickness and mean cube of the
  thickness (the corner thicknesses T1... of the element, TFLAG = 1: relative to the
  PSHELL's T; at a mid-side grid the mean of its edge's corners; linear over the facet:
  mean of t^3 = (sum t_i^3 + sum_{i != j} t_i^2 t_j + t1 t2 t3) / 10);
* the material axis (THETA degrees from the line G1-G2 about the element normal, or MCID:
  its x axis projected on the facet) turned into the facet's axes;
* ZOFFS: the reference plane lies at ZOFFS along the normal from the grids (rigid offset).

Stiffness and mass come from fem.elements.shell_element.local_matrices in blocks of facets.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fem.elements.offsets import offset_transform
from fem.elements.shell_element import local_frames, local_matrices, opt_beta0, to_global
from fem.imports.nastran.bdf import BulkData, Card
from fem.imports.nastran.coords import DeckGeometry
from fem.imports.nastran.materials import Materials, ShellSection, laminate, pshell, rotate
from jaxflex.errors import InputError

# card: (corner grids, grids, THETA/MCID, ZOFFS, TFLAG, first corner thickness) field indices
SHELL_LAYOUT = {
    "CQUAD4": (4, 4, 6, 7, 9, 10),
    "CQUADR": (4, 4, 6, 7, 9, 10),
    "CTRIA3": (3, 3, 5, 6, 9, 10),
    "CTRIAR": (3, 3, 5, 6, 9, 10),
    "CQUAD8": (4, 8, 14, 15, 16, 10),
    "CTRIA6": (3, 6, 8, 9, 13, 10),
}
SHELL_CARDS = tuple(SHELL_LAYOUT)
SHELL_PROPERTIES = ("PSHELL", "PCOMP", "PCOMPG")


@dataclass
class ShellElement:
    """A shell element card: ``corners`` (3 or 4 grid ids) and ``midside`` (one per edge,
    edge k from corner k to corner k + 1; None where the card leaves it blank)."""

    card: Card
    pid: int
    corners: tuple[int, ...]
    midside: tuple[int | None, ...]
    theta_deg: float
    mcid: int | None
    zoffs: float
    corner_t: tuple[float | None, ...]
    tflag: int

    @property
    def grids(self) -> tuple[int, ...]:
        """Every grid of the element: corners, then the mid-side grids given."""
        return self.corners + tuple(g for g in self.midside if g is not None)

    @property
    def quadratic(self) -> bool:
        return any(g is not None for g in self.midside)


def read_shell(card: Card, bulk: BulkData) -> ShellElement:
    """A shell element card (grids checked to be in the deck)."""
    corners, n_grids, orient, zoffs, tflag, first_t = SHELL_LAYOUT[card.name]
    eid = card.required(card.integer(0, "EID"), 0, "EID")
    grids: list[int | None] = []
    for k in range(n_grids):
        label = f"G{k + 1}"
        gid = card.integer(2 + k, label)
        if gid is None or gid == 0:
            if k < corners:
                card.required(None, 2 + k, label)
            grids.append(None)
            continue
        if gid not in bulk.grids:
            raise InputError(f"deck: {card.where(2 + k, label)}: grid {gid} is not in the deck")
        grids.append(gid)
    text = card.text(orient)
    mcid = None
    theta = 0.0
    if text and ("." in text or "E" in text.upper()):
        theta = card.real(orient, "THETA", 0.0)
    elif text:
        mcid = card.integer(orient, "MCID")
    thickness = tuple(card.real(first_t + k, f"T{k + 1}") for k in range(corners))
    midside = tuple(grids[corners:]) + (None,) * (2 * corners - n_grids)
    return ShellElement(
        card,
        card.integer(1, "PID", eid),  # blank PID: the element id (Quick Reference Guide)
        tuple(grids[:corners]),
        midside,
        theta,
        mcid,
        card.real(zoffs, "ZOFFS", 0.0),
        thickness,
        card.integer(tflag, "TFLAG", 0),
    )


class ShellSections:
    """The shell properties (PSHELL, PCOMP, PCOMPG), read when first used."""

    def __init__(self, bulk: BulkData, materials: Materials) -> None:
        self.bulk, self.materials = bulk, materials
        self.cards = bulk.by_id(*SHELL_PROPERTIES)
        self.read: dict[int, ShellSection] = {}

    def get(self, element: ShellElement) -> ShellSection:
        pid = element.pid
        card = self.bulk.referenced(self.cards, pid, SHELL_PROPERTIES, element.card, (1, "PID"))
        if pid not in self.read:
            reader = pshell if card.name == "PSHELL" else laminate
            self.read[pid] = reader(card, self.materials)
        return self.read[pid]


def _corner_thickness(element: ShellElement, section: ShellSection) -> np.ndarray:
    """The thickness at each corner: T1... of the element (TFLAG = 1: times the property's
    T), else the property's T (a laminate: its plies' total)."""
    base = section.thickness
    values = []
    for k, t in enumerate(element.corner_t):
        if t is None or section.laminate is not None:
            t = base
        elif element.tflag == 1:
            t = None if base is None else t * base
        if t is None:
            raise InputError(
                f"deck: {element.card.where(None)}: no thickness: T of "
                f"{section.card.label} and the corner thickness T{k + 1} are blank"
            )
        if t < 0:
            raise InputError(f"deck: {element.card.where(None)}: corner thickness {t:g} < 0")
        values.append(t)
    if not any(values):
        raise InputError(f"deck: {element.card.where(None)}: every corner thickness is 0")
    return np.array(values)


@dataclass
class Facets:
    """Triangles of the shell elements: ``triangles`` (F, 3) node indices, ``element``
    (F,) index into ``elements``, ``t_mean``, ``t3_mean`` (F,) deck units, ``angle`` (F,)
    rad of the material axis in the facet's axes (0 where isotropic), ``offset`` (F,)
    ZOFFS, ``pid`` (F,)."""

    elements: list[ShellElement]
    triangles: np.ndarray
    element: np.ndarray
    t_mean: np.ndarray
    t3_mean: np.ndarray
    angle: np.ndarray
    offset: np.ndarray
    pid: np.ndarray


def _material_directions(elements, xyz: np.ndarray, geometry: DeckGeometry) -> np.ndarray:
    """(E, 3) the material axis 1 in basic of ``elements`` whose corners are ``xyz`` (E, 4,
    3; a triangle's fourth repeats its first): THETA from the line G1-G2 about the element
    normal, or MCID's axis 1 at the element's centre (before projection on a facet)."""
    quad = np.array([len(e.corners) == 4 for e in elements])
    normal = np.where(
        quad[:, None],
        np.cross(xyz[:, 2] - xyz[:, 0], xyz[:, 3] - xyz[:, 1]),
        np.cross(xyz[:, 1] - xyz[:, 0], xyz[:, 2] - xyz[:, 0]),
    )
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    edge = xyz[:, 1] - xyz[:, 0]
    edge -= np.einsum("ei,ei->e", edge, normal)[:, None] * normal
    edge /= np.linalg.norm(edge, axis=1, keepdims=True)
    theta = np.radians([e.theta_deg for e in elements])[:, None]
    out = np.cos(theta) * edge + np.sin(theta) * np.cross(normal, edge)
    for mcid in {e.mcid for e in elements} - {None}:
        rows = np.flatnonzero([e.mcid == mcid for e in elements])
        first = elements[rows[0]]
        system = geometry.system(mcid, first.card, SHELL_LAYOUT[first.card.name][2], "MCID")
        centres = np.array([xyz[r, : len(elements[r].corners)].mean(axis=0) for r in rows])
        out[rows] = system.frames(centres)[:, 0]
    return out


def _mean_cube(t: np.ndarray) -> np.ndarray:
    """(F,) mean of t^3 over triangles whose thickness is linear between corner values
    ``t`` (F, 3): (sum t_i^3 + sum_{i != j} t_i^2 t_j + t1 t2 t3) / 10."""
    s1, s2, s3 = t.sum(axis=1), (t**2).sum(axis=1), (t**3).sum(axis=1)
    return (s3 + (s2 * s1 - s3) + t.prod(axis=1)) / 10


def polygon_triangles(slots: list[int], xyz: np.ndarray) -> list[tuple[int, int, int]]:
    """Facets (slot triples, in the polygon's order) of an element's boundary polygon:
    ``slots`` its corners (0-3) and mid-side grids (4 + edge) in order around it, at points
    ``xyz`` (len(slots), 3). Each corner between two mid-side grids is cut off, the rest
    goes by ears of the best shape (twice the area over the sum of squared sides, signed
    along the polygon's normal: a flat ear, such as a corner, the mid-side grid of its
    straight edge and the next corner, or one turned over, comes only when nothing else
    is left)."""
    points = dict(zip(slots, np.asarray(xyz, dtype=float), strict=True))
    ring = list(slots)
    size = len(ring)
    cut = [i for i in range(size) if ring[i] < 4 and ring[i - 1] >= 4 and ring[(i + 1) % size] >= 4]
    out = [(ring[i - 1], ring[i], ring[(i + 1) % size]) for i in cut]
    ring = [s for i, s in enumerate(ring) if i not in cut]
    loop = np.array([points[s] for s in slots])
    normal = np.cross(loop - loop.mean(axis=0), np.roll(loop, -1, axis=0) - loop.mean(axis=0))
    normal = normal.sum(axis=0)
    while len(ring) > 3:
        scores = []
        for i in range(len(ring)):
            a, b, c = (points[ring[(i + k) % len(ring)]] for k in (-1, 0, 1))
            sides = np.sum((b - a) ** 2) + np.sum((c - b) ** 2) + np.sum((a - c) ** 2)
            scores.append(np.cross(b - a, c - a) @ normal / sides)
        i = int(np.argmax(scores))
        out.append((ring[i - 1], ring[i], ring[(i + 1) % len(ring)]))
        del ring[i]
    out.append((ring[0], ring[1], ring[2]))
    return out


def element_slots(elements, index: dict) -> np.ndarray:
    """(E, 8) node indices (grid ids to nodes by ``index``) of each element's corners (slots
    0-3) and mid-side grids (4 + edge), -1 where absent."""
    slots = np.full((len(elements), 8), -1, dtype=np.int64)
    for e, element in enumerate(elements):
        slots[e, : len(element.corners)] = [index[g] for g in element.corners]
        for j, gid in enumerate(element.midside):
            if gid is not None:
                slots[e, 4 + j] = index[gid]
    return slots


def facet_slots(elements, slots: np.ndarray, nodes: np.ndarray):
    """(owner (F,) element index, local (F, 3) slots) of the facets of ``elements`` with
    ``slots`` (E, 8) (:func:`element_slots`) at ``nodes`` (N, 3); the facets' node indices
    are ``np.take_along_axis(slots[owner], local, axis=1)``."""
    quadratic = np.array([e.quadratic for e in elements], dtype=bool)
    quad = (slots[:, 3] >= 0) & ~quadratic
    xyz = nodes[np.where(slots[:, :4] >= 0, slots[:, :4], 0)]
    short_ac = np.linalg.norm(xyz[:, 0] - xyz[:, 2], axis=1) <= np.linalg.norm(
        xyz[:, 1] - xyz[:, 3], axis=1
    )
    first = np.where((quad & ~short_ac)[:, None], [0, 1, 3], [0, 1, 2])
    second = np.where(short_ac[:, None], [0, 2, 3], [1, 2, 3])
    linear = np.flatnonzero(~quadratic)
    owner = [linear, np.flatnonzero(quad)]
    local = [first[linear], second[quad]]
    for e in np.flatnonzero(quadratic):
        corners = len(elements[e].corners)
        ring = [s for k in range(corners) for s in (k, 4 + k) if slots[e, s] >= 0]
        triangles = polygon_triangles(ring, nodes[slots[e, ring]])
        owner.append(np.full(len(triangles), e))
        local.append(np.array(triangles, dtype=np.int64))
    owner_all, local_all = np.concatenate(owner), np.concatenate(local)
    order = np.argsort(owner_all, kind="stable")
    return owner_all[order], local_all[order]


def facets(elements, sections: ShellSections, geometry: DeckGeometry, index: dict) -> Facets:
    """The facets of ``elements`` (grid ids to node indices by ``index``), deck units."""
    n = len(elements)
    slots = element_slots(elements, index)
    thickness = np.zeros((n, 8))
    for e, element in enumerate(elements):
        k = len(element.corners)
        t = _corner_thickness(element, sections.get(element))
        thickness[e, :k] = t
        thickness[e, 4 : 4 + k] = 0.5 * (t + np.roll(t, -1))  # the mid-side grids'
    nodes = np.array([geometry.positions[g] for g in sorted(index, key=index.get)])
    owner, local = facet_slots(elements, slots, nodes)
    triangles = np.take_along_axis(slots[owner], local, axis=1)
    t = np.take_along_axis(thickness[owner], local, axis=1)
    corners = slots[:, :4]
    angle = np.zeros(len(owner))
    oriented = np.array([sections.get(e).oriented for e in elements])
    rows = np.flatnonzero(oriented[owner])
    if rows.size:
        chosen = np.flatnonzero(oriented)
        direction = np.zeros((n, 3))
        padded = np.where(corners[chosen] >= 0, corners[chosen], corners[chosen, :1])
        direction[chosen] = _material_directions(
            [elements[e] for e in chosen], nodes[padded], geometry
        )
        frames, _, _ = local_frames(nodes[triangles[rows]])
        d = direction[owner[rows]]
        angle[rows] = np.arctan2(
            np.einsum("fi,fi->f", frames[:, 1], d), np.einsum("fi,fi->f", frames[:, 0], d)
        )
    return Facets(
        elements,
        triangles,
        owner,
        t.mean(axis=1),
        _mean_cube(t),
        angle,
        np.array([elements[e].zoffs for e in owner]),
        np.array([elements[e].pid for e in owner], dtype=np.int64),
    )


def facet_resultants(f: Facets, sections: ShellSections, chunk: np.ndarray):
    """(A, B, D (C, 3, 3) in the facets' axes, beta0, mass, inertia (C,)) of facets
    ``chunk``."""
    n = len(chunk)
    a, b, d = (np.zeros((n, 3, 3)) for _ in range(3))
    beta0, mass, inertia = np.zeros(n), np.zeros(n), np.zeros(n)
    pids = f.pid[chunk]
    for pid in np.unique(pids):
        rows = np.flatnonzero(pids == pid)
        section = sections.read[int(pid)]
        ra, rb, rd, rm, ri = section.resultants(f.t_mean[chunk[rows]], f.t3_mean[chunk[rows]])
        angle = f.angle[chunk[rows]]
        a[rows], b[rows], d[rows] = (rotate(m, angle) for m in (ra, rb, rd))
        mass[rows], inertia[rows] = rm, ri
        beta0[rows] = opt_beta0(section.poisson)
    return a, b, d, beta0, mass, inertia


def facet_matrices(f: Facets, sections: ShellSections, nodes: np.ndarray, chunk: np.ndarray):
    """Stiffness and mass (C, 18, 18), global DOFs, of facets ``chunk`` (deck units)."""
    xyz = nodes[f.triangles[chunk]]
    frames, xy, _ = local_frames(xyz)
    a, b, d, beta0, mass, inertia = facet_resultants(f, sections, chunk)
    coupled = b if np.any(b) else None
    k, m = local_matrices(xy, a, coupled, d, beta0, mass, inertia)
    k, m = to_global(k, frames), to_global(m, frames)
    offset = f.offset[chunk]
    if np.any(offset):
        arm = np.repeat((offset[:, None] * frames[:, 2])[:, None], 3, axis=1)
        t = offset_transform(arm)
        k = np.einsum("eai,eab,ebj->eij", t, k, t, optimize=True)
        m = np.einsum("eai,eab,ebj->eij", t, m, t, optimize=True)
    return k, m
