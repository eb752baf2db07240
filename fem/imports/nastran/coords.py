"""Coordinate systems of a Nastran deck and the grids placed in them.

Systems (Quick Reference Guide, CORD1R/C/S and CORD2R/C/S): rectangular (x, y, z),
cylindrical (R, THETA in degrees, Z) and spherical (R, THETA from the z axis, PHI about it,
degrees). A CORD2x is given by three points A (origin), B (on the z axis) and C (in the
x-z plane) in its reference system RID (itself any kind); a CORD1x by three grids. Systems
and grids depend on each other (a CORD1x needs its grids, a grid its CP system), chains of
any depth are resolved, a cycle or a missing system is an error naming it.

A grid's position is given in its system CP; its displacements are in its system CD: the
components 1, 2, 3 (and the rotations 4, 5, 6 about them) run along the system's local
directions at the grid (cylindrical: radial, tangential, axial; spherical: radial,
meridional, azimuthal). On the axis of a cylindrical or spherical system THETA = 0 (and
PHI = 0) gives the directions, as Nastran does. Everything here is in the deck's units.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fem.imports.nastran.bdf import BulkData, Card
from jaxflex.errors import InputError

KINDS = {"CORD2R": "R", "CORD2C": "C", "CORD2S": "S", "CORD1R": "R", "CORD1C": "C"}
KINDS["CORD1S"] = "S"
UNSUPPORTED = ("CORD3G", "CORD3R")


@dataclass(frozen=True)
class CoordSystem:
    """A resolved system: ``kind`` "R", "C" or "S", ``origin`` (3,) and ``axes`` (3, 3)
    (rows: its x, y, z unit vectors) in the basic system."""

    id: int
    kind: str
    origin: np.ndarray
    axes: np.ndarray
    card: Card | None = None

    def to_basic(self, coords: np.ndarray) -> np.ndarray:
        """(N, 3) basic positions of (N, 3) coordinates in this system (angles in
        degrees)."""
        c = np.atleast_2d(np.asarray(coords, dtype=float))
        if self.kind == "C":
            t = np.radians(c[:, 1])
            local = np.column_stack([c[:, 0] * np.cos(t), c[:, 0] * np.sin(t), c[:, 2]])
        elif self.kind == "S":
            t, p = np.radians(c[:, 1]), np.radians(c[:, 2])
            sin_t = np.sin(t)
            local = c[:, :1] * np.column_stack([sin_t * np.cos(p), sin_t * np.sin(p), np.cos(t)])
        else:
            local = c
        return self.origin + local @ self.axes

    def frames(self, points: np.ndarray) -> np.ndarray:
        """(N, 3, 3) the directions of components 1, 2, 3 (rows, basic) at basic
        ``points`` (N, 3)."""
        points = np.atleast_2d(np.asarray(points, dtype=float))
        n = len(points)
        if self.kind == "R":
            return np.broadcast_to(self.axes, (n, 3, 3)).copy()
        q = (points - self.origin) @ self.axes.T
        phi = np.arctan2(q[:, 1], q[:, 0])
        cos_p, sin_p, zero = np.cos(phi), np.sin(phi), np.zeros(n)
        if self.kind == "C":
            local = np.stack(
                [
                    np.column_stack([cos_p, sin_p, zero]),
                    np.column_stack([-sin_p, cos_p, zero]),
                    np.column_stack([zero, zero, zero + 1]),
                ],
                axis=1,
            )
        else:
            theta = np.arctan2(np.hypot(q[:, 0], q[:, 1]), q[:, 2])
            cos_t, sin_t = np.cos(theta), np.sin(theta)
            local = np.stack(
                [
                    np.column_stack([sin_t * cos_p, sin_t * sin_p, cos_t]),
                    np.column_stack([cos_t * cos_p, cos_t * sin_p, -sin_t]),
                    np.column_stack([-sin_p, cos_p, zero]),
                ],
                axis=1,
            )
        return local @ self.axes


BASIC = CoordSystem(0, "R", np.zeros(3), np.eye(3))


def axes_from_points(a, b, c, what: str) -> np.ndarray:
    """(3, 3) the unit x, y, z axes (rows) of a system through A (origin), B (on its z axis)
    and C (in its x-z plane), basic points (3,); a ValueError naming ``what`` (points or
    grids) if they define none."""
    a, b, c = (np.asarray(p, dtype=float) for p in (a, b, c))
    z = b - a
    if np.linalg.norm(z) == 0:
        raise ValueError(f"{what} A and B coincide")
    z = z / np.linalg.norm(z)
    y = np.cross(z, c - a)
    if np.linalg.norm(y) <= 1e-12 * max(np.linalg.norm(c - a), 1e-300):
        raise ValueError(f"{what} C lies on the line A-B (no x-z plane)")
    y = y / np.linalg.norm(y)
    return np.stack([np.cross(y, z), y, z])


def _from_points(cid: int, kind: str, a, b, c, card: Card, what: str) -> CoordSystem:
    try:
        axes = axes_from_points(a, b, c, what)
    except ValueError as exc:
        raise InputError(f"deck: {card.where(None)}: system {cid}: {exc}") from None
    return CoordSystem(cid, kind, np.asarray(a, float), axes, card)


@dataclass
class _Pending:
    cid: int
    kind: str
    card: Card
    needs: str  # "system" (CORD2: RID) or "grids" (CORD1)
    refs: tuple[int, ...]
    first: int  # field index of the first reference


def _pending(bulk: BulkData) -> dict[int, _Pending]:
    out: dict[int, _Pending] = {}

    def add(item: _Pending) -> None:
        if item.cid in out or item.cid == 0:
            raise InputError(
                f"deck: {item.card.where(None)}: coordinate system {item.cid} is defined "
                + ("twice" if item.cid else "as the basic system 0")
            )
        out[item.cid] = item

    for card in bulk.named("CORD2R", "CORD2C", "CORD2S"):
        cid = card.required(card.integer(0, "CID"), 0, "CID")
        add(_Pending(cid, KINDS[card.name], card, "system", (card.integer(1, "RID", 0),), 1))
    for card in bulk.named("CORD1R", "CORD1C", "CORD1S"):
        for first in (0, 4):
            cid = card.integer(first, "CID")
            if cid is None:
                continue
            grids = tuple(card.required(card.integer(first + k, f"G{k}"), first + k, f"G{k}")
                          for k in (1, 2, 3))  # fmt: skip
            add(_Pending(cid, KINDS[card.name], card, "grids", grids, first + 1))
    return out


class DeckGeometry:
    """The deck's systems and every grid's basic position (deck units): ``systems`` by
    id, ``positions`` by grid id (3,)."""

    def __init__(self, bulk: BulkData) -> None:
        self.bulk = bulk
        self.systems: dict[int, CoordSystem] = {0: BASIC}
        self.positions: dict[int, np.ndarray] = {}
        pending = _pending(bulk)
        waiting = {g.id: g for g in bulk.grids.values()}
        while True:
            progress = self._place_grids(waiting)
            for cid, item in list(pending.items()):
                system = self._resolve(item)
                if system is not None:
                    self.systems[cid] = system
                    del pending[cid]
                    progress = True
            if not progress:
                break
        if waiting:
            grid = next(iter(waiting.values()))
            self._missing(grid.cp, grid.card, 1, "CP", pending)
        if pending:
            item = next(iter(pending.values()))
            if item.needs == "system":
                self._missing(item.refs[0], item.card, 1, "RID", pending)
            gid = next(g for g in item.refs if g not in self.positions)
            raise InputError(
                f"deck: {item.card.where(None)}: system {item.cid} is defined by grid {gid}, "
                "which is not in the deck"
            )

    def _place_grids(self, waiting: dict) -> bool:
        by_system: dict[int, list] = {}
        for grid in waiting.values():
            if grid.cp in self.systems:
                by_system.setdefault(grid.cp, []).append(grid)
        for cp, grids in by_system.items():
            placed = self.systems[cp].to_basic(np.array([g.xyz for g in grids]))
            for grid, xyz in zip(grids, placed, strict=True):
                self.positions[grid.id] = xyz
                del waiting[grid.id]
        return bool(by_system)

    def _resolve(self, item: _Pending) -> CoordSystem | None:
        card = item.card
        if item.needs == "system":
            ref = self.systems.get(item.refs[0])
            if ref is None:
                return None
            a, b, c = (
                [card.real(k, f"{p}{k - s + 1}", 0.0) for k in range(s, s + 3)]
                for p, s in (("A", 2), ("B", 5), ("C", 8))
            )
            a, b, c = ref.to_basic(np.array([a, b, c]))
            return _from_points(item.cid, item.kind, a, b, c, card, "points")
        if not all(g in self.positions for g in item.refs):
            return None
        a, b, c = (self.positions[g] for g in item.refs)
        return _from_points(item.cid, item.kind, a, b, c, card, "grids")

    def _missing(self, cid: int, card: Card, index: int, label: str, pending: dict) -> None:
        what = "is not in the deck"
        if cid in pending:
            what = "depends on itself through other systems or grids (a cycle)"
        other = [n for n in UNSUPPORTED if self.bulk.find(cid, n)]
        if other:
            what = f"is a {other[0]}; supported: CORD1R/C/S, CORD2R/C/S"
        raise InputError(f"deck: {card.where(index, label)}: coordinate system {cid} {what}")

    def system(self, cid: int, card: Card, index: int, label: str) -> CoordSystem:
        """The system ``cid`` a card's field refers to (an error naming the field if it is
        not in the deck)."""
        if cid not in self.systems:
            self._missing(cid, card, index, label, {})
        return self.systems[cid]

    def frames(self, grid_ids) -> np.ndarray:
        """(N, 3, 3) displacement directions (rows, basic) of grids ``grid_ids``: their CD
        systems at their positions."""
        ids = [int(g) for g in grid_ids]
        out = np.empty((len(ids), 3, 3))
        by_cd: dict[int, list[int]] = {}
        for k, gid in enumerate(ids):
            by_cd.setdefault(max(self.bulk.grids[gid].cd, 0), []).append(k)
        for cd, rows in by_cd.items():
            grid = self.bulk.grids[ids[rows[0]]]
            system = self.system(cd, grid.card, 5, "CD")
            out[rows] = system.frames(np.array([self.positions[ids[k]] for k in rows]))
        return out
