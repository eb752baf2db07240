"""A modal model from the modes another solver computed (``jaxflex model --from-modes``).

Files: Nastran OP2 (fem.imports.op2_modes), Nastran punch (fem.imports.punch), Universal File
datasets 55 (modes) or 58 (time responses to a unit hat, identified like the preprint's R1;
fem.imports.uff, fem.imports.r1). What each kind of file holds differs, and nothing it lacks is
guessed:

* **units**: a Universal File states them (dataset 164); Nastran files do not, so
  ``units`` is required (fem.imports.units);
* **coordinates**: the file's (OP2 geometry, UFF 15/2411) or ``nodes`` (a CSV node,x,y,z in
  file units, or another file of the same run that holds them);
* **mass normalisation**: where the file states the generalized masses (OP2 LAMA, UFF 55),
  shapes are scaled to unit modal mass and the summary says what was found; where it does
  not (punch, UFF with modal mass 0), the shapes are taken as the solver normalised them and
  the meta says so;
* **participation factors** Gamma = phi^T M R: from the file where it holds them (the OP2's
  MPFACS matrix of MEFFMASS), else from the user (``gamma``, one row x, y, z per kept mode,
  kg^0.5, for the shapes as the file gives them), else refused naming why;
* **rigid-body modes** (below ``rigid_tol_hz``): refused unless ``allow_rigid_modes``, then
  left out and reported (fem.imports.solver_modes.rigid_mask, as on every door);
* **static response**: a model built from modes alone has no stiffness matrix, so it has no
  exact quasi-static response (the meta's ``static_response`` says so).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from fem.imports.checks import check_finite
from fem.imports.imported import ImportedModes, file_digest
from fem.imports.op2_modes import read_op2_modes
from fem.imports.punch import read_punch_modes
from fem.imports.r1 import identify_r1
from fem.imports.r1_layout import R1Layout, steps_from_zero
from fem.imports.solver_modes import SolverModes, kept_modes, rigid_mask, rigid_meta, user_gamma
from fem.imports.uff import UffResponses, read_uff
from fem.imports.units import Units, resolve_units
from jaxflex.errors import InputError

READERS = {
    ".op2": read_op2_modes,
    ".pch": read_punch_modes,
    ".punch": read_punch_modes,
}
UFF_SUFFIXES = (".uff", ".unv", ".uf")
SUFFIXES = (*READERS, *UFF_SUFFIXES)
NORMALISED_RTOL = 1e-4  # generalized masses within this of 1: mass-normalised (float32 files)
STATIC_RESPONSE = (
    "none: a model built from modal results carries no stiffness matrix, so it has no exact "
    "quasi-static response (the mode-acceleration correction); responses are the modal sum "
    "of the retained modes"
)


def _read(path: Path) -> tuple[SolverModes | None, UffResponses | None]:
    suffix = path.suffix.lower()
    if suffix in UFF_SUFFIXES:
        return read_uff(path)
    if suffix not in READERS:
        raise InputError(
            f"from_modes: {str(path)!r}: expected a Nastran OP2 (.op2), punch (.pch) or "
            f"Universal File ({', '.join(UFF_SUFFIXES)})"
        )
    return READERS[suffix](path), None


def _nodes_from(path, node_ids: np.ndarray) -> np.ndarray:
    """Coordinates of ``node_ids`` (file units) from a CSV node,x,y,z or a result file."""
    path = Path(path)
    if path.suffix.lower() in SUFFIXES:
        modes, _ = _read(path)
        if modes is None or modes.nodes is None:
            raise InputError(f"nodes: {str(path)!r} holds no node coordinates")
        ids, coords = modes.node_ids, modes.nodes
    else:
        from fem.imports.ansys import read_node_coordinates

        ids, coords = read_node_coordinates(path)
    where = {int(n): i for i, n in enumerate(ids)}
    missing = [int(n) for n in node_ids if int(n) not in where]
    if missing:
        raise InputError(
            f"nodes: {str(path)!r} lacks {len(missing)} node(s) of the modes, e.g. {missing[:5]}"
        )
    return np.asarray(coords, dtype=float)[[where[int(n)] for n in node_ids]]


def from_modes(
    path: str | os.PathLike,
    *,
    units: str | Units | None = None,
    gamma=None,
    nodes: str | os.PathLike | None = None,
    n_modes: int | None = None,
    max_freq_hz: float | None = None,
    zeta=0.02,
    allow_rigid_modes: bool = False,
    rigid_tol_hz: float = 0.01,
) -> ImportedModes:
    """The modes of a solver's result file as ImportedModes (SI units; see the module).

    Args:
        path: .op2, .pch, or a Universal File (.uff, .unv).
        units: the file's consistent unit system (fem.imports.units name) where it states none.
        gamma: participation factors (M, 3) in kg^0.5 for the kept modes, where the file
            holds none.
        nodes: coordinates where the file holds none: a CSV node,x,y,z in file units or a
            result file of the same run.
        n_modes, max_freq_hz: keep the lowest ``n_modes`` elastic modes / those up to
            ``max_freq_hz`` (default: all).
        zeta: modal damping (scalar, per mode or fem.Rayleigh); a Universal File's measured
            responses give their identified damping instead.
        allow_rigid_modes: accept rigid-body modes (left out of the model and reported).
        rigid_tol_hz: modes below this frequency are rigid-body modes.
    """
    path = Path(path)
    modes, responses = _read(path)
    if responses is not None:
        return _identified(path, responses, nodes, n_modes, units)
    return _from_solver_modes(
        modes, units, gamma, nodes, n_modes, max_freq_hz, zeta, allow_rigid_modes, rigid_tol_hz
    )


def _from_solver_modes(
    modes: SolverModes, units, gamma, nodes, n_modes, max_freq_hz, zeta, allow, rigid_tol_hz
) -> ImportedModes:
    source = repr(modes.path)
    for name in ("freq_hz", "shapes", "generalized_mass", "gamma", "nodes"):
        check_finite(name, getattr(modes, name), source)  # before any scaling hides them
    unit = resolve_units(units, None, source) if modes.units is None else modes.units
    if units is not None and modes.units is not None:
        given = resolve_units(units, None, source)
        if not np.allclose([given.length_m, given.mass_kg], [unit.length_m, unit.mass_kg]):
            raise InputError(
                f"units: {source} states {unit.description}; units={units!r} says otherwise; "
                "omit units to use the file's"
            )
    rigid = rigid_mask(modes.freq_hz, rigid_tol_hz, allow, source, modes.nodes, modes.shapes)
    keep = ~rigid
    if max_freq_hz is not None:
        keep &= modes.freq_hz <= max_freq_hz
    kept = kept_modes(keep, n_modes, source, max_freq_hz)
    if kept.size == 0:
        raise InputError(f"from_modes: {source} leaves no elastic mode to keep")
    shapes = modes.shapes[:, :, kept]
    derived: dict = {}
    scale = np.ones(kept.size)
    if modes.generalized_mass is not None:
        mass = modes.generalized_mass[kept]
        if np.any(mass <= 0):
            raise InputError(f"from_modes: {source} states generalized masses <= 0: {mass[:5]}")
        normalised = bool(np.all(np.abs(mass - 1) <= NORMALISED_RTOL))
        scale = np.ones_like(mass) if normalised else 1 / np.sqrt(mass)
        derived["mass_normalisation"] = (
            f"generalized masses stated by the file: 1 within {np.abs(mass - 1).max():.1e}, "
            "mass-normalised as read"
            if normalised
            else f"generalized masses stated by the file {mass.min():.6g} ... {mass.max():.6g} "
            "(not mass-normalised, e.g. MAX normalisation): shapes scaled by 1/sqrt(mass)"
        )
    else:
        derived["mass_normalisation"] = (
            "not stated by the file: shapes taken as the solver normalised them (mass-"
            "normalised if it used the mass normalisation); participation factors must be "
            "for these shapes"
        )
    shapes = shapes * scale
    result_gamma, gamma_missing = None, modes.gamma_missing
    if modes.gamma is not None:
        if gamma is not None:
            raise InputError(f"gamma: {source} holds the participation factors; do not pass them")
        # the file's factors are phi^T M R / (phi^T M phi); for unit modal mass: x sqrt(mass)
        result_gamma = modes.gamma[kept] / scale[:, None]
        derived["gamma"] = f"from {modes.gamma_source}"
    elif gamma is not None:
        result_gamma = user_gamma(gamma, kept.size) * scale[:, None]
        derived["gamma"] = "given by the user (for the shapes as the file gives them)"
    else:
        gamma_missing += "; pass gamma= (--gamma: one row x,y,z per kept mode, kg^0.5)"
    coords, nodes_missing = modes.nodes, modes.nodes_missing
    inputs = {"modes": file_digest(modes.path)}
    if nodes is not None:
        coords, nodes_missing = _nodes_from(nodes, modes.node_ids), ""
        inputs["nodes"] = file_digest(nodes)
    provenance = {
        "source": f"fem.imports.from_modes ({modes.kind})",
        "input": inputs,
        "file_units": unit.describe(),
        "derived": {
            "modes": f"{kept.size} of the file's {modes.freq_hz.size} modes (mode numbers "
            f"{modes.mode_ids[kept].tolist()[:10]}{' ...' if kept.size > 10 else ''})",
            **derived,
        },
        "notes": modes.notes,
        "rigid_modes": rigid_meta(modes.freq_hz[rigid]),
        "static_response": STATIC_RESPONSE,
    }
    return ImportedModes(
        freq_hz=modes.freq_hz[kept],
        shapes=shapes * unit.shape_to_si,
        gamma=None if result_gamma is None else result_gamma * unit.gamma_to_si,
        nodes=None if coords is None else coords * unit.length_m,
        node_ids=modes.node_ids,
        zeta=zeta,
        gamma_missing=gamma_missing,
        nodes_missing=nodes_missing,
        provenance=provenance,
    )


def _identified(path: Path, responses: UffResponses, nodes, n_modes, units) -> ImportedModes:
    """Identify the modes of UFF time responses to a unit hat (datasets 58; fem.imports.r1)."""
    dt = responses.dt_s
    if abs(responses.first_time_s) <= 1e-6 * dt:
        layout = R1Layout(0, "time axis of the datasets 58 (first sample at t = 0)")
    elif abs(responses.first_time_s - dt) <= 1e-6 * dt:
        layout = R1Layout(1, "time axis of the datasets 58 (first sample at t = dt)")
    else:
        raise InputError(
            f"uff: {str(path)!r}: the responses start at {responses.first_time_s:g} s; responses "
            f"to the unit hat start at t = 0 or t = dt ({dt:g} s)"
        )
    r1 = np.stack([steps_from_zero(values, layout) for values in responses.values])
    coords = responses.nodes
    if nodes is not None:
        coords = _nodes_from(nodes, responses.node_ids)
    if coords is not None:
        stated = responses.units
        unit = stated if stated is not None else resolve_units(units, None, repr(str(path)))
        coords = coords * unit.length_m
    result = identify_r1(
        r1, dt, responses.axes, nodes=coords, node_ids=responses.node_ids, max_modes=n_modes
    )
    result.layouts = [f"{path.name}: {layout.describe()}"]
    result.provenance["input"] = {"r1": file_digest(path)}
    result.provenance["derived"]["dt_s"] = "from the file's time axis"
    result.provenance["derived"]["layout"] = result.layouts
    result.provenance["notes"] = responses.notes
    result.provenance["static_response"] = STATIC_RESPONSE
    return result
