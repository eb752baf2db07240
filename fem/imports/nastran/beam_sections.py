"""Beam and rod sections of a Nastran deck: PBAR, PBARL, PBEAM, PBEAML, PROD, PTUBE (and
the section a CONROD carries), in the deck's units.

* PBAR: A, I1, I2, I12, J, NSM; K1, K2 the shear area factors (blank: no shear
  deformation; both ignored when I12 is not 0, as in Nastran).
* PBEAM: the same at end A, stations up to end B (SO = YES, YESA, NO; X/XB = 1 is end B):
  a tapered beam takes the section averaged over its length (trapezoid rule over the
  stations, a note says so); K1, K2 default 1 (0: no shear deformation).
* PBARL, PBEAML (the beam library, y vertical and z horizontal as the Quick Reference Guide
  draws them): ROD, TUBE, TUBE2, BAR, BOX, BOX1, I, I1, CHAN, CHAN1, CHAN2, T, T2, L, Z,
  HAT; A, I1 = int y^2 dA, I2, I12 about the centroid from the rectangles of the section,
  J from the closed forms of thin-walled sections (open: the sum of long x short^3 / 3 over
  its rectangles; BOX, BOX1: Bredt's 4 A_m^2 / oint ds / t; BAR: Saint-Venant's series;
  ROD and TUBE exact). No shear deformation.
* PROD, PTUBE, CONROD: rods (axial and torsion only).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from fem.imports.nastran.bdf import BulkData, Card
from fem.imports.nastran.materials import Material, Materials
from jaxflex.errors import InputError

BEAM_PROPERTIES = ("PBAR", "PBARL", "PBEAM", "PBEAML", "PROD", "PTUBE")
LIBRARY_DIMENSIONS = {
    "ROD": 1, "TUBE": 2, "TUBE2": 2, "BAR": 2, "BOX": 4, "BOX1": 6, "I": 6, "I1": 4,
    "CHAN": 4, "CHAN1": 4, "CHAN2": 4, "T": 4, "T2": 4, "L": 4, "Z": 4, "HAT": 4,
}  # fmt: skip


@dataclass
class BeamSection:
    """A section: area, I1 (plane 1), I2, I12, J, shear area factors ``k1``, ``k2``
    (None: no shear deformation), non-structural mass per length ``nsm``, its material;
    ``rod``: axial and torsion only."""

    card: Card
    material: Material
    area: float
    i1: float = 0.0
    i2: float = 0.0
    i12: float = 0.0
    j: float = 0.0
    k1: float | None = None
    k2: float | None = None
    nsm: float = 0.0
    rod: bool = False
    notes: list[str] = field(default_factory=list)


def _rectangles(parts: list[tuple[float, float, float, float]]) -> tuple[float, ...]:
    """(A, I1, I2, I12) about the centroid of a union of rectangles (z0, z1, y0, y1)."""
    r = np.array(parts, dtype=float)
    w, h = r[:, 1] - r[:, 0], r[:, 3] - r[:, 2]
    if (w <= 0).any() or (h <= 0).any():
        raise ValueError("a wall of non-positive size")
    area = w * h
    zc, yc = (r[:, 0] + r[:, 1]) / 2, (r[:, 2] + r[:, 3]) / 2
    total = area.sum()
    z0, y0 = area @ zc / total, area @ yc / total
    i1 = np.sum(w * h**3 / 12 + area * (yc - y0) ** 2)
    i2 = np.sum(h * w**3 / 12 + area * (zc - z0) ** 2)
    i12 = np.sum(area * (yc - y0) * (zc - z0))
    if abs(i12) <= 1e-12 * np.sqrt(i1 * i2):  # a symmetric section: 0, not round-off
        i12 = 0.0
    return float(total), float(i1), float(i2), float(i12)


def _solid_rectangle_torsion(a: float, b: float) -> float:
    """Saint-Venant's torsion constant of an a x b rectangle (a >= b), series to 1e-12."""
    a, b = max(a, b), min(a, b)
    total = sum(math.tanh(n * math.pi * a / (2 * b)) / n**5 for n in range(1, 200, 2))
    return a * b**3 / 3 * (1 - 192 / math.pi**5 * b / a * total)


