"""Orientation paths through given orientations (jaxflex._pose.orientation_path) against
scipy's rotations and the kinematics of rigid rotation."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from jaxflex._pose import axis_angle, orientation_path
from jaxflex.errors import InputError

DT = 1e-3
LIMITS = (3.0, 20.0, 400.0)  # rad/s, rad/s^2, rad/s^3


def _via_samples(path) -> list[int]:
    """Sample indices where the path is at rest (segment ends): rate and acceleration 0."""
    rest = np.flatnonzero(
        (np.abs(path.omega_rad_s).max(axis=1) < 1e-12)
        & (np.abs(path.alpha_rad_s2).max(axis=1) < 1e-12)
    )
    # the last sample of each run of rest samples is where the next segment starts
    return [int(k) for k in rest if k + 1 >= len(path.rotation) or k + 1 not in rest]


def test_path_reaches_every_orientation_and_moves_like_a_rigid_rotation():
    """A swivel of 90 degrees about the vertical, then a 30 degree tilt about the body's x,
    then back to the start (a turn of 95 degrees about a skew axis): each via orientation
    (scipy's, from Euler angles) is reached to 1e-12; between samples the rotation matrices
    obey R^T R' = [w]x with the path's rate, checked by a central difference (error
    dt^2 / 6 |w''| <= 1e-6 * 400 / 6 rad/s here, with |w''| at most the jerk); and each
    segment stays on its geodesic (the relative rotation keeps one axis)."""
    goals = [
        np.eye(3),
        Rotation.from_euler("z", 90, degrees=True).as_matrix(),
        Rotation.from_euler("ZX", [90, 30], degrees=True).as_matrix(),
        np.zeros(3),
    ]
    path = orientation_path(goals, *LIMITS, DT)
    ends = [0, *[k for k in _via_samples(path) if k > 0]]
    assert len(ends) == len(goals)
    for k, goal in zip(ends, goals, strict=True):
        target = goal if goal.shape == (3, 3) else np.eye(3)
        assert np.abs(path.rotation[k] - target).max() <= 1e-12
    rot = path.rotation
    derivative = np.einsum("kji,kjl->kil", rot[1:-1], (rot[2:] - rot[:-2]) / (2 * DT))
    w = path.omega_rad_s[1:-1]
    skew = np.stack(
        [derivative[:, 2, 1], derivative[:, 0, 2], derivative[:, 1, 0]], axis=1
    )  # the axial vector of R^T R'
    assert np.abs(skew - w).max() <= 1e-4  # 400 / 6 * 1e-6 = 7e-5 rad/s
    for start, end in itertools.pairwise(ends):
        relative = np.einsum("ji,kjl->kil", rot[start], rot[start + 1 : end + 1])
        vectors = Rotation.from_matrix(relative).as_rotvec()
        axis = vectors[-1] / np.linalg.norm(vectors[-1])
        assert np.abs(np.cross(vectors, axis)).max() <= 1e-12


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.floats(-1, 1), min_size=3, max_size=3).filter(lambda v: np.linalg.norm(v) > 1e-3),
    st.floats(0.0, np.pi),
)
def test_axis_angle_inverts_scipy(axis, angle):
    """axis_angle of scipy's rotation by ``angle`` about ``axis`` gives them back (the axis
    up to the sense of a half turn, where both are the same rotation): the matrix it rebuilds
    equals scipy's to 1e-9 (the half-turn branch: 1e-6 of pi away from pi, 1e-9 beyond)."""
    unit = np.asarray(axis) / np.linalg.norm(axis)
    matrix = Rotation.from_rotvec(unit * angle).as_matrix()
    got_axis, got_angle = axis_angle(matrix)
    rebuilt = Rotation.from_rotvec(got_axis * got_angle).as_matrix()
    assert np.abs(rebuilt - matrix).max() <= 1e-9
    assert got_angle == pytest.approx(angle, abs=1e-9)


@pytest.mark.parametrize(
    ("orientations", "message"),
    [
        ([np.zeros(3)], "at least two"),
        ([np.zeros(3), [np.nan, 0, 0]], r"orientations\[1\]: a rotation vector"),
        ([np.zeros(3), 2 * np.eye(3)], r"orientations\[1\]: .*orthonormal"),
        ([np.zeros(3), -np.eye(3)], r"orientations\[1\]: .*determinant \+1"),
        ([np.zeros(3), [1, 2]], r"orientations\[1\]"),
    ],
)
def test_bad_orientations_are_named(orientations, message):
    with pytest.raises(InputError, match=message):
        orientation_path(orientations, *LIMITS, DT)
