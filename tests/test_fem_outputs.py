"""Cup reactions and surface stresses from the FE model (fem.outputs) and compliant cups."""

from __future__ import annotations

import numpy as np
import pytest
from closed_forms import ss_plate_stress_error

import fem
import jaxflex
from fem.outputs import reaction_outputs, stress_outputs
from jaxflex import as_move
from jaxflex._deviation import outputs_at

DT = 0.01


def _cups(stiffness=None, radius=0.03):
    return [
        fem.SuctionCup(x, y, radius, stiffness=stiffness) for x in (0.15, 0.45) for y in (0.1, 0.3)
    ]


def _sine_move(n_steps: int = 20) -> np.ndarray:
    t = np.arange(n_steps + 1) * DT
    shape = np.sin(2 * np.pi * t / (n_steps * DT))
    acc = np.outer(shape, [10.0, -5.0, 20.0])
    acc[[0, -1]] = 0.0
    return acc


def von_mises(voigt: np.ndarray) -> np.ndarray:
    """von Mises stress of Voigt rows (..., 6)."""
    sx, sy, sz, syz, sxz, sxy = np.moveaxis(voigt, -1, 0)
    return np.sqrt(
        0.5 * ((sx - sy) ** 2 + (sy - sz) ** 2 + (sz - sx) ** 2) + 3 * (syz**2 + sxz**2 + sxy**2)
    )


@pytest.fixture(scope="module", params=[None, "flat", "bellows"])
def plate_result(request):
    part = fem.rectangular_plate(0.6, 0.4, 1e-3, "steel", 0.025)
    return fem.modal_analysis(part, _cups(request.param), n_modes=12, zeta=0.02)


def test_reactions_add_up_to_the_part_mass(plate_result):
    """Summed over the cups: A = m I - sum Gamma Gamma^T and Q = -Omega^2 Gamma (module
    docstring of fem.outputs: the reactions equal m a + sum_i Gamma_i q_i''), exact up to
    the round-off of the sparse solves (1e-9 relative)."""
    result = plate_result
    model = result.to_modal_model(points=20)
    cups = model.cups
    a_sum = np.asarray(cups.reaction.a_map).reshape(cups.n_cups, 6, 3).sum(axis=0)[:3]
    gamma = np.asarray(model.gamma)
    expected = result.mass_kg * np.eye(3) - gamma.T @ gamma
    np.testing.assert_allclose(a_sum, expected, atol=1e-9 * result.mass_kg)
    q_sum = np.asarray(cups.reaction.q_map).reshape(cups.n_cups, 6, -1).sum(axis=0)[:3]
    expected_q = -((2 * np.pi * np.asarray(model.freq_hz)) ** 2) * gamma.T
    np.testing.assert_allclose(q_sum, expected_q, atol=1e-9 * np.abs(expected_q).max())
    # the same identity over a move, at the samples: sum F = m a + sum_i Gamma_i q_i''
    acc = _sine_move()
    t = DT * np.arange(acc.shape[0])
    forces = outputs_at(model, cups.reaction, as_move(acc, DT), t).reshape(len(t), -1, 6)[..., :3]
    states = jaxflex._engine.states_at(model, as_move(acc, DT), t)
    omega, zeta = np.asarray(model.omega_rad_s), np.asarray(model.zeta)
    qdd = -acc @ gamma.T - 2 * zeta * omega * states[..., 1] - omega**2 * states[..., 0]
    np.testing.assert_allclose(
        forces.sum(axis=1), result.mass_kg * acc + qdd @ gamma, atol=1e-8 * result.mass_kg * 20
    )


