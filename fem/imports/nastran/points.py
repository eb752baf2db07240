"""Masses, scalar springs and bushings of a Nastran deck as element matrices on grids
(basic axes, the deck's units).

* CONM2: a rigid mass M at the offset X from its grid (CID 0 or blank: X in basic; -1: X
  is the centre of gravity in basic; > 0: X and the inertia along that system's
  directions at the grid), inertia [[I11, -I21, -I31], [-I21, I22, -I32], [-I31, -I32,
  I33]] about the centre of gravity; CONM1: the 6 x 6 mass matrix (lower triangle) in CID.
* CMASS1 (PMASS), CMASS2 and CELAS1 (PELAS), CELAS2: a scalar mass or spring between
  component C1 of G1 and C2 of G2 (in their displacement systems; G2 blank: to ground):
  energy k (u1 - u2)^2 / 2.
* CBUSH (PBUSH K): six springs in the element system between the grids' rigid arms to the
  spring's point (S along GA-GB, or S1..S3 in OCID); the element system is CID's, or x
  along GA-GB and y towards the orientation vector (X1..X3 in GA's displacement system,
  or the grid GO); a grounded or zero-length bushing needs CID, as in Nastran.
* CBUSH1D (PBUSH1D K, M): an axial spring between the grids' translations along GA-GB (or
  CID's x; a grounded one needs CID), its mass M in halves on both ends;
* CGAP (PGAP) as Nastran's linear solutions take it, a spring of its initial state between
  the grids' translations (element axes as CBUSH's): closed (U0 <= 0) axial KA and
  transverse KT (default MU1 KA), open (U0 > 0) axial KB (default 1e-14 KA) alone.

Damping (CDAMPi, CVISC, PBUSH B, GE) does not enter a modal analysis (Nastran's SOL 103
ignores it too); it is listed as ignored by fem.imports.nastran.model.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from fem.elements.offsets import offset_transform
from fem.imports.nastran.bdf import BulkData, Card
from fem.imports.nastran.coords import DeckGeometry
from jaxflex.errors import InputError


@dataclass
class PointMatrices:
    """Element matrices on grids: ``grids`` lists of grid ids (one or more per element),
    ``stiffness``/``mass`` (6 n, 6 n) each, ``cards`` the elements' cards."""

    grids: list[tuple[int, ...]] = field(default_factory=list)
    stiffness: list[np.ndarray] = field(default_factory=list)
    mass: list[np.ndarray] = field(default_factory=list)
    cards: list[Card] = field(default_factory=list)

    def add(self, card: Card, grids, stiffness=None, mass=None) -> None:
        size = 6 * len(grids)
        zero = np.zeros((size, size))
        self.grids.append(tuple(grids))
        self.stiffness.append(zero if stiffness is None else stiffness)
        self.mass.append(zero if mass is None else mass)
        self.cards.append(card)


def component_vector(frame: np.ndarray, component: int) -> np.ndarray:
    """(6,) the basic DOF vector of component 1-6 of a grid whose displacement directions
    are the rows of ``frame`` (3, 3)."""
    out = np.zeros(6)
    if component <= 3:
        out[:3] = frame[component - 1]
    else:
        out[3:] = frame[component - 4]
    return out


def _grid(card: Card, index: int, label: str, bulk: BulkData, required=True) -> int | None:
    gid = card.integer(index, label)
    if gid in (None, 0):
        if required:
            card.required(None, index, label)
        return None
    if gid not in bulk.grids:
        raise InputError(f"deck: {card.where(index, label)}: grid {gid} is not in the deck")
    return gid


def _component(card: Card, index: int, label: str) -> int:
    text = card.components(index, label)
    if len(text) != 1:
        raise InputError(f"deck: {card.where(index, label)}: one component (1-6), got {text!r}")
    return int(text)


def _scalar(card: Card, value: float, first: int, bulk, geometry, out, kind: str) -> None:
    """A scalar spring or mass ``value`` between (G1, C1) at field ``first`` and (G2, C2)."""
    g1 = _grid(card, first, "G1", bulk)
    g2 = _grid(card, first + 2, "G2", bulk, required=False)
    c1 = _component(card, first + 1, "C1")
    grids = [g1] if g2 is None else [g1, g2]
    vector = [component_vector(geometry.frames([g1])[0], c1)]
    if g2 is not None:
        vector.append(
            -component_vector(geometry.frames([g2])[0], _component(card, first + 3, "C2"))
        )
    a = np.concatenate(vector)
    matrix = value * np.outer(a, a)
    out.add(card, grids, **{kind: matrix})


def _property_values(bulk: BulkData, name: str, label: str) -> dict[int, tuple[float, Card]]:
    """PELAS/PMASS values by property id (two properties per card)."""
    out = {}
    width = 4 if name == "PELAS" else 2
    for card in bulk.named(name):
        for first in range(0, 8, width):
            pid = card.integer(first, "PID")
            if pid is not None:
                out[pid] = (card.required(card.real(first + 1, label), first + 1, label), card)
    return out


