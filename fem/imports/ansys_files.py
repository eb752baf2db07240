"""The files of ANSYS (MAPDL) as they are: a ``.full``'s matrices, a ``.rst``'s modes, an
archive's (``.cdb``) or a CSV's node coordinates and nodal coordinate systems, in file units,
read with ansys-mapdl-reader in a child interpreter (jaxflex.isolated). What is made of them,
the modal model, is fem.imports.ansys's.

This module imports no more than the readers need (no JAX, no FE solver): each read starts a
fresh interpreter that imports it, and ansys-mapdl-reader's submodules without its package's
``__init__`` (``MAPDL``: that one imports pyvista's plotting and matplotlib, about 1 s of CPU
per read; a ``.rst``'s reader still imports them itself).
"""

from __future__ import annotations

import os
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from fem.imports.mapdl_check import check_mapdl_file
from fem.imports.numeric_csv import load_numeric_csv
from jaxflex.errors import InputError
from jaxflex.isolated import isolated

if TYPE_CHECKING:  # imported by read_full: an archive's or a .rst's reader does not need it
    import scipy.sparse as sp

MAPDL = ("ansys.mapdl.reader",)  # run in the child without its __init__ (module docstring)
DOF_LABELS = {1: "UX", 2: "UY", 3: "UZ", 4: "ROTX", 5: "ROTY", 6: "ROTZ"}
TRANSLATIONS = ("UX", "UY", "UZ")
ROTATIONS = ("ROTX", "ROTY", "ROTZ")
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
# MAPDL's analysis types (ANTYPE; the result header's "kan"): only a modal analysis holds modes
ANALYSIS_TYPES = {
    0: "a static analysis (ANTYPE,STATIC)",
    1: "a buckling analysis (ANTYPE,BUCKLE)",
    2: "a modal analysis (ANTYPE,MODAL)",
    3: "a harmonic analysis (ANTYPE,HARMIC)",
    4: "a transient analysis (ANTYPE,TRANS)",
    7: "a substructure analysis (ANTYPE,SUBSTR)",
    8: "a spectrum analysis (ANTYPE,SPECTR)",
}
MODAL = 2


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
    labels (D,) DOF labels, values (N, D, M) with translations in global axes, stress
    (N, 6, M) or None, units name or None, angles_deg (N, 3) the nodal coordinate systems'
    angles (THXY, THYZ, THZX) or None; what the file's result header says it holds:
    ``analysis`` (MAPDL's ANTYPE number, 2: modal), ``sectors`` (cyclic symmetry: > 1),
    ``complex_modes``, ``part_of`` (the global node count of a distributed result of which
    this file holds one part, else 0)."""

    freq_hz: np.ndarray
    node_ids: np.ndarray
    nodes: np.ndarray
    labels: np.ndarray
    values: np.ndarray
    stress: np.ndarray | None
    units: str | None
    path: str
    angles_deg: np.ndarray | None = None
    analysis: int = MODAL
    sectors: int = 1
    complex_modes: bool = False
    part_of: int = 0

    def refuse_unless_modes(self) -> None:
        """An InputError naming what the file holds unless it is the real modes of a modal
        analysis of the whole model (result sets of a static analysis are load steps, their
        "frequencies" the steps' times)."""
        name, sets = repr(self.path), f"{self.freq_hz.size} result set(s)"
        cyclic = f" of a cyclic symmetry model ({self.sectors} sectors)" if self.sectors > 1 else ""
        if self.analysis != MODAL:
            what = ANALYSIS_TYPES.get(self.analysis, f"analysis type {self.analysis}") + cyclic
            raise InputError(
                f"--from-ansys: {name} holds the results of {what}, not the modes of a modal "
                f"analysis (ANTYPE,MODAL): its {sets} are at times or frequencies "
                f"{listed(self.freq_hz)}; solve the modes with ANTYPE,MODAL and give that .rst"
            )
        if self.sectors > 1:
            raise InputError(
                f"--from-ansys: {name} holds a cyclic symmetry modal analysis ({self.sectors} "
                "sectors): its modes are one sector's, each of a harmonic index; expand them to "
                "the full model (/CYCEXPAND, or a full-model modal analysis) and give that .rst"
            )
        if self.complex_modes:
            raise InputError(
                f"--from-ansys: {name} holds complex modes (a damped or rotating modal "
                "analysis); real normal modes (MODOPT,LANB or SUBSP without damping) are read"
            )
        if self.part_of:
            raise InputError(
                f"--from-ansys: {name} is one part of a distributed result (the results of some "
                f"of its {self.part_of} nodes); give the first part (JOBNAME0.rst), read with the "
                "others beside it, or the combined result (RESCOMBINE)"
            )


def listed(values: np.ndarray, shown: int = 4) -> str:
    """The first ``shown`` of ``values``, comma-separated, "..." if there are more."""
    text = ", ".join(f"{v:.6g}" for v in values[:shown])
    return text + (", ..." if values.size > shown else "")


def _binary(path, suffix: str):
    from ansys.mapdl.reader.common import read_binary

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


@isolated("--from-ansys", "ansys-mapdl-reader", precheck=check_mapdl_file, bare=MAPDL)
def read_full(path: str | os.PathLike) -> FullMatrices:
    """K and M of a MAPDL ``.full`` file, symmetrised, with the DOF reference."""
    import scipy.sparse as sp
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


@isolated("--from-ansys", "ansys-mapdl-reader", precheck=check_mapdl_file, bare=MAPDL)
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
    header = rst._resultheader
    distributed = type(rst).__name__ == "DistributedResult"
    global_nodes, own_nodes = int(header.get("Glbnnod", 0) or 0), int(header.get("nnod", 0) or 0)
    return RstModes(
        np.asarray(rst.time_values, dtype=float),
        node_ids,
        coords,
        labels,
        values,
        stress,
        STATED_UNITS.get(header.get("units")),
        str(path),
        _angles(rst.mesh),
        analysis=int(header.get("kan", MODAL)),
        sectors=int(header.get("nSector", 1) or 1),
        complex_modes=bool(header.get("cpxrst", 0)),
        part_of=global_nodes if not distributed and global_nodes > own_nodes > 0 else 0,
    )


def _angles(mesh) -> np.ndarray | None:
    """(N, 3) node angles of a mesh of ansys-mapdl-reader, None if all zero or absent."""
    angles = getattr(mesh, "node_angles", None)
    if angles is None or not np.any(angles):
        return None
    return np.asarray(angles, dtype=float)[:, :3]


@isolated("nodes", "ansys-mapdl-reader", precheck=check_mapdl_file, bare=MAPDL)
def read_node_rotations(path: str | os.PathLike) -> dict[int, np.ndarray]:
    """{node: T (3, 3)} of the rotated nodal coordinate systems (u_global = T u_nodal) of a
    .cdb archive or a .rst (empty: none rotated, or a CSV, which cannot say)."""
    suffix = Path(path).suffix.lower()
    if suffix == ".rst":
        modes = read_rst(path)
        ids, angles = modes.node_ids, modes.angles_deg
    elif suffix == ".cdb":
        from ansys.mapdl.reader.archive import Archive

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            archive = Archive(str(path), parse_vtk=False)
        ids, angles = np.asarray(archive.nnum), _angles(archive)
    else:
        return {}
    if angles is None:
        return {}
    turned = np.flatnonzero(np.any(angles != 0, axis=1))
    return dict(zip(ids[turned].tolist(), nodal_rotations(angles[turned]), strict=True))


@isolated("nodes", "ansys-mapdl-reader", precheck=check_mapdl_file, bare=MAPDL)
def read_node_coordinates(path: str | os.PathLike) -> tuple[np.ndarray, np.ndarray]:
    """(node_ids (N,), coordinates (N, 3)) in file units from a MAPDL archive (.cdb), a
    result (.rst) or a CSV with rows ``node, x, y, z`` (an optional header row)."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"nodes: file {str(path)!r} does not exist")
    suffix = path.suffix.lower()
    if suffix == ".cdb":
        from ansys.mapdl.reader.archive import Archive

        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                archive = Archive(str(path), parse_vtk=False)
        except Exception as exc:
            raise InputError(f"nodes: cannot read the archive {str(path)!r} ({exc})") from exc
        ids, xyz = np.asarray(archive.nnum), np.asarray(archive.nodes, dtype=float)[:, :3]
    elif suffix == ".rst":
        modes = read_rst(path)
        ids, xyz = modes.node_ids, modes.nodes
    else:
        table = _read_csv_table(path, 4, "nodes")
        ids, xyz = table[:, 0].astype(np.int64), table[:, 1:4]
    bad = np.flatnonzero(~np.isfinite(xyz).all(axis=1))
    if bad.size:
        raise InputError(
            f"nodes: {str(path)!r}: node {int(ids[bad[0]])} has coordinates "
            f"{xyz[bad[0]].tolist()} ({bad.size} such node(s)); every coordinate must be finite"
        )
    return ids, xyz


def _read_csv_table(path: Path, width: int, name: str) -> np.ndarray:
    table = load_numeric_csv(path, name)
    if table.shape[1] != width or not np.isfinite(table).all():
        raise InputError(
            f"{name}: {str(path)!r} must have {width} finite numbers per row, got {table.shape[1]}"
        )
    return table


def nodal_rotations(angles_deg) -> np.ndarray:
    """(N, 3, 3) rotations T of MAPDL's nodal coordinate systems, u_global = T u_nodal, from
    the node angles (N, 3) THXY, THYZ, THZX in degrees (rotations about z, then the new x,
    then the new y: T = R_y(THZX) R_x(THYZ) R_z(THXY), as ansys-mapdl-reader turns .rst
    results to global)."""
    xy, yz, zx = np.radians(np.atleast_2d(np.asarray(angles_deg, dtype=float))).T

    def rot(c, s, axes):
        m = np.zeros((len(c), 3, 3))
        (i, j), k = axes, 3 - sum(axes)
        m[:, i, i], m[:, i, j], m[:, j, i], m[:, j, j] = c, -s, s, c
        m[:, k, k] = 1.0
        return m

    rz = rot(np.cos(xy), np.sin(xy), (0, 1))
    rx = rot(np.cos(yz), np.sin(yz), (1, 2))
    ry = rot(np.cos(zx), np.sin(zx), (2, 0))
    return ry @ rx @ rz
