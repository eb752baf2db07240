"""Nastran bulk data read into cards: the text layer of the Nastran door (fem.imports.nastran.door).

Formats, as the Nastran Quick Reference Guide defines them ("Bulk Data Entries, format"):

* small field: ten fields of 8 columns (field 1 the card name, 2-9 data, 10 the continuation
  marker); columns after 80 are ignored;
* large field: the name ends with ``*``; four data fields of 16 columns per line, so one row
  of eight data fields takes two lines, the second starting with ``*``;
* free field: fields separated by commas (``GRID*,...``: four data fields per line); a line
  of more than nine data fields goes on in the next row (MSC's long free-field lines), with
  nine the ninth is the continuation marker;
* continuation lines start with ``+`` (small), ``*`` (large) or a blank first field
  (implicit); they must follow their parent, and a marker in field 10 of the parent must
  match the continuation's field 1 (first character aside);
* ``$`` starts a comment; a deck with executive and case control has its bulk data between
  ``BEGIN BULK`` and ``ENDDATA`` (case control ``SPC = n`` and ``MPC = n`` select the
  constraint sets), a file without them is bulk data;
* ``INCLUDE 'file'``: resolved as Nastran resolves it, relative to the job directory (where
  the deck given lies; Nastran runs there), then beside the including file; the quoted name
  may continue over lines; ``NAME:rest`` is a logical symbol (Nastran's ``SYMBOL=NAME=dir``
  in its rc file), taken from the environment variable ``NAME``;
* real numbers: ``7.85-9``, ``1.+5``, ``.5+2``, ``2.1E5``, ``2.1D5``, ``1E7``, ``-.5``,
  ``7.`` (an integer is accepted for a real); component lists ``123456``, ``12 456``
  (blanks inside a field are dropped); blank fields take the card's default; ``THRU`` in
  lists of ids;
* an exact duplicate of a card is dropped (Nastran does the same); the cards of part
  superelements (``BEGIN SUPER = n``, ``BEGIN BULK SUPER = n``) are kept apart
  (``BulkData.parts``).

Every card is kept by name (``BulkData.cards``); GRID is typed here with its GRDSET
defaults, the others by the modules that use them (fem.imports.nastran). Errors name the card, the
file and line, and the field (numbered as in the Quick Reference Guide: 2-9 on each row).
"""

from __future__ import annotations

import os
import re
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

from jaxflex.errors import InputError
from jaxflex.files import read_text

_INT = re.compile(r"[+-]?\d+")
_REAL = re.compile(
    r"([+-]?(?:\d+\.\d*|\.\d+))(?:[ED]([+-]?\d+)|([+-]\d+))?|([+-]?\d+)(?:[ED]([+-]?\d+))?"
)
_BEGIN_BULK = re.compile(r"\s*BEGIN\s+BULK\b", re.IGNORECASE)
_BEGIN_SUPER = re.compile(
    r"\s*BEGIN\s+(?:BULK\s+)?(?:SUPER|AUXMODEL|ARBMODEL)\s*=?\s*(\d*)", re.IGNORECASE
)
_CEND = re.compile(r"\s*CEND\b", re.IGNORECASE)
_CASE_SET = re.compile(r"\s*(SPC|MPC)\s*=\s*(\d+)\s*$", re.IGNORECASE)
_INCLUDE = re.compile(r"\s*INCLUDE\b", re.IGNORECASE)
_SYMBOL = re.compile(r"([A-Za-z_][A-Za-z0-9_]+):(.*)")
HEAT_SOLUTIONS = ("153", "159", "NLSCSH", "NLTCSH")
_FOREIGN = re.compile(r"[^A-Za-z0-9 +\-.*,=()/'\"_]")  # outside Nastran's character set