def _conm2(card: Card, bulk, geometry: DeckGeometry, out) -> None:
    gid = _grid(card, 1, "G", bulk)
    cid = card.integer(2, "CID", 0)
    mass = card.real(3, "M", 0.0)
    x = np.array([card.real(k, f"X{k - 3}", 0.0) for k in (4, 5, 6)])
    names = ("I11", "I21", "I22", "I31", "I32", "I33")
    i11, i21, i22, i31, i32, i33 = (card.real(8 + k, n, 0.0) for k, n in enumerate(names))
    inertia = np.array([[i11, -i21, -i31], [-i21, i22, -i32], [-i31, -i32, i33]])
    position = geometry.positions[gid]
    if cid == -1:
        offset = x - position
    else:
        axes = geometry.system(cid, card, 2, "CID").frames(position[None])[0]
        offset = x @ axes
        inertia = axes.T @ inertia @ axes
    local = np.zeros((6, 6))
    local[:3, :3] = mass * np.eye(3)
    local[3:, 3:] = inertia
    t = offset_transform(offset[None, None])[0]
    out.add(card, [gid], mass=t.T @ local @ t)


def _conm1(card: Card, bulk, geometry: DeckGeometry, out) -> None:
    gid = _grid(card, 1, "G", bulk)
    cid = card.integer(2, "CID", 0)
    values = [card.real(k, "Mij", 0.0) for k in range(3, 24)]
    local = np.zeros((6, 6))
    local[np.tril_indices(6)] = values
    local = local + np.tril(local, -1).T
    axes = geometry.system(cid, card, 2, "CID").frames(geometry.positions[gid][None])[0]
    turn = np.kron(np.eye(2), axes)
    out.add(card, [gid], mass=turn.T @ local @ turn)


def _bush_stiffness(bulk: BulkData) -> dict[int, tuple[np.ndarray, Card]]:
    """PBUSH K1..K6 by property id."""
    out = {}
    for card in bulk.named("PBUSH"):
        pid = card.required(card.integer(0, "PID"), 0, "PID")
        k = np.zeros(6)
        for row in range(0, len(card.texts), 8):
            for offset in (0, 1):
                if card.text(row + offset) == "K":
                    k = np.array(
                        [card.real(row + offset + 1 + i, f"K{i + 1}", 0.0) for i in range(6)]
                    )
        out[pid] = (k, card)
    return out


def _bush_axes(card: Card, ga: int, gb, geometry: DeckGeometry, bulk) -> np.ndarray:
    cid = card.integer(7, "CID")
    xa = geometry.positions[ga]
    if cid is not None and cid >= 0:
        return geometry.system(cid, card, 7, "CID").frames(xa[None])[0]
    length = 0.0 if gb is None else float(np.linalg.norm(geometry.positions[gb] - xa))
    if gb is None or length <= 1e-4 * max(1.0, float(np.abs(xa).max())):
        raise InputError(
            f"deck: {card.where(7, 'CID')}: a grounded or zero-length {card.name} needs its "
            "element system CID (as in Nastran)"
        )
    x = (geometry.positions[gb] - xa) / length
    if card.text(4) and not card.text(5) and not card.text(6) and "." not in card.text(4):
        go = _grid(card, 4, "GO", bulk)
        v = geometry.positions[go] - xa
    else:
        v = np.array([card.real(k, f"X{k - 3}", 0.0) for k in (4, 5, 6)])
        v = v @ geometry.frames([ga])[0]
    z = np.cross(x, v)
    if np.linalg.norm(z) <= 1e-9 * max(np.linalg.norm(v), 1e-300):
        raise InputError(
            f"deck: {card.where(4, 'X1')}: the orientation vector is parallel to GA-GB (or "
            "zero); give another or CID"
        )
    z /= np.linalg.norm(z)
    return np.stack([x, np.cross(z, x), z])


def _cbush(card: Card, bulk, geometry: DeckGeometry, properties, out) -> None:
    ga = _grid(card, 2, "GA", bulk)
    gb = _grid(card, 3, "GB", bulk, required=False)
    pid = card.integer(1, "PID", card.integer(0, "EID"))
    bulk.referenced({p: c for p, (_, c) in properties.items()}, pid, ("PBUSH",), card, (1, "PID"))
    k = properties[pid][0]
    axes = _bush_axes(card, ga, gb, geometry, bulk)
    xa = geometry.positions[ga]
    xb = xa if gb is None else geometry.positions[gb]
    ocid = card.integer(9, "OCID", -1)
    if ocid == -1:
        point = xa + card.real(8, "S", 0.5) * (xb - xa)
    else:
        s = np.array([card.real(k, f"S{k - 9}", 0.0) for k in (10, 11, 12)])
        point = xa + s @ geometry.system(ocid, card, 9, "OCID").frames(xa[None])[0]
    turn = np.kron(np.eye(2), axes)
    arm_a = turn @ offset_transform((point - xa)[None, None])[0]
    if gb is None:
        b = -arm_a
        grids = [ga]
    else:
        b = np.hstack([-arm_a, turn @ offset_transform((point - xb)[None, None])[0]])
        grids = [ga, gb]
    out.add(card, grids, stiffness=b.T @ (k[:, None] * b))


