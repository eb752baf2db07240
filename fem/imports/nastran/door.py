"""Nastran bulk-data decks solved by our own models (SI units).

A deck (fem.imports.nastran.bdf reads it, fem.imports.nastran.coords places its grids) becomes one
of two models:

* **the deck model** (fem.imports.nastran.model, the default): six DOFs per grid in basic axes; its
  shells as facets of our shell (DKT + OPT, Kirchhoff; quadratic shells through their
  mid-side grids), any mix of properties (PSHELL, PCOMP/PCOMPG) and materials (MAT1, MAT2,
  MAT8), corner thicknesses and offsets; beams and rods, scalar springs, bushings, gaps,
  shear panels, fasteners, spot welds and masses; rigid elements and MPCs as dependent
  components, SPCs (translations and rotations, in the grids' displacement systems) as held
  components, but held drilling rotations that Nastran's shells do not feel
  (fem.imports.nastran.drilling), Nastran's AUTOSPC (fem.imports.nastran.reduce). Its lowest modes
  are sorted out (fem.imports.nastran.zero_modes: mechanisms and modes below the rigid cut-off that
  deform the part are refused with the figure), and the shift Nastran's default lumped mass would
  give its modes is estimated (fem.imports.nastran.mass, warned above 1 %);
* **our plate or thin solid** (``element`` "morley", "argyris" or "hex2"; a flat deck of
  shells alone, one isotropic PSHELL without offsets or corner thicknesses, translations
  held, is the Morley plate by default, as before): the part as fem.read_mesh would build
  it, SPCs as pinned points.

What the door leaves out or refuses is decided by fem.imports.nastran.scope (refusals name each card
with its share of the mass); a heat-transfer deck (SOL 153, 159, APP HEAT) is refused as
such. The suction cups of the gripper may be given as well
(``cups``). Nastran decks state no units: they are given (fem.imports.units). Grids are never
merged, even where two share a location (a deck keeps such seams apart on purpose).
"""

from __future__ import annotations

import os
import time
import warnings
from pathlib import Path

import numpy as np

from fem.discretisation import given_mesh_statement
from fem.imports.imported import file_digest
from fem.imports.nastran.advice import deck_mesh_warnings
from fem.imports.nastran.bdf import BulkData, read_bulk
from fem.imports.nastran.constraints import DeckConstraints, deck_constraints
from fem.imports.nastran.coords import DeckGeometry
from fem.imports.nastran.drilling import free_drilling
from fem.imports.nastran.mass import lumped_mass, lumped_note, lumped_shift
from fem.imports.nastran.materials import Materials
from fem.imports.nastran.model import (
    FORMULATION,
    assemble_deck,
    deck_outputs,
    read_parts,
    sheet_part,
    shell_cells,
    stats,
    to_si,
)
from fem.imports.nastran.reduce import reduce_deck
from fem.imports.nastran.scope import MODELLED, classify, refuse_outside
from fem.imports.nastran.shells import (
    SHELL_CARDS,
    ShellSections,
    element_slots,
    facet_slots,
    read_shell,
)
from fem.imports.nastran.thick import kirchhoff_note
from fem.imports.nastran.zero_modes import (
    RIGID_TOL_HZ,
    ZERO_ENERGY,
    mechanism_message,
    regroup,
    soft_message,
    sort_zero_modes,
)
from fem.imports.units import Units, resolve_units
from fem.materials import Material
from fem.mesh.mesh_io import FLAT_RELATIVE, sheet_from_cells
from fem.mesh_advice import coarse_mesh_warnings
from fem.modal import ModalResult, check_request, modal_analysis, modal_result, solve_modes
from fem.parts import part_from_mesh
from fem.sanity import PartWarning, unit_warnings
from fem.supports import PointSupport, as_support_list, check_layout
from fem.system import FESystem
from jaxflex.errors import InputError

