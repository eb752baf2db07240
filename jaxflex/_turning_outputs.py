"""Cup reactions and stresses of a part that turns (the straight move's jaxflex._outputs).

In the body frame of the gripper (jaxflex._turning) the part carries the load of the field
a_O - g_b + B r (B = [alpha]_x + w w^T - |w|^2 I: jaxflex._rotation_residual), so an output
linear in the modal state (cup reactions, stresses) is

    y = Q q + V q' + A (a_O - g_b) + A_rot b,      A_rot = static_rot + Q Omega^-2 S      (1)

with q the total modal state of jaxflex._turning (from the sag at the start pose, gravity
turned with the part in its forcing), b the nine coefficients of B and A, A_rot the exact
static maps of the translation and of the rotational loads plus the kept modes' share
(mode-acceleration split: the modes carry only the dynamic remainder). At rest in a pose y
is the static FE answer under gravity there; for a stiff part the cup reactions add up to
Newton-Euler: the force m (a_c - g) and, about the frame origin, the moment J alpha +
w x J w + m c x (a_O - g_b) (tests/test_turning_cell.py). Everything is in body components
(the cup's own axes turn with it, which is what its utilisation needs).

Values are taken at the move's samples (where the pose path is known) and, with
``extend_s``, at the samples of the free vibration after the move about the sag of the
final pose. A model without the static response to the rotational loads (a file written
before it was stored) gets A_rot = Q Omega^-2 S, the kept modes' share only: a
JaxflexWarning says so and the result's ``static_complete`` is False.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from jaxflex._loads import DEFAULT_CUP_SAFETY, CupUtilisation, VonMises
from jaxflex._rotation import require_rotation
from jaxflex._rotation_residual import output_residual, warn_missing_static
from jaxflex._turning import Turn, TurningInputs, turning_inputs
from jaxflex.errors import ModelError


@dataclass(frozen=True)
class TurningLoads:
    """Outputs of a turning move at the samples t_s (T,) s, body components (SI units).

    reactions (T, C, 6): force (N) and moment about the cup centre (N m) that each cup
    exerts on the part (jaxflex._outputs.CupSet rows), None without cups; utilisation (T, C)
    (jaxflex._loads.CupUtilisation with ``cup_safety``) or None; stress_pa (T, S, 6) Voigt,
    None without stresses; von_mises_pa (T, S) or None; static_complete: whether the static
    response to the rotational loads was known (module docstring).
    """

    t_s: np.ndarray
    reactions: np.ndarray | None
    utilisation: np.ndarray | None
    stress_pa: np.ndarray | None
    von_mises_pa: np.ndarray | None
    static_complete: bool


def output_values(model, outputs, static_rot, inputs: TurningInputs) -> np.ndarray:
    """(T, Y) equation (1) for jaxflex._outputs.LinearOutputs ``outputs`` of ``model`` with
    the static response to the rotational loads ``static_rot`` (Y, 3, 3) or None."""
    a_rot = output_residual(outputs, static_rot, model)
    return (
        inputs.q @ np.asarray(outputs.q_map).T
        + inputs.qd @ np.asarray(outputs.v_map).T
        + inputs.base @ np.asarray(outputs.a_map).T
        + inputs.coefficients @ a_rot.T
    )


def turning_loads(
    model, turn: Turn, *, extend_s: float = 0.0, cup_safety: float = DEFAULT_CUP_SAFETY
) -> TurningLoads:
    """Cup reactions, utilisation and stresses of ``model`` (with cups and/or stresses and
    its rotation data) over the turning move ``turn`` and, with ``extend_s`` (s), the
    free vibration after it (as jaxflex._turning.simulate_turning; module docstring).
    ModelError for a model with neither cups nor stresses."""
    if model.cups is None and model.stress is None:
        raise ModelError(
            "turning_loads: the model has no cups and no stresses (build it with "
            "`jaxflex model` on a part held by suction cups)"
        )
    rotation = require_rotation(model)
    complete = rotation.static_shapes is not None and (
        (model.cups is None or rotation.cup_static is not None)
        and (model.stress is None or rotation.stress_static is not None)
    )
    if not complete:
        warn_missing_static("cup reactions and stresses")
    inputs = turning_inputs(model, turn, extend_s=extend_s)
    reactions = utilisation = stress = von_mises = None
    if model.cups is not None:
        y = output_values(model, model.cups.reaction, rotation.cup_static, inputs)
        reactions = y.reshape(len(inputs.t_s), -1, 6)
        items = np.arange(model.cups.n_cups)
        utilisation = CupUtilisation(model.cups, cup_safety).values(reactions, items)
    if model.stress is not None:
        y = output_values(model, model.stress.stress, rotation.stress_static, inputs)
        stress = y.reshape(len(inputs.t_s), -1, 6)
        von_mises = VonMises(model.stress.n_points).values(stress, None)
    return TurningLoads(inputs.t_s, reactions, utilisation, stress, von_mises, complete)
