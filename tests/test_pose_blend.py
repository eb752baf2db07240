"""Blended orientation paths (jaxflex._pose_blend) against scipy.spatial.transform: the
angular velocity and acceleration against central differences of the rotations, the limits,
the vias passed without stopping; and the turning engine driven by one against the
independent floating-frame integration (tests/floating_frame.py)."""

from __future__ import annotations

import numpy as np
import pytest
from floating_frame import ACC, DT, JERK, RATE, floating_frame_deviation
from scipy.spatial.transform import Rotation

import fem
from jaxflex._pose import orientation_path
from jaxflex._pose_blend import blended_path
from jaxflex._turning import Turn, simulate_turning
from jaxflex.errors import InputError

SHARP = [np.zeros(3), [0.0, 0.0, np.pi / 2], Rotation.from_euler("ZX", [90, 30], degrees=True)]
GENTLE = [np.zeros(3), [0.0, 0.0, np.radians(60)], [0.3, 0.0, np.radians(150)]]


def _goals(goals):
    """The orientations as matrices (the rotation vectors through scipy)."""
    return [(g if isinstance(g, Rotation) else Rotation.from_rotvec(g)).as_matrix() for g in goals]


@pytest.mark.parametrize("goals", [SHARP, GENTLE], ids=["sharp", "gentle"])
def test_rates_against_scipy_rotations(goals):
    """R^T R' = [w]x: w against scipy's log of R_(k-1)^T R_(k+1) / (2 dt) (central
    difference: error dt^2 (|w''| + |w| |w'|) / 6 at most, |w''| <= jerk, |w'| <= acc; a
    factor 2 over it), alpha against the central difference of w (a jerk jump of up to 2 J
    at a corner of the grid: error <= dt J); the limits at the samples; the start, the
    goal, at rest at both ends; every via passed within one sample's turn (rate dt),
    turning there (not stopped)."""
    goals = _goals(goals)
    path = blended_path(goals, RATE, ACC, JERK, DT)
    rot = Rotation.from_matrix(path.rotation)
    central = (rot[:-2].inv() * rot[2:]).as_rotvec() / (2 * DT)
    tolerance = 2 * DT**2 * (JERK + RATE * ACC) / 6
    assert np.abs(central - path.omega_rad_s[1:-1]).max() <= tolerance
    w_central = (path.omega_rad_s[2:] - path.omega_rad_s[:-2]) / (2 * DT)
    assert np.abs(w_central - path.alpha_rad_s2[1:-1]).max() <= DT * JERK
    assert np.linalg.norm(path.omega_rad_s, axis=1).max() <= RATE * (1 + 1e-9)
    assert np.linalg.norm(path.alpha_rad_s2, axis=1).max() <= ACC * (1 + 1e-9)
    jerk = np.linalg.norm(np.diff(path.alpha_rad_s2, axis=0), axis=1) / DT
    assert jerk.max() <= JERK * (1 + 1e-9)
    assert np.abs(path.rotation[0] - goals[0]).max() <= 1e-12
    assert np.abs(path.rotation[-1] - goals[-1]).max() <= 1e-12
    ends = np.abs(path.omega_rad_s[[0, -1]]).max(), np.abs(path.alpha_rad_s2[[0, -1]]).max()
    assert max(ends) <= 1e-12
    for via in goals[1:-1]:
        off = np.linalg.norm((rot.inv() * Rotation.from_matrix(via)).as_rotvec(), axis=1)
        k = int(np.argmin(off))
        assert off[k] <= RATE * DT
        assert np.linalg.norm(path.omega_rad_s[k]) > 0.1 * RATE


def test_gentle_vias_are_faster_blended_than_stopping():
    """Through vias whose turning axis changes little the blended path is shorter than the
    path that stops at each via (measured 1.094 s against 1.283 s); three 45 degree steps
    about one axis take about the time of one 135 degree turn."""
    blended = blended_path(_goals(GENTLE), RATE, ACC, JERK, DT)
    stopping = orientation_path(_goals(GENTLE), RATE, ACC, JERK, DT)
    assert blended.n_steps < stopping.n_steps
    steps = [np.zeros(3)] + [[0.0, 0.0, np.radians(a)] for a in (45, 90, 135)]
    single = orientation_path([steps[0], steps[-1]], RATE, ACC, JERK, DT)
    assert blended_path(steps, RATE, ACC, JERK, DT).n_steps <= single.n_steps + 2


def test_blended_path_refusals():
    with pytest.raises(InputError, match="half turn"):
        blended_path([np.zeros(3), [0.0, 0.0, np.pi]], RATE, ACC, JERK, DT)
    with pytest.raises(InputError, match="the same"):
        blended_path([np.zeros(3), [0.0, 0.0, 1.0], [0.0, 0.0, 1.0]], RATE, ACC, JERK, DT)
    with pytest.raises(InputError, match="at least two"):
        blended_path([np.zeros(3)], RATE, ACC, JERK, DT)


@pytest.mark.slow
def test_blended_turn_against_the_floating_frame_reference():
    """The gentle blended path on the clamped curved cantilever of tests/test_turning.py
    (4 modes) under gravity, 0.3 s of free decay: the engine within 1e-4 of the peak of the
    reference with the kept terms (the sampled forcing's hold; the reference integrates the
    orientation from the same alpha samples, linear between them, an O(dt^2) difference),
    within 0.5 % with every term, and the bound covers the neglected terms' effect."""
    part = fem.curved_panel(0.3, 0.2, 2e-3, "steel", 0.1, radius_x=0.6, radius_y=None)
    result = fem.modal_analysis(part, [fem.ClampedEdge("left")], n_modes=4, zeta=0.02)
    model = result.to_modal_model(points="all")._replace(static_shapes=None)
    path = blended_path(_goals(GENTLE), RATE, ACC, JERK, DT)
    response = simulate_turning(model, Turn(path, np.zeros((path.n_steps + 1, 3))), extend_s=0.3)
    args = (result, model, path.alpha_rad_s2, response.t_s[-1])
    full = floating_frame_deviation(*args, full=True)
    kept = floating_frame_deviation(*args, full=False)
    peak = full.max()
    assert np.abs(response.deviation_m - kept).max() <= 1e-4 * peak
    assert np.abs(response.deviation_m - full).max() <= 5e-3 * peak
    assert np.abs(full - kept).max() <= response.neglected_bound_m + 1e-6 * peak
