"""The inertia data of turning moves from an FE modal analysis (jaxflex._rotation).

The inertia shape integrals S_m[i, j] = phi_m^T M (e_j r_i) need the DOF vectors of the
linear fields u = e_j r_i (component j equal to the coordinate r_i, m, in the model frame):

* thin solid (hex2): the field's values at every node (translations only);
* shell: the translations at every node and, as rotations, the field's infinitesimal rotation
  (1/2 curl u = e_i x e_j / 2: the skew part, exact for the rigid rotations). A symmetric
  field's normal deflection on a curved shell is no nodal DOF vector of the shell, so its
  loads M (e_j r_i) are not taken as M F but as the virtual work of the sheet's 3-D mass
  facet by facet (:func:`inertia_loads`, fem.elements.shell.ShellOutputs.field_loads: fibres
  turned by n x (B n), no fictitious drilling inertia): its S, rigid inertia, static
  response and cups at rest are those of the faceted sheet (tests/test_rotation_shell.py);
* Kirchhoff plate: the deflection w only (fields along z: w = x, y or the mid-plane height);
  a plate has no in-plane DOFs, so in-plane loads (a turn about its normal) do not deform
  it, exactly as its x and y participation is zero;
* a Nastran deck (fem.imports.nastran.model.DeckOutputs) and an ANSYS ``.full`` with its node
  coordinates: nodal translations and rotations as for the shell
  (fem.elements.rigid_fields.nodal_fields; an ANSYS DOF in a rotated nodal system takes the field's
  component along its own axis).

The part's exact static response to the nine unit loads M (e_j r_i) (:func:`inertia_loads`;
one sparse solve with the translation's factorisation, fem.outputs) gives the points', the
cup reactions' and the stresses' static response to the rotational loads
(:func:`rotation_statics`), exactly as fem.outputs does for the translation: z_r = K_ff^-1
(M F)_free, the points' -T z_r, the
outputs' A_b,r - A_u z_r with A_b,r = V^T M_H F the inertia of the held DOFs (rigid cups).
A plate's in-plane share (F_x, F_y, M_z) is that of a part rigid in its plane on the cups'
springs (fem.outputs.in_plane_share) carrying the in-plane resultant of each field: force
m c_i e_j, moment about the centre of mass from the mass's second moments.

The couplings of the deformation, G_k = phi^T M X_k phi and P_kl = phi^T M X_k X_l phi with
X_k the DOF operator of u -> e_k x u (:func:`coupling_matrices`; the neglected terms' bound of
jaxflex._turning): the thin solid's X_k turns each node's translation (its shape functions
are the same for the three components, so this is exact for its field); the shell's are the
integrals int rho v_m . (e_k x v_n) dV of its own displacement field
(fem.elements.shell.ShellOutputs.mass_products: the cubic normal deflection and the fibres; turning
its nodal rotation vectors, as done before, missed G by 2.4 % against the thin solid); a Kirchhoff
plate's deflection w e_z turned about any axis is in its plane (G_k = 0) and e_k x (e_l x w e_z) has
the z component (d_kz d_lz - d_kl) w, so P_kl = (d_kz d_lz - d_kl) phi^T M phi (its kinetic energy
has no rotary inertia: exact); decks and ANSYS imports get none (their DOFs may be in rotated nodal
systems), and jaxflex._turning falls back to its energy bound.

Every formulation's fields are checked against its own rigid rotations (eps_kij e_j r_i =
e_k x r: fem.system.FormulationOutputs.rigid_motion) before use. Sources without a mass
matrix and coordinates (R1 matrices, ``.rst`` results alone, modal results from other
solvers) get no data: their models refuse turning moves (jaxflex.response.require_rotation).
"""

from __future__ import annotations

import numpy as np

from fem.elements.rigid_fields import mass_field_loads
from fem.outputs import (
    has_cups,
    held_inertia,
    in_plane_share,
    physical_outputs,
    plate_centre,
    static_solve,
)
from fem.system import RotationFields
from jaxflex.response import LEVI_CIVITA, RotationalInertia


