"""Nastran bulk data read into typed cards: the grids, shells, properties, materials and
single-point constraints a shell model needs.

Formats, as the Nastran Quick Reference Guide defines them ("Bulk Data Entries, format"):

* small field: ten fields of 8 columns (field 1 the card name, 2-9 data, 10 the continuation
  marker); columns after 80 are ignored;
* large field: the name ends with ``*``; four data fields of 16 columns per line, so one row
  of eight data fields takes two lines, the second starting with ``*``;
* free field: fields separated by commas (``GRID*,...``: four data fields per line);
* continuation lines start with ``+`` (small), ``*`` (large) or a blank first field
  (implicit); they must follow their parent, and a marker in field 10 of the parent must
  match the continuation's field 1 (first character aside);
* ``$`` starts a comment; ``INCLUDE 'file'`` (relative to the including file); a deck with
  executive and case control has its bulk data between ``BEGIN BULK`` and ``ENDDATA``
  (case control ``SPC = n`` selects the constraint set), a file without them is bulk data;
* real numbers: ``7.85-9``, ``1.+5``, ``2.1E5``, ``2.1D5``, ``-.5``, ``7.`` (an integer is
  accepted for a real); blank fields take the card's default.

Cards read: GRID (CP and CD in the basic system), GRDSET, CQUAD4, CTRIA3, CQUAD8, CTRIA6,
PSHELL, MAT1, SPC, SPC1 (with THRU), PARAM WTMASS. Cards that would change the structure
(other elements, masses, springs, rigid elements, MPCs, reduction sets, ...) are listed in
one error; cards that do not (solution control, loads, output requests, unused coordinate
systems, ...) are counted in ``BulkData.ignored``. Errors name the card, the file and line,
and the field (numbered as in the Quick Reference Guide: 2-9 on each row).
"""

from __future__ import annotations

import os
import re
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

from jaxflex.errors import InputError
from jaxflex.inputs import read_text

SHELL_CARDS = {"CQUAD4": 4, "CTRIA3": 3, "CQUAD8": 4, "CTRIA6": 3}  # card: corner grids
# grids per element, then the flat field indices (0 = field 2 of the first row) of the
# element's ZOFFS and corner thicknesses T1...
_SHELL_LAYOUT = {
    "CQUAD4": (4, 7, range(10, 14)),
    "CTRIA3": (3, 6, range(10, 13)),
    "CQUAD8": (8, 15, range(10, 14)),
    "CTRIA6": (6, 9, range(10, 13)),
}
# Cards that add stiffness, mass, constraints or a reduction but are not read here: a deck
# with any of them is refused (one error lists them all).
STRUCTURAL = re.compile(
    r"C(?!ORD|AERO|HBDY|ONV)\w+"  # elements, masses, springs, dampers, gaps, welds
    r"|R(BE\d|BAR\d?|ROD|SPLINE|TRPLT|JOINT)"  # rigid elements
    r"|MPC\w*|SPCADD|SPCD|SPCAX|SUPORT\d?|SESUP|[ABCQ]SET\d?|OMIT\d?"
    r"|DMIG\w*|GENEL|NSM\w*|SPOINT"
)
_INT = re.compile(r"[+-]?\d+")
_REAL = re.compile(r"([+-]?(?:\d+\.\d*|\.\d+))(?:[ED]([+-]?\d+)|([+-]\d+))?|([+-]?\d+)")
_BEGIN_BULK = re.compile(r"\s*BEGIN\s+BULK\b", re.IGNORECASE)
_CEND = re.compile(r"\s*CEND\b", re.IGNORECASE)
_CASE_SPC = re.compile(r"\s*SPC\s*=\s*(\d+)\s*$", re.IGNORECASE)
_INCLUDE = re.compile(r"\s*INCLUDE\b", re.IGNORECASE)
_FOREIGN = re.compile(r"[^A-Za-z0-9 +\-.*,=()/'\"_]")  # outside Nastran's character set