def _open_torsion(parts) -> float:
    """Saint-Venant's constant of a thin-walled open section: the sum of long x short^3 / 3
    over its rectangles."""
    r = np.array(parts, dtype=float)
    w, h = r[:, 1] - r[:, 0], r[:, 3] - r[:, 2]
    return float(np.sum(np.maximum(w, h) * np.minimum(w, h) ** 3 / 3))


def _open_parts(kind: str, d: list[float]) -> list[tuple[float, float, float, float]]:
    """The rectangles (z0, z1, y0, y1) of an open library section (y up, z across)."""
    if kind == "I":
        h, a, b, tw, ta, tb = d
        return [(-a / 2, a / 2, 0, ta), (-tw / 2, tw / 2, ta, h - tb), (-b / 2, b / 2, h - tb, h)]
    if kind == "I1":
        overhang, tw, inner, h = d
        tf, w = (h - inner) / 2, overhang + tw
        return [(-w / 2, w / 2, 0, tf), (-tw / 2, tw / 2, tf, h - tf), (-w / 2, w / 2, h - tf, h)]
    if kind == "CHAN":
        width, h, tw, tf = d
        return [(0, tw, 0, h), (tw, width, 0, tf), (tw, width, h - tf, h)]
    if kind == "CHAN1":
        flange, tw, inner, h = d
        tf = (h - inner) / 2
        return [(0, tw, 0, h), (tw, tw + flange, 0, tf), (tw, tw + flange, h - tf, h)]
    if kind == "CHAN2":
        leg, bottom, h, width = d
        return [(0, width, 0, bottom), (0, leg, bottom, h), (width - leg, width, bottom, h)]
    if kind == "T":
        width, h, tf, tw = d
        return [(-width / 2, width / 2, h - tf, h), (-tw / 2, tw / 2, 0, h - tf)]
    if kind == "T2":
        width, h, tf, tw = d
        return [(-width / 2, width / 2, 0, tf), (-tw / 2, tw / 2, tf, h)]
    if kind == "L":
        width, h, t1, t2 = d
        return [(0, width, 0, t1), (0, t2, t1, h)]
    if kind == "Z":
        flange, tw, inner, h = d
        tf = (h - inner) / 2
        return [(0, flange, h - tf, h), (flange, flange + tw, 0, h),
                (flange + tw, 2 * flange + tw, 0, tf)]  # fmt: skip
    if kind == "HAT":
        h, t, top, brim = d
        return [(0, top, h - t, h), (0, t, t, h - t), (top - t, top, t, h - t),
                (-brim, t, 0, t), (top - t, top + brim, 0, t)]  # fmt: skip
    raise KeyError(kind)


def library_section(kind: str, dims: list[float]) -> tuple[float, float, float, float, float]:
    """(A, I1, I2, I12, J) of a beam-library section ``kind`` with dimensions ``dims``."""
    if kind == "ROD":
        (r,) = dims
        return math.pi * r**2, math.pi * r**4 / 4, math.pi * r**4 / 4, 0.0, math.pi * r**4 / 2
    if kind in ("TUBE", "TUBE2"):
        outer, inner = dims if kind == "TUBE" else (dims[0], dims[0] - dims[1])
        if not 0 <= inner < outer:
            raise ValueError("the inner radius must lie in [0, the outer radius)")
        i = math.pi * (outer**4 - inner**4) / 4
        return math.pi * (outer**2 - inner**2), i, i, 0.0, 2 * i
    if kind == "BAR":
        b, h = dims
        return b * h, b * h**3 / 12, h * b**3 / 12, 0.0, _solid_rectangle_torsion(b, h)
    if kind in ("BOX", "BOX1"):
        if kind == "BOX":
            b, h, t_flange, t_web = dims
            top = bottom = t_flange
            left = right = t_web
        else:
            b, h, top, bottom, right, left = dims
        parts = [(0, b, 0, bottom), (0, b, h - top, h), (0, left, bottom, h - top)]
        parts.append((b - right, b, bottom, h - top))
        bm, hm = b - (left + right) / 2, h - (top + bottom) / 2  # mid-line of the walls
        loop = bm / top + bm / bottom + hm / left + hm / right
        return (*_rectangles(parts), 4 * (bm * hm) ** 2 / loop)  # Bredt
    parts = _open_parts(kind, dims)
    return (*_rectangles(parts), _open_torsion(parts))