PART_ELEMENTS = ("morley", "argyris", "hex2")
LAMINATE = (
    "each laminate is an equivalent shell by classical lamination theory (its A, B, D, mass and "
    "rotary inertia kept); lost: transverse shear flexibility (the shell is Kirchhoff), ply "
    "stresses and failure indices (the model's stresses are those of a homogeneous section)"
)
NOT_HELD = (
    "deck: no SPC and no cups hold the part; add SPC/SPC1 to the deck, give cups (--cups "
    "X,Y,R ...) or pass allow_rigid_modes=True (--allow-rigid-modes: a free-free part, its "
    "rigid-body modes reported and kept out of the model)"
)


def _simple(bulk: BulkData, shells, sections: ShellSections, constraints: DeckConstraints):
    """Why the deck is not one sheet our plate or thin solid can take (empty: it is), and
    its (thickness, MAT1 card) in file units when it is."""
    reasons = [
        f"{name} ({len(bulk.cards[name])})"
        for name in MODELLED
        if name not in SHELL_CARDS and name in bulk.cards
    ]
    if any(r.card.name == "MPC" for r in constraints.relations):
        reasons.append("MPC")
    props = {}
    for element in shells:
        section = sections.get(element)
        props[element.pid] = section
        if any(t is not None for t in element.corner_t):
            reasons.append(f"corner thicknesses ({element.card.label})")
        if element.zoffs:
            reasons.append(f"offsets ({element.card.label})")
        if reasons:
            break
    values = set()
    material = None
    for section in props.values():
        card = section.card
        if card.name != "PSHELL":
            reasons.append(card.name)
            continue
        mids = {card.integer(k, "MID") for k in (1, 3)} - {None, 0}
        mats = [sections.materials.get(m, card, 3, "MID") for m in mids]
        if not all(m.isotropic for m in mats) or not card.integer(3, "MID2"):
            reasons.append(f"{card.label} is not one isotropic bending material")
            continue
        if len({(m.e, m.nu, m.rho) for m in mats}) > 1 or section.thickness is None:
            reasons.append(f"{card.label}: MID1 and MID2 differ or T is blank")
            continue
        if card.real(4, "12I/T**3", 1.0) != 1.0 or section.nsm or card.integer(10, "MID4"):
            reasons.append(f"{card.label}: 12I/T**3, NSM or MID4")
            continue
        values.add((section.thickness, mats[0].e, mats[0].nu, mats[0].rho))
        material = mats[0]
    if len(values) > 1:
        reasons.append("several shell properties")
    rotations = sorted({g for (g, c) in constraints.held if c in (4, 5)})
    if rotations:
        reasons.append(f"rotations held (grid {rotations[0]}, ...)")
    if any(bulk.grids[g].cd for g, _ in constraints.held):
        reasons.append("held components in a displacement system (CD)")
    return reasons, (next(iter(values))[0] if values else None, material)


def _pins(bulk, constraints, flat: bool, shell_grids: set):
    """Grid ids pinned (translations held) for our plate or thin solid, and counts."""
    held: dict[int, set] = {}
    for gid, comp in constraints.held:
        held.setdefault(gid, set()).add(str(comp))
    pinned, ignored = [], 0
    for gid, comps in sorted(held.items()):
        translations = comps & {"1", "2", "3"}
        if flat:
            keep = "3" in translations  # 1, 2 (in-plane) and 6 (drilling): not plate DOFs
        else:
            if translations and translations != {"1", "2", "3"}:
                card = constraints.held[(gid, int(min(translations)))]
                raise InputError(
                    f"deck: {card.where(None)}: grid {gid} holds translations "
                    f"{''.join(sorted(comps))}; the thin solid pins all three (123) at a point"
                )
            keep = bool(translations)
        if not keep:
            ignored += 1
            continue
        if gid not in shell_grids:
            card = next(c for (g, _), c in constraints.held.items() if g == gid)
            raise InputError(f"deck: {card.where(None)}: grid {gid} is held but no shell uses it")
        pinned.append(gid)
    return pinned, {"held_grids": len(pinned), "constraints_without_effect": ignored}