def parse_real(text: str) -> float:
    """A Nastran real: ``7.85-9`` = 7.85e-9, ``1.+5``, ``2.1E5``, ``2.1D5``, ``-.5``, ``7.``;
    an integer is accepted. Raises ValueError otherwise."""
    match = _REAL.fullmatch(text.strip().upper())
    if match is None:
        raise ValueError(text)
    mantissa, exp_letter, exp_sign, integer = match.groups()
    if integer is not None:
        return float(integer)
    exponent = exp_letter or exp_sign
    return float(mantissa + ("e" + exponent if exponent else ""))


@dataclass
class Card:
    """A bulk-data entry with its continuations: ``name`` (without the large-field ``*``),
    the text of its data fields in order (index i is field 2 + i % 8 of row i // 8, upper
    case, stripped) and the line of each, in the file ``path`` where the card starts."""

    name: str
    texts: list[str]
    lines: list[int]
    path: str
    line: int

    @property
    def label(self) -> str:
        return f"{self.name} {self.text(0)}".strip()

    def where(self, index: int | None = None, label: str = "") -> str:
        """``CQUAD4 12 (deck.bdf line 40, field 3 PID)`` for messages."""
        place = f"{Path(self.path).name} line {self.line}"
        if index is not None:
            line = self.lines[index] if index < len(self.lines) else self.line
            row = f"row {index // 8 + 1} " if index >= len(self.lines) else ""
            place = f"{Path(self.path).name} line {line}, {row}field {2 + index % 8}"
        return f"{self.label} ({place}{' ' + label if label else ''})"

    def text(self, index: int) -> str:
        return self.texts[index] if index < len(self.texts) else ""

    def blank(self, index: int) -> bool:
        return self.text(index) == ""

    def integer(self, index: int, label: str, default: int | None = None) -> int | None:
        text = self.text(index)
        if not text:
            return default
        if len(text) > 16:  # a field holds at most 16 characters; Nastran IDs have 8 digits
            raise InputError(f"deck: {self.where(index, label)}: an integer of {len(text)} digits")
        if text.isascii() and text.isdigit():
            return int(text)
        if not _INT.fullmatch(text):
            raise InputError(f"deck: {self.where(index, label)}: {text!r} is not an integer")
        return int(text)

    def real(self, index: int, label: str, default: float | None = None) -> float | None:
        text = self.text(index)
        if not text:
            return default
        try:
            return parse_real(text)
        except ValueError:
            raise InputError(
                f"deck: {self.where(index, label)}: {text!r} is not a real number (Nastran "
                "forms: 2.1E5, 2.1+5, 210000., -.5)"
            ) from None

    def required(self, value, index: int, label: str):
        if value is None:
            raise InputError(f"deck: {self.where(index, label)}: required, the field is blank")
        return value

    def components(self, index: int, label: str) -> str:
        """A component list: distinct digits 1-6 (e.g. ``123``)."""
        text = self.text(index)
        if not text or not set(text) <= set("123456") or len(set(text)) != len(text):
            raise InputError(
                f"deck: {self.where(index, label)}: {text!r} is not a component list "
                "(distinct digits 1-6, e.g. 123)"
            )
        return "".join(sorted(text))


@dataclass(frozen=True)
class Grid:
    id: int
    xyz: tuple[float, float, float]
    ps: str  # permanent single-point constraints, component digits
    card: Card


@dataclass(frozen=True)
class Shell:
    name: str
    id: int
    pid: int
    grids: tuple[int, ...]  # corners first, then the mid-side grids given
    card: Card

    @property
    def corners(self) -> tuple[int, ...]:
        return self.grids[: SHELL_CARDS[self.name]]


@dataclass(frozen=True)
class PShell:
    id: int
    mid1: int | None
    t: float | None
    mid2: int | None
    mid3: int | None
    card: Card


@dataclass(frozen=True)
class Mat1:
    """Isotropic material; E, G, NU completed by the rule E = 2 (1 + NU) G."""

    id: int
    e: float
    g: float
    nu: float
    rho: float
    derived: str  # which of E, G, NU was computed from the other two ("" if all given)
    card: Card


