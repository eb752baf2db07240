"""What the Nastran door models, what it leaves out on purpose, and what it refuses: by
card name, with the share of the deck's mass each refused card carries.

* Modelled: shells (fem.imports.nastran.shells), solids (fem.imports.nastran.solids), beams and rods
  (fem.imports.nastran.lines), masses, scalar springs, bushings and gaps
  (fem.imports.nastran.points), shear panels (fem.imports.nastran.panels), fasteners and spot welds
  between shells (fem.imports.nastran.connectors), rigid elements and MPCs
  (fem.imports.nastran.constraints), their properties, materials and coordinate systems.
* Left out, listed in the model's record: damping (CDAMPi, CVISC: a modal analysis has
  none, as Nastran's SOL 103), reduction and support sets (ASET, OMIT, QSET, SUPORT: the
  full model is solved, rigid-body modes are found by the eigen solver), SPCD (the
  component is held), and every card that changes no stiffness or mass (loads, output,
  solution control, aerodynamics, heat transfer).
* Refused, in one message: other elements (pyramids, axisymmetric elements, elements on
  scalar points, seams), direct matrix input, glued or contact surfaces, part
  superelements. The message gives each card's count and its share of the mass (estimated
  from the element geometry, its property and material; "no mass" for massless elements)
  and recommends reading the modes the user's own solver computed.
"""

from __future__ import annotations

import re

import numpy as np

from fem.imports.nastran.bdf import BulkData, Card
from fem.imports.nastran.beam_sections import BeamSections
from fem.imports.nastran.connectors import CONNECTOR_CARDS
from fem.imports.nastran.constraints import RIGID_CARDS
from fem.imports.nastran.coords import DeckGeometry
from fem.imports.nastran.lines import BEAMS, LINE_CARDS, RODS
from fem.imports.nastran.materials import Materials
from fem.imports.nastran.shells import SHELL_CARDS, ShellSections, read_shell
from fem.imports.nastran.solids import SOLID_CARDS
from jaxflex.errors import InputError

POINT_CARDS = ("CONM1", "CONM2", "CMASS1", "CMASS2", "CELAS1", "CELAS2", "CBUSH", "CBUSH1D")
POINT_CARDS += ("CGAP",)
PANEL_CARDS = ("CSHEAR",)
MODELLED = (*SHELL_CARDS, *LINE_CARDS, *POINT_CARDS, *PANEL_CARDS, *CONNECTOR_CARDS)
MODELLED += (*SOLID_CARDS, *RIGID_CARDS)
READ = (
    *("GRID", "GRDSET", "BAROR", "BEAMOR", "PSHELL", "PCOMP", "PCOMPG", "PBAR", "PBARL"),
    *("PBEAM", "PBEAML", "PROD", "PTUBE", "PELAS", "PMASS", "PBUSH", "MAT1", "MAT2", "MAT8"),
    *("PGAP", "PSHEAR", "PFAST", "PWELD", "PBUSH1D", "PSOLID"),
    *("CORD1R", "CORD1C", "CORD1S", "CORD2R", "CORD2C", "CORD2S"),
)  # properties, materials, systems the modelled cards use (others' are left out)
DAMPING = ("CDAMP1", "CDAMP2", "CDAMP3", "CDAMP4", "CDAMP5", "CVISC")
SETS = re.compile(r"[ABCQ]SET1?|OMIT1?|SUPORT1?|SPCD|SESUP|SEQSET1?")
# cards that add stiffness, mass or constraints (elements, rigid elements, MPCs, matrices)
STRUCTURAL = re.compile(
    r"C(?!ORD|AERO|HBDY|ONV|ONTRL|SSCHD|MODE|YAX|YJOIN|YSUP|LOAD\b)\w+"
    r"|R(BE\d|BAR\d?|ROD|SPLINE|TRPLT\d?|JOINT|SSCON|BE2A|BE2GS)"
    r"|MPC\w*|SPC(ADD)?|SPC1|SPCAX|DMIG\w*|GENEL|NSM\w*|BGSET|BGADD|BCTSET"
)
ADVICE = (
    "jaxflex solves shells (CQUAD4, CTRIA3, CQUAD8, CTRIA6, CQUADR, CTRIAR), solids (CHEXA, "
    "CPENTA, CTETRA of MAT1), shear panels (CSHEAR), beams and rods (CBAR, CBEAM, CROD, "
    "CONROD, CTUBE), springs and gaps (CELAS1/2, CBUSH, CBUSH1D, CGAP), fasteners and spot "
    "welds between shells (CFAST, CWELD), masses (CONM1/2, CMASS1/2) and rigid elements "
    "(RBE2, RBE3, RBAR, RBAR1, RROD); for the rest, read the modes your own solver computed: "
    "jaxflex model --from-modes FILE"
)
SOLIDS = {"CHEXA": 8, "CPENTA": 6, "CTETRA": 4, "CPYRAM": 5}
MASSLESS = ("CGAP", "CWELD", "CFAST", "CSEAM", "CELAS3", "CELAS4", "CBUSH2D")
MASSLESS += ("BGSET", "BGADD", "BCTSET")  # glued and contact surfaces
DENSITY_FIELD = {"MAT1": 4, "MAT2": 7, "MAT8": 7, "MAT9": 22, "MAT10": 2, "MAT3": 7}


