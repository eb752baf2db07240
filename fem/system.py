"""The assembled finite-element system shared by the plate and thin-solid formulations.

Degrees of freedom (DOFs) are those of the formulation (plate: deflection and its
derivatives; solid: x, y, z displacement per node). Supports remove DOFs (``fixed``) or
hold displacement components along given directions at nodes (``directions``), which is
expressed by a sparse basis T of the admissible displacements: u = T z.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp


@dataclass(eq=False)
class Constraints:
    """Held DOFs: ``fixed`` DOF indices, and ``directions``: node DOF triples (3,) with unit
    vectors (k, 3) along which that node's displacement is held (k < 3)."""

    fixed: np.ndarray = field(default_factory=lambda: np.empty(0, dtype=np.int64))
    directions: list[tuple[np.ndarray, np.ndarray]] = field(default_factory=list)

    @classmethod
    def union(cls, parts: Iterable[Constraints]) -> Constraints:
        """Everything any of ``parts`` holds (the constraints of several supports)."""
        parts = list(parts)
        fixed = [c.fixed for c in parts]
        return cls(
            fixed=np.unique(np.concatenate(fixed)) if fixed else np.empty(0, dtype=np.int64),
            directions=[d for c in parts for d in c.directions],
        )

    def basis(self, n_dof: int) -> sp.csc_matrix:
        """Sparse T (n_dof, n_free) whose columns span the admissible displacements."""
        fixed = np.zeros(n_dof, dtype=bool)
        fixed[self.fixed] = True
        rotated = np.zeros(n_dof, dtype=bool)
        for dofs, _ in self.directions:
            rotated[dofs] = True
        rotated &= ~fixed
        plain = np.flatnonzero(~fixed & ~rotated)
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
        return sp.csc_matrix(
            (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
            shape=(n_dof, col),
        )


def _merge_directions(directions):
    merged: dict[tuple[int, int, int], list[np.ndarray]] = {}
    for dofs, held in directions:
        merged.setdefault(tuple(int(d) for d in dofs), []).append(np.atleast_2d(held))
    for key, blocks in merged.items():
        yield np.array(key), np.concatenate(blocks)


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