def parse_real(text: str) -> float:
    """A Nastran real: ``7.85-9`` = 7.85e-9, ``1.+5``, ``2.1E5``, ``2.1D5``, ``1E7``, ``-.5``,
    ``7.``; an integer is accepted. Raises ValueError otherwise."""
    match = _REAL.fullmatch(text.strip().upper())
    if match is None:
        raise ValueError(text)
    mantissa, exp_letter, exp_sign, integer, int_exponent = match.groups()
    if integer is not None:
        return float(integer + ("e" + int_exponent if int_exponent else ""))
    exponent = exp_letter or exp_sign
    return float(mantissa + ("e" + exponent if exponent else ""))


@dataclass
class Card:
    """A bulk-data entry with its continuations: ``name`` (without the large-field ``*``),
    the text of its data fields in order (index i is field 2 + i % 8 of row i // 8, upper
    case, stripped) and the line of each, in the file ``path`` where the card starts;
    ``section`` the part superelement it belongs to (0: the main bulk data)."""

    name: str
    texts: list[str]
    lines: list[int]
    path: str
    line: int
    section: int = 0

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
        """A component list: distinct digits 1-6 (e.g. ``123``, ``12 456``), sorted."""
        text = self.text(index).replace(" ", "")
        if not text or not set(text) <= set("123456") or len(set(text)) != len(text):
            raise InputError(
                f"deck: {self.where(index, label)}: {text!r} is not a component list "
                "(distinct digits 1-6, e.g. 123)"
            )
        return "".join(sorted(text))

    def ids(self, start: int, label: str, stop: int | None = None, known=None) -> list[int]:
        """The ids from field index ``start`` on (to ``stop``): integers, blanks skipped,
        ``A THRU B`` every id from A to B (those in ``known`` if given: ids missing from
        the range are skipped, as Nastran does for THRU)."""
        out: list[int] = []
        index, end = start, len(self.texts) if stop is None else min(stop, len(self.texts))
        while index < end:
            if self.text(index) == "THRU":
                if not out or self.blank(index + 1):
                    raise InputError(f"deck: {self.where(index, 'THRU')}: needs an id on each side")
                last = self.integer(index + 1, label)
                if last < out[-1]:
                    raise InputError(
                        f"deck: {self.where(index + 1, label)}: THRU runs from {out[-1]} up, "
                        f"got {last}"
                    )
                span = range(out[-1] + 1, last + 1)
                out.extend(g for g in span if known is None or g in known)
                index += 2
                continue
            value = self.integer(index, label)
            if value is not None:
                out.append(value)
            index += 1
        return out


@dataclass(frozen=True)
class Grid:
    """A GRID: ``xyz`` in its coordinate system ``cp`` (file units), displacements in
    system ``cd`` (-1: a fluid grid), ``ps`` permanent single-point constraints."""

    id: int
    cp: int
    xyz: tuple[float, float, float]
    cd: int
    ps: str
    card: Card


