"""The quasi-static share of the modes left out under the rotational loads of a turning move.

The Euler and centrifugal loads of a turning part are those of the linear field B r with

    B = [alpha]_x + w w^T - |w|^2 I        (alpha, w: angular acceleration and velocity),

so every response to them is a combination of the responses to the nine unit fields e_j r_i
with coefficients b_ij = B_ji (:func:`load_coefficients`, (T, 9) in the order 3 i + j of the
stored arrays). With the part's exact static response to these loads (jaxflex._rotation:
``static_shapes`` and the outputs' ``cup_static``, ``stress_static``, from the FE) the
mode-acceleration split of jaxflex.model extends from the translation to the rotation:

    u = Phi q + D (a_O - g_b) + D_rot b,      D_rot = static_rot + Phi Omega^-2 S        (1)

(S the inertia shape integrals (M, 9)): exact at rest under constant rates (the modes settle
at q = -Omega^-2 S b), the modes left out respond quasi-statically. An output y (cup
reactions, stresses) likewise gains A_rot b with A_rot = static_rot + Q Omega^-2 S.

A model without that static response (a file written before it was stored, an import that
does not compute it) has D_rot = 0:
the share of the modes it keeps is in q, the share of the modes left out is missing
(:func:`rotation_residual` returns None and callers say so).

For the deviation during a move the coefficients b are nine more coordinates with "shapes"
D_rot after those of jaxflex._deviation.response_shapes (:func:`turning_shapes`,
:func:`turning_coordinates`), so the pruned all-point evaluation holds unchanged.
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np

from jaxflex._deviation import block_model, response_shapes, with_acceleration
from jaxflex._rotation import LEVI_CIVITA
from jaxflex.errors import JaxflexWarning

MISSING_STATIC = (
    "the model holds no static response to the rotational loads (a model file written "
    "before it was stored, or a source that does not compute it): the quasi-static share of "
    "the modes left out under the Euler and centrifugal loads is missing from the {what} of "
    "this turning move; a part built with `jaxflex model` (plate, thin solid, shell) has it"
)


def warn_missing_static(what: str, stacklevel: int = 3) -> None:
    """JaxflexWarning that the static response to the rotational loads is missing from
    ``what`` (e.g. "deviation")."""
    warnings.warn(MISSING_STATIC.format(what=what), JaxflexWarning, stacklevel=stacklevel)


def load_tensor(omega_rad_s, alpha_rad_s2, xp: Any = np):
    """(T, 3, 3) B = [alpha]_x + w w^T - |w|^2 I (1/s^2) of angular velocities ``omega_rad_s``
    and accelerations ``alpha_rad_s2`` (T, 3): the field B r is alpha x r + w x (w x r)."""
    w, alpha = xp.asarray(omega_rad_s), xp.asarray(alpha_rad_s2)
    skew = -xp.einsum("kij,tk->tij", xp.asarray(LEVI_CIVITA), alpha)  # [alpha]_x
    spin = xp.einsum("ti,tj->tij", w, w) - xp.einsum("t,ij->tij", xp.sum(w * w, 1), xp.eye(3))
    return skew + spin


def load_coefficients(omega_rad_s, alpha_rad_s2, xp: Any = np):
    """(T, 9) b[t, 3 i + j] = B_ji: the coefficients of the unit fields e_j r_i."""
    b = load_tensor(omega_rad_s, alpha_rad_s2, xp)
    return xp.swapaxes(b, 1, 2).reshape(b.shape[0], 9)


def modal_static(model) -> np.ndarray:
    """(M, 9) Omega^-2 S: the modes' static coordinates per unit coefficient (negated)."""
    omega = np.asarray(model.omega_rad_s)
    s = np.asarray(model.rotation.shape_integrals).reshape(-1, 9)
    return s / omega[:, None] ** 2


def rotation_residual(model) -> np.ndarray | None:
    """(K, 3, 9) D_rot of equation (1) at the model's points (m s^2), or None without the
    static response to the rotational loads."""
    rotation = model.rotation
    if rotation is None or rotation.static_shapes is None:
        return None
    static = np.asarray(rotation.static_shapes).reshape(model.n_points, 3, 9)
    return static + np.asarray(model.shapes) @ modal_static(model)


def output_residual(outputs, static_rot, model) -> np.ndarray:
    """(Y, 9) A_rot = static_rot + Q Omega^-2 S of jaxflex._outputs.LinearOutputs ``outputs``
    with the static response ``static_rot`` (Y, 3, 3) or None (then Q Omega^-2 S: the
    kept modes' static share only)."""
    modal = np.asarray(outputs.q_map) @ modal_static(model)
    return modal if static_rot is None else modal + np.asarray(static_rot).reshape(-1, 9)


def turning_shapes(model) -> np.ndarray:
    """(K, 3, M') the shapes of the displacement during a turning move: those of
    jaxflex._deviation.response_shapes, then D_rot's nine columns where the model has it."""
    shapes = response_shapes(model)
    residual = rotation_residual(model)
    return shapes if residual is None else np.concatenate([shapes, residual], axis=2)


def turning_coordinates(model, q, acc, coefficients, xp: Any = np):
    """The coordinates of :func:`turning_shapes`: modal q (T, M), the frame origin's
    acceleration ``acc`` (T, 3) where the model has a static residual, the load
    ``coefficients`` (T, 9) where it has the rotational one."""
    coords = with_acceleration(model, q, acc, xp)
    if model.rotation is None or model.rotation.static_shapes is None:
        return coords
    return xp.concatenate([coords, xp.asarray(coefficients, coords.dtype)], axis=-1)


def turning_blocks(model):
    """The jaxflex._blocks.PointBlocks of :func:`turning_shapes` of a concrete model (built
    once per model)."""
    cache = model.__dict__.setdefault("_turning_blocks", {})
    if "blocks" not in cache:
        cache["blocks"] = block_model(turning_shapes(model), model.points)
    return cache["blocks"]
