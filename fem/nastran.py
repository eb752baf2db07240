"""Nastran bulk-data decks solved by our own shell models.

A deck's GRID points and shell elements (CQUAD4, CTRIA3, CQUAD8, CTRIA6; the mid-side grids
of the quadratic ones are dropped, our elements have their own edge DOFs), its PSHELL
thickness and MAT1 material (fem.bdf reads them) become a fem part: a flat deck a Kirchhoff
plate (triangles; quads are split), a curved or folded one the shell (fem.shell; or the
one-layer thin solid on request, quads only). Grids are never merged, even where two share
a location (a deck keeps such seams apart on purpose).
Single-point constraints (the SPC/SPC1 set case control or ``spc_id`` selects, and GRID
PS) become pinned points; the suction cups of the gripper may be given as well (``cups``).
Nastran decks state no units: they are given (fem.units), everything is converted to SI
before the analysis.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from fem.bdf import SHELL_CARDS, BulkData, Shell, read_bulk
from fem.imported import file_digest
from fem.materials import Material
from fem.mesh_io import sheet_from_cells
from fem.modal import ModalResult, modal_analysis
from fem.parts import part_from_mesh
from fem.supports import PointSupport, as_support_list
from fem.units import Units, resolve_units
from jaxflex.errors import InputError


def _one(values: dict, what: str):
    """The one value of ``values`` ({value: card label}); several are refused by name."""
    if len(values) != 1:
        shown = "; ".join(f"{v} ({label})" for v, label in values.items())
        raise InputError(f"deck: {what} differs between elements ({shown}); one is required")
    return next(iter(values))


def _material_of(bulk: BulkData, shells: list[Shell]):
    """(thickness, (E, NU, RHO) of the bending material, description) in file units."""
    thickness: dict = {}
    material: dict = {}
    notes: dict = {}
    for pid in sorted({s.pid for s in shells}):
        user = next(s for s in shells if s.pid == pid)
        prop = bulk.pshells.get(pid)
        if prop is None:
            other = bulk.card_with_id(pid, "P")
            kind = f"a {other.name}; only PSHELL is supported" if other else "not in the deck"
            raise InputError(f"deck: {user.card.where(1, 'PID')}: property {pid} is {kind}")
        if prop.t is None:
            prop.card.required(None, 2, "T")
        thickness[prop.t] = prop.card.label
        mats = {}
        for index, mid in ((1, prop.mid1), (3, prop.mid2)):
            if mid is None:
                continue
            mat = bulk.mat1s.get(mid)
            if mat is None:
                other = bulk.card_with_id(mid, "MAT")
                kind = f"a {other.name}; only MAT1 is supported" if other else "not in the deck"
                label = f"MID{1 if index == 1 else 2}"
                raise InputError(f"deck: {prop.card.where(index, label)}: material {mid} is {kind}")
            mats[mid] = mat
        values = {(m.e, m.nu, m.rho) for m in mats.values()}
        if len(values) > 1:
            raise InputError(
                f"deck: {prop.card.where(None)}: membrane (MID1) and bending (MID2) materials "
                "differ; an isotropic shell of one material is required"
            )
        bending = mats[prop.mid2]
        material[(bending.e, bending.nu, bending.rho)] = bending.card.label
        if bending.derived:
            notes[bending.card.label] = f"{bending.derived} from E = 2 (1 + NU) G"
    return (
        _one(thickness, "PSHELL thickness T"),
        _one(material, "material (E, NU, RHO)"),
        notes,
    )


def _selected_set(bulk: BulkData, spc_id: int | None) -> tuple[int | None, str]:
    """The SPC set to apply and why."""
    sets = sorted(bulk.spcs)
    if spc_id is not None:
        if spc_id not in bulk.spcs:
            raise InputError(f"spc_id: no SPC set {spc_id} in the deck (it has {sets})")
        return spc_id, "given"
    if bulk.case_spc is not None:
        if len(bulk.case_spc) > 1:
            raise InputError(
                f"spc_id: case control selects SPC sets {bulk.case_spc} in different subcases; "
                "choose one (--spc-id)"
            )
        if not bulk.case_spc:
            unused = f" (sets {sets} not applied, as in Nastran)" if sets else ""
            return None, "case control selects none" + unused
        chosen = bulk.case_spc[0]
        if chosen not in bulk.spcs:
            raise InputError(f"deck: case control selects SPC = {chosen}; the deck has {sets}")
        return chosen, "selected by case control"
    if len(sets) > 1:
        raise InputError(f"spc_id: the deck has SPC sets {sets}; choose one (--spc-id)")
    return (sets[0], "the deck's only set") if sets else (None, "none in the deck")


def _held_grids(bulk: BulkData, spc_id, flat: bool, part_grids: set, midside: set):
    """Grid ids pinned (translations held) and a description of the constraints."""
    chosen, reason = _selected_set(bulk, spc_id)
    wanted: dict[int, tuple[set, str]] = {}
    for grid in bulk.grids.values():
        if grid.ps:
            wanted[grid.id] = (set(grid.ps), grid.card.where(6, "PS"))
    for con in bulk.spcs.get(chosen, []):
        if con.grid not in bulk.grids:
            raise InputError(f"deck: {con.card.where(None)}: grid {con.grid} is not in the deck")
        comps, where = wanted.get(con.grid, (set(), ""))
        wanted[con.grid] = (comps | set(con.components), where or con.card.where(None))
    pinned, ignored, on_midside = [], 0, 0
    for gid, (comps, where) in sorted(wanted.items()):
        if comps & {"4", "5"}:
            raise InputError(
                f"deck: {where}: grid {gid} has its rotations {''.join(sorted(comps))} held; our "
                "shell models hold slopes through suction cups (cups=, --cups) or clamped "
                "edges, not per grid: keep the translations (123) in the deck"
            )
        translations = comps & {"1", "2", "3"}
        if gid in midside and gid not in part_grids:
            on_midside += 1
            continue
        if flat:
            held = "3" in translations  # 1, 2 (in-plane) and 6 (drilling): not plate DOFs
        else:
            if translations and translations != {"1", "2", "3"}:
                raise InputError(
                    f"deck: {where}: grid {gid} holds translations {''.join(sorted(comps))}; "
                    "the shell and the thin solid pin all three (123) at a point"
                )
            held = bool(translations)
        if not held:
            ignored += 1
            continue
        if gid not in part_grids:
            raise InputError(f"deck: {where}: grid {gid} is held but no shell element uses it")
        pinned.append(gid)
    info = {
        "spc_set": chosen,
        "spc_set_reason": reason,
        "held_grids": len(pinned),
        "constraints_without_effect": ignored,
        "constraints_on_midside_grids": on_midside,
    }
    return pinned, info


def part_from_deck(
    path: str | os.PathLike,
    units: str | Units | None = None,
    *,
    element: str | None = None,
    spc_id: int | None = None,
):
    """(part, pinned supports, grid ids of the part's nodes, description) from a deck."""
    bulk = read_bulk(path)
    unit = resolve_units(units, None, f"the Nastran deck {str(path)!r}")
    if not bulk.shells:
        raise InputError(f"deck: {str(path)!r} has no shell elements (CQUAD4, CTRIA3, ...)")
    thickness, (e_mod, nu, rho), derived = _material_of(bulk, bulk.shells)
    corners = [list(s.corners) for s in bulk.shells]
    grid_ids = np.unique(np.concatenate(corners))
    index = {int(g): i for i, g in enumerate(grid_ids)}
    xyz = np.array([bulk.grids[int(g)].xyz for g in grid_ids]) * unit.length_m
    try:
        material = Material(
            "deck MAT1",
            e_mod * unit.modulus_to_si,
            nu,
            rho * bulk.wtmass * unit.density_to_si,
        )
    except InputError as exc:
        raise InputError(f"deck: MAT1 {exc}") from exc
    counts = {t: sum(s.name == t for s in bulk.shells) for t in SHELL_CARDS}
    description = {"shape": "Nastran deck", "path": str(path), "elements": counts}
    blocks = [
        (kind, np.array([[index[g] for g in c] for c in corners if len(c) == n]))
        for kind, n in (("triangle", 3), ("quad", 4))
        if any(len(c) == n for c in corners)
    ]
    sheet = sheet_from_cells(xyz, blocks, str(path), weld=False)
    flat = sheet.is_flat
    element = element or ("morley" if flat else "shell")
    part = part_from_mesh(
        sheet, thickness * unit.length_m, material, element, Path(path).name, description
    )
    midside = {g for s in bulk.shells for g in s.grids[len(s.corners) :]}
    held, spc = _held_grids(bulk, spc_id, bool(flat), set(index), midside)
    supports = [PointSupport(*xyz[index[g]]) for g in held]
    info = {
        "units": unit.describe(),
        "elements": counts,
        **spc,
        "wtmass": bulk.wtmass,
        "mat1_derived": derived,
        "ignored_cards": bulk.ignored,
        "included_files": bulk.files[1:],
    }
    return part, supports, grid_ids, info


def from_nastran(
    path: str | os.PathLike,
    *,
    units: str | Units | None = None,
    cups=(),
    spc_id: int | None = None,
    element: str | None = None,
    n_modes: int | str | None = 20,
    max_freq_hz: float | None = None,
    zeta=0.02,
    allow_rigid_modes: bool = False,
    progress: bool | None = None,
) -> ModalResult:
    """Modal analysis of a Nastran deck's part with our shell models (SI units).

    Args:
        path: the deck (.bdf/.dat/.nas): bulk data, or executive and case control with
            BEGIN BULK; INCLUDEd files are read.
        units: its consistent unit system (fem.units.UNIT_SYSTEMS name), e.g. "SI" or
            "MPA" (mm, t, s, N, MPa); Nastran decks do not state one (PARAM WTMASS is
            applied to the density).
        cups: suction cups (fem.SuctionCup) holding the part besides the deck's SPCs.
        spc_id: the SPC set to use (default: the one case control selects, or the deck's
            only set).
        element: "morley" (default for flat decks), "argyris", "shell" (default for curved
            and folded decks) or "hex2" (the thin solid, quads only).
        n_modes, max_freq_hz, zeta, allow_rigid_modes, progress: as fem.modal_analysis.
    Returns the fem.ModalResult (``.to_modal_model(points)``); its meta records the deck,
    its hash and the conversions.
    """
    part, pins, grid_ids, info = part_from_deck(path, units, element=element, spc_id=spc_id)
    supports = as_support_list(list(cups)) + pins
    if not supports and not allow_rigid_modes:
        raise InputError(
            "deck: no SPC and no cups hold the part; add SPC/SPC1 to the deck or give cups "
            "(--cups X,Y,R ...)"
        )
    result = modal_analysis(
        part,
        supports,
        n_modes=n_modes,
        zeta=zeta,
        max_freq_hz=max_freq_hz,
        allow_rigid_modes=allow_rigid_modes,
        progress=progress,
    )
    included = {"included": [file_digest(p) for p in info["included_files"]]}
    result.provenance = {
        "source": "fem.from_nastran (deck read by fem.bdf, solved by jaxflex's shell model)",
        "input": {"deck": file_digest(path), **(included if info["included_files"] else {})},
        "derived": {
            "mesh": "deck GRIDs and shell corner grids (mid-side grids dropped); quads split "
            "into triangles for the plate",
            "supports": f"{len(pins)} SPC grids pinned (translation held), {len(cups)} cups",
            **{k: v for k, v in info.items() if k != "included_files"},
            "grids": int(grid_ids.size),
        },
    }
    return result