def linear_fields(system) -> np.ndarray | None:
    """(n_dof, 3, 3) DOF vectors F[:, i, j] of the fields u = e_j r_i of ``system``
    (fem.system.FESystem) as its formulation gives them (fem.system.RotationFields), checked
    against its own rigid rotations; None for a formulation without them (module docstring)."""
    outputs = system.outputs
    if not isinstance(outputs, RotationFields):
        return None
    out = outputs.linear_fields(system.n_dof)
    if out is None:
        return None
    rotations = np.einsum("kij,nij->nk", LEVI_CIVITA, out)
    expected = outputs.rigid_motion(np.zeros(3))[:, 3:]
    error = np.abs(rotations - expected).max() / max(1.0, np.abs(expected).max())
    if error > 1e-9:  # both are exact sums of coordinates: only round-off differs
        raise RuntimeError(f"linear fields miss the rigid rotations by {error:.1e}")
    return out


def inertia_loads(system, fields: np.ndarray) -> np.ndarray:
    """(n_dof, 9) the consistent load of each unit field's acceleration e_j r_i (column
    3 i + j) on the DOFs of ``system``, kg m: M F for the ``fields`` (n_dof, 3, 3) of
    :func:`linear_fields`, as the formulation answers it (a shell: the virtual work of its
    3-D mass facet by facet, fem.elements.shell.ShellOutputs.field_loads)."""
    if isinstance(system.outputs, RotationFields):
        return system.outputs.inertia_loads(system.M, fields)
    return mass_field_loads(system.M, fields)


def rigid_inertia(mass_matrix, fields: np.ndarray, translations: np.ndarray, loads: np.ndarray):
    """(mass, centre (3,), inertia (3, 3) about the origin) of ``mass_matrix`` (n, n) from
    its linear ``fields`` (n, 3, 3), their inertia ``loads`` (n, 9) (:func:`inertia_loads`)
    and ``translations`` (n, 3), the DOF vectors of unit translations along x, y, z (zero
    columns where the DOFs have none: a plate's x, y).

    The rigid rotations are eps_kij F[:, i, j] = e_k x r, their loads eps_kij L[:, 3 i + j],
    so the inertia is exact (that of the loads: a shell's without drilling), and so is
    the centre, from the coupling t_d^T M (e_k x r) = m eps_dki c_i of translations and
    rotations: a point mass off its grid (a CONM2 offset) counts where it is. Where only the
    vertical translation exists (a plate) its height is the fields' (exact for a sheet)."""
    lift = mass_matrix @ translations
    mass = float(translations[:, 2] @ lift[:, 2])
    rotations = np.einsum("kij,nij->nk", LEVI_CIVITA, fields)
    coupling = lift.T @ rotations  # (3, 3): C[d, k] = m eps_dki c_i
    inertia = rotations.T @ np.einsum("kij,nij->nk", LEVI_CIVITA, loads.reshape(-1, 3, 3))
    if translations[:, :2].any():
        rows = LEVI_CIVITA.reshape(9, 3) * mass
        centre = np.linalg.lstsq(rows, coupling.reshape(9), rcond=None)[0]
    else:
        height = lift[:, 2] @ fields[:, 2, 2] / mass
        centre = np.array([-coupling[2, 1], coupling[2, 0], mass * height]) / mass
    return mass, centre, 0.5 * (inertia + inertia.T)


def rotational_inertia(
    result, nodes: np.ndarray | None = None, *, outputs: bool = False
) -> RotationalInertia | None:
    """The RotationalInertia of ``result`` (fem.ModalResult) about the model frame's origin:
    shape integrals of its elastic modes, the rigid mass, centre and inertia tensor of the
    FE mass matrix (the plate's: of its deflection DOFs, J_zz = J_xx + J_yy of a flat
    sheet); None where the formulation gives no linear fields. With ``nodes`` (K,) (a held
    part) the static response to the rotational loads at those nodes, and with ``outputs``
    the cup reactions' and stresses' (:func:`rotation_statics`)."""
    system = result.system
    fields = linear_fields(system)
    if fields is None:
        return None
    loads = inertia_loads(system, fields)
    reduced = result.basis.T @ loads  # (n_free, 9)
    shape_integrals = (result.vectors.T @ reduced).reshape(-1, 3, 3)
    _, centre, inertia = rigid_inertia(system.M, fields, system.rigid, loads)
    if not system.outputs.moves_in_plane:  # flat plate: about z from x and y
        inertia[2, 2] = inertia[0, 0] + inertia[1, 1]
    statics = (
        {} if nodes is None else rotation_statics(result, fields, loads, nodes, outputs=outputs)
    )
    couplings = coupling_matrices(result)
    if couplings is not None:
        statics["gyroscopic"], statics["spin"] = couplings
    return RotationalInertia(
        shape_integrals, np.float64(result.mass_kg), centre, inertia, **statics
    )