def classify(bulk: BulkData) -> tuple[dict[str, list[Card]], dict[str, int]]:
    """(cards refused by name, cards left out on purpose with their count)."""
    refused: dict[str, list[Card]] = {}
    left_out: dict[str, int] = {}
    handled = {*MODELLED, *READ, "MPC", "MPCADD", "SPC", "SPC1", "SPCADD"}
    for name, cards in bulk.cards.items():
        if name in handled:
            continue
        if STRUCTURAL.fullmatch(name) and name not in DAMPING:
            refused[name] = cards
        else:
            left_out[name] = len(cards)
    return refused, left_out


def _density(bulk: BulkData, mid: int | None) -> float | None:
    for name, index in DENSITY_FIELD.items():
        for card in bulk.cards.get(name, []):
            if card.text(0) == str(mid):
                try:
                    return card.real(index, "RHO", 0.0)
                except InputError:
                    return None
    return None


def _property(bulk: BulkData, pid: int | None, prefix: str) -> Card | None:
    return None if pid is None else bulk.find(pid, prefix)


def _volume(xyz: np.ndarray, corners: int) -> float:
    """Volume of a solid from its corner points (tetrahedra around the centroid of the
    corners, each face split into triangles)."""
    faces = {
        4: [(0, 1, 2), (0, 1, 3), (1, 2, 3), (0, 2, 3)],
        5: [(0, 1, 2, 3), (0, 1, 4), (1, 2, 4), (2, 3, 4), (3, 0, 4)],
        6: [(0, 1, 2), (3, 4, 5), (0, 1, 4, 3), (1, 2, 5, 4), (2, 0, 3, 5)],
        8: [(0, 1, 2, 3), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)],
    }[corners]
    centre = xyz.mean(axis=0)
    total = 0.0
    for face in faces:
        p = xyz[list(face)]
        mid = p.mean(axis=0)
        for k in range(len(face)):
            a, b = p[k], p[(k + 1) % len(face)]
            total += abs(np.dot(a - centre, np.cross(b - centre, mid - centre))) / 6
    return total