def _plate_part(path, bulk, geometry, unit, shells, element, simple, constraints):
    """(part, pinned supports, info) of our plate or thin solid (quadratic elements as the
    facets of the deck model, fem.imports.nastran.shells)."""
    thickness, mat = simple
    if mat.rho * bulk.wtmass <= 0:
        raise InputError(_massless(bulk))
    grid_ids = sorted({g for s in shells for g in s.grids})
    index = {g: i for i, g in enumerate(grid_ids)}
    xyz = np.array([geometry.positions[g] for g in grid_ids]) * unit.length_m
    try:
        material = Material(
            f"deck {mat.card.label}",
            mat.e * unit.modulus_to_si,
            mat.nu,
            mat.rho * bulk.wtmass * unit.density_to_si,
        )
    except InputError as exc:
        raise InputError(f"deck: {mat.card.label} {exc}") from exc
    slots = element_slots(shells, index)
    owner, local = facet_slots(shells, slots, xyz)
    triangles = np.take_along_axis(slots[owner], local, axis=1)
    blocks = shell_cells(shells, triangles, owner, index)
    sheet = sheet_from_cells(xyz, blocks, str(path), weld=False, max_extent_m=np.inf)
    description = {"shape": "Nastran deck", "path": str(path)}
    part = part_from_mesh(
        sheet, thickness * unit.length_m, material, element, Path(path).name, description
    )
    pinned, info = _pins(bulk, constraints, bool(sheet.is_flat), set(index))
    return part, [PointSupport(*xyz[index[g]]) for g in pinned], info


def _deck_result(
    path, bulk, geometry, unit, shells, constraints, sections, cups, request, progress
):
    """Modal analysis of the deck model (module docstring)."""
    n_modes, max_freq_hz, zeta, allow_rigid_modes = request
    t_start = time.perf_counter()
    timings: dict[str, float] = {}
    parts = read_parts(bulk, geometry, shells, constraints, sections)
    K, M = assemble_deck(parts, geometry, unit, bulk.wtmass, progress)
    n_grids = len(parts.grid_ids)
    rigid = np.zeros((6 * n_grids, 3))
    for d in range(3):
        rigid[d::6, d] = 1.0
    mass = float(np.max(np.einsum("id,id->d", rigid, M @ rigid)))
    if mass <= 0:
        raise InputError(_massless(bulk))
    timings["assembly_s"] = time.perf_counter() - t_start
    part, mesh = sheet_part(parts, geometry, unit, str(path), mass, Path(path).name)
    nodes = np.array([geometry.positions[int(g)] for g in parts.grid_ids]) * unit.length_m
    outputs, dofs = deck_outputs(parts, part, mesh, nodes, unit)
    supports = as_support_list(list(cups))
    check_layout(supports, part, allow_rigid_modes=True)  # rigid modes: the solver says
    index = parts.index
    held = {k: c for k, c in constraints.held.items() if k[0] in index}
    frames = geometry.frames(parts.grid_ids)
    drilling = free_drilling(held, parts, nodes, frames, constraints.grids)
    held = {k: c for k, c in held.items() if k not in drilling}
    model_constraints = DeckConstraints(held, constraints.relations, constraints.info)
    tick = time.perf_counter()
    reduction = reduce_deck(
        K,
        M,
        frames,
        lambda key: 6 * index[key[0]] + key[1] - 1,
        model_constraints,
        [s.hold_solid(dofs, i) for i, s in enumerate(supports)],
        lambda g: f"component {g % 6 + 1} of grid {parts.grid_ids[g // 6]}",
    )
    timings["constraints_s"] = time.perf_counter() - tick
    n_shell = parts.n_shell
    system = FESystem(
        K=K, M=M, rigid=rigid, nodes=nodes[:n_shell],
        node_dofs=6 * np.arange(n_shell)[:, None] + np.arange(3),
        cells=parts.facets.triangles, cell_type="triangle", constraints=reduction.constraints,
        stats=stats(parts, nodes), formulation=FORMULATION, outputs=outputs,
        support_constraints=reduction.held_by_support,
    )  # fmt: skip
    T = reduction.basis
    observation = (system.observation() @ T).tocsr()
    load = T.T @ (M @ rigid)
    count = n_modes
    if isinstance(n_modes, int) and T.shape[1] <= n_modes + 8:  # a model of a few DOFs
        count = "all"  # every mode, densely (the sparse solver needs more DOFs than modes)
    grids = (nodes, parts.grid_ids, frames)
    modes = _solve(reduction, load, observation, count, max_freq_hz, allow_rigid_modes,
                   grids, progress)  # fmt: skip
    timings.update(modes.timings_s)
    reduced = (T, reduction.stiffness, reduction.mass, load, observation)
    result = modal_result(part, supports, system, reduced, modes, zeta, timings, t_start)
    shift = _lumped_shift(bulk, parts, unit, nodes, T @ modes.vectors, modes.freq_hz, part.name)
    info = {
        "grids": n_grids,
        "shell_facets": len(parts.facets.triangles),
        "held_components_without_effect": len(constraints.held) - len(held) - len(drilling),
        "held_drilling_rotations_left_free": len(drilling),
        "lumped_mass_shift": shift,
        **reduction.info,
        "notes": _notes(parts),
    }
    return result, info, parts


