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
(fem.units). Nodes in rotated nodal coordinate systems are not supported for ``.full``
alone (its DOFs are nodal): the rigid translations would be wrong.

ansys-mapdl-reader loads pyvista and VTK (about 10 s on a loaded 2-core machine): it is
imported where a file is read, so that `import fem` and `jaxflex model` for other parts do
not pay for it.
"""

from __future__ import annotations

import os
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from fem.imported import ImportedModes, file_digest
from fem.mapdl_check import check_mapdl_file
from fem.modal import solve_modes
from fem.units import Units, resolve_units
from jaxflex.errors import InputError
from jaxflex.isolated import isolated

DOF_LABELS = {1: "UX", 2: "UY", 3: "UZ", 4: "ROTX", 5: "ROTY", 6: "ROTZ"}
TRANSLATIONS = ("UX", "UY", "UZ")
STATED_UNITS = {
    "SI": "SI",
    "MKS": "SI",
    "CSG": "CGS",
    "CGS": "CGS",
    "MPA": "MPA",
    "uMKS": "UMKS",
    "U.S. Customary units (inches)": "BIN",
    "U.S. Customary units (feet)": "BFT",
}
# Largest relative eigen residual |K phi - w^2 M phi| / |K phi| accepted for .rst modes paired
# with a .full: MAPDL's eigen solvers converge far below it; a different model (material,
# geometry, constraints) misses it by orders of magnitude.
PAIRING_RESIDUAL = 1e-4


@dataclass(eq=False)
class FullMatrices:
    """The matrices of a ``.full`` file in file units: K, M (n, n) symmetric csr over all DOFs,
    node_ids (n,), labels (n,) DOF labels, constrained (n,) bool, units name or None."""

    K: sp.csr_matrix
    M: sp.csr_matrix
    node_ids: np.ndarray
    labels: np.ndarray
    constrained: np.ndarray
    units: str | None
    path: str


@dataclass(eq=False)
class RstModes:
    """Modes of an ``.rst`` file in file units: freq_hz (M,), node_ids (N,), nodes (N, 3),
    labels (D,) DOF labels, values (N, D, M), stress (N, 6, M) or None, units name or None."""

    freq_hz: np.ndarray
    node_ids: np.ndarray
    nodes: np.ndarray
    labels: np.ndarray
    values: np.ndarray
    stress: np.ndarray | None
    units: str | None
    path: str


def _binary(path, suffix: str):
    from ansys.mapdl.reader import read_binary

    path = Path(path)
    if not path.is_file():
        raise InputError(f"{suffix} file {str(path)!r} does not exist")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return read_binary(str(path))
    except Exception as exc:  # the reader raises bare Exceptions for foreign files
        raise InputError(
            f"{str(path)!r}: not a MAPDL {suffix} file ansys-mapdl-reader can read "
            f"({type(exc).__name__}: {exc})"
        ) from exc


@isolated("--from-ansys", "ansys-mapdl-reader", precheck=check_mapdl_file)
def read_full(path: str | os.PathLike) -> FullMatrices:
    """K and M of a MAPDL ``.full`` file, symmetrised, with the DOF reference."""
    from ansys.mapdl.reader.common import read_table
    from ansys.mapdl.reader.full import FullFile

    full = _binary(path, ".full")
    if not isinstance(full, FullFile):
        raise InputError(f"{str(path)!r}: expected a .full file, got {type(full).__name__}")
    dof_ref, k_upper, m_upper = full.load_km(sort=True)
    if k_upper is None or m_upper is None:
        raise InputError(f"{str(path)!r}: the file lacks the stiffness or the mass matrix")
    with open(path, "rb") as handle:  # record 3: the DOF labels of each node, MAPDL numbers
        read_table(handle, skip=True)
        read_table(handle, skip=True)
        dof_numbers = np.asarray(read_table(handle))
    ndof = np.unique(full.ndof[full.ndof > 0])
    if ndof.size != 1 or ndof[0] != dof_numbers.size:
        raise InputError(
            f"{str(path)!r}: nodes carry different DOF sets ({ndof.tolist()} DOFs per node); "
            "only models with one DOF set for all nodes are supported"
        )
    unknown = [int(d) for d in dof_numbers if int(d) not in DOF_LABELS]
    if unknown:
        raise InputError(
            f"{str(path)!r}: DOFs other than UX..ROTZ (MAPDL numbers {unknown}); a structural "
            "modal model is required"
        )
    labels = np.array([DOF_LABELS[int(dof_numbers[j])] for j in dof_ref[:, 1]])
    constrained = np.zeros(len(dof_ref), dtype=bool)
    if len(full.const):
        key = {(int(n), int(j)): i for i, (n, j) in enumerate(dof_ref)}
        constrained[[key[(int(n), int(j))] for n, j in full.const]] = True

    def symmetric(upper):
        upper = sp.csr_matrix(upper)
        return (upper + sp.triu(upper, k=1).T).tocsr()

    units = STATED_UNITS.get(full._standard_header.get("units"))
    return FullMatrices(
        symmetric(k_upper),
        symmetric(m_upper),
        np.asarray(dof_ref[:, 0]),
        labels,
        constrained,
        units,
        str(path),
    )


@isolated("--from-ansys", "ansys-mapdl-reader", precheck=check_mapdl_file)
def read_rst(path: str | os.PathLike) -> RstModes:
    """Frequencies, shapes, coordinates and nodal stresses of a MAPDL modal ``.rst`` file."""
    from ansys.mapdl.reader.rst import Result

    rst = _binary(path, ".rst")
    if not isinstance(rst, Result) or rst.nsets == 0:
        raise InputError(f"{str(path)!r}: expected a MAPDL result file with modes")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        node_ids = np.asarray(rst.mesh.nnum)
        coords = np.asarray(rst.mesh.nodes, dtype=float)[:, :3]
        labels = np.asarray(rst.result_dof(0))
        if not set(TRANSLATIONS) <= set(labels):
            raise InputError(
                f"{str(path)!r}: the results hold DOFs {labels.tolist()}, not the "
                "displacements UX, UY, UZ of a structural modal analysis"
            )
        values = np.zeros((len(node_ids), len(labels), rst.nsets))
        where = {int(n): i for i, n in enumerate(node_ids)}
        for m in range(rst.nsets):
            nnum, data = rst.nodal_solution(m)
            values[[where[int(n)] for n in nnum], :, m] = data[:, : len(labels)]
        stress = None
        if "ENS" in rst.available_results:
            stress = np.full((len(node_ids), 6, rst.nsets), np.nan)
            for m in range(rst.nsets):
                nnum, data = rst.nodal_stress(m)
                stress[[where[int(n)] for n in nnum], :, m] = data[:, :6]
    return RstModes(
        np.asarray(rst.time_values, dtype=float),
        node_ids,
        coords,
        labels,
        values,
        stress,
        STATED_UNITS.get(rst._resultheader.get("units")),
        str(path),
    )


@isolated("nodes", "ansys-mapdl-reader", precheck=check_mapdl_file)
def read_node_coordinates(path: str | os.PathLike) -> tuple[np.ndarray, np.ndarray]:
    """(node_ids (N,), coordinates (N, 3)) in file units from a MAPDL archive (.cdb), a
    result (.rst) or a CSV with rows ``node, x, y, z`` (an optional header row)."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"nodes: file {str(path)!r} does not exist")
    suffix = path.suffix.lower()
    if suffix == ".cdb":
        from ansys.mapdl.reader import Archive

        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                archive = Archive(str(path), parse_vtk=False)
        except Exception as exc:
            raise InputError(f"nodes: cannot read the archive {str(path)!r} ({exc})") from exc
        return np.asarray(archive.nnum), np.asarray(archive.nodes, dtype=float)[:, :3]
    if suffix == ".rst":
        modes = read_rst(path)
        return modes.node_ids, modes.nodes
    table = _read_csv_table(path, 4, "nodes")
    return table[:, 0].astype(np.int64), table[:, 1:4]