def coupling_matrices(result) -> tuple[np.ndarray, np.ndarray] | None:
    """(G (3, M, M), P (3, 3, M, M)) = (phi^T M X_k phi, phi^T M X_k X_l phi) of the modes
    of ``result`` (fem.ModalResult), X_k the DOF operator of u -> e_k x u, as the
    formulation answers it (fem.system.RotationFields; module docstring); None for a
    formulation without it."""
    system = result.system
    if not isinstance(system.outputs, RotationFields):
        return None
    phi = result.basis @ result.vectors  # (n_dof, M) the modes on every DOF
    return system.outputs.couplings(phi, system.M @ phi)


def rotation_statics(
    result, fields: np.ndarray, loads: np.ndarray, nodes: np.ndarray, *, outputs: bool
) -> dict[str, np.ndarray]:
    """The static response to the nine unit inertia loads M (e_j r_i) (module docstring):
    {"static_shapes": (K, 3, 3, 3) at ``nodes``, and with ``outputs`` "cup_static"
    (6 C, 3, 3) where there are suction cups and "stress_static" (6 S, 3, 3)}, per unit
    B_ji (1/s^2) of the field B r; ``fields`` (n_dof, 3, 3) from :func:`linear_fields`,
    ``loads`` (n_dof, 9) theirs from :func:`inertia_loads`."""
    system = result.system
    z_rot = result.__dict__.get("_rotation_static_response")  # (n_free, 9), once per result
    if z_rot is None:
        z_rot = static_solve(result, result.basis.T @ loads)
        result.__dict__["_rotation_static_response"] = z_rot
    n_nodes = len(system.nodes)
    points = -(result.observation @ z_rot).reshape(n_nodes, 3, 3, 3)
    out = {"static_shapes": points[nodes]}
    if not outputs or system.outputs is None:
        return out
    reactions, _, stress = physical_outputs(result)
    out["stress_static"] = -np.asarray(stress.stiffness @ z_rot).reshape(-1, 3, 3)
    if reactions is not None and has_cups(result):
        base = held_inertia(result, loads)
        if not system.outputs.moves_in_plane:
            base += in_plane_share(result, _in_plane_loads(result, fields))
        cups = base - np.asarray(reactions.stiffness @ z_rot)
        out["cup_static"] = cups.reshape(-1, 3, 3)
    return out


def _in_plane_loads(result, fields: np.ndarray) -> np.ndarray:
    """(3, 9) the in-plane resultant (F_x, F_y, M_z about the centre of mass) of the inertia
    of a plate's mass under each unit field e_j r_i (column 3 i + j): force m c_i e_j,
    moment int rho r_i ((r - c) x e_j)_z, from the second moments int rho r_i r_k of its
    deflection DOFs (the fields along z are r_i)."""
    along_z = fields[:, :, 2]  # (n_dof, 3): w = x, y, z0
    second = along_z.T @ (result.system.M @ along_z)  # int rho r_i r_k
    first = (result.system.M @ result.system.rigid[:, 2]) @ along_z  # m c_i
    c_x, c_y = plate_centre(result)
    load = np.zeros((3, 3, 3))  # (resultant, i, j)
    load[0, :, 0] = load[1, :, 1] = first
    load[2, :, 0] = -(second[:, 1] - first * c_y)
    load[2, :, 1] = second[:, 0] - first * c_x
    return load.reshape(3, 9)


def imported_inertia(
    mass_matrix, vectors: np.ndarray, fields: np.ndarray, translations: np.ndarray, unit
) -> RotationalInertia:
    """The RotationalInertia (SI) of modes ``vectors`` (n, M) of an imported ``mass_matrix``
    (n, n) with the fem.elements.rigid_fields.nodal_fields ``fields`` of its DOFs and the DOF
    vectors ``translations`` (n, 3) of unit translations along x, y, z, all in the file's consistent
    units ``unit`` (fem.imports.units.Units). The mass is the matrix's: without the DOFs the file
    constrains (the mass the modes can move, like the participation factors)."""
    loads = mass_matrix @ fields.reshape(len(fields), 9)
    shape_integrals = (vectors.T @ loads).reshape(-1, 3, 3)
    mass, centre, inertia = rigid_inertia(mass_matrix, fields, translations, loads)
    return RotationalInertia(
        shape_integrals * unit.gamma_to_si * unit.length_m,
        np.float64(mass * unit.mass_kg),
        centre * unit.length_m,
        inertia * unit.mass_kg * unit.length_m**2,
    )