RIGID_MESSAGE = (
    "supports: the deck's constraints and the cups leave {count} rigid-body mode(s) (below "
    "{tol:g} Hz): the part is not held; add SPC or cups, or pass allow_rigid_modes=True "
    "(--allow-rigid-modes)"
)


def _solve(reduction, load, observation, count, max_freq_hz, allow_rigid_modes, grids, progress):
    """The modes of the reduced deck model, its lowest ones sorted out
    (fem.imports.nastran.zero_modes): mechanisms and modes below the rigid cut-off that deform the
    part are refused, rigid-body modes without ``allow_rigid_modes`` too. ``grids``: (nodes (N, 3)
    m, grid ids, their displacement systems (N, 3, 3))."""

    def solve(rigid_count):
        try:
            return solve_modes(
                reduction.stiffness,
                reduction.mass,
                load,
                observation,
                count,
                max_freq_hz=max_freq_hz,
                rigid_count=rigid_count,
                rigid_message=RIGID_MESSAGE,
                progress=progress,
            )
        except (RuntimeError, np.linalg.LinAlgError) as exc:  # a singular mass or K - s M
            raise InputError(
                f"deck: the model cannot be solved ({exc}): a motion without mass or without "
                "stiffness that spans several grids (point masses without rotary inertia on a "
                "rigid element, a mechanism); give the masses inertia or hold the mechanism"
            ) from None

    try:
        modes = solve(6 if allow_rigid_modes else None)
    except InputError as exc:  # rigid-body modes, or what looks like them: say which
        if not str(exc).startswith("supports:"):
            raise
        modes = solve(6)
    found = sort_zero_modes(
        reduction.stiffness,
        reduction.basis,
        grids,
        reduction.autospc,
        modes.rigid_vectors,
        modes.rigid_freq_hz,
        modes.vectors,
    )
    if found.mechanisms:
        raise InputError(mechanism_message(found))
    if found.soft_hz.size:
        raise InputError(soft_message(found))
    called = len(modes.rigid_freq_hz)
    deforming = found.energy[:called] >= ZERO_ENERGY  # called rigid by a frequency gap
    rigid = found.energy[called:] < ZERO_ENERGY  # rigid, above the cut-off
    modes = regroup(modes, deforming, rigid, count if isinstance(count, int) else None)
    if modes.rigid_freq_hz.size and not allow_rigid_modes:
        raise InputError(RIGID_MESSAGE.format(count=modes.rigid_freq_hz.size, tol=RIGID_TOL_HZ))
    return modes