def _library(card: Card, kind: str, dims: list[float], where: int) -> tuple[float, ...]:
    if kind not in LIBRARY_DIMENSIONS:
        raise InputError(
            f"deck: {card.where(3, 'TYPE')}: section type {kind!r} is not supported; supported: "
            f"{', '.join(LIBRARY_DIMENSIONS)} (or give the section as a PBAR/PBEAM)"
        )
    try:
        values = library_section(kind, dims)
    except (ValueError, ZeroDivisionError) as exc:
        raise InputError(f"deck: {card.where(where, 'DIM1')}: {kind} {dims}: {exc}") from None
    if values[0] <= 0:
        raise InputError(f"deck: {card.where(where, 'DIM1')}: {kind} {dims} has no area")
    return values


def _dims(card: Card, start: int, count: int) -> list[float]:
    return [
        card.required(card.real(start + k, f"DIM{k + 1}"), start + k, f"DIM{k + 1}")
        for k in range(count)
    ]


def _pbar(card: Card, material: Material) -> BeamSection:
    area = card.real(2, "A", 0.0)
    section = BeamSection(card, material, area, card.real(3, "I1", 0.0), card.real(4, "I2", 0.0))
    section.j, section.nsm = card.real(5, "J", 0.0), card.real(6, "NSM", 0.0)
    section.i12 = card.real(18, "I12", 0.0)
    if section.i12 == 0:
        section.k1, section.k2 = card.real(16, "K1"), card.real(17, "K2")
    return section


def _pbarl(card: Card, material: Material) -> BeamSection:
    kind = card.text(3)
    count = LIBRARY_DIMENSIONS.get(kind, 0)
    area, i1, i2, i12, j = _library(card, kind, _dims(card, 8, count), 8)
    section = BeamSection(card, material, area, i1, i2, i12, j)
    section.nsm = card.real(8 + count, "NSM", 0.0)
    return section


def _averaged(values_at: list[tuple[float, list[float]]]) -> list[float]:
    """Trapezoid averages over x/L in [0, 1] of the values at stations (x/L, values)."""
    x = np.array([s for s, _ in values_at])
    y = np.array([v for _, v in values_at])
    if x[-1] < 1.0:  # end B not given: the last station's values
        x, y = np.append(x, 1.0), np.vstack([y, y[-1]])
    return list(np.trapezoid(y, x, axis=0))


def _pbeam(card: Card, material: Material) -> BeamSection:
    names = ("A", "I1", "I2", "I12", "J", "NSM")
    keywords = ("YES", "YESA", "NO")
    end_a = [card.real(2 + k, n, 0.0) for k, n in enumerate(names)]
    # row 2 holds end A's stress points unless it starts a station (as pyNastran reads it)
    index = 8 if card.text(8) in keywords else 16
    stations = []
    while card.text(index) in keywords:  # stations in any order, end B at X/XB = 1
        x = card.real(index + 1, "X/XB", 1.0)
        values = [card.real(index + 2 + k, n) for k, n in enumerate(names)]
        if x >= 1.0:  # end B: blanks take end A's values
            values = [a if v is None else v for v, a in zip(values, end_a, strict=True)]
        if None not in values:  # an intermediate station left blank is interpolated
            stations.append((x, values))
        index += 16 if card.text(index) == "YES" else 8
    stations.sort(key=lambda station: station[0])
    section_values = end_a
    notes = []
    if stations and any(v != end_a for _, v in stations):
        section_values = _averaged([(0.0, end_a), *stations])
        notes.append(f"{card.label}: tapered; the section averaged over the length")
    area, i1, i2, i12, j, nsm = section_values
    section = BeamSection(card, material, area, i1, i2, i12, j, nsm=nsm, notes=notes)
    k1, k2 = card.real(index, "K1", 1.0), card.real(index + 1, "K2", 1.0)
    if i12 == 0:
        section.k1, section.k2 = (k if k else None for k in (k1, k2))
    return section