@dataclass(frozen=True)
class Constraint:
    sid: int
    grid: int
    components: str
    card: Card


@dataclass
class BulkData:
    """The cards of a deck that a shell model needs, by id, and what was left out."""

    grids: dict[int, Grid] = field(default_factory=dict)
    shells: list[Shell] = field(default_factory=list)
    pshells: dict[int, PShell] = field(default_factory=dict)
    mat1s: dict[int, Mat1] = field(default_factory=dict)
    spcs: dict[int, list[Constraint]] = field(default_factory=dict)
    others: dict[str, list[Card]] = field(default_factory=dict)  # every other card by name
    case_spc: list[int] | None = None  # SPC sets case control selects (None: no case control)
    wtmass: float = 1.0
    files: list[str] = field(default_factory=list)

    @property
    def ignored(self) -> dict[str, int]:
        """Cards read past, with their count."""
        return {name: len(cards) for name, cards in sorted(self.others.items())}

    def card_with_id(self, ident: int, prefix: str) -> Card | None:
        """A card read past whose name starts with ``prefix`` ("P": a property, "MAT": a
        material) and whose id is ``ident``: named when a shell refers to it."""
        for name, cards in self.others.items():
            if name.startswith(prefix):
                for card in cards:
                    if card.text(0) == str(ident):
                        return card
        return None


# -- lines -> cards ---------------------------------------------------------------------


def _read_text(path: Path, context: str) -> list[str]:
    return read_text(f"deck: {context}".rstrip(": "), path).splitlines()


def _bulk_lines(path: Path, start: int, lines: list[str], stack: tuple[Path, ...], files):
    """(path, line number, text) of the bulk data from ``lines[start:]``, INCLUDEs expanded,
    comments removed; stops at ENDDATA (returns True when it was seen)."""
    i = start
    while i < len(lines):
        number, text = i + 1, lines[i].split("$", 1)[0].expandtabs(8).rstrip()
        i += 1
        if not text.strip() or _BEGIN_BULK.match(text):  # an included deck may repeat it
            continue
        if _INCLUDE.match(text):
            name = text.strip()[7:].strip()
            while name.startswith("'") and name.count("'") < 2 and i < len(lines):
                name += lines[i].split("$", 1)[0].strip()  # a quoted name continues
                i += 1
            name = name.strip("'\" ")
            if not name:
                raise InputError(f"deck: INCLUDE ({path.name} line {number}): no file name")
            target = (path.parent / name).resolve()
            if target in stack:
                raise InputError(
                    f"deck: INCLUDE ({path.name} line {number}): {name} is already being read "
                    "(an INCLUDE cycle)"
                )
            included = _read_text(target, f"INCLUDE ({path.name} line {number}): ")
            files.append(str(target))
            ended = yield from _bulk_lines(target, 0, included, (*stack, target), files)
            if ended:
                return True
            continue
        if text.upper().startswith("ENDDATA"):
            return True
        foreign = _FOREIGN.search(text)
        if foreign:  # named, not echoed: an INCLUDE may point at any file
            raise InputError(
                f"deck: {path.name} line {number}: the character {foreign.group()!r} is not "
                "bulk data (letters, digits, blanks and + - . * , = ( ) / ' \" _); is "
                f"{path.name} a Nastran deck?"
            )
        yield str(path), number, text
    return False