def _read_csv_table(path: Path, width: int, name: str) -> np.ndarray:
    try:
        table = np.loadtxt(path, delimiter=",", ndmin=2)
    except ValueError:
        try:
            table = np.loadtxt(path, delimiter=",", ndmin=2, skiprows=1)
        except ValueError as exc:
            raise InputError(f"{name}: {str(path)!r} is not a numeric CSV ({exc})") from exc
    if table.shape[1] != width or not np.isfinite(table).all():
        raise InputError(
            f"{name}: {str(path)!r} must have {width} finite numbers per row, got {table.shape[1]}"
        )
    return table


def _free_system(full: FullMatrices):
    free = np.flatnonzero(~full.constrained)
    K = full.K[free][:, free].tocsr()
    M = full.M[free][:, free].tocsr()
    rigid = np.zeros((free.size, 3))
    for d, name in enumerate(TRANSLATIONS):
        rigid[full.labels[free] == name, d] = 1.0
    return free, K, M, rigid


def _observation(node_ids: np.ndarray, dof_nodes: np.ndarray, labels: np.ndarray):
    """Sparse (3N, n) selecting UX, UY, UZ of each node in ``node_ids`` among DOFs."""
    row_of = {int(n): i for i, n in enumerate(node_ids)}
    rows, cols = [], []
    for col, (node, label) in enumerate(zip(dof_nodes, labels, strict=True)):
        if label in TRANSLATIONS and int(node) in row_of:
            rows.append(3 * row_of[int(node)] + TRANSLATIONS.index(label))
            cols.append(col)
    return sp.csr_matrix(
        (np.ones(len(rows)), (rows, cols)), shape=(3 * len(node_ids), len(dof_nodes))
    )


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
        units: the consistent unit system (fem.units.UNIT_SYSTEMS name) when the file does
            not state one, e.g. "SI", "MPA" (mm, t, s), "BIN" (in, lbf s^2/in, s).
        n_modes: modes to keep (a ``.full``: to compute; "all" for a dense solve of a small
            model); None with ``max_freq_hz``.
        max_freq_hz: keep modes up to this frequency.
        gamma: with a ``.rst`` alone: participation factors (M, 3) in kg^0.5, one row per
            kept mode (e.g. from MAPDL's participation factor listing).
        zeta: modal damping ratio (scalar, per mode or fem.Rayleigh).
        rigid_tol_hz: modes below this frequency are rigid-body modes (dropped).
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
        return _from_full(path, nodes, units, n_modes, max_freq_hz, zeta, rigid_tol_hz, progress)
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
    )