def test_a_stiff_part_loads_its_cups_with_m_a():
    """A part 10^6 times stiffer (modes 1000x higher) moved slowly is a rigid part: its cups
    carry m a (plate, thin solid and shell). The dynamic share is (f_move / f_1)^2 ~ 1e-9 of it."""
    steel = fem.materials.PRESETS["steel"]
    stiff = fem.Material("stiff steel", steel.E_pa * 1e6, steel.nu, steel.rho_kg_m3)
    for part in (
        fem.rectangular_plate(0.6, 0.4, 1e-3, stiff, 0.05),
        fem.curved_panel(0.6, 0.4, 1e-3, stiff, 0.1),
        fem.curved_panel(0.6, 0.4, 1e-3, stiff, 0.05, element="shell"),
    ):
        result = fem.modal_analysis(part, _cups(), n_modes=6, zeta=0.02)
        model = result.to_modal_model(points=10)
        acc = _sine_move()
        t = np.linspace(0, 0.3, 61)
        forces = outputs_at(model, model.cups.reaction, as_move(acc, DT), t).reshape(len(t), 4, 6)
        expected = result.mass_kg * jaxflex._profile.acceleration_at(as_move(acc, DT), t)
        np.testing.assert_allclose(forces[..., :3].sum(axis=1), expected, atol=1e-6 * 20)


def test_reactions_and_stress_match_the_full_order_transient():
    """Cup reactions from the modal model equal the full-order FE transient's reaction forces
    to 1 % of the peak; the von Mises peak agrees to 2 % (the issue's targets). Measured:
    ~3e-3 of the peak with 10 modes, ~1e-4 with 40 (the quasi-static share is exact, so the
    truncation error is that of the dynamic correction); Newmark's period error at h = 1e-4 s
    is ~4e-4 (omega h <= 0.07 up to the 10th mode)."""
    part = fem.rectangular_plate(0.6, 0.4, 1e-3, "steel", 0.025)
    damping = fem.Rayleigh.from_zeta(0.02, 40.0, 400.0)
    result = fem.modal_analysis(part, _cups(), n_modes=20, zeta=damping)
    model = result.to_modal_model(points=30)
    acc = _sine_move(20)
    full = fem.transient_reference(
        result,
        jaxflex.as_move(acc, DT),
        points=model.points,
        extend_s=0.1,
        substeps=100,
        output_substeps=4,
        outputs={"cups": reaction_outputs(result), "stress": stress_outputs(result)[1]},
    )
    ours = outputs_at(model, model.cups.reaction, as_move(acc, DT), full.t_s)
    ref = full.outputs["cups"]
    for rows in (slice(0, 3), slice(3, 6)):  # forces, moments
        a = ours.reshape(len(full.t_s), 4, 6)[..., rows]
        b = ref.reshape(len(full.t_s), 4, 6)[..., rows]
        assert np.abs(a - b).max() <= 0.01 * np.abs(b).max()
    vm_ours = von_mises(
        outputs_at(model, model.stress.stress, as_move(acc, DT), full.t_s).reshape(-1, 6)
    )
    vm_ref = von_mises(full.outputs["stress"].reshape(-1, 6))
    assert abs(vm_ours.max() / vm_ref.max() - 1) <= 0.02


def test_modal_stress_of_the_simply_supported_plate():
    """Argyris (quintic) is exact to ~1e-4 at 50 mm (tolerance 1e-3). Morley's curvature is
    constant per element, so its centroid value is off by about |grad sigma| h / 3: first
    order, ~7 % of the peak at 12.5 mm on the fourth mode (measured 6.6 %; 13.6 % at 25 mm,
    3.3 % at 6.25 mm), halving with h."""
    assert ss_plate_stress_error("argyris", 0.05) <= 1e-3
    coarse, fine = ss_plate_stress_error("morley", 0.025), ss_plate_stress_error("morley", 0.0125)
    assert fine <= 0.08
    assert 1.6 <= coarse / fine <= 2.5  # first order


