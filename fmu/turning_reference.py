"""The jaxflex response a co-simulation host's run of a turning part should reproduce: the
part's model (with its rotation data) driven by the move its FMU embeds (the resource's pose
samples, pivot accelerations, pivot and gravity).

* ``hold="linear"``: jaxflex.simulate_turning of the stored move (the forcing linear between
  the samples): what the part computes when a master forwards the trajectory source's output
  derivatives as its input derivatives (FMI 2.0), or replays its embedded move.
* ``hold="zero"``: the forcing of each pose sample held over its step (the exact zero-order
  hold, jaxflex's recursion with ``hold="zero"``), the deviation at the end of a step about
  the sag of the held pose with the held loads' static residual: what the part computes when
  a host copies the source's values at the communication points (Ecos, libcosim, any FMI 3.0
  host; fmpy's simulate_ssp would too, but it starts every connection at 0, a zero
  quaternion the part refuses, so fmu.crosscheck skips it for turning packages), as the part
  FMU measures it.

Both at the communication points k dt, k = 0..n_steps, the move padded at rest in its last
pose after its last sample (as the source outputs it).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from fmu.resource import ResourceData
from jaxflex.errors import InputError
from jaxflex.model import ModalModel
from jaxflex.response import (
    PosePath,
    Turn,
    body_loads,
    forced_states,
    load_coefficients,
    point_displacements,
    require_rotation,
    simulate_turning,
    turning_coordinates,
    turning_forces,
    turning_shapes,
)


def stored_turn(stored: ResourceData, model: ModalModel, n_steps: int) -> Turn:
    """The move (a jaxflex.response.Turn: the pose path, the pivot's accelerations at rest
    after the move, the pivot and gravity) of the turning part's resource ``stored`` padded
    to ``n_steps`` + 1 samples (at rest in the last pose), checked against ``model``: the
    part the FMU was exported from, with its rotation data (the resource does not hold the
    part's mass and inertia). InputError when the FMU is not a turning part with an
    embedded move or ``model`` is not its part (other points or modes)."""
    turning = stored.turning
    if turning is None or turning.pose_samples is None or stored.acc is None:
        raise InputError("the part FMU is not a turning part with an embedded move of poses")
    require_rotation(model)
    held = stored.model
    if (model.n_points, model.n_modes) != (held.n_points, held.n_modes) or not np.allclose(
        model.freq_hz, held.freq_hz, rtol=1e-12
    ):
        raise InputError(
            f"model: {model.n_points} points, {model.n_modes} modes; the part FMU holds "
            f"{held.n_points} points and {held.n_modes} modes of other frequencies: give the "
            "model it was exported from"
        )
    poses = turning.pose_samples
    n = max(n_steps + 1, len(poses))
    rest = np.repeat(poses[-1:], n - len(poses), axis=0)
    rest[:, 4:] = 0.0
    poses = np.vstack([poses, rest])
    acc = np.vstack([stored.acc, np.zeros((n - len(stored.acc), 3))])
    pose = PosePath(
        Rotation.from_quat(poses[:, :4], scalar_first=True).as_matrix(),
        poses[:, 4:7],
        poses[:, 7:10],
        stored.dt_s,
    )
    return Turn(pose, acc, pivot_m=turning.pivot_m, gravity_m_s2=turning.gravity_m_s2)


def turning_reference(model: ModalModel, turn: Turn, *, hold: str = "linear") -> np.ndarray:
    """(T,) m: the deviation of ``model`` (the part with its rotation data, damped as the FMU
    simulates it) at the samples of ``turn`` for ``hold`` (module docstring)."""
    if hold == "linear":
        return simulate_turning(model, turn).deviation_m
    if hold != "zero":
        raise InputError(f"hold: 'linear' or 'zero', got {hold!r}")
    pose = turn.path
    a_origin, gravity = body_loads(pose, turn.acc, turn.gravity_m_s2, turn.pivot_m)
    force = turning_forces(model, pose, a_origin, gravity)
    sag = gravity @ np.asarray(model.gamma).T / np.asarray(model.omega_rad_s) ** 2
    x0 = np.stack([sag[0], np.zeros_like(sag[0])], axis=-1)
    q = forced_states(model, force, pose.dt_s, x0=x0, hold="zero", xp=np)[..., 0]
    held = np.concatenate([[0], np.arange(len(q) - 1)])  # the sample held over the last step
    b = load_coefficients(pose.omega_rad_s, pose.alpha_rad_s2)
    coords = turning_coordinates(model, q - sag[held], a_origin[held], b[held])
    disp = point_displacements(turning_shapes(model), np.asarray(coords))
    return np.linalg.norm(disp, axis=2).max(axis=1)
