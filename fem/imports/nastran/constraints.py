"""Constraints of a Nastran deck as Nastran defines them, on the components of grids in
their displacement systems (CD): held components and dependent components.

* Held (Nastran's s-set): SPC, SPC1 (THRU) of the selected set (SPCADD combines sets; the
  set case control selects, ``spc_id``, or the deck's only one), GRID PS and GRDSET PS;
  translations and rotations alike. An enforced value (SPC D, SPCD) only matters for a
  static load: the component is held.
* Dependent (Nastran's m-set), each a linear combination of other components:
  RBE2 (the components CM of GM1... move rigidly with GN), RBE3 (the components REFC of the
  reference grid are the weighted least-squares rigid motion of the independent grids'
  components Ci with weights WTi, rotational weights times Lc^2, Lc the mean distance of
  the independent grids from the reference grid), RBAR and RBAR1 (a rigid bar: one end
  independent, the other's CMB dependent), RROD (the length along GA-GB held), MPC of the
  selected set (MPCADD combines; the first term's component is dependent).

Components are (grid id, 1..6). A component may be dependent once and may not also be
held, as in Nastran; such decks are refused naming both cards.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from fem.elements.offsets import offset_transform
from fem.imports.nastran.bdf import BulkData, Card
from fem.imports.nastran.coords import DeckGeometry
from jaxflex.errors import InputError

RIGID_CARDS = ("RBE2", "RBE3", "RBAR", "RBAR1", "RROD")


@dataclass
class Relation:
    """Component ``dependent`` = sum of coefficient x component over ``terms``."""

    dependent: tuple[int, int]
    terms: dict[tuple[int, int], float]
    card: Card


@dataclass
class DeckConstraints:
    """Held components (with the card that holds each), dependent relations, and what
    was selected how."""

    held: dict[tuple[int, int], Card] = field(default_factory=dict)
    relations: list[Relation] = field(default_factory=list)
    info: dict = field(default_factory=dict)

    @property
    def grids(self) -> set[int]:
        """Grids a relation ties (they belong to the model even without elements)."""
        out = set()
        for r in self.relations:
            out.add(r.dependent[0])
            out.update(g for g, _ in r.terms)
        return out


def selected_set(bulk: BulkData, kind: str, given: int | None) -> tuple[int | None, str]:
    """The ``kind`` ("SPC" or "MPC") set to apply and why."""
    names = (kind, f"{kind}1", f"{kind}ADD") if kind == "SPC" else (kind, f"{kind}ADD")
    sets = sorted({c.integer(0, "SID") for c in bulk.named(*names)} - {None})
    case = bulk.case_spc if kind == "SPC" else bulk.case_mpc
    option = "spc_id (--spc-id)" if kind == "SPC" else "case control MPC = n"
    if given is not None:
        if given not in sets:
            raise InputError(f"spc_id: no SPC set {given} in the deck (it has {sets})")
        return given, "given"
    if case is not None:
        if len(case) > 1:
            raise InputError(
                f"spc_id: case control selects {kind} sets {case} in different subcases; "
                f"choose one ({option})"
            )
        if not case:
            unused = f" (sets {sets} not applied, as in Nastran)" if sets else ""
            return None, "case control selects none" + unused
        if case[0] not in sets:
            if kind == "MPC":  # rigid elements need no MPC set: an empty selection
                return None, f"case control selects MPC = {case[0]}, not in the deck: none"
            raise InputError(f"deck: case control selects {kind} = {case[0]}; the deck has {sets}")
        return case[0], "selected by case control"
    if len(sets) > 1:
        raise InputError(f"spc_id: the deck has {kind} sets {sets}; choose one ({option})")
    return (sets[0], "the deck's only set") if sets else (None, "none in the deck")


def _members(bulk: BulkData, kind: str, sid: int | None) -> set[int]:
    """Set ``sid`` and the sets its ``kind``ADD cards combine."""
    if sid is None:
        return set()
    out, todo = set(), [sid]
    adds = bulk.named(f"{kind}ADD")
    while todo:
        current = todo.pop()
        if current in out:
            continue
        out.add(current)
        for card in adds:
            if card.integer(0, "SID") == current:
                todo.extend(card.ids(1, "S"))
    return out


def _check_grid(card: Card, index: int, label: str, bulk: BulkData) -> int:
    gid = card.required(card.integer(index, label), index, label)
    if gid not in bulk.grids:
        raise InputError(f"deck: {card.where(index, label)}: grid {gid} is not in the deck")
    return gid


def _held(bulk: BulkData, sets: set[int], out: DeckConstraints) -> None:
    enforced = 0
    for grid in bulk.grids.values():
        for c in grid.ps:
            out.held.setdefault((grid.id, int(c)), grid.card)
    for card in bulk.named("SPC"):
        if card.integer(0, "SID") not in sets:
            continue
        for first in (1, 4):
            if card.blank(first):
                continue
            gid = _check_grid(card, first, f"G{first // 3 + 1}", bulk)
            for c in card.components(first + 1, f"C{first // 3 + 1}"):
                out.held.setdefault((gid, int(c)), card)
            enforced += card.real(first + 2, f"D{first // 3 + 1}", 0.0) != 0.0
    for card in bulk.named("SPC1"):
        if card.integer(0, "SID") not in sets:
            continue
        comps = card.components(1, "C")
        grids = card.ids(2, "G", known=bulk.grids)
        if not grids:
            card.required(None, 2, "G1")
        for gid in grids:
            if gid not in bulk.grids:
                raise InputError(f"deck: {card.where(None)}: grid {gid} is not in the deck")
            for c in comps:
                out.held.setdefault((gid, int(c)), card)
    out.info["enforced_displacements_held"] = int(enforced) + len(bulk.named("SPCD"))


def _rigid_map(geometry: DeckGeometry, dependent: int, independent: int) -> np.ndarray:
    """(6, 6) the dependent grid's components (its CD) per independent component (its CD)
    when the dependent grid moves rigidly with the independent one."""
    arm = geometry.positions[dependent] - geometry.positions[independent]
    basic = offset_transform(arm[None, None])[0]
    fd, fi = geometry.frames([dependent, independent])
    return np.kron(np.eye(2), fd) @ basic @ np.kron(np.eye(2), fi).T


def _terms(row: np.ndarray, grid: int) -> dict:
    big = np.abs(row).max(initial=0.0)
    return {(grid, k + 1): float(v) for k, v in enumerate(row) if abs(v) > 1e-13 * big}


def _rbe2(card: Card, bulk, geometry, out) -> None:
    gn = _check_grid(card, 1, "GN", bulk)
    comps = card.components(2, "CM")
    grids = []
    index = 3
    while index < len(card.texts):  # GMi ... then ALPHA (a real) ends the list
        text = card.text(index)
        if text and ("." in text or "E" in text):
            break
        if text == "THRU" and grids:
            last = card.integer(index + 1, "GM")
            grids.extend(g for g in range(grids[-1] + 1, last + 1) if g in bulk.grids)
            index += 2
            continue
        if text:
            grids.append(_check_grid(card, index, "GM", bulk))
        index += 1
    for gm in grids:
        mapping = _rigid_map(geometry, gm, gn)
        for c in comps:
            out.relations.append(Relation((gm, int(c)), _terms(mapping[int(c) - 1], gn), card))


def _rbar(card: Card, bulk, geometry, out) -> None:
    ga, gb = (_check_grid(card, k, f"G{'AB'[k - 1]}", bulk) for k in (1, 2))
    if card.name == "RBAR1":
        independent, dependent, comps = ga, gb, card.components(3, "CB")
    else:
        cna, cnb, cma, cmb = (card.text(k).replace(" ", "") for k in (3, 4, 5, 6))
        if sorted(cna) == list("123456") and not cnb and not cma and cmb:
            independent, dependent, comps = ga, gb, card.components(6, "CMB")
        elif sorted(cnb) == list("123456") and not cna and not cmb and cma:
            independent, dependent, comps = gb, ga, card.components(5, "CMA")
        else:
            raise InputError(
                f"deck: {card.where(None)}: only one end independent in all six components "
                "(CNA = 123456 and CMB, or CNB = 123456 and CMA) is supported"
            )
    mapping = _rigid_map(geometry, dependent, independent)
    for c in comps:
        terms = _terms(mapping[int(c) - 1], independent)
        out.relations.append(Relation((dependent, int(c)), terms, card))


def _rrod(card: Card, bulk, geometry, out) -> None:
    ga, gb = (_check_grid(card, k, f"G{'AB'[k - 1]}", bulk) for k in (1, 2))
    axis = geometry.positions[gb] - geometry.positions[ga]
    if np.linalg.norm(axis) == 0:
        raise InputError(f"deck: {card.where(None)}: GA and GB coincide")
    axis /= np.linalg.norm(axis)
    fa, fb = geometry.frames([ga, gb])
    along = {ga: fa @ axis, gb: fb @ axis}  # the axis in each grid's components
    if card.text(3):
        dep = (ga, int(card.components(3, "CMA")))
    elif card.text(4):
        dep = (gb, int(card.components(4, "CMB")))
    else:
        dep = (gb, int(np.argmax(np.abs(along[gb]))) + 1)
    sign = {ga: -1.0, gb: 1.0}
    coeff = {(g, k + 1): sign[g] * along[g][k] for g in (ga, gb) for k in range(3)}
    lead = coeff.pop(dep)
    if abs(lead) < 1e-9:
        raise InputError(f"deck: {card.where(None)}: its dependent component is normal to the rod")
    terms = {key: -v / lead for key, v in coeff.items() if abs(v) > 1e-13}
    out.relations.append(Relation(dep, terms, card))


def _rbe3_items(card: Card) -> list[tuple[float, str, list[int]]]:
    """(weight, components, grids) groups of an RBE3 from field 6 on; UM refused."""
    groups, index = [], 4
    while index < len(card.texts):
        text = card.text(index)
        if text in ("UM", "ALPHA", "TEMP"):
            if text == "UM":
                raise InputError(
                    f"deck: {card.where(index, 'UM')}: RBE3 with UM (other dependent "
                    "components) is not supported"
                )
            break
        if not text:
            index += 1
            continue
        weight = card.real(index, "WT")
        comps = card.components(index + 1, "C")
        grids, index = [], index + 2
        while index < len(card.texts):
            text = card.text(index)
            if text and ("." in text or "E" in text or text in ("UM", "ALPHA", "TEMP")):
                break
            if text == "THRU":
                grids.extend(range(grids[-1] + 1, card.integer(index + 1, "G") + 1))
                index += 2
                continue
            if text:
                grids.append(card.integer(index, "G"))
            index += 1
        groups.append((weight, comps, grids))
    return groups


def _rbe3(card: Card, bulk, geometry: DeckGeometry, out) -> None:
    ref = _check_grid(card, 2, "REFGRID", bulk)
    refc = card.components(3, "REFC")
    rows, weights, keys = [], [], []
    groups = _rbe3_items(card)
    if not groups:
        card.required(None, 4, "WT1")
    independent = {g for _, _, grids in groups for g in grids}
    for g in independent:
        if g not in bulk.grids:
            raise InputError(f"deck: {card.where(None)}: grid {g} is not in the deck")
    arms = [np.linalg.norm(geometry.positions[g] - geometry.positions[ref]) for g in independent]
    length = float(np.mean(arms)) if arms and np.mean(arms) > 0 else 1.0
    for weight, comps, grids in groups:
        for g in grids:
            mapping = _rigid_map(geometry, g, ref) @ np.kron(np.eye(2), geometry.frames([ref])[0])
            for c in comps:
                k = int(c)
                rows.append(mapping[k - 1])  # the component per reference basic motion
                weights.append(weight * (length**2 if k > 3 else 1.0))
                keys.append((g, k))
    s = np.array(rows)
    w = np.array(weights)
    normal = s.T @ (w[:, None] * s)
    values, vectors = np.linalg.eigh(normal)
    null = vectors[:, values <= 1e-10 * max(values.max(), 1e-300)]
    wanted = np.kron(np.eye(2), geometry.frames([ref])[0])  # reference CD per basic motion
    for c in refc:
        if null.size and np.abs(wanted[int(c) - 1] @ null).max() > 1e-8:
            raise InputError(
                f"deck: {card.where(3, 'REFC')}: the independent grids and components do not "
                f"determine component {c} of the reference grid {ref} (e.g. grids on one line "
                "with translations only)"
            )
    solve = np.linalg.pinv(normal) @ (s.T * w)
    for c in refc:
        row = wanted[int(c) - 1] @ solve
        terms: dict = {}
        for key, v in zip(keys, row, strict=True):
            terms[key] = terms.get(key, 0.0) + float(v)
        big = max(abs(v) for v in terms.values())
        terms = {k: v for k, v in terms.items() if abs(v) > 1e-13 * big}
        out.relations.append(Relation((ref, int(c)), terms, card))


def _mpcs(bulk: BulkData, sets: set[int], out: DeckConstraints) -> None:
    for card in bulk.named("MPC"):
        if card.integer(0, "SID") not in sets:
            continue
        entries = []
        starts = [1, 4] + [i for r in range(8, len(card.texts), 8) for i in (r + 1, r + 4)]
        for first in starts:
            if card.blank(first):
                continue
            gid = _check_grid(card, first, "G", bulk)
            comp = card.components(first + 1, "C")
            if len(comp) != 1:
                raise InputError(f"deck: {card.where(first + 1, 'C')}: one component, got {comp}")
            entries.append(
                ((gid, int(comp)), card.required(card.real(first + 2, "A"), first + 2, "A"))
            )
        (dep, lead), rest = entries[0], entries[1:]
        if lead == 0:
            raise InputError(f"deck: {card.where(3, 'A1')}: the dependent term's coefficient is 0")
        terms: dict = {}
        for key, a in rest:
            terms[key] = terms.get(key, 0.0) - a / lead
        out.relations.append(Relation(dep, terms, card))


def deck_constraints(bulk: BulkData, geometry: DeckGeometry, spc_id: int | None):
    """Held components and dependent relations of the deck (module docstring)."""
    out = DeckConstraints()
    spc, spc_reason = selected_set(bulk, "SPC", spc_id)
    mpc, mpc_reason = selected_set(bulk, "MPC", None)
    out.info.update(spc_set=spc, spc_set_reason=spc_reason, mpc_set=mpc, mpc_set_reason=mpc_reason)
    _held(bulk, _members(bulk, "SPC", spc), out)
    for card in bulk.named("RBE2"):
        _rbe2(card, bulk, geometry, out)
    for card in bulk.named("RBE3"):
        _rbe3(card, bulk, geometry, out)
    for card in bulk.named("RBAR", "RBAR1"):
        _rbar(card, bulk, geometry, out)
    for card in bulk.named("RROD"):
        _rrod(card, bulk, geometry, out)
    _mpcs(bulk, _members(bulk, "MPC", mpc), out)
    seen: dict[tuple[int, int], Card] = {}
    for relation in out.relations:
        key = relation.dependent
        if key in seen:
            raise InputError(
                f"deck: {relation.card.where(None)}: component {key[1]} of grid {key[0]} is "
                f"already dependent in {seen[key].where(None)} (Nastran allows one)"
            )
        seen[key] = relation.card
        if key in out.held:
            raise InputError(
                f"deck: {relation.card.where(None)}: component {key[1]} of grid {key[0]} is "
                f"dependent and held by {out.held[key].where(None)} (Nastran refuses it too)"
            )
    return out