def _pbeaml(card: Card, material: Material) -> BeamSection:
    kind = card.text(3)
    count = LIBRARY_DIMENSIONS.get(kind, 0)
    index = 8
    values = [(0.0, [*_library(card, kind, _dims(card, index, count), index),
                     card.real(index + count, "NSM", 0.0)])]  # fmt: skip
    index += count + 1
    while index + 2 + count <= len(card.texts) and card.text(index) in ("YES", "NO"):
        x = card.real(index + 1, "X/XB", 1.0)
        dims = _dims(card, index + 2, count)
        nsm = card.real(index + 2 + count, "NSM", 0.0)
        values.append((x, [*_library(card, kind, dims, index + 2), nsm]))
        index += 3 + count
        if x >= 1.0:
            break
    notes = []
    averaged = values[0][1]
    if len(values) > 1 and any(v != values[0][1] for _, v in values):
        averaged = _averaged(values)
        notes.append(f"{card.label}: tapered; the section averaged over the length")
    area, i1, i2, i12, j, nsm = averaged
    return BeamSection(card, material, area, i1, i2, i12, j, nsm=nsm, notes=notes)


def _prod(card: Card, material: Material) -> BeamSection:
    section = BeamSection(card, material, card.real(2, "A", 0.0), j=card.real(3, "J", 0.0))
    section.nsm, section.rod = card.real(5, "NSM", 0.0), True
    return section


def _ptube(card: Card, material: Material) -> BeamSection:
    outer = card.required(card.real(2, "OD"), 2, "OD")
    wall = card.real(3, "T", outer / 2)
    area, _, _, _, j = library_section("TUBE", [outer / 2, outer / 2 - wall])
    section = BeamSection(card, material, area, j=j, nsm=card.real(4, "NSM", 0.0), rod=True)
    if card.real(5, "OD2") not in (None, outer):
        section.notes.append(f"{card.label}: tapered; the section at end A")
    return section


READERS = {
    "PBAR": _pbar,
    "PBARL": _pbarl,
    "PBEAM": _pbeam,
    "PBEAML": _pbeaml,
    "PROD": _prod,
    "PTUBE": _ptube,
}


class BeamSections:
    """The deck's beam and rod properties, read when first used."""

    def __init__(self, bulk: BulkData, materials: Materials) -> None:
        self.bulk, self.materials = bulk, materials
        self.cards = bulk.by_id(*READERS)
        self._read: dict[int, BeamSection] = {}

    def get(self, pid: int, user: Card, index: int, allowed: tuple[str, ...]) -> BeamSection:
        card = self.bulk.referenced(self.cards, pid, allowed, user, (index, "PID"))
        if pid not in self._read:
            material = self.materials.any(
                card.required(card.integer(1, "MID"), 1, "MID"), card, 1, "MID", ("MAT1",)
            )
            self._read[pid] = READERS[card.name](card, material)
        return self._read[pid]

    def conrod(self, card: Card) -> BeamSection:
        """The section a CONROD carries on itself (MID, A, J, C, NSM in fields 5-9)."""
        material = self.materials.any(
            card.required(card.integer(3, "MID"), 3, "MID"), card, 3, "MID", ("MAT1",)
        )
        section = BeamSection(card, material, card.real(4, "A", 0.0), j=card.real(5, "J", 0.0))
        section.nsm, section.rod = card.real(7, "NSM", 0.0), True
        return section

    def notes(self) -> list[str]:
        return [n for s in self._read.values() for n in s.notes]
