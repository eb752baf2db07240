"""Nastran bulk-data decks read with pyNastran and solved by our own shell models.

A deck's GRID points and shell elements (CQUAD4, CTRIA3, CQUAD8, CTRIA6; the mid-side
grids of the quadratic ones are dropped, our elements have their own edge DOFs), its
PSHELL thickness and MAT1 material become a fem part: a flat deck a Kirchhoff plate
(triangles; quads are split), a curved one of quads the one-layer thin solid. SPC/SPC1
translations become pinned points; the suction cups of the gripper may be given as well
(``cups``). Nastran decks state no units: they are given (fem.units), everything is
converted to SI before the analysis.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from fem import meshing
from fem.ansys import file_digest
from fem.materials import Material
from fem.mesh_io import surface_from_quads
from fem.modal import ModalResult, modal_analysis
from fem.parts import PlateMesh, part_from_mesh
from fem.supports import PointSupport, as_support_list
from fem.units import Units, resolve_units
from jaxflex.errors import InputError

SHELLS = {"CTRIA3": 3, "CTRIA6": 3, "CQUAD4": 4, "CQUAD8": 4}  # corner grids first
FLAT_TOLERANCE = 1e-9  # z spread of a flat deck relative to its extent


def read_deck(path: str | os.PathLike):
    """The pyNastran BDF model of a deck (bulk data only, or with executive and case
    control), cross-referenced."""
    from pyNastran.bdf.bdf import BDF

    path = Path(path)
    if not path.is_file():
        raise InputError(f"deck: file {str(path)!r} does not exist")
    text = path.read_text(errors="replace").upper()
    model = BDF(debug=None)
    try:
        model.read_bdf(str(path), punch="BEGIN BULK" not in text, xref=True)
    except Exception as exc:  # pyNastran raises many types for a broken deck
        raise InputError(
            f"deck: pyNastran cannot read {str(path)!r} ({type(exc).__name__}: {exc})"
        ) from exc
    return model


def _one(kind: str, values: set, what: str):
    if len(values) != 1:
        raise InputError(
            f"deck: {what} differs between elements ({sorted(values)}); a part of one "
            f"{kind} is required"
        )
    return values.pop()


def _constraints(model, spc_id: int | None) -> tuple[list[int], dict]:
    """Grid ids whose translation normal to the sheet is held, and a description."""
    if not model.spcs:
        return [], {}
    if spc_id is None:
        if len(model.spcs) > 1:
            raise InputError(
                f"spc_id: the deck has SPC sets {sorted(model.spcs)}; choose one (--spc-id)"
            )
        spc_id = next(iter(model.spcs))
    if spc_id not in model.spcs:
        raise InputError(f"spc_id: no SPC set {spc_id} in the deck (it has {sorted(model.spcs)})")
    held: list[int] = []
    for card in model.spcs[spc_id]:
        if card.type == "SPC1":
            pairs = [(card.components, nid) for nid in card.node_ids]
        elif card.type == "SPC":
            pairs = list(zip(card.components, card.node_ids, strict=True))
            if any(v != 0 for v in card.enforced):
                raise InputError("deck: SPC with enforced non-zero values is not a support")
        else:
            raise InputError(f"deck: {card.type} constraints are not supported (SPC, SPC1 are)")
        for components, nid in pairs:
            comps = str(components)
            if set(comps) & {"4", "5", "6"}:
                raise InputError(
                    f"deck: SPC set {spc_id} holds rotations ({comps}) of grid {nid}; our "
                    "shell models hold slopes through suction cups (cups=, --cups) or clamped "
                    "edges, not per grid: keep the translations (123) in the deck"
                )
            held.append(int(nid))
    return sorted(set(held)), {"spc_id": int(spc_id), "held_grids": len(set(held))}


def part_from_deck(
    path: str | os.PathLike,
    units: str | Units | None = None,
    *,
    element: str | None = None,
    spc_id: int | None = None,
):
    """(part, pinned supports, grid ids of the part's nodes, description) from a deck."""
    model = read_deck(path)
    unit = resolve_units(units, None, f"the Nastran deck {str(path)!r}")
    shells = [e for e in model.elements.values() if e.type in SHELLS]
    others = sorted({e.type for e in model.elements.values()} - set(SHELLS))
    if others:
        raise InputError(f"deck: elements {others} are not supported (shells: {sorted(SHELLS)})")
    if not shells:
        raise InputError(f"deck: {str(path)!r} has no shell elements ({sorted(SHELLS)})")
    props = list({e.pid: e.pid_ref for e in shells}.values())
    if any(p.type != "PSHELL" for p in props):
        raise InputError("deck: shell properties other than PSHELL are not supported")
    thickness = _one("thickness", {float(p.t) for p in props}, "PSHELL thickness T")
    if any(float(p.nsm or 0.0) != 0.0 for p in props):
        raise InputError("deck: PSHELL non-structural mass (NSM) is not supported")
    mats = [p.mid1_ref for p in props]
    if any(m is None or m.type != "MAT1" for m in mats):
        raise InputError("deck: the PSHELL material must be a MAT1")
    e_mod, nu, rho = _one(
        "material", {(float(m.e), float(m.nu), float(m.rho)) for m in mats}, "MAT1 (E, NU, RHO)"
    )
    corners = [list(e.node_ids[: SHELLS[e.type]]) for e in shells]
    grid_ids = np.unique(np.concatenate(corners))
    index = {int(g): i for i, g in enumerate(grid_ids)}
    xyz = np.array([model.nodes[int(g)].get_position() for g in grid_ids]) * unit.length_m
    material = Material("deck MAT1", e_mod * unit.modulus_to_si, nu, rho * unit.density_to_si)
    extent = float(np.ptp(xyz, axis=0).max())
    flat = np.ptp(xyz[:, 2]) <= FLAT_TOLERANCE * extent
    description = {
        "shape": "Nastran deck",
        "path": str(path),
        "elements": {t: sum(e.type == t for e in shells) for t in SHELLS},
    }
    if flat:
        tris = [c for c in corners if len(c) == 3]
        quads = [c for c in corners if len(c) == 4]
        triangles = [[index[g] for g in c] for c in tris]
        if quads:
            quad_idx = np.array([[index[g] for g in c] for c in quads])
            triangles += meshing.split_quads(quad_idx, xyz[:, :2]).tolist()
        triangles = np.array(triangles)
        a, b, c = (xyz[triangles[:, k], :2] for k in range(3))
        cross = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (
            c[:, 0] - a[:, 0]
        )
        triangles = np.where((cross < 0)[:, None], triangles[:, [0, 2, 1]], triangles)
        mesh = PlateMesh(xyz[:, :2], triangles, float(xyz[0, 2]))
        element = element or "morley"
    else:
        if any(len(c) == 3 for c in corners):
            raise InputError(
                "deck: a curved part is modelled as a thin solid of quads; the deck has "
                "triangles (CTRIA3/CTRIA6) off the plane"
            )
        mesh = surface_from_quads(xyz, np.array([[index[g] for g in c] for c in corners]), path)
        element = element or "hex2"
    part = part_from_mesh(
        mesh, thickness * unit.length_m, material, element, Path(path).name, description
    )
    held, spc = _constraints(model, spc_id)
    missing = [g for g in held if g not in index]
    if missing:
        raise InputError(f"deck: SPC on grids {missing[:5]} that no shell element uses")
    supports = [PointSupport(*xyz[index[g], :2]) for g in held]
    return part, supports, grid_ids, {"units": unit.describe(), **spc}


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
        path: the bulk-data deck (.bdf/.dat/.nas).
        units: its consistent unit system (fem.units.UNIT_SYSTEMS name), e.g. "SI" or
            "MPA" (mm, t, s, N, MPa); Nastran decks do not state one.
        cups: suction cups (fem.SuctionCup) holding the part besides the deck's SPCs.
        spc_id: the SPC set to use when the deck has several.
        element: "morley" (default for flat decks), "argyris", or "hex2" (curved decks).
        n_modes, max_freq_hz, zeta, allow_rigid_modes, progress: as fem.modal_analysis.
    Returns the fem.ModalResult (``.to_modal_model(points)``); its meta records the deck,
    its hash and the conversions.
    """
    part, pins, grid_ids, info = part_from_deck(path, units, element=element, spc_id=spc_id)
    supports = as_support_list(list(cups)) + pins
    if not supports:
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
    result.provenance = {
        "source": "fem.from_nastran (deck solved by jaxflex's shell model)",
        "input": {"deck": file_digest(path)},
        "derived": {
            "mesh": "deck GRIDs and shell corner grids (mid-side grids dropped); quads split "
            "into triangles for the plate",
            "supports": f"{len(pins)} SPC grids pinned (translation held), {len(cups)} cups",
            **info,
            "grids": int(grid_ids.size),
        },
    }
    return result
