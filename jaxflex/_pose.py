"""Orientation paths of the gripper: rotation, angular velocity and acceleration at the samples.

A :class:`PosePath` gives, at t_k = k dt_s (k = 0..n), the rotation R_k (3, 3) that takes
body (gripper = model frame) components to world components, and the angular velocity w_k
(rad/s) and angular acceleration alpha_k (rad/s^2) in body components. The translation of
the move stays the acceleration samples of jaxflex._profile (world components).

:func:`fixed_axis_path` turns about one axis fixed in the body (and in the world: the axis
is carried along unchanged) with a piecewise-linear angular acceleration, the same sampling
as the translation's: the angle and the rate are then exact (piecewise cubic and
quadratic, jaxflex._profile.integrate). :func:`turn_acceleration` gives the jerk-limited,
time-optimal-on-the-grid angular acceleration of a turn by an angle.
:func:`orientation_path` goes through a sequence of orientations (rotation vectors or
matrices, e.g. a robot's tool orientations at via points), each segment the shortest turn
(the geodesic: a fixed axis) from rest to rest, jerk-limited: exact like a single turn.
"""

from __future__ import annotations

from dataclasses import dataclass

import jax
import numpy as np

from jaxflex._profile import integrate, jerk_limited_move
from jaxflex._scalars import check_positive
from jaxflex.errors import InputError


@jax.tree_util.register_pytree_node_class
@dataclass(frozen=True)
class PosePath:
    """Orientation at the samples (module docstring): ``rotation`` (n+1, 3, 3) body to world,
    ``omega_rad_s`` and ``alpha_rad_s2`` (n+1, 3) in body components, step ``dt_s`` s."""

    rotation: np.ndarray
    omega_rad_s: np.ndarray
    alpha_rad_s2: np.ndarray
    dt_s: float

    def tree_flatten(self):
        return (self.rotation, self.omega_rad_s, self.alpha_rad_s2), self.dt_s

    @classmethod
    def tree_unflatten(cls, dt_s, children):
        return cls(*children, dt_s)

    @property
    def n_steps(self) -> int:
        return int(self.rotation.shape[0]) - 1

    @property
    def turns(self) -> bool:
        """Whether the part turns at all (some angular velocity or acceleration)."""
        return bool(np.any(self.omega_rad_s) or np.any(self.alpha_rad_s2))


def axis_rotation(axis: np.ndarray, angle_rad) -> np.ndarray:
    """(T, 3, 3) rotations by ``angle_rad`` (T,) about the unit ``axis`` (3,) (Rodrigues)."""
    k = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    s, c = np.sin(angle_rad)[:, None, None], np.cos(angle_rad)[:, None, None]
    return np.eye(3) + s * k + (1.0 - c) * (k @ k)


def unit_axis(axis) -> np.ndarray:
    """``axis`` (3,) or "x", "y", "z" as a unit vector; InputError otherwise."""
    if isinstance(axis, str):
        if axis not in ("x", "y", "z"):
            raise InputError(f"axis: 'x', 'y', 'z' or three numbers, got {axis!r}")
        return np.eye(3)["xyz".index(axis)]
    arr = np.asarray(axis, dtype=np.float64).reshape(-1)
    norm = float(np.linalg.norm(arr)) if arr.shape == (3,) else 0.0
    if not (np.isfinite(arr).all() and norm > 0):
        raise InputError(f"axis: three finite numbers, not all zero, got {axis!r}")
    return arr / norm


def fixed_axis_path(axis, angular_acc_rad_s2, dt_s: float, *, start=None) -> PosePath:
    """The turn about ``axis`` (body components, or "x"/"y"/"z") with angular acceleration
    samples ``angular_acc_rad_s2`` (n+1,) rad/s^2 (linear in between, from rest), starting
    at orientation ``start`` ((3, 3) body to world, default identity)."""
    dt_s = check_positive("dt_s", dt_s)
    n_axis = unit_axis(axis)
    alpha = np.asarray(angular_acc_rad_s2, dtype=np.float64).reshape(-1)
    if alpha.size < 2 or not np.isfinite(alpha).all():
        raise InputError("angular_acc_rad_s2: at least two finite samples (rad/s^2)")
    padded = np.zeros((alpha.size, 3))
    padded[:, 0] = alpha
    rate, angle = (v[:, 0] for v in integrate(padded, dt_s))
    r0 = np.eye(3) if start is None else np.asarray(start, dtype=np.float64)
    if r0.shape != (3, 3) or not np.allclose(r0 @ r0.T, np.eye(3), atol=1e-9):
        raise InputError("start: a 3 x 3 rotation matrix (body to world)")
    rotation = r0[None] @ axis_rotation(n_axis, angle)
    return PosePath(rotation, np.outer(rate, n_axis), np.outer(alpha, n_axis), dt_s)


