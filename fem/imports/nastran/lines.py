"""The line elements of a Nastran deck (CBAR, CBEAM, CROD, CONROD, CTUBE) as 12-DOF
beams (fem.elements.beam), basic axes, the deck's units.

CBAR/CBEAM: x from end A to end B (the grids plus the offsets WA, WB), y towards the
orientation vector v (X1, X2, X3, or the grid G0: v = G0 - GA), z = x cross v; OFFT (CBAR;
CBEAM field 9 when not a real BIT) says where v and the offsets are given: G the
displacement system of the grid (default GGG), B basic, O (offsets) the element system.
BAROR/BEAMOR give blank fields their defaults. Pin flags PA, PB (element system) are
condensed out. Sections with I12 turn to their principal axes. CBEAM's warping DOFs (SA,
SB) are refused. CROD/CONROD/CTUBE: axial and torsion (no bending stiffness).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from fem.elements.beam import local_matrices, release, to_global
from fem.imports.nastran.bdf import BulkData, Card
from fem.imports.nastran.beam_sections import BeamSection, BeamSections
from fem.imports.nastran.coords import DeckGeometry
from jaxflex.errors import InputError

BEAMS = {"CBAR": ("PBAR", "PBARL"), "CBEAM": ("PBEAM", "PBEAML", "PBAR", "PBARL")}
RODS = {"CROD": ("PROD",), "CTUBE": ("PTUBE",)}
LINE_CARDS = (*BEAMS, *RODS, "CONROD")


@dataclass
class LineElements:
    """Beams and rods: ``grids`` (E, 2) ids, ``cards``, per element section and geometry;
    :meth:`matrices` gives their stiffness and mass (E, 12, 12) in basic axes."""

    grids: list[tuple[int, int]] = field(default_factory=list)
    cards: list[Card] = field(default_factory=list)
    sections: list[BeamSection] = field(default_factory=list)
    axes: list[np.ndarray] = field(default_factory=list)
    lengths: list[float] = field(default_factory=list)
    offsets: list[np.ndarray] = field(default_factory=list)
    released: list[np.ndarray] = field(default_factory=list)

    def matrices(self) -> tuple[np.ndarray, np.ndarray]:
        if not self.cards:
            return np.zeros((0, 12, 12)), np.zeros((0, 12, 12))
        s = self.sections
        area = np.array([x.area for x in s])
        inertia = np.array([[x.i1, x.i2, x.i12] for x in s])
        axes = np.array(self.axes)
        i1, i2 = inertia[:, 0].copy(), inertia[:, 1].copy()
        coupled = np.flatnonzero(inertia[:, 2] != 0)
        for e in coupled:  # principal axes of the section
            tensor = np.array([[inertia[e, 0], inertia[e, 2]], [inertia[e, 2], inertia[e, 1]]])
            values, vectors = np.linalg.eigh(tensor)
            i1[e], i2[e] = values[1], values[0]
            y, z = axes[e, 1], axes[e, 2]
            new_y = vectors[0, 1] * y + vectors[1, 1] * z
            axes[e] = np.stack([axes[e, 0], new_y, np.cross(axes[e, 0], new_y)])
        e_mod = np.array([x.material.e for x in s])
        g_mod = np.array([x.material.g for x in s])

        def shear(k):
            return np.array([np.inf if getattr(x, k) is None else getattr(x, k) for x in s]) * area

        k, m = local_matrices(
            np.array(self.lengths), e_mod, g_mod, area, i1, i2, np.array([x.j for x in s]),
            np.array([x.material.rho for x in s]), np.array([x.nsm for x in s]),
            shear("k1"), shear("k2"), np.array([x.rod for x in s]),
        )  # fmt: skip
        k, m = release(k, m, self.released, [c.where(None) for c in self.cards])
        offsets = np.array(self.offsets)
        return to_global(k, axes, offsets), to_global(m, axes, offsets)


def _orientation(card, offt: str, ga: int, geometry: DeckGeometry, bulk, defaults) -> np.ndarray:
    """The orientation vector v in basic (CBAR/CBEAM fields 5-7, or BAROR/BEAMOR's)."""
    source = card if card.text(4) else defaults
    if source is None:
        card.required(None, 4, "X1/G0")
    first = source.text(4)
    if first and "." not in first and "E" not in first and not source.text(5):
        g0 = source.integer(4, "G0")
        if g0 not in bulk.grids:
            raise InputError(f"deck: {source.where(4, 'G0')}: grid {g0} is not in the deck")
        return geometry.positions[g0] - geometry.positions[ga]
    v = np.array([source.real(k, f"X{k - 3}", 0.0) for k in (4, 5, 6)])
    return v if offt[0] == "B" else v @ geometry.frames([ga])[0]


def _offset(card, start: int, code: str, grid: int, geometry, axes_of) -> np.ndarray:
    w = np.array([card.real(start + k, f"W{k + 1}", 0.0) for k in range(3)])
    if code == "B" or not w.any():
        return w
    if code == "G":
        return w @ geometry.frames([grid])[0]
    return w @ axes_of()


def _pins(card: Card, index: int, label: str) -> list[int]:
    text = card.text(index)
    return [] if not text else [int(c) - 1 for c in card.components(index, label)]


def _defaults(bulk: BulkData, name: str) -> Card | None:
    cards = bulk.named(name)
    return cards[0] if cards else None


def line_elements(bulk: BulkData, geometry: DeckGeometry, sections: BeamSections):
    """Every beam and rod of the deck."""
    out = LineElements()
    for name in (*BEAMS, *RODS, "CONROD"):
        defaults = _defaults(bulk, {"CBAR": "BAROR", "CBEAM": "BEAMOR"}.get(name, ""))
        for card in bulk.named(name):
            first = 1 if name == "CONROD" else 2
            ga, gb = (card.required(card.integer(first + k, f"G{'AB'[k]}"), first + k,
                                    f"G{'AB'[k]}") for k in (0, 1))  # fmt: skip
            for k, g in enumerate((ga, gb)):
                if g not in bulk.grids:
                    raise InputError(
                        f"deck: {card.where(first + k, f'G{chr(65 + k)}')}: grid {g} is not in "
                        "the deck"
                    )
            if name == "CONROD":
                section = sections.conrod(card)
            else:
                eid = card.integer(0, "EID")
                pid = card.integer(1, "PID")
                if pid is None and defaults is not None:
                    pid = defaults.integer(1, "PID")
                pid = eid if pid is None else pid
                section = sections.get(pid, card, 1, {**BEAMS, **RODS}[name])
            _add(out, card, name, ga, gb, section, geometry, bulk, defaults)
    return out


def _add(out, card, name, ga, gb, section, geometry, bulk, defaults) -> None:
    xa, xb = geometry.positions[ga], geometry.positions[gb]
    released = np.zeros(0, dtype=np.int64)
    offsets = np.zeros((2, 3))
    offt = "GGG"
    if name in BEAMS:
        if name == "CBEAM" and (card.text(16) or card.text(17)):
            raise InputError(f"deck: {card.where(16, 'SA')}: warping DOFs are not supported")
        text = card.text(7) or (defaults.text(7) if defaults is not None else "")
        if text and not any(ch.isdigit() for ch in text):
            offt = text
        if len(offt) != 3 or offt[0] not in "GB" or any(c not in "GBO" for c in offt[1:]):
            raise InputError(
                f"deck: {card.where(7, 'OFFT')}: {offt!r}; allowed: G/B, then G/B/O twice"
            )
        v = _orientation(card, offt, ga, geometry, bulk, defaults)
        axes_cache: list[np.ndarray] = []

        def axes_of():
            if not axes_cache:
                axes_cache.append(_axes(card, xb - xa, v))
            return axes_cache[0]

        offsets[0] = _offset(card, 10, offt[1], ga, geometry, axes_of)
        offsets[1] = _offset(card, 13, offt[2], gb, geometry, axes_of)
        released = np.array(
            _pins(card, 8, "PA") + [6 + p for p in _pins(card, 9, "PB")], dtype=np.int64
        )
    else:
        v = None
    axis = (xb + offsets[1]) - (xa + offsets[0])
    length = float(np.linalg.norm(axis))
    if length <= 0:
        raise InputError(f"deck: {card.where(None)}: its ends coincide (zero length)")
    out.grids.append((ga, gb))
    out.cards.append(card)
    out.sections.append(section)
    out.axes.append(_axes(card, axis, v))
    out.lengths.append(length)
    out.offsets.append(offsets)
    out.released.append(released)


def _axes(card: Card, axis: np.ndarray, v: np.ndarray | None) -> np.ndarray:
    x = axis / np.linalg.norm(axis)
    if v is None:  # a rod: any axes normal to it
        v = np.eye(3)[int(np.argmin(np.abs(x)))]
    z = np.cross(x, v)
    if np.linalg.norm(z) <= 1e-9 * max(np.linalg.norm(v), 1e-300):
        raise InputError(
            f"deck: {card.where(4, 'X1')}: the orientation vector is parallel to the beam (or zero)"
        )
    z /= np.linalg.norm(z)
    return np.stack([x, np.cross(z, x), z])
