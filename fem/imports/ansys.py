"""ANSYS (MAPDL) modal models read with ansys-mapdl-reader: ``.full`` matrices and ``.rst`` modes.

* ``.full``: stiffness and mass matrices with the DOF reference (node number, DOF label).
  MAPDL stores one triangle of each symmetric matrix, and the DOFs it constrained appear as
  empty rows and columns. They are symmetrised, the constrained DOFs are removed, and the
  modes and participation factors are computed exactly as for our own models
  (fem.modal.solve_modes): Gamma = phi^T M R with R the unit rigid translations of the
  translational DOFs (UX, UY, UZ; rotations take no part). The mass coupling between free and
  constrained DOFs is not in the file, so the load is M_ff R_f and the participation factors
  of all modes add up to R_f^T M_ff R_f per direction. The file holds no coordinates: they
  come from an archive (.cdb), a result (.rst) or a CSV of the same mesh.
* ``.rst``: frequencies, mode shapes (global x, y, z), node coordinates and, where stored,
  nodal stresses per mode. Participation factors need the mass matrix, which a result file
  does not hold: they are taken from the user or computed with the ``.full`` of the same model
  after checking that nodes, DOFs and constraints match and that the modes solve its
  eigenproblem.

Results are converted to SI with the unit system the file states or the user gives
(fem.imports.units). Nodes in rotated nodal coordinate systems (NROTAT, node angles): the DOFs of a
``.full`` are nodal, so the rigid translations R and the shapes are turned with the node
angles of the ``.cdb`` or ``.rst`` given for the coordinates (a CSV cannot state them); a
``.rst``'s shapes are turned to global axes by ansys-mapdl-reader, and back to nodal axes
where they are paired with a ``.full``.

ansys-mapdl-reader loads pyvista and VTK (about 10 s on a loaded 2-core machine): it is
imported where a file is read, so that `import fem` and `jaxflex model` for other parts do
not pay for it. The files are read by fem.imports.ansys_files, each in a child interpreter
that imports only that module (no JAX, no FE solver).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from fem.eigen import factorize
from fem.elements.rigid_fields import nodal_fields
from fem.imports.ansys_files import (
    ROTATIONS,
    TRANSLATIONS,
    FullMatrices,
    RstModes,
    listed,
    nodal_rotations,
    read_full,
    read_node_coordinates,
    read_node_rotations,
    read_rst,
)
from fem.imports.imported import ImportedModes, file_digest
from fem.imports.solver_modes import kept_modes, rigid_mask, rigid_meta, user_gamma
from fem.imports.units import Units, resolve_units
from fem.modal import solve_modes
from fem.rotation_integrals import imported_inertia
from jaxflex.errors import InputError

# Largest relative eigen residual |K phi - w^2 M phi| / |K phi| accepted for .rst modes paired
# with a .full: MAPDL's eigen solvers converge far below it; a different model (material,
# geometry, constraints) misses it by orders of magnitude.
PAIRING_RESIDUAL = 1e-4


def _dof_rotation(
    dof_nodes: np.ndarray, labels: np.ndarray, rotations: dict | None, names=TRANSLATIONS
):
    """(n, 3): for each DOF, the global components of its unit nodal translation (T[:, i] of
    its node for UX, UY, UZ = i; zeros for rotations); with ``names`` ROTATIONS those of its
    unit nodal rotation (zeros for translations)."""
    out = np.zeros((len(labels), 3))
    for d, name in enumerate(names):
        rows = np.flatnonzero(labels == name)
        if rows.size == 0:
            continue
        if rotations is None:
            out[rows, d] = 1.0
        else:
            eye = np.eye(3)
            out[rows] = np.array([rotations.get(int(n), eye)[:, d] for n in dof_nodes[rows]])
    return out


def _rotation_data(full: FullMatrices, free, M, vectors, node_ids, coords, rotations, unit):
    """The turning moves' RotationalInertia (jaxflex._rotation) of the modes ``vectors``
    (free DOFs, file units) from the .full's mass matrix ``M`` and the coordinates ``coords``
    (file units) of ``node_ids`` (fem.rotation_integrals.imported_inertia)."""
    dof_nodes, labels = full.node_ids[free], full.labels[free]
    where = {int(n): i for i, n in enumerate(node_ids)}
    points = coords[[where[int(n)] for n in dof_nodes]]
    translations = _dof_rotation(dof_nodes, labels, rotations)
    axes = _dof_rotation(dof_nodes, labels, rotations, ROTATIONS)
    return imported_inertia(
        M, vectors, nodal_fields(points, translations, axes), translations, unit
    )


def _free_system(full: FullMatrices, rotations: dict | None = None):
    """Free DOFs, K_ff, M_ff and R_f (unit global translations in the DOFs, which are nodal:
    R[dof of node n along its axis i, d] = T_n[d, i])."""
    free = np.flatnonzero(~full.constrained)
    K = full.K[free][:, free].tocsr()
    M = full.M[free][:, free].tocsr()
    rigid = _dof_rotation(full.node_ids[free], full.labels[free], rotations)
    return free, K, M, rigid


def _observation(node_ids: np.ndarray, dof_nodes: np.ndarray, labels: np.ndarray, rotations=None):
    """Sparse (3N, n): global x, y, z displacements of each node in ``node_ids`` from the
    DOFs (UX, UY, UZ in each node's nodal system; ``rotations`` {node: T} or None)."""
    row_of = {int(n): i for i, n in enumerate(node_ids)}
    axes = _dof_rotation(dof_nodes, labels, rotations)
    rows, cols, vals = [], [], []
    for col, node in enumerate(dof_nodes):
        if int(node) in row_of and axes[col].any():
            for d in range(3):
                rows.append(3 * row_of[int(node)] + d)
                cols.append(col)
                vals.append(axes[col, d])
    return sp.csr_matrix((vals, (rows, cols)), shape=(3 * len(node_ids), len(dof_nodes)))


def from_ansys(
    path: str | os.PathLike,
    *,
    full: str | os.PathLike | None = None,
    nodes: str | os.PathLike | None = None,
    units: str | Units | None = None,
    n_modes: int | str | None = 20,
    max_freq_hz: float | None = None,
    gamma=None,
    zeta=0.02,
    rigid_tol_hz: float = 0.01,
    allow_rigid_modes: bool = False,
    progress: bool | None = None,
) -> ImportedModes:
    """Modes of an ANSYS model (SI units); ``.to_modal_model(points)`` gives the ModalModel.

    Args:
        path: a ``.full`` (matrices: modes and participation are computed here) or a ``.rst``
            (modes as MAPDL computed them).
        full: with a ``.rst``: the ``.full`` of the same model, for the participation
            factors (nodes, DOFs and constraints must match; the modes must solve its
            eigenproblem).
        nodes: with a ``.full``: node coordinates from a ``.cdb`` archive, a ``.rst`` or a
            CSV ``node, x, y, z`` of the same mesh (file units).
        units: the consistent unit system (fem.imports.units.UNIT_SYSTEMS name) when the file does
            not state one, e.g. "SI", "MPA" (mm, t, s), "BIN" (in, lbf s^2/in, s).
        n_modes: modes to keep (a ``.full``: to compute; "all" for a dense solve of a small
            model); None with ``max_freq_hz``.
        max_freq_hz: keep modes up to this frequency.
        gamma: with a ``.rst`` alone: participation factors (M, 3) in kg^0.5, one row per
            kept mode (e.g. from MAPDL's participation factor listing).
        zeta: modal damping ratio (scalar, per mode or fem.Rayleigh).
        rigid_tol_hz: modes below this frequency are rigid-body modes.
        allow_rigid_modes: accept a model with rigid-body modes (a free part): they are
            left out of the model and reported; refused otherwise (the rule of every door).
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in (".full", ".rst"):
        raise InputError(f"from_ansys: expected a .full or .rst file, got {str(path)!r}")
    if n_modes is None and max_freq_hz is None:
        raise InputError("n_modes: give a number of modes or max_freq_hz")
    if suffix == ".full":
        if full is not None:
            raise InputError("full: only with a .rst (the .full itself was given)")
        if gamma is not None:
            raise InputError("gamma: computed from the .full's mass matrix; do not pass it")
        rigid = (rigid_tol_hz, allow_rigid_modes)
        return _from_full(path, nodes, units, n_modes, max_freq_hz, zeta, rigid, progress)
    if nodes is not None:
        raise InputError("nodes: a .rst holds its node coordinates")
    if full is not None and gamma is not None:
        raise InputError("gamma: give the participation factors or full=, not both")
    return from_rst_modes(
        read_rst(path),
        full=full,
        units=units,
        n_modes=n_modes,
        max_freq_hz=max_freq_hz,
        gamma=gamma,
        zeta=zeta,
        rigid_tol_hz=rigid_tol_hz,
        allow_rigid_modes=allow_rigid_modes,
    )


def _from_full(path, nodes, units, n_modes, max_freq_hz, zeta, rigid, progress):
    rigid_tol_hz, allow = rigid
    mats = read_full(path)
    unit = resolve_units(units, mats.units, f"{str(path)!r}")
    rotations = read_node_rotations(nodes) if nodes is not None else {}
    free, K, M, rigid = _free_system(mats, rotations)
    node_ids = np.unique(mats.node_ids)
    observation = _observation(node_ids, mats.node_ids[free], mats.labels[free], rotations)
    modes = solve_modes(
        K,
        M,
        M @ rigid,
        observation,
        n_modes,
        max_freq_hz=max_freq_hz,
        rigid_count=6,
        rigid_tol_hz=rigid_tol_hz,
        progress=progress,
    )
    rigid_mask(modes.rigid_freq_hz, rigid_tol_hz, allow, repr(str(path)))
    shapes = (observation @ modes.vectors).reshape(len(node_ids), 3, -1) * unit.shape_to_si
    static = None  # per unit acceleration: s^2, the same in every consistent unit system
    if not modes.rigid_freq_hz.size:
        solved = factorize(K).solve(np.ascontiguousarray(M @ rigid))
        static = -(observation @ solved).reshape(len(node_ids), 3, 3)
    coords, missing, rotation = None, "", None
    if nodes is None:
        missing = (
            f"{str(path)!r} holds none; pass nodes= (--nodes) with a .cdb archive, a .rst or a "
            "CSV node,x,y,z of the same mesh"
        )
    else:
        coords = _coordinates_for(node_ids, nodes)
        rotation = _rotation_data(mats, free, M, modes.vectors, node_ids, coords, rotations, unit)
        coords = coords * unit.length_m
    provenance = {
        "source": "fem.from_ansys (.full: modes computed by jaxflex)",
        "input": {"full": file_digest(path), **({"nodes": file_digest(nodes)} if nodes else {})},
        "file_units": unit.describe(),
        "derived": {
            "matrices": "MAPDL upper triangles symmetrised; constrained DOFs (empty rows and "
            f"columns, {int(mats.constrained.sum())}) removed",
            "modes": "fem.eigen (shift-invert Lanczos, or dense for n_modes='all'), "
            "mass-normalised",
            "gamma": "phi^T M_ff R_f, R: unit global translations in the nodal DOFs",
            "nodal_coordinate_systems": f"{len(rotations)} node(s) rotated (node angles of "
            "--nodes), applied to the shapes and to R"
            if rotations
            else "none rotated"
            + (
                " (a CSV cannot say: pass a .cdb or .rst to apply nodal rotations)"
                if nodes is not None and Path(nodes).suffix.lower() not in (".cdb", ".rst")
                else ""
            ),
        },
        "rigid_modes": rigid_meta(modes.rigid_freq_hz),
        "n_dof": {"total": len(mats.labels), "free": int(free.size)},
    }
    return ImportedModes(
        freq_hz=modes.freq_hz,
        shapes=shapes,
        gamma=modes.gamma * unit.gamma_to_si,
        nodes=coords,
        node_ids=node_ids,
        zeta=zeta,
        mobile_mass_kg=modes.mobile_mass_kg * unit.mass_kg,
        static_shapes=static,
        nodes_missing=missing,
        provenance=provenance,
        rotation=rotation,
    )


def _coordinates_for(node_ids: np.ndarray, nodes_path) -> np.ndarray:
    ids, coords = read_node_coordinates(nodes_path)
    where = {int(n): i for i, n in enumerate(ids)}
    missing = [int(n) for n in node_ids if int(n) not in where]
    if missing:
        raise InputError(
            f"nodes: {str(nodes_path)!r} lacks {len(missing)} node(s) of the model, e.g. "
            f"{missing[:5]}; give the coordinates of the same mesh"
        )
    return coords[[where[int(n)] for n in node_ids]]


def from_rst_modes(
    rst: RstModes,
    *,
    full: str | os.PathLike | None = None,
    units: str | Units | None = None,
    n_modes: int | str | None = 20,
    max_freq_hz: float | None = None,
    gamma=None,
    zeta=0.02,
    rigid_tol_hz: float = 0.01,
    allow_rigid_modes: bool = False,
) -> ImportedModes:
    """The ImportedModes of modes read from a ``.rst`` (see :func:`from_ansys`)."""
    path, full_path = rst.path, full
    rst.refuse_unless_modes()
    unit = resolve_units(units, rst.units, f"{str(path)!r}")
    translations = [list(rst.labels).index(name) for name in TRANSLATIONS]
    rigid = rigid_mask(
        rst.freq_hz,
        rigid_tol_hz,
        allow_rigid_modes,
        repr(str(path)),
        rst.nodes,
        rst.values[:, translations, :],
    )
    keep = ~rigid
    if max_freq_hz is not None:
        keep &= rst.freq_hz <= max_freq_hz
    kept = kept_modes(keep, n_modes, repr(str(path)), max_freq_hz)
    if kept.size == 0:
        raise InputError(
            f"from_ansys: {str(path)!r} leaves no elastic mode to keep (its {rst.freq_hz.size} "
            f"mode(s): {listed(rst.freq_hz)} Hz)"
        )
    freq = rst.freq_hz[kept]
    values = rst.values[:, :, kept]
    columns = [list(rst.labels).index(name) for name in TRANSLATIONS]
    shapes = values[:, columns, :] * unit.shape_to_si
    provenance = {
        "source": "fem.from_ansys (.rst: modes as MAPDL computed them)",
        "input": {"rst": file_digest(path) if Path(path).is_file() else {"path": str(path)}},
        "file_units": unit.describe(),
        "derived": {
            "modes": "frequencies and global x, y, z shapes from the .rst (MAPDL normalises "
            "modes to the mass matrix unless MODOPT NRMKEY=ON)",
        },
        "rigid_modes": rigid_meta(rst.freq_hz[rigid]),
    }
    stress = None
    if rst.stress is not None:
        stress = rst.stress[:, :, kept] * unit.modulus_to_si / (unit.gamma_to_si * unit.length_m)
    result = ImportedModes(
        freq_hz=freq,
        shapes=shapes,
        gamma=None,
        nodes=rst.nodes * unit.length_m,
        node_ids=rst.node_ids,
        zeta=zeta,
        stress=stress,
        gamma_missing=f"{str(path)!r} (a result file) holds no mass matrix, so the "
        "participation factors Gamma = phi^T M R cannot be known from it; pass gamma= "
        "(--gamma, (M, 3) in kg^0.5) or full= (--full) with the .full of the same model",
        provenance=provenance,
    )
    if gamma is not None:
        result.gamma = user_gamma(gamma, freq.size)
        provenance["derived"]["gamma"] = "given by the user"
    if full_path is not None:
        _pair_with_full(result, rst, values, full_path, unit)
    return result


def _dof_names(nodes: np.ndarray, labels: np.ndarray, limit: int = 4) -> str:
    shown = ", ".join(
        f"node {int(n)} {lab}" for n, lab in zip(nodes[:limit], labels[:limit], strict=True)
    )
    return shown + (", ..." if len(nodes) > limit else "")


def _pair_with_full(result: ImportedModes, rst: RstModes, values, full_path, unit) -> None:
    """Participation factors of the .rst modes with the .full's mass matrix, after checking
    that both files describe the same model."""
    full = read_full(full_path)
    rst_name, full_name = Path(rst.path).name, Path(full_path).name
    if full.units is not None and rst.units is not None and full.units != rst.units:
        raise InputError(
            f"full: {full_name} is in {full.units} units, {rst_name} in {rst.units}; they are "
            "not the same model"
        )
    full_nodes, rst_nodes = set(np.unique(full.node_ids).tolist()), set(rst.node_ids.tolist())
    if full_nodes != rst_nodes:
        only_full = sorted(full_nodes - rst_nodes)[:5]
        only_rst = sorted(rst_nodes - full_nodes)[:5]
        raise InputError(
            f"full: nodes differ: {full_name} has {len(full_nodes)} nodes, {rst_name} "
            f"{len(rst_nodes)} (only in the .full: {only_full}, only in the .rst: {only_rst})"
        )
    if set(full.labels.tolist()) != set(rst.labels.tolist()):
        raise InputError(
            f"full: DOFs differ: {full_name} has {sorted(set(full.labels))}, {rst_name} "
            f"{sorted(set(rst.labels))}"
        )
    row = {int(n): i for i, n in enumerate(rst.node_ids)}
    col = {name: j for j, name in enumerate(rst.labels)}
    rows = np.array([row[int(n)] for n in full.node_ids])
    cols = np.array([col[name] for name in full.labels])
    rotations = {}
    if rst.angles_deg is not None:  # the .full's DOFs are nodal: turn the global values back
        turned = np.flatnonzero(np.any(rst.angles_deg != 0, axis=1))
        rotations = dict(
            zip(rst.node_ids[turned].tolist(), nodal_rotations(rst.angles_deg[turned]), strict=True)
        )
        values = values.copy()
        t_cols = [col[name] for name in TRANSLATIONS]
        for node, T in rotations.items():
            values[row[node], t_cols, :] = T.T @ values[row[node], t_cols, :]
    phi = values[rows, cols, :]  # (n_dof, M) in .full order, file units
    zero = np.all(phi == 0, axis=1)
    moving = full.constrained & ~zero
    held = zero & ~full.constrained
    if moving.any() or held.any():
        parts = []
        if moving.any():
            i = np.flatnonzero(moving)
            parts.append(
                f"{i.size} DOF(s) constrained in {full_name} move in the modes of {rst_name} "
                f"({_dof_names(full.node_ids[i], full.labels[i])})"
            )
        if held.any():
            i = np.flatnonzero(held)
            parts.append(
                f"{i.size} DOF(s) free in {full_name} are zero in every mode of {rst_name} "
                f"({_dof_names(full.node_ids[i], full.labels[i])})"
            )
        raise InputError(
            f"full: constraints differ, so {full_name} and {rst_name} are not the same model: "
            + "; ".join(parts)
            + f" ({int(full.constrained.sum())} DOFs constrained in the .full, "
            f"{int(zero.sum())} zero in the .rst modes)"
        )
    free, K, M, rigid = _free_system(full, rotations)
    phi = phi[free]
    omega2 = (2 * np.pi * result.freq_hz) ** 2
    k_phi = K @ phi
    residual = np.linalg.norm(k_phi - (M @ phi) * omega2, axis=0) / np.linalg.norm(k_phi, axis=0)
    if (residual > PAIRING_RESIDUAL).any():
        i = int(np.argmax(residual))
        raise InputError(
            f"full: mode {i + 1} of {rst_name} ({result.freq_hz[i]:.6g} Hz) does not solve the "
            f"eigenproblem of {full_name} (relative residual {residual[i]:.2e} > "
            f"{PAIRING_RESIDUAL:g}); they are not the same model"
        )
    modal_mass = np.einsum("im,im->m", phi, M @ phi)
    scale = 1 / np.sqrt(modal_mass)  # 1 when MAPDL normalised to the mass matrix
    phi = phi * scale
    result.shapes = result.shapes * scale
    result.gamma = (phi.T @ (M @ rigid)) * unit.gamma_to_si
    result.mobile_mass_kg = np.einsum("id,id->d", rigid, M @ rigid) * unit.mass_kg
    result.rotation = _rotation_data(full, free, M, phi, rst.node_ids, rst.nodes, rotations, unit)
    result.provenance["input"]["full"] = file_digest(full_path)
    result.provenance["derived"]["gamma"] = (
        "phi^T M_ff R_f with M from the .full (nodes, DOFs, constraints checked; eigen "
        f"residual of the .rst modes {float(residual.max()):.2e})"
    )
    result.provenance["derived"]["mass_normalisation"] = {
        "modal_mass_before": modal_mass.tolist(),
        "rescaled": bool(np.any(np.abs(modal_mass - 1) > 1e-6)),
    }