def test_compliant_cups_rigid_plate_on_springs():
    """A plate 10^6 times stiffer on four soft cups is a rigid body on springs: bounce
    sqrt(4 k_a / m), pitch and roll sqrt((sum k_a d_i^2 + 4 k_tilt) / I) with I = m L^2/12
    about the centre line (closed form; the plate's own modes are 1000x higher)."""
    steel = fem.materials.PRESETS["steel"]
    stiff = fem.Material("stiff steel", steel.E_pa * 1e6, steel.nu, steel.rho_kg_m3)
    k = fem.cups.CupStiffness(5e3, 1e5, 20.0, 30.0)
    part = fem.rectangular_plate(0.6, 0.4, 1e-3, stiff, 0.025)
    result = fem.modal_analysis(part, _cups(k), n_modes=3, zeta=0.02)
    m = result.mass_kg
    bounce = np.sqrt(4 * k.axial_n_m / m)
    roll = np.sqrt((4 * k.axial_n_m * 0.1**2 + 4 * k.tilt_nm_rad) / (m * 0.4**2 / 12))
    pitch = np.sqrt((4 * k.axial_n_m * 0.15**2 + 4 * k.tilt_nm_rad) / (m * 0.6**2 / 12))
    expected = np.sort([bounce, roll, pitch]) / (2 * np.pi)
    np.testing.assert_allclose(result.freq_hz, expected, rtol=1e-5)


def test_stiff_springs_recover_the_clamp():
    """Cups whose springs are 10^6 x stiffer than the flat preset behave like the rigid
    clamp (the pad then moves ~1e-6 of the plate's deflection)."""
    part = fem.rectangular_plate(0.6, 0.4, 1e-3, "steel", 0.025)
    flat = fem.cups.CupStiffness.flat(0.03)
    k = fem.cups.CupStiffness(
        flat.axial_n_m * 1e6, flat.lateral_n_m, flat.tilt_nm_rad * 1e6, flat.torsion_nm_rad
    )
    rigid = fem.modal_analysis(part, _cups(), n_modes=6, zeta=0.02)
    springs = fem.modal_analysis(part, _cups(k), n_modes=6, zeta=0.02)
    np.testing.assert_allclose(springs.freq_hz, rigid.freq_hz, rtol=1e-4)


def test_cup_presets_are_softer_for_bellows():
    flat, bellows = fem.cups.CupStiffness.flat(0.04), fem.cups.CupStiffness.bellows(0.04)
    assert bellows.axial_n_m < flat.axial_n_m / 100
    assert bellows.tilt_nm_rad < flat.tilt_nm_rad
    # Gent's relation: 60 Shore A is about 3.6 MPa
    assert fem.cups.shore_a_modulus_pa(60) == pytest.approx(3.605e6, rel=1e-3)
    with pytest.raises(jaxflex.InputError, match="stiffness"):
        fem.SuctionCup(0.1, 0.1, 0.03, stiffness="foam")
    with pytest.raises(jaxflex.InputError, match=r"stiffness\.axial_n_m"):
        fem.SuctionCup(0.1, 0.1, 0.03, stiffness=(0, 1, 1, 1))


def test_cup_rating_in_the_model():
    part = fem.rectangular_plate(0.6, 0.4, 1e-3, "steel", 0.025)
    cups = [
        fem.SuctionCup(x, y, 0.03, vacuum_pa=50e3, friction=0.3)
        for x in (0.15, 0.45)
        for y in (0.1, 0.3)
    ]
    model = fem.modal_analysis(part, cups, n_modes=4, zeta=0.02).to_modal_model(points=10)
    np.testing.assert_allclose(model.cups.holding_force_n, 50e3 * np.pi * 0.03**2)
    np.testing.assert_allclose(model.cups.friction, 0.3)
    np.testing.assert_allclose(model.cups.normal, np.tile([0.0, 0.0, 1.0], (4, 1)))
    np.testing.assert_allclose(
        np.asarray(model.cups.centre_m)[:, :2], [[0.15, 0.1], [0.15, 0.3], [0.45, 0.1], [0.45, 0.3]]
    )