def _split_line(text: str, path: str, number: int) -> tuple[str, list[str], str]:
    """(field 1, data fields (8, or 4 for large field), field 10) of one line in any of the
    three formats; data fields stripped and upper case."""
    text = text.upper()
    if "," in text:
        tokens = [t.strip() for t in text.split(",")]
        first = tokens[0]
        width = 4 if (first.endswith("*") or first.startswith("*")) else 8
        data, rest = tokens[1 : 1 + width], tokens[1 + width :]
        if any(rest[1:]):
            raise InputError(
                f"deck: {Path(path).name} line {number}: a free-field line holds at most "
                f"{width} data fields and a continuation field, got {len(tokens) - 1} fields"
            )
        data += [""] * (width - len(data))
        return first, data, rest[0] if rest else ""
    text = text[:80]
    first = text[:8].strip()
    if first.endswith("*") or first.startswith("*"):
        data = [text[8 + 16 * k : 24 + 16 * k].strip() for k in range(4)]
    else:
        data = [text[8 + 8 * k : 16 + 8 * k].strip() for k in range(8)]
    return first, data, text[72:80].strip()


def _cards(lines: Iterator[tuple[str, int, str]]) -> Iterator[Card]:
    card: Card | None = None
    marker = ""
    for path, number, text in lines:
        first, data, cont = _split_line(text, path, number)
        if not first or first[0] in "+*":
            if card is None:
                raise InputError(
                    f"deck: {Path(path).name} line {number}: a continuation line with no "
                    "card before it"
                )
            mine, parent = first[1:].strip(), marker[1:].strip()
            if mine and parent and mine != parent:
                raise InputError(
                    f"deck: {card.where()}: line {number} continues marker {first!r}, the card "
                    f"announced {marker!r}; continuation lines must follow their card"
                )
        else:
            if card is not None:
                yield card
            card = Card(first.rstrip("*"), [], [], path, number)
        card.texts.extend(data)
        card.lines.extend([number] * len(data))
        marker = cont
    if card is not None:
        yield card


# -- cards -> model ---------------------------------------------------------------------


def _grid(card: Card, defaults: Card | None) -> Grid:
    gid = card.required(card.integer(0, "ID"), 0, "ID")
    for index, label in ((1, "CP"), (5, "CD")):
        source = card if card.text(index) or defaults is None else defaults
        system = source.integer(index, label)
        if system:
            given = "" if source is card else f", blank: the default of {defaults.where(index)}"
            raise InputError(
                f"deck: {card.where(index, label)}{given}: coordinate system {system}; only the "
                "basic system (0 or blank) is supported: export the grids in basic coordinates"
            )
    xyz = tuple(card.real(i, f"X{i - 1}", 0.0) for i in (2, 3, 4))
    ps = ""
    if card.text(6):
        ps = card.components(6, "PS")
    elif defaults is not None and defaults.text(6):
        ps = defaults.components(6, "PS")
    return Grid(gid, xyz, ps, card)


def _shell(card: Card, grid_ids) -> Shell:
    n_grids, zoffs, thicknesses = _SHELL_LAYOUT[card.name]
    eid = card.required(card.integer(0, "EID"), 0, "EID")
    pid = card.integer(1, "PID", eid)  # blank PID: the element id (Quick Reference Guide)
    corners = SHELL_CARDS[card.name]
    grids = []
    for k in range(n_grids):
        label = f"G{k + 1}"
        gid = card.integer(2 + k, label)  # G7, G8 of a CQUAD8: row 2, fields 2 and 3
        if gid is None or gid == 0:
            if k < corners:
                card.required(None, 2 + k, label)
            continue
        if gid not in grid_ids:
            raise InputError(f"deck: {card.where(2 + k, label)}: grid {gid} is not in the deck")
        grids.append(gid)
    if card.real(zoffs, "ZOFFS", 0.0) != 0.0:
        raise InputError(f"deck: {card.where(zoffs, 'ZOFFS')}: offset shells are not supported")
    for k, index in enumerate(thicknesses):
        if not card.blank(index):
            raise InputError(
                f"deck: {card.where(index, f'T{k + 1}')}: corner thicknesses are not supported; "
                "give the thickness T on the PSHELL"
            )
    return Shell(card.name, eid, pid, tuple(grids), card)