def _gap_stiffness(bulk: BulkData) -> dict[int, tuple[np.ndarray, Card]]:
    """PGAP by property id: the spring constants (axial, transverse, transverse) of the
    gap's initial state (module docstring)."""
    out = {}
    for card in bulk.named("PGAP"):
        pid = card.required(card.integer(0, "PID"), 0, "PID")
        ka = card.required(card.real(3, "KA"), 3, "KA")
        if card.real(1, "U0", 0.0) > 0:  # open
            k = np.array([card.real(4, "KB", 1e-14 * ka), 0.0, 0.0])
        else:
            kt = card.real(5, "KT", card.real(6, "MU1", 0.0) * ka)
            k = np.array([ka, kt, kt])
        out[pid] = (k, card)
    return out


def _cgap(card: Card, bulk, geometry: DeckGeometry, properties, out) -> None:
    ga = _grid(card, 2, "GA", bulk)
    gb = _grid(card, 3, "GB", bulk)
    pid = card.integer(1, "PID", card.integer(0, "EID"))
    bulk.referenced({p: c for p, (_, c) in properties.items()}, pid, ("PGAP",), card, (1, "PID"))
    axes = _bush_axes(card, ga, gb, geometry, bulk)
    block = axes.T @ (properties[pid][0][:, None] * axes)
    k = np.zeros((12, 12))
    for i, j, sign in ((0, 0, 1), (1, 1, 1), (0, 1, -1), (1, 0, -1)):
        k[6 * i : 6 * i + 3, 6 * j : 6 * j + 3] = sign * block
    out.add(card, [ga, gb], stiffness=k)


def _cbush1d(card: Card, bulk, geometry: DeckGeometry, properties, out) -> None:
    ga = _grid(card, 2, "GA", bulk)
    gb = _grid(card, 3, "GB", bulk, required=False)
    pid = card.integer(1, "PID", card.integer(0, "EID"))
    prop = bulk.referenced(properties, pid, ("PBUSH1D",), card, (1, "PID"))
    cid = card.integer(4, "CID")
    xa = geometry.positions[ga]
    if cid is not None and cid >= 0:
        axis = geometry.system(cid, card, 4, "CID").frames(xa[None])[0][0]
    elif gb is None or np.allclose(geometry.positions[gb], xa):
        raise InputError(
            f"deck: {card.where(4, 'CID')}: a grounded or zero-length CBUSH1D needs CID"
        )
    else:
        axis = geometry.positions[gb] - xa
        axis = axis / np.linalg.norm(axis)
    a = np.concatenate([-axis, np.zeros(3), axis, np.zeros(3)])
    half = np.zeros(12)
    half[[0, 1, 2, 6, 7, 8]] = prop.real(3, "M", 0.0) / 2
    k, m = prop.real(1, "K", 0.0) * np.outer(a, a), np.diag(half)
    if gb is None:
        k, m = k[6:, 6:], m[:6, :6] * 2
    out.add(card, [ga] if gb is None else [ga, gb], stiffness=k, mass=m)


def point_matrices(bulk: BulkData, geometry: DeckGeometry) -> PointMatrices:
    """The element matrices of every mass, scalar spring and bushing of the deck."""
    out = PointMatrices()
    for card in bulk.named("CONM2"):
        _conm2(card, bulk, geometry, out)
    for card in bulk.named("CONM1"):
        _conm1(card, bulk, geometry, out)
    for name, prop, label, kind in (
        ("CELAS1", "PELAS", "K", "stiffness"),
        ("CMASS1", "PMASS", "M", "mass"),
    ):
        values = _property_values(bulk, prop, label)
        for card in bulk.named(name):
            pid = card.integer(1, "PID", card.integer(0, "EID"))
            if pid not in values:
                raise InputError(
                    f"deck: {card.where(1, 'PID')}: property {pid} is not a {prop} of the deck"
                )
            _scalar(card, values[pid][0], 2, bulk, geometry, out, kind)
    for name, label, kind in (("CELAS2", "K", "stiffness"), ("CMASS2", "M", "mass")):
        for card in bulk.named(name):
            value = card.required(card.real(1, label), 1, label)
            _scalar(card, value, 2, bulk, geometry, out, kind)
    properties = _bush_stiffness(bulk)
    for card in bulk.named("CBUSH"):
        _cbush(card, bulk, geometry, properties, out)
    gaps = _gap_stiffness(bulk)
    for card in bulk.named("CGAP"):
        _cgap(card, bulk, geometry, gaps, out)
    bushings = bulk.by_id("PBUSH1D")
    for card in bulk.named("CBUSH1D"):
        _cbush1d(card, bulk, geometry, bushings, out)
    return out
