"""The assembled finite-element system shared by the plate, shell and thin-solid formulations.

Degrees of freedom (DOFs) are those of the formulation (plate: deflection and its
derivatives; solid: x, y, z displacement per node; shell: displacement and rotation per
node). Supports remove DOFs (``fixed``), hold
displacement components along given directions at nodes (``directions``), or tie DOFs to a
rigid pad on springs (``springs``: a compliant suction cup), which is expressed by a sparse
basis T of the admissible displacements, u = T z, and the springs' stiffness on the pad
coordinates among z (:meth:`Constraints.reduction`).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

import numpy as np
import scipy.sparse as sp


@dataclass(eq=False)
class Spring:
    """DOFs ``dofs`` (n,) moving with r pad coordinates m as u[dofs] = ``shape`` (n, r) @ m,
    the pad held to the gripper by springs of ``stiffness`` (r,) on m (N/m for translations,
    N m/rad for rotations when the columns of ``shape`` are unit rigid motions). ``frame``
    (6, r) maps the pad coordinates' reactions to (F_x, F_y, F_z, M_x, M_y, M_z) about
    ``centre_m`` (3,): what the cup exerts on the part is -frame @ (stiffness * m)."""

    dofs: np.ndarray
    shape: np.ndarray
    stiffness: np.ndarray
    frame: np.ndarray
    centre_m: np.ndarray

    @classmethod
    def on_pad(cls, dofs, motions, centre_m, normal, stiffness) -> Spring:
        """A rigid pad at ``centre_m`` (3,) on springs ``stiffness`` (6,) along and about its
        local axes (t1, t2, n): translations N/m, then rotations N m/rad; n = ``normal``
        (3,), t1 the global x (y where x is nearly normal) projected on the pad. ``dofs``
        (n,) move with the pad as ``motions`` (n, 6), the unit rigid motions of those DOFs
        about ``centre_m`` (FormulationOutputs.rigid_motion)."""
        normal = np.asarray(normal, dtype=np.float64)
        t1 = np.array([1.0, 0.0, 0.0]) - normal[0] * normal
        if np.linalg.norm(t1) < 0.1:
            t1 = np.array([0.0, 1.0, 0.0]) - normal[1] * normal
        t1 /= np.linalg.norm(t1)
        axes = np.column_stack([t1, np.cross(normal, t1), normal])
        frame = np.kron(np.eye(2), axes)  # (6, 6): local pad coordinates -> x, y, z
        return cls(
            np.asarray(dofs),
            np.asarray(motions) @ frame,
            np.asarray(stiffness, np.float64),
            frame,
            np.asarray(centre_m, dtype=np.float64),
        )


def rigid_translations(n_dof: int, dofs_per_node: int) -> np.ndarray:
    """(n_dof, 3) unit rigid translations along x, y, z of a mesh whose node p holds its x, y,
    z displacements at the DOFs ``dofs_per_node`` p + (0, 1, 2)."""
    rigid = np.zeros((n_dof, 3))
    for d in range(3):
        rigid[d::dofs_per_node, d] = 1.0
    return rigid


def rigid_motions(points_m: np.ndarray, centre_m) -> np.ndarray:
    """(N, 3, 6) displacements at ``points_m`` (N, 3) of unit translations along x, y, z and
    unit rotations about x, y, z through ``centre_m`` (3,): u = t + theta x (p - centre)."""
    r = np.asarray(points_m, dtype=np.float64) - np.asarray(centre_m, dtype=np.float64)
    zero = np.zeros(len(r))
    x, y, z = r.T
    out = np.zeros((len(r), 3, 6))
    out[:, :, :3] = np.eye(3)
    out[:, :, 3:] = np.stack(
        [np.stack([zero, -z, y], -1), np.stack([z, zero, -x], -1), np.stack([-y, x, zero], -1)],
        axis=-1,
    )  # column j: e_j x r
    return out


@dataclass(eq=False)
class Constraints:
    """Held DOFs: ``fixed`` DOF indices, ``directions``: node DOF triples (3,) with unit
    vectors (k, 3) along which that node's displacement is held (k < 3), and ``springs``:
    DOFs tied to a pad on springs (:class:`Spring`)."""

    fixed: np.ndarray = field(default_factory=lambda: np.empty(0, dtype=np.int64))
    directions: list[tuple[np.ndarray, np.ndarray]] = field(default_factory=list)
    springs: list[Spring] = field(default_factory=list)

    @classmethod
    def union(cls, parts: Iterable[Constraints]) -> Constraints:
        """Everything any of ``parts`` holds (the constraints of several supports)."""
        parts = list(parts)
        fixed = [c.fixed for c in parts]
        return cls(
            fixed=np.unique(np.concatenate(fixed)) if fixed else np.empty(0, dtype=np.int64),
            directions=[d for c in parts for d in c.directions],
            springs=[s for c in parts for s in c.springs],
        )

    def basis(self, n_dof: int) -> sp.csc_matrix:
        """Sparse T (n_dof, n_free) whose columns span the admissible displacements."""
        return self.reduction(n_dof)[0]

    def pad_columns(self, n_dof: int) -> list[np.ndarray]:
        """Per spring, the columns of T (entries of z) that are its pad coordinates."""
        return self.reduction(n_dof)[2]

    def reduction(self, n_dof: int) -> tuple[sp.csc_matrix, sp.csr_matrix, list[np.ndarray]]:
        """(T (n_dof, n_free), the springs' stiffness on z (n_free, n_free), the pad columns
        of every spring): u = T z, and the reduced stiffness is T^T K T + that matrix."""
        fixed = np.zeros(n_dof, dtype=bool)
        fixed[self.fixed] = True
        tied = np.zeros(n_dof, dtype=bool)
        for spring in self.springs:
            tied[spring.dofs] = True
        rotated = np.zeros(n_dof, dtype=bool)
        for dofs, _ in self.directions:
            rotated[dofs] = True
        rotated &= ~fixed & ~tied
        plain = np.flatnonzero(~fixed & ~rotated & ~tied)
        rows, cols, vals = [plain], [np.arange(plain.size)], [np.ones(plain.size)]
        col = plain.size
        for dofs, held in _merge_directions(self.directions):
            if fixed[dofs].any():
                continue
            # orthonormal complement of the held directions
            _, s, vt = np.linalg.svd(held, full_matrices=True)
            rank = int((s > 1e-9).sum())
            for vec in vt[rank:]:
                rows.append(dofs)
                cols.append(np.full(3, col))
                vals.append(vec)
                col += 1
        pads, stiffness = [], []
        for spring in self.springs:
            keep = ~fixed[spring.dofs]
            n_pad = spring.shape.shape[1]
            block = np.arange(col, col + n_pad)
            rows.append(np.repeat(spring.dofs[keep], n_pad))
            cols.append(np.tile(block, int(keep.sum())))
            vals.append(spring.shape[keep].ravel())
            pads.append(block)
            stiffness.append(spring.stiffness)
            col += n_pad
        T = sp.csc_matrix(
            (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
            shape=(n_dof, col),
        )
        where = np.concatenate(pads) if pads else np.zeros(0, dtype=np.int64)
        k = np.concatenate(stiffness) if stiffness else np.zeros(0)
        springs = sp.csr_matrix((k, (where, where)), shape=(col, col))
        return T, springs, pads


def _merge_directions(directions):
    merged: dict[tuple[int, int, int], list[np.ndarray]] = {}
    for dofs, held in directions:
        merged.setdefault(tuple(int(d) for d in dofs), []).append(np.atleast_2d(held))
    for key, blocks in merged.items():
        yield np.array(key), np.concatenate(blocks)


class FormulationOutputs(Protocol):
    """What a formulation provides for the outputs beyond displacements (fem.outputs): unit
    rigid motions as DOF vectors, and the surface stress as a linear map of the DOFs."""

    @property
    def moves_in_plane(self) -> bool:
        """False for a Kirchhoff plate (no DOFs along x, y): the in-plane share of the cup
        reactions is then that of a rigid part (fem.outputs)."""

    def rigid_motion(self, centre_m: np.ndarray) -> np.ndarray:
        """(n_dof, 6) DOF vectors of unit translations along x, y, z and unit rotations about
        x, y, z through ``centre_m`` (3,) (zero columns for motions the DOFs cannot make)."""

    def surface_frame(
        self, x: float, y: float, z: float | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """(point (3,) on the mid-surface above (x, y) or nearest to (x, y, z), unit normal
        (3,)): where a cup sits and its axis."""

    def stress_operator(self) -> tuple[np.ndarray, sp.csr_matrix]:
        """(points (S, 3) m, sparse (6 S, n_dof)): the stress tensor (Voigt xx, yy, zz, yz,
        xz, xy; Pa) at S surface points per unit DOF."""


@runtime_checkable
class RotationFields(Protocol):
    """What a formulation answers for turning moves (fem.rotation_integrals), beyond
    FormulationOutputs; one that does not (e.g. an import without coordinates) gives its
    models no turning data."""

    def linear_fields(self, n_dof: int) -> np.ndarray | None:
        """(n_dof, 3, 3) DOF vectors F[:, i, j] of the fields u = e_j r_i (component j equal
        to the coordinate r_i, m), or None where its DOFs cannot hold them."""

    def inertia_loads(self, mass, fields: np.ndarray) -> np.ndarray:
        """(n_dof, 9) the consistent load of each unit field's acceleration (column 3 i + j),
        kg m: ``mass`` (n_dof, n_dof) @ ``fields`` where the fields are nodal DOF vectors
        (fem.elements.rigid_fields.mass_field_loads)."""

    def couplings(self, phi: np.ndarray, mass_phi: np.ndarray) -> tuple | None:
        """(G (3, M, M), P (3, 3, M, M)) = (phi^T M X_k phi, phi^T M X_k X_l phi) of the
        modes ``phi`` (n_dof, M) with ``mass_phi`` = M phi, X_k the DOF operator of
        u -> e_k x u; None where the formulation cannot form X_k."""


@dataclass(eq=False)
class FESystem:
    """Assembled matrices and the geometry needed to report results.

    Attributes:
        K, M: (n, n) sparse stiffness (N/m) and consistent mass (kg) matrices.
        rigid: (n, 3) DOF vectors of unit rigid translations along x, y, z.
        nodes: (N, 3) coordinates (m) of the nodes where displacements are reported (plate:
            vertices; thin solid: mid-surface nodes).
        node_dofs: (N, 3) DOF index of the x, y, z displacement at each node, -1 where the
            formulation has none (a Kirchhoff plate only moves along z).
        cells: (C, c) connectivity of ``nodes`` for viewing, meshio type ``cell_type``.
        constraints: the supports as Constraints.
        stats: mesh statistics for the model metadata.
        formulation: its description; outputs: its FormulationOutputs;
        support_constraints: the Constraints of each support (in the supports' order).
    """

    K: sp.csr_matrix
    M: sp.csr_matrix
    rigid: np.ndarray
    nodes: np.ndarray
    node_dofs: np.ndarray
    cells: np.ndarray
    cell_type: str
    constraints: Constraints
    stats: dict
    formulation: str
    outputs: FormulationOutputs | None = None
    support_constraints: list[Constraints] = field(default_factory=list)

    @classmethod
    def held_by(cls, held: list[Constraints], **fields) -> FESystem:
        """The system of ``fields`` (every attribute but the constraints, by name) held by
        the supports' constraints ``held`` (in the supports' order): their union."""
        return cls(constraints=Constraints.union(held), support_constraints=held, **fields)

    @property
    def n_dof(self) -> int:
        return int(self.K.shape[0])

    def observation(self) -> sp.csr_matrix:
        """Sparse O (3N, n): displacements at the nodes, row 3 p + d = node p, direction d."""
        rows = np.flatnonzero(self.node_dofs.ravel() >= 0)
        cols = self.node_dofs.ravel()[rows]
        return sp.csr_matrix(
            (np.ones(rows.size), (rows, cols)), shape=(3 * len(self.nodes), self.n_dof)
        )


def surface_triangles(cells: np.ndarray, cell_type: str) -> np.ndarray:
    """(T, 3) triangles of node indices covering the viewing ``cells`` of an FESystem (meshio
    ``cell_type`` "triangle" as they are; "quad9" each into 4 sub-quads of 2 triangles)."""
    if cell_type == "triangle":
        return np.asarray(cells)
    if cell_type != "quad9":
        raise ValueError(f"surface_triangles: cell type {cell_type!r} is not a surface")
    a, b, c, d, ab, bc, cd, da, o = np.asarray(cells).T
    quads = [(a, ab, o, da), (ab, b, bc, o), (o, bc, c, cd), (da, o, cd, d)]
    tris = [np.column_stack(t) for q in quads for t in ((q[0], q[1], q[2]), (q[0], q[2], q[3]))]
    return np.concatenate(tris)


def mesh_stats(
    cell_type: str, n_nodes: int, n_elements: int, n_dof: int, edge_lengths_m: np.ndarray
) -> dict:
    """The mesh statistics an FESystem carries (the model's meta)."""
    return {
        "cell_type": cell_type,
        "n_nodes": int(n_nodes),
        "n_elements": int(n_elements),
        "n_dof": int(n_dof),
        "edge_length_min_m": float(np.min(edge_lengths_m)),
        "edge_length_max_m": float(np.max(edge_lengths_m)),
    }