def _pshell(card: Card) -> PShell:
    pid = card.required(card.integer(0, "PID"), 0, "PID")
    mid2 = card.integer(3, "MID2")
    if mid2 is None or mid2 <= 0:
        raise InputError(
            f"deck: {card.where(3, 'MID2')}: a shell that bends needs a bending material "
            "(blank or -1 means none, or plane strain, in Nastran)"
        )
    if card.real(4, "12I/T**3", 1.0) != 1.0:
        raise InputError(
            f"deck: {card.where(4, '12I/T**3')}: only the homogeneous plate (1.0) is supported"
        )
    if card.real(7, "NSM", 0.0) != 0.0:
        raise InputError(f"deck: {card.where(7, 'NSM')}: non-structural mass is not supported")
    if card.integer(10, "MID4") is not None:
        raise InputError(
            f"deck: {card.where(10, 'MID4')}: membrane-bending coupling is not supported"
        )
    t = card.real(2, "T")
    if t is not None and t <= 0:
        raise InputError(f"deck: {card.where(2, 'T')}: the thickness must be > 0, got {t:g}")
    return PShell(pid, card.integer(1, "MID1"), t, mid2, card.integer(5, "MID3"), card)


# Nastran's MAT1 check: E, G and NU all given should satisfy E = 2 (1 + NU) G within 1 %;
# an isotropic model cannot represent more of a difference
MAT1_CONSISTENCY = 0.01


def _mat1(card: Card) -> Mat1:
    mid = card.required(card.integer(0, "MID"), 0, "MID")
    e, g, nu = card.real(1, "E"), card.real(2, "G"), card.real(3, "NU")
    given = [name for name, v in (("E", e), ("G", g), ("NU", nu)) if v is not None]
    derived = ""
    if len(given) < 2:
        raise InputError(
            f"deck: {card.where(None)}: gives only {' and '.join(given) or 'none'} of E, G, NU; "
            "Nastran needs two (the third follows from E = 2 (1 + NU) G; one alone sets the "
            "others to 0, no stiffness)"
        )
    if e is None:
        e, derived = 2 * (1 + nu) * g, "E"
    elif g is None:
        g, derived = e / (2 * (1 + nu)), "G"
    elif nu is None:
        nu, derived = e / (2 * g) - 1, "NU"
    elif abs(e / (2 * (1 + nu) * g) - 1) > MAT1_CONSISTENCY:
        raise InputError(
            f"deck: {card.where(None)}: E, G and NU are all given but E / (2 (1 + NU) G) = "
            f"{e / (2 * (1 + nu) * g):.4g}; an isotropic material needs them consistent "
            "(leave one blank and Nastran's rule gives it)"
        )
    rho = card.real(4, "RHO", 0.0)
    if rho <= 0:
        raise InputError(
            f"deck: {card.where(4, 'RHO')}: the density must be > 0 for a modal analysis"
        )
    return Mat1(mid, e, g, nu, rho, derived, card)


def _spc(card: Card) -> list[Constraint]:
    sid = card.required(card.integer(0, "SID"), 0, "SID")
    out = []
    for first in (1, 4):
        gid = card.integer(first, f"G{first // 3 + 1}")
        if gid is None:
            continue
        comps = card.components(first + 1, f"C{first // 3 + 1}")
        if card.real(first + 2, f"D{first // 3 + 1}", 0.0) != 0.0:
            raise InputError(
                f"deck: {card.where(first + 2, f'D{first // 3 + 1}')}: an enforced non-zero "
                "displacement is not a support"
            )
        out.append(Constraint(sid, gid, comps, card))
    return out


def _spc1(card: Card, grid_ids) -> list[Constraint]:
    sid = card.required(card.integer(0, "SID"), 0, "SID")
    comps = card.components(1, "C")
    grids: list[int] = []
    index = 2
    while index < len(card.texts):
        if card.text(index) == "THRU":
            if not grids or card.blank(index + 1):
                raise InputError(f"deck: {card.where(index, 'THRU')}: needs a grid on each side")
            last = card.integer(index + 1, "G")
            if last < grids[-1]:
                raise InputError(
                    f"deck: {card.where(index + 1, 'G')}: THRU runs from {grids[-1]} up, got {last}"
                )
            # grids missing from the range are skipped, as Nastran does for this form
            grids.extend(g for g in range(grids[-1] + 1, last + 1) if g in grid_ids)
            index += 2
            continue
        gid = card.integer(index, "G")
        if gid is not None:
            grids.append(gid)
        index += 1
    if not grids:
        card.required(None, 2, "G1")
    return [Constraint(sid, gid, comps, card) for gid in grids]