def turn_acceleration(
    angle_rad: float, rate_rad_s: float, acc_rad_s2: float, jerk_rad_s3: float, dt_s: float
) -> np.ndarray:
    """(n+1,) angular acceleration samples (rad/s^2) of the shortest jerk-limited turn by
    ``angle_rad`` within the rate, acceleration and jerk limits, corners on the dt grid
    (jaxflex._profile.jerk_limited_move along one axis)."""
    limits = [check_positive(n, v) for n, v in (("rate", rate_rad_s), ("acc", acc_rad_s2))]
    jerk = check_positive("jerk", jerk_rad_s3)
    return jerk_limited_move([float(angle_rad), 0.0, 0.0], *limits, jerk, dt_s).acc[:, 0]


def as_rotation(value, name: str) -> np.ndarray:
    """``value`` as a (3, 3) rotation matrix (body to world): a rotation vector (3,) in rad
    (axis times angle) or a (3, 3) matrix; InputError naming ``name`` otherwise."""
    arr = np.asarray(value, dtype=np.float64)
    if arr.shape == (3,) and np.isfinite(arr).all():
        angle = float(np.linalg.norm(arr))
        return axis_rotation(arr / angle, np.array([angle]))[0] if angle > 0 else np.eye(3)
    finite = arr.shape == (3, 3) and np.isfinite(arr).all()
    if finite and np.allclose(arr @ arr.T, np.eye(3), atol=1e-9) and np.linalg.det(arr) > 0:
        return arr
    raise InputError(
        f"{name}: a rotation vector (three finite numbers, rad) or a 3 x 3 rotation matrix "
        f"(orthonormal, determinant +1), got {np.array2string(arr.reshape(-1)[:9])}"
    )


def axis_angle(rotation: np.ndarray) -> tuple[np.ndarray, float]:
    """(unit axis (3,), angle in [0, pi] rad) of a rotation matrix; axis z for no turn."""
    skew = np.array([rotation[2, 1] - rotation[1, 2], rotation[0, 2] - rotation[2, 0],
                     rotation[1, 0] - rotation[0, 1]])  # fmt: skip
    # 2 sin(angle) a and 2 cos(angle): atan2 keeps small angles exact (arccos of the trace
    # alone loses half the digits near 0)
    angle = float(np.arctan2(0.5 * np.linalg.norm(skew), 0.5 * (np.trace(rotation) - 1.0)))
    if angle < 1e-12:
        return np.array([0.0, 0.0, 1.0]), 0.0
    if np.pi - angle > 1e-6:
        return skew / np.linalg.norm(skew), angle  # well scaled short of pi
    # a half turn: R = 2 a a^T - I, the axis from the largest diagonal entry
    outer = 0.5 * (rotation + np.eye(3))
    k = int(np.argmax(np.diag(outer)))
    axis = outer[:, k] / np.sqrt(outer[k, k])
    return (-axis if axis @ skew < 0 else axis), angle  # the sense of a turn just short of pi


def orientation_path(
    orientations, rate_rad_s: float, acc_rad_s2: float, jerk_rad_s3: float, dt_s: float
) -> PosePath:
    """The path through ``orientations`` (a sequence of at least two rotation vectors (3,)
    rad or (3, 3) matrices, body to world; the first is the start) segment by segment: each
    the shortest turn (a fixed axis in the body) from rest to rest, jerk-limited within the
    rate, acceleration and jerk limits (:func:`turn_acceleration`), corners on the dt grid.
    A segment starts where the previous one ended (no jump)."""
    poses = [as_rotation(o, f"orientations[{i}]") for i, o in enumerate(orientations)]
    if len(poses) < 2:
        raise InputError("orientations: at least two (a start and a goal)")
    pieces: list[PosePath] = []
    current = poses[0]
    for goal in poses[1:]:
        axis, angle = axis_angle(current.T @ goal)
        alpha = turn_acceleration(angle, rate_rad_s, acc_rad_s2, jerk_rad_s3, dt_s)
        piece = fixed_axis_path(axis, alpha, dt_s, start=current)
        pieces.append(piece)
        current = piece.rotation[-1]
    return joined_paths(pieces)


def joined_paths(pieces: list[PosePath]) -> PosePath:
    """One path of ``pieces`` (same step) run one after the other, each starting at the
    sample where the previous one ends (that sample taken once, from the earlier piece)."""
    first, rest = pieces[0], pieces[1:]
    return PosePath(
        np.concatenate([first.rotation, *(p.rotation[1:] for p in rest)]),
        np.concatenate([first.omega_rad_s, *(p.omega_rad_s[1:] for p in rest)]),
        np.concatenate([first.alpha_rad_s2, *(p.alpha_rad_s2[1:] for p in rest)]),
        float(first.dt_s),
    )
