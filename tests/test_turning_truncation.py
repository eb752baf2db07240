"""Modal truncation of turning moves: a model with the 4 lowest modes and the FE's static
response to the rotational loads against the independent floating-frame integration with 12
modes and every inertial term (tests/test_turning.py's reference). 12 and 24 reference modes
agree to 3e-4 of the peak here (measured: 1.13 % and 1.10 % for the 4 modes without the
static response), so the reference stands for the full-order part within that."""

from __future__ import annotations

import numpy as np
import pytest
from floating_frame import ACC, DT, JERK, RATE, floating_frame_deviation
from scipy.spatial.transform import Rotation

import fem
import jaxflex
from jaxflex._pose import fixed_axis_path, orientation_path, turn_acceleration
from jaxflex._turning import Turn, simulate_turning


@pytest.fixture(scope="module")
def panels():
    part = fem.curved_panel(0.3, 0.2, 2e-3, "steel", 0.1, radius_x=0.6, radius_y=None)
    cups = [fem.ClampedEdge("left")]
    big = fem.modal_analysis(part, cups, n_modes=12, zeta=0.02, progress=False)
    small = fem.modal_analysis(part, cups, n_modes=4, zeta=0.02, progress=False)
    return big, big.to_modal_model(points="all"), small.to_modal_model(points="all")


@pytest.mark.slow
@pytest.mark.parametrize("scene", ["swivel", "tilt", "combined"])
def test_four_modes_with_the_static_response_match_twelve(panels, scene):
    """Swivel 90 degrees about the vertical, tilt 30 degrees about x under gravity, and the
    combined move (swivel, then tilt about the part's own x, while travelling 0.5 m): the
    4-mode model's deviation within 0.5 % of the peak of the 12-mode reference (the issue's
    target); without the rotational static response the swivel misses by 1.1 %."""
    big, reference_model, model = panels
    if scene == "combined":
        goals = [np.zeros(3), [0.0, 0.0, np.pi / 2]]
        goals.append(Rotation.from_euler("ZX", [90, 30], degrees=True).as_matrix())
        path = orientation_path(goals, RATE, ACC, JERK, DT)
        travel = jaxflex.jerk_limited_move([0.5, 0.0, 0.2], 1.0, 5.0, 50.0, DT).acc
    else:
        axis, angle = ("z", 90.0) if scene == "swivel" else ("x", 30.0)
        alpha = turn_acceleration(np.radians(angle), RATE, ACC, JERK, DT)
        path = fixed_axis_path(axis, alpha, DT)
        travel = np.zeros((2, 3))
    acc = np.zeros((path.n_steps + 1, 3))
    acc[: len(travel)] = travel
    response = simulate_turning(model, Turn(path, acc), extend_s=0.3)
    reference = floating_frame_deviation(
        big, reference_model, path.alpha_rad_s2, response.t_s[-1], full=True, acc_world=acc
    )
    peak = reference.max()
    assert np.abs(response.deviation_m - reference).max() <= 5e-3 * peak
