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

**Static response to the rotational loads** (optional, from the FE's static solve like the
translation's static response of jaxflex.model): the load of the field B r is the sum of
B_ji times the nine unit cases f_ij = M (e_j r_i), and the part's exact static response to
them, at rest per unit B_ji (1/s^2), is stored for the points (``static_shapes`` (K, 3, 3, 3)
m s^2: [k, c, i, j] component c of point k), the cup reactions (``cup_static`` (6 C, 3, 3):
N s^2 or N m s^2 per row of jaxflex._outputs.CupSet) and the stresses (``stress_static``
(6 S, 3, 3) Pa s^2). With them the modes left out respond quasi-statically to the Euler and
centrifugal loads too (jaxflex._rotation_residual); without them that share is missing.

**Couplings of the deformation** (optional, from the FE): the loads the turning engine
neglects, -M [2 w x u' + alpha x u + w x (w x u)] (jaxflex._turning), in the kept modes:
``gyroscopic`` (3, M, M) G_k = phi^T M X_k phi and ``spin`` (3, 3, M, M) P_kl =
phi^T M X_k X_l phi (dimensionless), X_k the DOF operator of u -> e_k x u (fem.
rotation_integrals; a shell's: the integrals int rho v_m . (e_k x v_n) dV of its own
field). The modal load of the neglected terms is then -(2 G(w) q' + G(alpha) q
+ P(w) q) with G(v) = sum_k v_k G_k and P(w) = sum_kl w_k w_l P_kl; with them
jaxflex._turning bounds the neglected terms' effect a posteriori, without them by an energy
estimate alone.
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
# the optional static response to the nine unit inertia loads (module docstring): the file's
# groups "rotation_static", "rotation_cups", "rotation_stress" (jaxflex._model_file)
STATIC_FIELDS = {
    "static_shapes": "rotation_static_shapes",
    "cup_static": "rotation_cup_static",
    "stress_static": "rotation_stress_static",
}
# the optional couplings of the deformation (module docstring): the file's group
# "rotation_coupling" (jaxflex._model_file)
COUPLING_FIELDS = {"gyroscopic": "rotation_gyroscopic", "spin": "rotation_spin"}


@jax.tree_util.register_pytree_node_class
@dataclass(frozen=True, eq=False)
class RotationalInertia:
    """Inertia data of a part for turning moves (SI units; module docstring).

    Attributes:
        shape_integrals: (M, 3, 3) S_m[i, j] = phi_m^T M (e_j r_i), kg^0.5 m.
        mass_kg: () the part's mass, kg.
        centre_m: (3,) its centre of mass in the model frame, m.
        inertia_kg_m2: (3, 3) its inertia tensor about the model frame's origin, kg m^2.
        static_shapes, cup_static, stress_static: the optional static response to the unit
            inertia loads (module docstring), (K, 3, 3, 3), (6 C, 3, 3), (6 S, 3, 3) or None.
        gyroscopic, spin: the optional couplings of the deformation (module docstring),
            (3, M, M) and (3, 3, M, M) or None.
    """

    shape_integrals: Any
    mass_kg: Any
    centre_m: Any
    inertia_kg_m2: Any
    static_shapes: Any = None
    cup_static: Any = None
    stress_static: Any = None
    gyroscopic: Any = None
    spin: Any = None

    def tree_flatten(self):
        return (
            self.shape_integrals,
            self.mass_kg,
            self.centre_m,
            self.inertia_kg_m2,
            self.static_shapes,
            self.cup_static,
            self.stress_static,
            self.gyroscopic,
            self.spin,
        ), None

    @classmethod
    def tree_unflatten(cls, aux, children):
        return cls(*children)

    def replace(self, **changes: Any) -> RotationalInertia:
        """The same data with the fields ``changes`` replaced."""
        names = ROTATION_ATTRIBUTES + tuple(STATIC_FIELDS) + tuple(COUPLING_FIELDS)
        return RotationalInertia(**{n: changes.get(n, getattr(self, n)) for n in names})

    @property
    def gamma_rot(self):
        """(M, 3) rotational participation Gamma_rot[m, k] = phi_m^T M (e_k x r), kg^0.5 m."""
        return np.einsum("kij,mij->mk", LEVI_CIVITA, np.asarray(self.shape_integrals))

    def take_modes(self, keep) -> RotationalInertia:
        """The same data for the modes ``keep`` (indices); the static response stays (the
        modes dropped join its quasi-static residual), the couplings among the kept stay."""
        keep = np.asarray(keep)
        couplings = {
            name: None if value is None else np.asarray(value)[..., keep[:, None], keep]
            for name, value in ((n, getattr(self, n)) for n in COUPLING_FIELDS)
        }
        return self.replace(shape_integrals=np.asarray(self.shape_integrals)[keep], **couplings)

    def posed(
        self,
        rotation: np.ndarray,
        offset_m: np.ndarray,
        gamma: np.ndarray,
        translation: dict[str, Any] | None = None,
    ):
        """The data in a frame where x is at ``rotation`` x + ``offset_m`` ((3, 3), (3,) m);
        ``gamma`` (M, 3): the modes' translational participation in the model's own frame.
        S' = R S R^T + o (R Gamma)^T per mode; the inertia by the parallel-axis theorem.
        ``translation`` maps the names of STATIC_FIELDS to functions (values, rotation,
        offset) -> posed values (jaxflex.model.ModalModel.posed: :func:`posed_tensor` with
        the translation's static response and the output rows' own rotation); a static
        response without one is dropped. The couplings turn with the axes: G'_k = R_ka G_a,
        P'_kl = R_ka P_ab R_lb (they do not depend on the origin)."""
        r, o = np.asarray(rotation), np.asarray(offset_m)
        s = posed_tensor(self.shape_integrals, np.asarray(gamma), r, o)
        m, c = float(self.mass_kg), np.asarray(self.centre_m)
        j_c = np.asarray(self.inertia_kg_m2) - m * (c @ c * np.eye(3) - np.outer(c, c))
        c_new = r @ c + o
        j_new = r @ j_c @ r.T + m * (c_new @ c_new * np.eye(3) - np.outer(c_new, c_new))
        statics = {}
        for name in STATIC_FIELDS:
            value = getattr(self, name)
            moved = None if translation is None else translation.get(name)
            statics[name] = None if value is None or moved is None else moved(value, r, o)
        if self.gyroscopic is not None:
            statics["gyroscopic"] = np.einsum("ka,a...->k...", r, np.asarray(self.gyroscopic))
            statics["spin"] = np.einsum("ka,lb,ab...->kl...", r, r, np.asarray(self.spin))
        return RotationalInertia(s, np.float64(m), c_new, j_new, **statics)

    def to_fields(self) -> dict[str, np.ndarray]:
        """The model file's ``rotation`` group and the static response's groups
        (jaxflex._model_file)."""
        values = (
            self.shape_integrals,
            np.reshape(self.mass_kg, 1),
            self.centre_m,
            self.inertia_kg_m2,
        )
        out = {k: np.asarray(v) for k, v in zip(ROTATION_FIELDS, values, strict=True)}
        for name, field in STATIC_FIELDS.items():
            value = getattr(self, name)
            if value is not None:
                value = np.asarray(value)
                out[field] = value if name == "static_shapes" else value.reshape(-1, 6, 3, 3)
        for name, field in COUPLING_FIELDS.items():
            if getattr(self, name) is not None:
                out[field] = np.asarray(getattr(self, name))
        return out

    @classmethod
    def from_fields(cls, fields: dict[str, np.ndarray]) -> RotationalInertia:
        """Inverse of :meth:`to_fields` (the static response's and couplings' fields
        optional)."""
        statics = {}
        for name, field in STATIC_FIELDS.items():
            value = fields.get(field)
            if value is not None and name != "static_shapes":
                value = value.reshape(-1, 3, 3)
            statics[name] = value
        for name, field in COUPLING_FIELDS.items():
            statics[name] = fields.get(field)
        return cls(
            fields["rotation_shape_integrals"],
            np.float64(fields["rotation_mass_kg"][0]),
            fields["rotation_centre_m"],
            fields["rotation_inertia_kg_m2"],
            **statics,
        )


ROTATION_ATTRIBUTES = ("shape_integrals", "mass_kg", "centre_m", "inertia_kg_m2")


def posed_tensor(values, translation, rotation: np.ndarray, offset_m: np.ndarray) -> np.ndarray:
    """Values per unit inertia load B_ji (..., 3, 3) in a frame where x is at ``rotation`` x
    + ``offset_m``, from those in the model's frame and ``translation`` (..., 3) the same
    quantity per unit base acceleration there: the field B' r' is, in the model's frame,
    (R^T B' R) r plus the translation R^T B' o, so V' = R V R^T + o (R T)^T over the last two
    axes. The leading axes are not transformed (the caller maps output rows)."""
    r, o = np.asarray(rotation), np.asarray(offset_m)
    v = np.einsum("ia,...ab,jb->...ij", r, np.asarray(values), r)
    return v + np.einsum("i,...j->...ij", o, np.asarray(translation) @ r.T)


def checked_rotation(
    value: Any, n_modes: int, static_rows: tuple = (None, None, None)
) -> RotationalInertia:
    """``value`` as a RotationalInertia of float64 arrays whose shapes fit ``n_modes`` and,
    for its static responses, the model's ``static_rows`` (K points with static shapes,
    6 C cup rows, 6 S stress rows; None: the model has none, and the static response of
    that quantity to the rotational loads goes with it, as a model without static shapes
    knows only its modes); ModelError naming the field otherwise (finite values, a positive
    mass, a symmetric inertia tensor)."""
    value_in = value
    if not isinstance(value, RotationalInertia):
        raise ModelError(
            "ModalModel.rotation: expected jaxflex.response.RotationalInertia or None, got "
            f"{type(value).__name__}"
        )
    out = []
    for name, shape in (
        ("shape_integrals", (n_modes, 3, 3)),
        ("mass_kg", ()),
        ("centre_m", (3,)),
        ("inertia_kg_m2", (3, 3)),
    ):
        out.append(_checked_field(name, getattr(value, name), shape))
    if not out[1] > 0:
        raise ModelError(f"ModalModel.rotation.mass_kg: must be > 0 kg, got {float(out[1])}")
    inertia = out[3]
    if not np.allclose(inertia, inertia.T, rtol=1e-9, atol=1e-12 * np.abs(inertia).max()):
        raise ModelError("ModalModel.rotation.inertia_kg_m2: must be symmetric")
    for name, rows in zip(STATIC_FIELDS, static_rows, strict=True):
        given = getattr(value_in, name)
        if given is None or rows is None:  # a model without the quantity has no share of it
            out.append(None)
            continue
        shape = (rows, 3, 3, 3) if name == "static_shapes" else (rows, 3, 3)
        out.append(_checked_field(name, given, shape))
    couplings = [getattr(value_in, name) for name in COUPLING_FIELDS]
    if all(c is not None for c in couplings):  # both or none (the file's group)
        shapes = ((3, n_modes, n_modes), (3, 3, n_modes, n_modes))
        couplings = [
            _checked_field(name, c, shape)
            for name, c, shape in zip(COUPLING_FIELDS, couplings, shapes, strict=True)
        ]
    else:
        couplings = [None, None]
    return RotationalInertia(*out, *couplings)


def _checked_field(name: str, value: Any, shape: tuple) -> np.ndarray:
    """``value`` as a read-only float64 array of ``shape``, finite; ModelError naming the
    field of ModalModel.rotation otherwise."""
    arr = np.array(value, dtype=np.float64)
    if arr.shape != shape:
        raise ModelError(f"ModalModel.rotation.{name}: expected shape {shape}, got {arr.shape}")
    if not np.isfinite(arr).all():
        raise ModelError(f"ModalModel.rotation.{name}: must be finite")
    arr.setflags(write=False)
    return arr


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