def _lumped_shift(bulk, parts, unit, nodes_m: np.ndarray, vectors_u, freq_hz, name: str):
    """Nastran's lumped mass's estimated shift of the modes (fem.imports.nastran.mass) as a list,
    warned where it exceeds 1 %; "coupled" when the deck asks Nastran for coupled mass (PARAM
    COUPMASS > 0)."""
    for card in bulk.named("PARAM"):
        if card.text(0) == "COUPMASS" and (card.integer(1, "V1") or 0) > 0:
            return "coupled (PARAM COUPMASS)"
    lumped = to_si(lumped_mass(parts, nodes_m / unit.length_m), unit, bulk.wtmass)
    shift = lumped_shift(freq_hz, vectors_u, lumped)
    note = lumped_note(shift)
    if note:
        warnings.warn(f"{name}: {note}", PartWarning, stacklevel=4)
    return [round(float(v), 5) for v in shift]


def _massless(bulk: BulkData) -> str:
    """The refusal of a deck without mass, naming its materials."""
    names = [c.label for c in bulk.named("MAT1", "MAT2", "MAT8")]
    shown = ", ".join(names[:4]) + (", ..." if len(names) > 4 else "")
    return (
        f"deck: the model has no mass: RHO is blank or 0 on {shown or 'its materials'} and "
        "there is no CONM1/CONM2/CMASS; a modal analysis needs the mass (a static deck?)"
    )


def _notes(parts) -> list[str]:
    notes = [n for s in parts.shell_sections.read.values() for n in s.notes]
    return notes + parts.beam_sections.notes()