def _from_full(path, nodes, units, n_modes, max_freq_hz, zeta, rigid_tol_hz, progress):
    mats = read_full(path)
    unit = resolve_units(units, mats.units, f"{str(path)!r}")
    free, K, M, rigid = _free_system(mats)
    node_ids = np.unique(mats.node_ids)
    observation = _observation(node_ids, mats.node_ids[free], mats.labels[free])
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
    shapes = (observation @ modes.vectors).reshape(len(node_ids), 3, -1) * unit.shape_to_si
    coords, missing = None, ""
    if nodes is None:
        missing = (
            f"{str(path)!r} holds none; pass nodes= (--nodes) with a .cdb archive, a .rst or a "
            "CSV node,x,y,z of the same mesh"
        )
    else:
        coords = _coordinates_for(node_ids, nodes) * unit.length_m
    provenance = {
        "source": "fem.from_ansys (.full: modes computed by jaxflex)",
        "input": {"full": file_digest(path), **({"nodes": file_digest(nodes)} if nodes else {})},
        "file_units": unit.describe(),
        "derived": {
            "matrices": "MAPDL upper triangles symmetrised; constrained DOFs (empty rows and "
            f"columns, {int(mats.constrained.sum())}) removed",
            "modes": "fem.eigen (shift-invert Lanczos, or dense for n_modes='all'), "
            "mass-normalised",
            "gamma": "phi^T M_ff R_f, R: unit translations of UX, UY, UZ",
        },
        "rigid_modes": {"count": int(modes.rigid_freq_hz.size)},
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
        nodes_missing=missing,
        provenance=provenance,
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
) -> ImportedModes:
    """The ImportedModes of modes read from a ``.rst`` (see :func:`from_ansys`)."""
    path, full_path = rst.path, full
    unit = resolve_units(units, rst.units, f"{str(path)!r}")
    keep = rst.freq_hz >= rigid_tol_hz
    if max_freq_hz is not None:
        keep &= rst.freq_hz <= max_freq_hz
    kept = np.flatnonzero(keep)
    if isinstance(n_modes, int | np.integer):
        kept = kept[: int(n_modes)]
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
        "rigid_modes": {"count": int(np.sum(rst.freq_hz < rigid_tol_hz))},
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
        result.gamma = _user_gamma(gamma, freq.size)
        provenance["derived"]["gamma"] = "given by the user"
    if full_path is not None:
        _pair_with_full(result, rst, values, full_path, unit)
    return result


def _user_gamma(gamma, n_modes: int) -> np.ndarray:
    try:
        arr = np.asarray(gamma, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InputError(f"gamma: expected numbers, (M, 3) in kg^0.5 ({exc})") from exc
    if arr.shape != (n_modes, 3) or not np.isfinite(arr).all():
        raise InputError(
            f"gamma: expected finite values of shape ({n_modes}, 3) in kg^0.5 (one row per "
            f"kept mode, x y z), got {arr.shape}"
        )
    return arr


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
    free, K, M, rigid = _free_system(full)
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
    result.provenance["input"]["full"] = file_digest(full_path)
    result.provenance["derived"]["gamma"] = (
        "phi^T M_ff R_f with M from the .full (nodes, DOFs, constraints checked; eigen "
        f"residual of the .rst modes {float(residual.max()):.2e})"
    )
    result.provenance["derived"]["mass_normalisation"] = {
        "modal_mass_before": modal_mass.tolist(),
        "rescaled": bool(np.any(np.abs(modal_mass - 1) > 1e-6)),
    }
