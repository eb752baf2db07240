"""Participation factors, effective mass, residual check, the ModalModel and damping."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
import scipy.sparse.linalg
from hypothesis import given, settings
from hypothesis import strategies as st

import fem
import jaxflex

STEEL = fem.PRESETS["steel"]


def test_free_plate_participation_sums_to_its_mass():
    # full eigen decomposition of a free Kirchhoff plate: sum over all modes (3 rigid + all
    # elastic) of Gamma_z^2 = R^T M R = rho h A exactly (the constant is in the FE space)
    part = fem.rectangular_plate(0.3, 0.2, mesh_size=0.02)
    result = fem.modal_analysis(part, [], "all", allow_rigid_modes=True)
    assert result.rigid_freq_hz.size == 3
    mass = STEEL.rho_kg_m3 * 1e-3 * 0.3 * 0.2
    total = np.sum(result.gamma[:, 2] ** 2) + np.sum(result.rigid_gamma[:, 2] ** 2)
    assert total == pytest.approx(mass, rel=1e-9)
    assert result.mass_kg == pytest.approx(mass, rel=1e-12)


def test_free_thin_solid_participation_sums_to_its_mass_per_direction():
    # 6 rigid modes; sum of Gamma_d^2 over all modes = rho V along x, y and z
    part = fem.rectangular_plate(0.1, 0.08, 2e-3, element="hex2", mesh_size=0.04)
    result = fem.modal_analysis(part, [], "all", allow_rigid_modes=True)
    assert result.rigid_freq_hz.size == 6
    mass = STEEL.rho_kg_m3 * 2e-3 * 0.1 * 0.08
    totals = np.sum(result.gamma**2, axis=0) + np.sum(result.rigid_gamma**2, axis=0)
    np.testing.assert_allclose(totals, mass, rtol=1e-7)  # thin-solid conditioning, see solid


def test_held_plate_participation_sums_to_mobile_mass_and_residual_is_consistent():
    part = fem.rectangular_plate(0.3, 0.2, mesh_size=0.03)
    cups = fem.default_gripper(0.3, 0.2, 0.03)
    # the cups' rings coarser than the default (r / 2): a dense solve is limited to 6000 DOFs
    part = replace(part, cup_fine_fraction=0.5)
    full = fem.modal_analysis(part, cups, "all")
    # sum over all modes of Gamma^2 equals b^T M_ff^-1 b (the residual check's sparse solve)
    assert np.sum(full.gamma[:, 2] ** 2) == pytest.approx(full.mobile_mass_kg[2], rel=1e-9)
    assert full.residual_fraction[2] == pytest.approx(0.0, abs=1e-9)
    assert full.static_residual_fraction[2] == pytest.approx(0.0, abs=1e-9)
    # the mobile mass is the part's mass less (at most) the mass over the cups
    held_upper = 4 * STEEL.rho_kg_m3 * 1e-3 * np.pi * (0.03 + 0.01) ** 2
    assert full.mass_kg - held_upper < full.mobile_mass_kg[2] < full.mass_kg
    # truncation: 10 modes carry the same Gamma as the first 10 of the full set (up to sign)
    # and the residual fraction is what the other modes carry
    part10 = fem.modal_analysis(part, cups, 10)
    np.testing.assert_allclose(part10.freq_hz, full.freq_hz[:10], rtol=1e-8)
    np.testing.assert_allclose(np.abs(part10.gamma), np.abs(full.gamma[:10]), atol=1e-6)
    rest = np.sum(full.gamma[10:, 2] ** 2) / full.mobile_mass_kg[2]
    assert part10.residual_fraction[2] == pytest.approx(rest, rel=1e-6)
    assert np.isnan(part10.effective_mass_fraction[:, :2]).all()  # a plate has no x, y DOFs


def test_modal_model_from_analysis():
    part = fem.rectangular_plate(0.6, 0.4, mesh_size=0.02)
    cups = fem.default_gripper(0.6, 0.4, 0.03)
    result = fem.modal_analysis(part, cups, 8, zeta=0.03)
    model = result.to_modal_model(points=150)
    assert isinstance(model, jaxflex.ModalModel)
    assert 135 <= model.n_points <= 165 and model.n_modes == 8
    np.testing.assert_allclose(model.zeta, 0.03)
    np.testing.assert_allclose(model.freq_hz, result.freq_hz)
    meta = model.meta
    assert meta["units"].startswith("SI")
    assert meta["material"]["E_pa"] == STEEL.E_pa
    assert len(meta["gripper"]) == 4 and meta["gripper"][0]["type"] == "suction_cup"
    assert meta["mesh"]["n_dof"] == result.system.n_dof
    assert "Morley" in meta["formulation"]
    assert len(meta["effective_mass"]["fraction_per_mode"]) == 8
    # every node, and given key points with labels
    assert result.to_modal_model().n_points == len(result.system.nodes)
    keys = [[0.3, 0.2], [0.05, 0.05]]
    named = result.to_modal_model(points=keys, labels=["centre", "corner"])
    assert named.labels == ("centre", "corner")
    np.testing.assert_allclose(named.points[:, :2], keys, atol=0.02)
    # a voxel-reduced set always keeps the key points (snapped to the nearest node)
    reduced = result.to_modal_model(points=40, key_points=keys)
    for key in named.points:
        assert np.min(np.linalg.norm(reduced.points - key, axis=1)) == 0.0
    # mass normalisation at the nodes: the shapes come from M-orthonormal vectors
    phi = result.vectors
    np.testing.assert_allclose(phi.T @ (result.M_free @ phi), np.eye(8), atol=1e-9)
    # static response to 1 m/s^2 along z: modal sum vs a direct solve (residual check; scipy's
    # sparse LU: the dense LU of these 12 385 DOFs, equal to 2e-12, took 31 s of CPU)
    static = -scipy.sparse.linalg.spsolve(result.K_free.tocsc(), result.load[:, 2])
    modal = -(phi * (result.gamma[:, 2] / (2 * np.pi * result.freq_hz) ** 2)) @ np.ones(8)
    missing = 1 - (modal @ (result.K_free @ modal)) / (static @ (result.K_free @ static))
    assert missing == pytest.approx(result.static_residual_fraction[2], abs=0.02)


def test_frequency_limit_and_save_roundtrip(tmp_path):
    part = fem.rectangular_plate(0.6, 0.4, mesh_size=0.03)
    cups = fem.default_gripper(0.6, 0.4, 0.03)
    limited = fem.modal_analysis(part, cups, None, max_freq_hz=150.0)
    counted = fem.modal_analysis(part, cups, 30)
    expected = counted.freq_hz[counted.freq_hz <= 150.0]
    assert 0 < expected.size < 30
    np.testing.assert_allclose(limited.freq_hz, expected, rtol=1e-9)
    model = limited.to_modal_model(points=50)
    model.save(tmp_path / "m.npz")
    again = jaxflex.load_model(tmp_path / "m.npz")
    np.testing.assert_allclose(again.shapes, model.shapes)
    assert again.meta["gripper"] == model.meta["gripper"]


def test_rigid_modes_when_explicitly_allowed():
    # two cups: the plate can rotate about the line through them (a near-rigid mode is
    # prevented by the discs' clamp, so a point-supported plate shows true rigid modes)
    part = fem.rectangular_plate(0.6, 0.4, mesh_size=0.03)
    points = [fem.PointSupport(0.1, 0.2), fem.PointSupport(0.5, 0.2)]
    result = fem.modal_analysis(part, points, 5, allow_rigid_modes=True)
    assert result.rigid_freq_hz.size == 1  # rotation about the line through the points
    assert result.n_modes == 5 and result.freq_hz[0] > 1.0
    model = result.to_modal_model(points=40)
    assert model.meta["rigid_modes"]["count"] == 1


def test_rayleigh_damping_helpers():
    damping = fem.Rayleigh.from_zeta(0.02, 10.0, 100.0)
    np.testing.assert_allclose(damping.zeta([10.0, 100.0]), 0.02, rtol=1e-12)
    assert damping.zeta(np.sqrt(10.0 * 100.0)) < 0.02  # lower in between
    omega = 2 * np.pi * 25.0
    expected = damping.alpha_per_s / (2 * omega) + damping.beta_s * omega / 2
    assert damping.zeta(25.0) == pytest.approx(expected)


@settings(max_examples=30, deadline=None)
@given(
    st.floats(1e-3, 0.2),
    st.floats(0.5, 50.0),
    st.floats(1.1, 100.0),
    st.floats(0.1, 10.0),
)
def test_rayleigh_from_zeta_property(zeta, f1, ratio, f_probe_scale):
    damping = fem.Rayleigh.from_zeta(zeta, f1, f1 * ratio)
    np.testing.assert_allclose(damping.zeta([f1, f1 * ratio]), zeta, rtol=1e-9)
    probe = f1 * f_probe_scale
    inside = f1 <= probe <= f1 * ratio
    assert (damping.zeta(probe) <= zeta * (1 + 1e-9)) == inside or np.isclose(
        damping.zeta(probe), zeta
    )


def test_same_matrices_give_the_same_modes_to_the_last_bit():
    """The eigen solve starts from a fixed vector: two analyses of one layout agree bit for
    bit (ARPACK's own random start made the frequencies, and every cycle time and deviation
    a sweep computes from them, differ between runs by ~1e-15 relative)."""
    part = fem.rectangular_plate(0.6, 0.4, mesh_size=0.05)
    cups = fem.default_gripper(0.6, 0.4, 0.03)
    first, second = (fem.modal_analysis(part, cups, 6, progress=False) for _ in range(2))
    assert first.freq_hz.tobytes() == second.freq_hz.tobytes()
    assert first.vectors.tobytes() == second.vectors.tobytes()