def _warn(part, unit: Units, nu: float, shear_flexible: bool) -> None:
    hint = f"check the unit system (the deck was read as {unit.name}: {unit.description})"
    for message in unit_warnings(part, hint):
        warnings.warn(f"{part.name}: {message}", PartWarning, stacklevel=3)
    note = kirchhoff_note(part.thickness_m, part.span_m, nu, part.element)
    if note:
        if shear_flexible:
            note += " (the deck's MID3 gives Nastran's element that shear flexibility)"
        warnings.warn(f"{part.name}: {note}", PartWarning, stacklevel=3)


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
    """Modal analysis of a Nastran deck with our models (SI units; module docstring).

    Args:
        path: the deck (.bdf/.dat/.nas): bulk data, or executive and case control with
            BEGIN BULK; INCLUDEd files are read (relative to the deck's directory).
        units: its consistent unit system (fem.imports.units.UNIT_SYSTEMS name), e.g. "SI" or
            "MPA" (mm, t, s, N, MPa); Nastran decks do not state one (PARAM WTMASS is
            applied to every mass).
        cups: suction cups (fem.SuctionCup) holding the part besides the deck's SPCs.
        spc_id: the SPC set to use (default: the one case control selects, or the deck's
            only set).
        element: "shell" (the deck model; the default), or "morley", "argyris", "hex2" (our
            plate or thin solid, for a deck of one isotropic sheet; a flat one is "morley"
            by default).
        n_modes, max_freq_hz, zeta, allow_rigid_modes, progress: as fem.modal_analysis.
    Returns the fem.ModalResult (``.to_modal_model(points)``); its meta records the deck,
    its hash and what was read, left out and derived. Issues fem.sanity.PartWarning for a
    thickness, mass or size that looks like a unit slip and for a thick part.
    """
    max_freq_hz = check_request(n_modes, max_freq_hz, zeta)
    bulk = read_bulk(path)
    unit = resolve_units(units, None, f"the Nastran deck {str(path)!r}")
    if bulk.heat:
        raise InputError(
            f"deck: {Path(path).name} is a heat-transfer analysis ({bulk.heat}): its materials "
            "(MAT4, MAT5) and elements carry heat, not the stiffness and mass of modes"
        )
    geometry = DeckGeometry(bulk)
    refused, left_out = classify(bulk)
    if refused or bulk.parts:
        refuse_outside(bulk, geometry, refused)
    shells = [read_shell(card, bulk) for card in bulk.named(*SHELL_CARDS)]
    if not shells:
        raise InputError(f"deck: {str(path)!r} has no shell elements (CQUAD4, CTRIA3, ...)")
    constraints = deck_constraints(bulk, geometry, spc_id)
    sections = ShellSections(bulk, Materials(bulk))
    reasons, simple = _simple(bulk, shells, sections, constraints)
    flat = _is_flat(geometry, shells)
    if element is None:
        element = "morley" if flat and not reasons else "shell"
    if element in PART_ELEMENTS and reasons:
        raise InputError(
            f"element: {element!r} takes a deck of one isotropic sheet; this one has "
            f"{', '.join(reasons[:4])}: use element='shell' (the deck model, the default)"
        )
    if element not in (*PART_ELEMENTS, "shell"):
        raise InputError(f"element: one of {('shell', *PART_ELEMENTS)}, got {element!r}")
    info = {
        "units": unit.describe(),
        "elements": {n: len(bulk.cards[n]) for n in MODELLED if n in bulk.cards},
        **constraints.info,
        "wtmass": bulk.wtmass,
        "ignored_cards": dict(sorted(left_out.items())),
        **({"include_notes": bulk.include_notes} if bulk.include_notes else {}),
        **({"duplicates_dropped": bulk.duplicates_dropped} if bulk.duplicates_dropped else {}),
    }
    if element == "shell":
        request = (n_modes, max_freq_hz, zeta, allow_rigid_modes)
        result, more, parts = _deck_result(
            path, bulk, geometry, unit, shells, constraints, sections, cups, request, progress
        )
        info.update(more)
        first = parts.shell_sections.read[int(parts.facets.pid[0])]
        shear = any(s.shear_flexible for s in parts.shell_sections.read.values())
        _warn(result.part, unit, first.poisson, shear)
        advice = deck_mesh_warnings(result, parts, unit, bulk.wtmass)
        for message in advice:
            warnings.warn(f"{result.part.name}: {message}", PartWarning, stacklevel=2)
        result.discretisation = given_mesh_statement(advice)
        laminates = [s.card.label for s in parts.shell_sections.read.values() if s.laminate]
        if laminates:
            message = f"{result.part.name}: {', '.join(laminates)}: {LAMINATE}"
            warnings.warn(message, PartWarning, stacklevel=2)
        described = "deck model: 6 DOFs per grid (fem.imports.nastran.model)"
    else:
        part, pins, pinned = _plate_part(
            path, bulk, geometry, unit, shells, element, simple, constraints
        )
        info.update(pinned)
        supports = as_support_list(list(cups)) + pins
        if not supports and not allow_rigid_modes:
            raise InputError(NOT_HELD)
        _warn(part, unit, part.material.nu, any(s.shear_flexible for s in sections.read.values()))
        result = modal_analysis(
            part,
            supports,
            n_modes=n_modes,
            zeta=zeta,
            max_freq_hz=max_freq_hz,
            allow_rigid_modes=allow_rigid_modes,
            progress=progress,
        )
        for message in coarse_mesh_warnings(result):
            warnings.warn(f"{part.name}: {message}", PartWarning, stacklevel=2)
        described = f"{len(pins)} SPC grids pinned (translation held), {len(cups)} cups"
    info["material_notes"] = sections.materials.notes()
    included = {"included": [file_digest(p) for p in bulk.files[1:]]}
    result.provenance = {
        "source": (
            "fem.from_nastran (deck read by fem.imports.nastran.bdf, solved by jaxflex's models)"
        ),
        "input": {"deck": file_digest(path), **(included if bulk.files[1:] else {})},
        "derived": {"model": described, **info},
    }
    return result


def _is_flat(geometry: DeckGeometry, shells) -> bool:
    """Whether the shells' grids lie in a plane z = const (as fem.mesh.mesh_io)."""
    xyz = np.array([geometry.positions[g] for s in shells for g in s.grids])
    extent = float(np.ptp(xyz, axis=0).max())
    return bool(np.ptp(xyz[:, 2]) <= FLAT_RELATIVE * max(extent, 1e-300))