@dataclass
class BulkData:
    """Every card of a deck by name, the grids, what case control selects; the part
    superelements (``BEGIN SUPER = n`` sections) as BulkData of their own in ``parts``."""

    cards: dict[str, list[Card]] = field(default_factory=dict)
    grids: dict[int, Grid] = field(default_factory=dict)
    case_spc: list[int] | None = None  # SPC sets case control selects (None: no case control)
    case_mpc: list[int] | None = None
    heat: str = ""  # what makes the deck a heat-transfer analysis ("SOL 153", "APP HEAT")
    wtmass: float = 1.0
    files: list[str] = field(default_factory=list)
    parts: dict[int, BulkData] = field(default_factory=dict)
    begins: dict[int, str] = field(default_factory=dict)  # part: where its section starts
    include_notes: list[str] = field(default_factory=list)
    duplicates_dropped: int = 0

    def named(self, *names: str) -> list[Card]:
        """The cards of the given names, in the order read per name."""
        return [card for name in names for card in self.cards.get(name, [])]

    def by_id(self, *names: str) -> dict[int, Card]:
        """Cards of ``names`` by their id (field 2); a repeated id is an error."""
        out: dict[int, Card] = {}
        for card in self.named(*names):
            ident = card.required(card.integer(0, "ID"), 0, "ID")
            if ident in out:
                raise InputError(
                    f"deck: {card.where(None)}: id {ident} is defined twice (first at "
                    f"{out[ident].where(None)})"
                )
            out[ident] = card
        return out

    def referenced(self, cards: dict[int, Card], ident, allowed, user: Card, field) -> Card:
        """The card ``ident`` of ``cards`` (by id) that field ``field`` = (index, label) of
        ``user`` refers to; an error naming the field, what the id is in the deck (another
        card or nothing) and the kinds ``allowed``, if it is not one of them."""
        card = cards.get(ident)
        if card is None or card.name not in allowed:
            index, label = field
            prefix = "MAT" if label.startswith("MID") else label[0]
            other = card or self.find(ident, prefix)
            kind = f"a {other.name}" if other else "not in the deck"
            what = "material" if prefix == "MAT" else "property"
            raise InputError(
                f"deck: {user.where(index, label)}: {what} {ident} is {kind}; {user.name} "
                f"takes {', '.join(allowed)}"
            )
        return card

    def find(self, ident: int, prefix: str) -> Card | None:
        """A card whose name starts with ``prefix`` ("P": a property, "MAT": a material)
        and whose id is ``ident``: named when an element refers to it."""
        for name, cards in self.cards.items():
            if name.startswith(prefix):
                for card in cards:
                    if card.text(0) == str(ident):
                        return card
        return None


# -- lines -> cards ---------------------------------------------------------------------


def _read_text(path: Path, context: str) -> list[str]:
    return read_text(f"deck: {context}".rstrip(": "), path).splitlines()


def _include_target(name: str, path: Path, job: Path, where: str, notes: list[str]) -> Path:
    """Where Nastran finds INCLUDE ``name`` of ``path``: a logical symbol from the
    environment, else relative to the job directory ``job``, else beside ``path``."""
    symbol = _SYMBOL.fullmatch(name)
    if symbol and len(symbol.group(1)) > 1:  # C:\... is a drive, not a symbol
        value = os.environ.get(symbol.group(1))
        if value is None:
            raise InputError(
                f"deck: {where}: {name!r} names the logical symbol {symbol.group(1)} (Nastran "
                f"takes it from SYMBOL={symbol.group(1)}=... in its rc file); set the "
                f"environment variable {symbol.group(1)} to that directory"
            )
        name = str(Path(value) / symbol.group(2).lstrip("/\\"))
    candidate = Path(name)
    if candidate.is_absolute():
        return candidate.resolve()
    in_job = (job / candidate).resolve()
    beside = (path.parent / candidate).resolve()
    if in_job.is_file() or not beside.is_file():
        return in_job
    notes.append(f"{where}: {name} found beside {path.name}, not in the job directory")
    return beside


def _include_name(text: str, lines: list[str], i: int) -> tuple[str, int]:
    """The file name of the INCLUDE statement ``text`` (a quoted name may continue on the
    following lines) and the index of the line after it."""
    name = text.strip()[7:].strip()
    while name.startswith("'") and name.count("'") < 2 and i < len(lines):
        name += lines[i].split("$", 1)[0].strip()
        i += 1
    return name.strip("'\" "), i


def _bulk_lines(path: Path, start: int, lines: list[str], stack, job: Path, bulk: BulkData):
    """(path, line number, text, section) of the bulk data from ``lines[start:]``, INCLUDEs
    expanded, comments removed; stops at ENDDATA (returns True when it was seen)."""
    i = start
    while i < len(lines):
        number, text = i + 1, lines[i].split("$", 1)[0].expandtabs(8).rstrip()
        i += 1
        if not text.strip():
            continue
        superelement = _BEGIN_SUPER.match(text)
        if superelement:
            section = int(superelement.group(1) or -1)
            bulk.begins.setdefault(section, f"{path.name} line {number}")
            yield str(path), number, None, section
            continue
        if _BEGIN_BULK.match(text):  # an included deck may repeat it
            continue
        if _INCLUDE.match(text):
            name, i = _include_name(text, lines, i)
            where = f"INCLUDE ({path.name} line {number})"
            if not name:
                raise InputError(f"deck: {where}: no file name")
            target = _include_target(name, path, job, where, bulk.include_notes)
            if target in stack:
                raise InputError(f"deck: {where}: {name} is already being read (an INCLUDE cycle)")
            included = _read_text(target, f"{where}: ")
            bulk.files.append(str(target))
            ended = yield from _bulk_lines(target, 0, included, (*stack, target), job, bulk)
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
        yield str(path), number, text, None
    return False