def _unique(store: dict, key: int, value, card: Card, what: str) -> None:
    if key in store:
        raise InputError(
            f"deck: {card.where(None)}: {what} {key} is defined twice (first at "
            f"{store[key].card.where(None)})"
        )
    store[key] = value


def read_bulk(path: str | os.PathLike) -> BulkData:
    """The typed bulk data of a Nastran deck (see the module docstring for the formats)."""
    path = Path(path)
    lines = _read_text(path, "")
    start = next((i + 1 for i, line in enumerate(lines) if _BEGIN_BULK.match(line)), None)
    bulk = BulkData(files=[str(path)])
    if start is None:
        cend = next((i for i, line in enumerate(lines) if _CEND.match(line)), None)
        if cend is not None:
            raise InputError(
                f"deck: {path.name} has executive and case control (CEND on line {cend + 1}) "
                "but no BEGIN BULK"
            )
        start = 0
    else:
        cend = next((i for i in range(start) if _CEND.match(lines[i])), None)
        if cend is not None:  # case control between CEND and BEGIN BULK
            case = [_CASE_SPC.match(line.split("$", 1)[0]) for line in lines[cend : start - 1]]
            bulk.case_spc = sorted({int(m.group(1)) for m in case if m})
    cards = list(_cards(_bulk_lines(path, start, lines, (path.resolve(),), bulk.files)))

    grdsets = [c for c in cards if c.name == "GRDSET"]
    if len(grdsets) > 1:
        raise InputError(f"deck: {grdsets[1].where(None)}: a deck has at most one GRDSET")
    defaults = grdsets[0] if grdsets else None
    for card in cards:
        if card.name == "GRID":
            grid = _grid(card, defaults)
            _unique(bulk.grids, grid.id, grid, card, "grid")
    shell_ids: dict[int, Shell] = {}
    for card in cards:
        name = card.name
        if name in SHELL_CARDS:
            shell = _shell(card, bulk.grids)
            _unique(shell_ids, shell.id, shell, card, "element")
            bulk.shells.append(shell)
        elif name == "PSHELL":
            pshell = _pshell(card)
            _unique(bulk.pshells, pshell.id, pshell, card, "property")
        elif name == "MAT1":
            mat = _mat1(card)
            _unique(bulk.mat1s, mat.id, mat, card, "material")
        elif name in ("SPC", "SPC1"):
            found = _spc(card) if name == "SPC" else _spc1(card, bulk.grids)
            bulk.spcs.setdefault(found[0].sid, []).extend(found)
        elif name == "PARAM" and card.text(0) == "WTMASS":
            bulk.wtmass = card.required(card.real(1, "V1"), 1, "V1")
            if bulk.wtmass <= 0:
                raise InputError(f"deck: {card.where(1, 'V1')}: WTMASS must be > 0")
        elif name not in ("GRID", "GRDSET"):
            bulk.others.setdefault(name, []).append(card)
    structural = {n: c for n, c in bulk.others.items() if STRUCTURAL.fullmatch(n)}
    if structural:
        listed = ", ".join(
            f"{n} ({len(c)}, first {Path(c[0].path).name} line {c[0].line})"
            for n, c in sorted(structural.items())
        )
        raise InputError(
            f"deck: cards that change the structure are not supported: {listed}; supported: "
            "GRID, CQUAD4, CTRIA3, CQUAD8, CTRIA6, PSHELL, MAT1, SPC, SPC1"
        )
    return bulk
