"""The linear fields u = e_j r_i as DOF vectors of nodal translations and rotations, and the
couplings of a formulation's own displacement field: the pieces every formulation shares
when it answers the rotation integrals (fem.system.FormulationOutputs, fem.rotation_integrals).

Pure NumPy: the finite elements and the readers of other tools' files use it alike. The
Levi-Civita symbol is imported where it is used: its home (jaxflex.response) loads JAX, which
the readers' child interpreters (jaxflex.isolated) would otherwise import for nothing (1 s of
CPU a file)."""

from __future__ import annotations

import numpy as np

DOFS_PER_NODE = 6  # translations x, y, z, then rotations about x, y, z


def nodal_fields(points_m: np.ndarray, translation: np.ndarray, rotation: np.ndarray):
    """(n, 3, 3) DOF vectors F[:, i, j] of u = e_j r_i for DOFs that are nodal translations
    and rotations: ``points_m`` (n, 3) the position of each DOF's node (any length unit),
    ``translation`` (n, 3) the global direction a translation DOF moves along (zeros for a
    rotation DOF), ``rotation`` (n, 3) the global axis of a rotation DOF (zeros else). A
    translation takes the field's component along it, a rotation the component of the
    field's infinitesimal rotation 1/2 curl(e_j r_i) = 1/2 eps_kij e_k along its axis."""
    from jaxflex.response import LEVI_CIVITA

    return translation[:, None, :] * points_m[:, :, None] + 0.5 * np.einsum(
        "nk,kij->nij", rotation, LEVI_CIVITA
    )


def six_dof_axes(nodes_m: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The :func:`nodal_fields` arguments of six DOFs per node (translations x, y, z, then
    rotations about x, y, z, global axes) at ``nodes_m`` (N, 3)."""
    eye = np.eye(3)
    zero = np.zeros((3, 3))
    translation = np.tile(np.vstack([eye, zero]), (len(nodes_m), 1))
    rotation = np.tile(np.vstack([zero, eye]), (len(nodes_m), 1))
    return np.repeat(nodes_m, DOFS_PER_NODE, axis=0), translation, rotation


def six_dof_fields(nodes_m: np.ndarray, n_dof: int) -> np.ndarray | None:
    """(n_dof, 3, 3) the linear fields of six DOFs per node at ``nodes_m`` (N, 3), or None
    where the DOFs are more than the nodes' (scalar points besides the grids)."""
    if DOFS_PER_NODE * len(nodes_m) != n_dof:
        return None
    return nodal_fields(*six_dof_axes(nodes_m))


def couplings_from_mass_products(products: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(G, P) from C[a, b, m, n] = int rho (v_m)_a (v_n)_b dV: G_k = int rho v_m . (e_k x
    v_n) = eps_kab C[b, a], P_kl = int rho v_m . (e_k x (e_l x v_n)) = C[l, k] - d_kl tr C."""
    from jaxflex.response import LEVI_CIVITA

    gyroscopic = np.einsum("kab,bamn->kmn", LEVI_CIVITA, products)
    trace = np.einsum("aamn->mn", products)
    spin = products.transpose(1, 0, 2, 3) - np.eye(3)[:, :, None, None] * trace
    return gyroscopic, spin


def mass_field_loads(mass, fields: np.ndarray) -> np.ndarray:
    """(n_dof, 9) M F: the consistent loads of the fields ``fields`` (n_dof, 3, 3) that are
    nodal DOF vectors, under the mass matrix ``mass`` (n_dof, n_dof), column 3 i + j."""
    return np.asarray(mass @ fields.reshape(len(fields), 9))