def _split_line(text: str, path: str, number: int) -> tuple[str, list[list[str]], str]:
    """(field 1, rows of data fields (8, or 4 for large field), field 10) of one line in
    any of the three formats; data fields stripped and upper case."""
    text = text.upper()
    if "," in text:
        tokens = [t.strip() for t in text.split(",")]
        first = tokens[0]
        width = 4 if (first.endswith("*") or first.startswith("*")) else 8
        data = tokens[1:]
        while data and not data[-1]:
            data.pop()
        if len(data) <= width + 1:  # the field after the data is the continuation marker
            marker = data[width] if len(data) > width else ""
            data = data[:width] + [""] * (width - len(data[:width]))
            return first, [data], marker
        if width == 4:
            raise InputError(
                f"deck: {Path(path).name} line {number}: a large free-field line holds at "
                f"most 4 data fields and a continuation field, got {len(data)} fields"
            )
        data += [""] * (-len(data) % width)
        return first, [data[k : k + width] for k in range(0, len(data), width)], ""
    text = text[:80]
    first = text[:8].strip()
    if first.endswith("*") or first.startswith("*"):
        data = [text[8 + 16 * k : 24 + 16 * k].strip() for k in range(4)]
    else:
        data = [text[8 + 8 * k : 16 + 8 * k].strip() for k in range(8)]
    return first, [data], text[72:80].strip()


def _replicate(previous: Card, pattern: list[str], path: str, number: int) -> Card:
    """The entry a replication line ``pattern`` (its data fields) makes of ``previous``:
    ``=`` copies a field, ``==`` every remaining one, ``*x`` adds x to it, a blank stays
    blank (Quick Reference Guide, "Replication")."""
    texts = []
    for index, spec in enumerate(pattern):
        old = previous.text(index)
        if spec == "==":
            texts.extend(previous.texts[index:])
            break
        if spec == "=":
            texts.append(old)
        elif spec.startswith("*"):
            try:
                step = spec[1:].strip("()")
                if _INT.fullmatch(old) and _INT.fullmatch(step):
                    texts.append(str(int(old) + int(step)))
                else:
                    texts.append(repr(parse_real(old) + parse_real(step)).upper())
            except ValueError:
                raise InputError(
                    f"deck: {Path(path).name} line {number}: replication {spec!r} of "
                    f"{previous.where(index)} {old!r} is not a number increment"
                ) from None
        else:
            texts.append(spec)
    return Card(previous.name, texts, [number] * len(texts), path, number, previous.section)


def _cards(lines: Iterator[tuple[str, int, str | None, int | None]]) -> Iterator[Card]:
    card: Card | None = None
    marker = ""
    section = 0
    pattern: list[str] = []
    for path, number, text, new_section in lines:
        if text is None:
            if card is not None:
                yield card
            card, section = None, new_section
            continue
        first, rows, cont = _split_line(text, path, number)
        if first.startswith("=") and (first == "=" or first[1:].isdigit()):
            if card is None:
                raise InputError(f"deck: {Path(path).name} line {number}: nothing to replicate")
            if first == "=":
                pattern = [t for row in rows for t in row]
                while pattern and not pattern[-1]:
                    pattern.pop()
                repeats = 1
            elif not pattern:
                raise InputError(f"deck: {Path(path).name} line {number}: {first} repeats no '='")
            else:
                repeats = int(first[1:])
            for _ in range(repeats):
                yield card
                card = _replicate(card, pattern, path, number)
            marker = ""
            continue
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
            card = Card(first.rstrip("*"), [], [], path, number, section)
        for data in rows:
            card.texts.extend(data)
            card.lines.extend([number] * len(data))
        marker = cont
    if card is not None:
        yield card


