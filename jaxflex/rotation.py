"""What a model needs for moves that turn the part: its inertia shape integrals and rigid inertia.

In the body (gripper) frame, whose origin is the model frame's origin, a material point at r
(m) of a part turning with angular velocity w and angular acceleration alpha (body
components, rad/s and rad/s^2) feels the inertial acceleration alpha x r + w x (w x r) on top
of the frame origin's acceleration. Both are linear fields of r: w x (w x r) = A(w) r with
A(w) = w w^T - |w|^2 I. With mass-normalised modes phi_m and the FE's consistent mass matrix
M, the modal load of any linear field u = B r is sum_ij B_ji S_m[i, j], where

    S_m[i, j] = phi_m^T M (e_j r_i)     (kg^0.5 m; the field whose component j is r_i)

are the **inertia shape integrals** (M, 3, 3). The rotational participation follows from
them, Gamma_rot[m, k] = phi_m^T M (e_k x r) = eps_kij S_m[i, j], and so does the
centrifugal load tr(A(w) S_m). The rigid part's mass (kg), centre of mass (m) and inertia
tensor about the frame origin (kg m^2) complete the data (Newton-Euler of the whole part).

:class:`RotationalInertia` holds them, ``None`` on a model that does not know them (an R1
matrix, a modal result without a mass matrix, a file written before): such a model refuses
turning moves (:func:`require_rotation`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import jax
import numpy as np

from jaxflex.errors import ModelError

# eps[k, i, j]: the Levi-Civita symbol, (e_i x e_j)_k
LEVI_CIVITA = np.zeros((3, 3, 3))
for _k, _i, _j in ((0, 1, 2), (1, 2, 0), (2, 0, 1)):
    LEVI_CIVITA[_k, _i, _j], LEVI_CIVITA[_k, _j, _i] = 1.0, -1.0

ROTATION_FIELDS = (
    "rotation_shape_integrals",
    "rotation_mass_kg",
    "rotation_centre_m",
    "rotation_inertia_kg_m2",
)


@jax.tree_util.register_pytree_node_class
@dataclass(frozen=True, eq=False)
class RotationalInertia:
    """Inertia data of a part for turning moves (SI units; module docstring).

    Attributes:
        shape_integrals: (M, 3, 3) S_m[i, j] = phi_m^T M (e_j r_i), kg^0.5 m.
        mass_kg: () the part's mass, kg.
        centre_m: (3,) its centre of mass in the model frame, m.
        inertia_kg_m2: (3, 3) its inertia tensor about the model frame's origin, kg m^2.
    """

    shape_integrals: Any
    mass_kg: Any
    centre_m: Any
    inertia_kg_m2: Any

    def tree_flatten(self):
        return (self.shape_integrals, self.mass_kg, self.centre_m, self.inertia_kg_m2), None

    @classmethod
    def tree_unflatten(cls, aux, children):
        return cls(*children)

    @property
    def gamma_rot(self):
        """(M, 3) rotational participation Gamma_rot[m, k] = phi_m^T M (e_k x r), kg^0.5 m."""
        return np.einsum("kij,mij->mk", LEVI_CIVITA, np.asarray(self.shape_integrals))

    def take_modes(self, keep) -> RotationalInertia:
        """The same data for the modes ``keep`` (indices)."""
        return RotationalInertia(
            np.asarray(self.shape_integrals)[keep], self.mass_kg, self.centre_m, self.inertia_kg_m2
        )

    def posed(self, rotation: np.ndarray, offset_m: np.ndarray, gamma: np.ndarray):
        """The data in a frame where x is at ``rotation`` x + ``offset_m`` ((3, 3), (3,) m);
        ``gamma`` (M, 3): the modes' translational participation in the model's own frame.
        S' = R S R^T + o (R Gamma)^T per mode; the inertia by the parallel-axis theorem."""
        r, o = np.asarray(rotation), np.asarray(offset_m)
        s = np.einsum("ia,mab,jb->mij", r, np.asarray(self.shape_integrals), r)
        s = s + np.einsum("i,mj->mij", o, np.asarray(gamma) @ r.T)
        m, c = float(self.mass_kg), np.asarray(self.centre_m)
        j_c = np.asarray(self.inertia_kg_m2) - m * (c @ c * np.eye(3) - np.outer(c, c))
        c_new = r @ c + o
        j_new = r @ j_c @ r.T + m * (c_new @ c_new * np.eye(3) - np.outer(c_new, c_new))
        return RotationalInertia(s, np.float64(m), c_new, j_new)

    def to_fields(self) -> dict[str, np.ndarray]:
        """The model file's ``rotation`` group (jaxflex.model_file)."""
        values = (
            self.shape_integrals,
            np.reshape(self.mass_kg, 1),
            self.centre_m,
            self.inertia_kg_m2,
        )
        return {k: np.asarray(v) for k, v in zip(ROTATION_FIELDS, values, strict=True)}

    @classmethod
    def from_fields(cls, fields: dict[str, np.ndarray]) -> RotationalInertia:
        """Inverse of :meth:`to_fields`."""
        return cls(
            fields["rotation_shape_integrals"],
            np.float64(fields["rotation_mass_kg"][0]),
            fields["rotation_centre_m"],
            fields["rotation_inertia_kg_m2"],
        )


def checked_rotation(value: Any, n_modes: int) -> RotationalInertia:
    """``value`` as a RotationalInertia of float64 arrays whose shapes fit ``n_modes``;
    ModelError naming the field otherwise (finite values, a positive mass, a symmetric
    inertia tensor)."""
    if not isinstance(value, RotationalInertia):
        raise ModelError(
            "ModalModel.rotation: expected jaxflex.rotation.RotationalInertia or None, got "
            f"{type(value).__name__}"
        )
    out = []
    for name, shape in (
        ("shape_integrals", (n_modes, 3, 3)),
        ("mass_kg", ()),
        ("centre_m", (3,)),
        ("inertia_kg_m2", (3, 3)),
    ):
        arr = np.array(getattr(value, name), dtype=np.float64)
        if arr.shape != shape:
            raise ModelError(f"ModalModel.rotation.{name}: expected shape {shape}, got {arr.shape}")
        if not np.isfinite(arr).all():
            raise ModelError(f"ModalModel.rotation.{name}: must be finite")
        arr.setflags(write=False)
        out.append(arr)
    if not out[1] > 0:
        raise ModelError(f"ModalModel.rotation.mass_kg: must be > 0 kg, got {float(out[1])}")
    inertia = out[3]
    if not np.allclose(inertia, inertia.T, rtol=1e-9, atol=1e-12 * np.abs(inertia).max()):
        raise ModelError("ModalModel.rotation.inertia_kg_m2: must be symmetric")
    return RotationalInertia(*out)


def require_rotation(model) -> RotationalInertia:
    """The model's RotationalInertia; ModelError saying what is missing where it has none."""
    rotation = getattr(model, "rotation", None)
    if rotation is None:
        source = dict(model.meta).get("source", "this model")
        raise ModelError(
            f"turning moves need the part's inertia shape integrals (phi^T M (e_j r_i): the "
            f"mass matrix and node coordinates of an FE model), which {source} does not hold; "
            "build the model with `jaxflex model` (plate, thin solid, shell) or import a "
            "source with a mass matrix (ANSYS .full, Nastran deck); R1 matrices, .rst results "
            "and model files written before turning moves cannot turn the part"
        )
    return rotation
