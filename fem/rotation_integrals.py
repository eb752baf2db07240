"""The inertia data of turning moves from an FE modal analysis (jaxflex.rotation).

The inertia shape integrals S_m[i, j] = phi_m^T M (e_j r_i) need the DOF vectors of the
linear fields u = e_j r_i (component j equal to the coordinate r_i, m, in the model frame):

* thin solid (hex2): the field's values at every node (translations only);
* shell: the translations at every node and, as rotations, the field's infinitesimal rotation
  (1/2 curl u = e_i x e_j / 2: the skew part; the director of a symmetric field is left
  unrotated, an O(h^2 / L^2) share of the rotary inertia);
* Kirchhoff plate: the deflection w only (fields along z: w = x, y or the mid-plane height);
  a plate has no in-plane DOFs, so in-plane loads (a turn about its normal) do not deform
  it, exactly as its x and y participation is zero.

Every formulation's fields are checked against its own rigid rotations (eps_kij e_j r_i =
e_k x r: fem.system.FormulationOutputs.rigid_motion) before use. Systems of other sources
(Nastran decks, ANSYS, R1) get no data: :func:`rotational_inertia` returns None and their
models refuse turning moves (jaxflex.rotation.require_rotation).
"""

from __future__ import annotations

import numpy as np

from fem.plate import PlateOutputs
from fem.shell import DOFS_PER_NODE, ShellOutputs
from fem.solid import SolidOutputs
from jaxflex.response import LEVI_CIVITA, RotationalInertia


def linear_fields(system) -> np.ndarray | None:
    """(n_dof, 3, 3) DOF vectors F[:, i, j] of the fields u = e_j r_i of ``system``
    (fem.system.FESystem), or None for a formulation without them (module docstring)."""
    outputs = system.outputs
    n_dof = system.n_dof
    out = np.zeros((n_dof, 3, 3))
    if isinstance(outputs, SolidOutputs):
        points = outputs.layer.points
        for j in range(3):
            out[j::3, :, j] = points
    elif isinstance(outputs, ShellOutputs):
        nodes = outputs.layer.nodes
        for j in range(3):
            out[j::DOFS_PER_NODE, :, j] = nodes
        for axis in range(3):  # rotation about `axis` = eps_axis,i,j / 2
            out[3 + axis :: DOFS_PER_NODE] = 0.5 * LEVI_CIVITA[axis][None]
    elif isinstance(outputs, PlateOutputs):
        ones, x, y = outputs.linear_dofs().T
        out[:, 0, 2], out[:, 1, 2], out[:, 2, 2] = x, y, outputs.z0 * ones
    else:
        return None
    rotations = np.einsum("kij,nij->nk", LEVI_CIVITA, out)
    expected = outputs.rigid_motion(np.zeros(3))[:, 3:]
    error = np.abs(rotations - expected).max() / max(1.0, np.abs(expected).max())
    if error > 1e-9:  # both are exact sums of coordinates: only round-off differs
        raise RuntimeError(f"linear fields miss the rigid rotations by {error:.1e}")
    return out


def rotational_inertia(result) -> RotationalInertia | None:
    """The RotationalInertia of ``result`` (fem.ModalResult) about the model frame's origin:
    shape integrals of its elastic modes, the rigid mass, centre and inertia tensor of the
    FE mass matrix (the plate's: of its deflection DOFs, J_zz = J_xx + J_yy of a flat
    sheet); None where the formulation gives no linear fields."""
    system = result.system
    fields = linear_fields(system)
    if fields is None:
        return None
    n_dof = system.n_dof
    flat = fields.reshape(n_dof, 9)
    reduced = result.basis.T @ (system.M @ flat)  # (n_free, 9)
    shape_integrals = (result.vectors.T @ reduced).reshape(-1, 3, 3)
    mass = float(result.mass_kg)
    lift = system.M @ system.rigid[:, 2]  # M times the unit translation along z
    centre = (lift @ fields[:, :, 2]) / mass
    rigid_rot = system.outputs.rigid_motion(np.zeros(3))[:, 3:]
    inertia = rigid_rot.T @ (system.M @ rigid_rot)
    if not system.outputs.moves_in_plane:  # flat plate: about z from x and y
        inertia[2, 2] = inertia[0, 0] + inertia[1, 1]
    return RotationalInertia(shape_integrals, np.float64(mass), centre, 0.5 * (inertia + inertia.T))