# -- cards -> grids ---------------------------------------------------------------------


def _grid(card: Card, defaults: Card | None) -> Grid:
    gid = card.required(card.integer(0, "ID"), 0, "ID")
    fields = {}
    for index, label in ((1, "CP"), (5, "CD"), (6, "PS")):
        source = card if card.text(index) or defaults is None else defaults
        if label == "PS":  # "0" (as some MSC decks write it): nothing held
            given = source.text(index) not in ("", "0")
            fields[label] = source.components(index, label) if given else ""
        else:
            fields[label] = source.integer(index, label, 0)
    xyz = tuple(card.real(i, f"X{i - 1}", 0.0) for i in (2, 3, 4))
    return Grid(gid, fields["CP"], xyz, fields["CD"], fields["PS"], card)


def _case_control(lines: list[str], bulk: BulkData) -> None:
    """SPC and MPC sets case control selects (any subcase)."""
    found: dict[str, set[int]] = {"SPC": set(), "MPC": set()}
    for line in lines:
        match = _CASE_SET.match(line.split("$", 1)[0])
        if match:
            found[match.group(1).upper()].add(int(match.group(2)))
    bulk.case_spc, bulk.case_mpc = sorted(found["SPC"]), sorted(found["MPC"])


def _heat_transfer(executive: list[str]) -> str:
    """The executive control statement that makes a deck a heat-transfer analysis: SOL 153
    or 159 (or their names), APP HEAT; "" otherwise."""
    for line in executive:
        text = line.split("$", 1)[0].strip().upper()
        words = text.replace("=", " ").split()
        if words[:1] == ["SOL"] and words[1:2] and words[1] in HEAT_SOLUTIONS:
            return f"SOL {words[1]}"
        if words[:2] == ["APP", "HEAT"]:
            return "APP HEAT"
    return ""


def read_bulk(path: str | os.PathLike) -> BulkData:
    """Every card of a Nastran deck (see the module docstring for the formats)."""
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
            _case_control(lines[cend : start - 1], bulk)
            bulk.heat = _heat_transfer(lines[:cend])
    stream = _bulk_lines(path, start, lines, (path.resolve(),), path.resolve().parent, bulk)
    seen: set[tuple] = set()
    for card in _cards(stream):
        key = (card.name, card.section, *card.texts)
        if key in seen and card.name != "PARAM":
            bulk.duplicates_dropped += 1
            continue
        seen.add(key)
        target = bulk if card.section == 0 else bulk.parts.setdefault(card.section, BulkData())
        target.cards.setdefault(card.name, []).append(card)
    for part in (bulk, *bulk.parts.values()):
        _typed(part)
    return bulk


def _typed(bulk: BulkData) -> None:
    """The grids (with the GRDSET defaults) and PARAM WTMASS of a bulk data section."""
    grdsets = bulk.named("GRDSET")
    if len(grdsets) > 1:
        raise InputError(f"deck: {grdsets[1].where(None)}: a deck has at most one GRDSET")
    defaults = grdsets[0] if grdsets else None
    for card in bulk.named("GRID"):
        grid = _grid(card, defaults)
        if grid.id in bulk.grids:
            raise InputError(
                f"deck: {card.where(None)}: grid {grid.id} is defined twice (first at "
                f"{bulk.grids[grid.id].card.where(None)})"
            )
        bulk.grids[grid.id] = grid
    for card in bulk.named("PARAM"):
        if card.text(0) == "WTMASS":
            bulk.wtmass = card.required(card.real(1, "V1"), 1, "V1")
            if bulk.wtmass <= 0:
                raise InputError(f"deck: {card.where(1, 'V1')}: WTMASS must be > 0")