def element_mass(card: Card, bulk: BulkData, geometry: DeckGeometry, props) -> float | None:
    """The mass of one element card (deck units, without WTMASS), None when unknown."""
    name = card.name
    try:
        if name in MASSLESS or name in DAMPING or name.startswith("R"):
            return 0.0
        if name == "CONM2":
            return card.real(3, "M", 0.0)
        if name == "CONM1":
            return card.real(3, "M11", 0.0)
        if name in ("CMASS2", "CMASS4"):
            return card.real(1, "M", 0.0)
        grids = [g for g in card.ids(2, "G") if g in geometry.positions]
        xyz = np.array([geometry.positions[g] for g in grids]) if grids else np.zeros((0, 3))
        if name in SHELL_CARDS:
            element = read_shell(card, bulk)
            section = props["shell"].get(element)
            corners = np.array([geometry.positions[g] for g in element.corners])
            t = section.thickness or float(np.mean([x for x in element.corner_t if x]))
            per_area = section.resultants(np.array([t]), np.array([t**3]))[3][0]
            return _polygon_area(corners) * per_area
        if name in LINE_CARDS:
            first = 1 if name == "CONROD" else 2
            ends = [geometry.positions[card.integer(first + k, "G")] for k in (0, 1)]
            beams = props["beam"]
            if name == "CONROD":
                section = beams.conrod(card)
            else:
                section = beams.get(card.integer(1, "PID"), card, 1, {**BEAMS, **RODS}[name])
            length = float(np.linalg.norm(ends[1] - ends[0]))
            return length * (section.material.rho * section.area + section.nsm)
        if name in SOLIDS:
            prop = _property(bulk, card.integer(1, "PID"), "PSOLID")
            rho = _density(bulk, prop.integer(1, "MID")) if prop else None
            n = SOLIDS[name]
            if rho is None or len(xyz) < n:
                return None
            return rho * _volume(xyz[:n], n)
        if name == "CSHEAR":
            prop = _property(bulk, card.integer(1, "PID"), "PSHEAR")
            rho = _density(bulk, prop.integer(1, "MID")) if prop else None
            if rho is None or len(xyz) < 4:
                return None
            return _polygon_area(xyz[:4]) * (
                rho * prop.real(2, "T", 0.0) + prop.real(3, "NSM", 0.0)
            )
    except (InputError, KeyError, TypeError, IndexError, ValueError, AttributeError):
        return None
    return None


def _polygon_area(xyz: np.ndarray) -> float:
    if len(xyz) == 3:
        return 0.5 * float(np.linalg.norm(np.cross(xyz[1] - xyz[0], xyz[2] - xyz[0])))
    return 0.5 * float(np.linalg.norm(np.cross(xyz[2] - xyz[0], xyz[3] - xyz[1])))


def _masses(bulk: BulkData, geometry: DeckGeometry, names) -> dict[str, float | None]:
    materials = Materials(bulk)
    props = {"shell": ShellSections(bulk, materials), "beam": BeamSections(bulk, materials)}
    out: dict[str, float | None] = {}
    for name in names:
        total: float | None = 0.0
        for card in bulk.named(name):
            m = element_mass(card, bulk, geometry, props)
            total = None if total is None or m is None else total + m
        out[name] = total
    return out


def _share(mass: float | None, total: float) -> str:
    if mass is None:
        return "its mass not known"
    if mass == 0:
        return "no mass"
    return f"{100 * mass / total:.3g} % of the mass" if total > 0 else "all of the known mass"


def refuse_outside(bulk: BulkData, geometry: DeckGeometry, refused: dict[str, list[Card]]):
    """Raise the one InputError naming every refused card with its share of the mass."""
    parts = []
    if bulk.parts:
        parts.append(_parts_note(bulk))
    if refused:
        modelled = [n for n in MODELLED if n in bulk.cards]
        masses = _masses(bulk, geometry, [*modelled, *refused])
        known = sum(m for m in masses.values() if m)
        for name, cards in sorted(refused.items()):
            where = f"first {cards[0].where(None).split('(', 1)[1].rstrip(')')}"
            parts.append(f"{name} ({len(cards)}, {_share(masses[name], known)}; {where})")
    if parts:
        raise InputError(f"deck: outside our element set: {', '.join(parts)}. {ADVICE}")


def _parts_note(bulk: BulkData) -> str:
    """The part superelements and the share of the mass they hold."""
    try:
        own = _masses(bulk, DeckGeometry(bulk), [n for n in bulk.cards if n[0] == "C"])
        total_main = sum(m for m in own.values() if m)
        in_parts = 0.0
        for part in bulk.parts.values():
            masses = _masses(part, DeckGeometry(part), [n for n in part.cards if n[0] == "C"])
            in_parts += sum(m for m in masses.values() if m)
        share = _share(in_parts, in_parts + total_main)
    except InputError:
        share = "its mass not known"
    first = min(bulk.begins)
    return (
        f"part superelements (BEGIN SUPER, {len(bulk.parts)} parts, first at "
        f"{bulk.begins[first]}; {share})"
    )
