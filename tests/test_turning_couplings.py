"""The couplings of the deformation (jaxflex._rotation: G_k = phi^T M X_k phi, P_kl =
phi^T M X_k X_l phi) against operators built here from the node coordinates and the mass
matrix, their closed form on a Kirchhoff plate, and their path through the model file,
truncation and a change of frame (the bound on the neglected terms does not depend on it)."""

from __future__ import annotations

import numpy as np
import pytest
from floating_frame import ACC, DT, JERK, RATE, skew
from scipy.spatial.transform import Rotation

import fem
import jaxflex
from jaxflex._pose import fixed_axis_path, turn_acceleration
from jaxflex._turning import Turn, simulate_turning


@pytest.fixture(scope="module")
def solid():
    part = fem.curved_panel(0.3, 0.2, 2e-3, "steel", 0.1, radius_x=0.6, radius_y=None)
    return fem.modal_analysis(part, [fem.ClampedEdge("left")], n_modes=5, zeta=0.02)


def test_thin_solid_couplings_against_node_operators(solid):
    """phi^T M (I_N (x) [e_k]x) phi and its square from the FE's mass matrix and modes: the
    stored couplings to round-off (1e-10 of the largest: sums of the same products), G_k
    skew (the consistent mass commutes with the per-node cross product)."""
    rotation = solid.to_modal_model(points=10).rotation
    phi = solid.basis @ solid.vectors
    n_nodes = phi.shape[0] // 3
    cross = [np.kron(np.eye(n_nodes), skew(e)) for e in np.eye(3)]
    gyro = np.stack([phi.T @ solid.system.M @ x @ phi for x in cross])
    spin = np.stack([[phi.T @ solid.system.M @ a @ b @ phi for b in cross] for a in cross])
    assert np.abs(rotation.gyroscopic - gyro).max() <= 1e-10 * np.abs(gyro).max()
    assert np.abs(rotation.spin - spin).max() <= 1e-10 * np.abs(spin).max()
    assert np.abs(gyro + gyro.transpose(0, 2, 1)).max() <= 1e-10 * np.abs(gyro).max()
    # the sum over k of e_k x (e_k x u) is -2 u: P_kk sums to -2 phi^T M phi = -2 I
    assert np.abs(np.einsum("kkmn->mn", spin) + 2 * np.eye(5)).max() <= 1e-9


def test_plate_couplings_closed_form():
    """A Kirchhoff plate's deflection turned about any axis lies in its plane (G = 0), and
    e_k x (e_l x w e_z) has the z part (d_kz d_lz - d_kl) w: P_kl = that times the identity
    for mass-normalised modes (no rotary inertia), to the eigen solver's orthonormality."""
    part = fem.rectangular_plate(0.6, 0.4, 1e-3, "steel", 0.1)
    cups = [fem.SuctionCup(x, y, 0.03) for x in (0.15, 0.45) for y in (0.1, 0.3)]
    rotation = fem.modal_analysis(part, cups, n_modes=4, zeta=0.02).to_modal_model().rotation
    assert not np.any(rotation.gyroscopic)
    expected = np.einsum("kl,mn->klmn", np.diag([-1.0, -1.0, 0.0]), np.eye(4))
    assert np.abs(rotation.spin - expected).max() <= 1e-9


def test_couplings_through_file_truncation_and_frame(solid, tmp_path):
    """The couplings survive the model file, truncation keeps the kept modes' block, and a
    model posed in another frame reports the same bound for the same physical turn (the
    couplings turn with the axes; the neglected load does not depend on the frame)."""
    model = solid.to_modal_model(points="all")._replace(static_shapes=None)
    model.save(tmp_path / "m.npz")
    again = jaxflex.load_model(tmp_path / "m.npz")
    assert np.array_equal(again.rotation.spin, model.rotation.spin)
    assert np.array_equal(again.rotation.gyroscopic, model.rotation.gyroscopic)
    three = again.truncate_modes(3).rotation
    assert np.array_equal(three.gyroscopic, model.rotation.gyroscopic[:, :3, :3])
    assert np.array_equal(three.spin, model.rotation.spin[:, :, :3, :3])
    rot = Rotation.from_rotvec([0.3, -0.2, 0.5]).as_matrix()
    offset = np.array([0.2, -0.1, 0.3])
    posed = model.posed(rot, offset)
    alpha = turn_acceleration(np.radians(40), RATE, ACC, JERK, DT)
    axis = np.array([0.2, 0.5, 1.0]) / np.linalg.norm([0.2, 0.5, 1.0])
    acc = np.zeros((len(alpha), 3))
    here = simulate_turning(
        model, Turn(fixed_axis_path(axis, alpha, DT), acc, gravity_m_s2=(0, 0, 0))
    )
    there = simulate_turning(  # the same axis through the model's origin, now at offset
        posed,
        Turn(
            fixed_axis_path(rot @ axis, alpha, DT, start=rot.T),
            acc,
            pivot_m=offset,
            gravity_m_s2=(0, 0, 0),
        ),
    )
    assert here.neglected_bound_m > 0
    assert there.neglected_bound_m == pytest.approx(here.neglected_bound_m, rel=1e-9)
