"""The exact static response in the model: gravity in every load (issue: certified for the part).

A part hangs at rest in gravity before the move. Its cups then carry its weight, its points
sag and its stresses are those of a static FE solve under gravity, whatever modes the model
keeps: the model stores the FE's static response per unit base acceleration (fem.outputs,
jaxflex.model), and gravity's share comes from it. Checked against Newton's laws (the cups
carry m g, and m (a - g) during a move of a stiff part) and against a static FE solve written
independently (tests/independent.py: scipy's spsolve of the stiffness).
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse.linalg
from independent import static_nodes

import fem
import jaxflex
from fem.outputs import stress_outputs
from jaxflex import as_move
from jaxflex._deviation import outputs_at
from jaxflex._profile import acceleration_at
from jaxflex.response import upsample

DT = 0.01
G = 9.81


def _cups(stiffness=None, radius=0.03):
    return [
        fem.SuctionCup(x, y, radius, stiffness=stiffness) for x in (0.15, 0.45) for y in (0.1, 0.3)
    ]


PARTS = {
    "plate": lambda material="steel": (fem.rectangular_plate(0.6, 0.4, 1e-3, material, 0.04), None),
    "plate on bellows cups": lambda material="steel": (
        fem.rectangular_plate(0.6, 0.4, 1e-3, material, 0.04),
        "bellows",
    ),
    "thin solid": lambda material="steel": (fem.curved_panel(0.6, 0.4, 1e-3, material, 0.1), None),
    "shell": lambda material="steel": (
        fem.curved_panel(0.6, 0.4, 1e-3, material, 0.05, element="shell"),
        None,
    ),
}


@pytest.fixture(scope="module", params=sorted(PARTS))
def analysed(request):
    part, stiffness = PARTS[request.param]()
    result = fem.modal_analysis(part, _cups(stiffness), n_modes=6, zeta=0.02, progress=False)
    return request.param, result, result.to_modal_model(points=None)


@pytest.mark.parametrize("axis", [0, 1, 2])
def test_cups_carry_the_weight_at_rest(analysed, axis):
    """Newton at rest: the cups' forces on the part add up to -m g for gravity along every
    axis, exactly (1e-9 of the weight: the round-off of one sparse solve), with only six of
    the part's modes kept (the modes alone carried 13 of 92 N of the built-in plate)."""
    _, result, model = analysed
    gravity = np.zeros(3)
    gravity[axis] = -G
    forces = model.cups.reaction.offset(gravity).reshape(-1, 6)[:, :3]
    np.testing.assert_allclose(
        forces.sum(axis=0), -result.mass_kg * gravity, atol=1e-9 * result.mass_kg * G
    )


def test_cups_carry_the_moment_of_the_weight(analysed):
    """About the part's centre of mass (the footprint's centre: the parts are symmetric in
    x and y) the cups' forces and moments under gravity along z leave no moment."""
    _, _, model = analysed
    y = model.cups.reaction.offset([0.0, 0.0, -G]).reshape(-1, 6)
    arms = np.asarray(model.cups.centre_m)[:, :2] - [0.3, 0.2]
    moment_x = np.sum(arms[:, 1] * y[:, 2]) + y[:, 3].sum()
    moment_y = np.sum(-arms[:, 0] * y[:, 2]) + y[:, 4].sum()
    weight = np.abs(y[:, 2]).sum()
    assert abs(moment_x) <= 1e-9 * weight and abs(moment_y) <= 1e-9 * weight


def test_sag_and_stress_equal_a_static_fe_solve(analysed):
    """The points' sag under gravity and the stresses at rest equal an independent static
    FE solve (scipy's own sparse LU of K_ff z = (M R)_free g, COLAMD with pivoting, not fem's
    symmetric MMD one): both are exact, they differ by the round-off of two sparse solvers, at
    most about cond(K_ff) x machine epsilon of the largest value (the condition number
    estimated in the 1-norm; 1e7-1e9 for these parts, the soft bellows cups the largest). The
    modes alone miss a share of both (the part's modes above the sixth)."""
    name, result, model = analysed
    g = np.array([0.0, 0.0, -G])
    stiffness = result.K_free.tocsc()
    factor = scipy.sparse.linalg.splu(stiffness)
    inverse = scipy.sparse.linalg.LinearOperator(
        stiffness.shape, matvec=factor.solve, rmatvec=lambda x: factor.solve(x, trans="T")
    )
    cond = scipy.sparse.linalg.onenormest(stiffness) * scipy.sparse.linalg.onenormest(inverse)
    rel = max(1e-10, 10 * cond * np.finfo(float).eps)  # 10: the estimate's own slack
    # one independent LU (scipy's defaults: COLAMD, pivoting) for both: the sag's right-hand
    # side (M R)_free g is the stresses' (a second factorisation, spsolve's, cost ~19 s CPU of
    # the thin solid's 47 295 DOFs and differed from this one only by round-off)
    sag = static_nodes(result, -g, solve=factor.solve)
    np.testing.assert_allclose(model.static_displacement(-g), sag, atol=rel * np.abs(sag).max())
    load = np.asarray(result.load) @ g
    z = factor.solve(load)
    _, stress = stress_outputs(result)
    expected = stress.stiffness @ z
    np.testing.assert_allclose(
        model.stress.stress.offset(g), expected, atol=rel * np.abs(expected).max()
    )
    if name == "plate":  # the modes alone: what the model held before it stored S
        omega = 2 * np.pi * np.asarray(model.freq_hz)
        modal = np.asarray(model.stress.stress.q_map) @ (np.asarray(model.gamma) @ g / omega**2)
        assert np.abs(modal - expected).max() > 0.01 * np.abs(expected).max()


def test_newton_euler_during_a_move_of_a_stiff_part():
    """A part 10^6 times stiffer than steel (first mode ~ 50 kHz) carried along a smooth
    move is rigid: its cups carry m (a - g) at every instant, to 1e-6 (the dynamic share is
    ~(f_move / f_1)^2 ~ 1e-8 of it)."""
    steel = fem.materials.PRESETS["steel"]
    stiff = fem.Material("stiff steel", steel.E_pa * 1e6, steel.nu, steel.rho_kg_m3)
    for make in (PARTS["plate"], PARTS["shell"]):
        part, _ = make(stiff)
        result = fem.modal_analysis(part, _cups(), n_modes=6, zeta=0.02, progress=False)
        model = result.to_modal_model(points=10)
        t = np.arange(31) * DT
        acc = np.outer(np.sin(2 * np.pi * t / 0.3), [8.0, -3.0, 15.0])
        acc[[0, -1]] = 0.0
        g = np.array([0.0, 0.0, -G])
        times = np.linspace(0, 0.4, 81)
        y = outputs_at(
            model, model.cups.reaction, as_move(acc, DT), times, model.cups.reaction.offset(g)
        )
        total = y.reshape(len(times), -1, 6)[..., :3].sum(axis=1)
        expected = result.mass_kg * (acceleration_at(as_move(acc, DT), times) - g)
        scale = np.abs(expected).max()
        np.testing.assert_allclose(total, expected, atol=1e-6 * scale)


def test_a_scaled_model_is_the_stiffer_fe_model():
    """with_frequency_scale(s) is the part with its stiffness scaled by s^2 (what a robust
    grid's models stand for): frequencies, static sag, cup and stress maps equal a second FE
    analysis with E s^2, to 1e-7 (the eigen solver's tolerance on the modes)."""
    steel = fem.materials.PRESETS["steel"]
    s = 1.1
    stiffer = fem.Material("stiffer", steel.E_pa * s**2, steel.nu, steel.rho_kg_m3)
    nominal = fem.modal_analysis(*_plate_and_cups("steel"), n_modes=6, zeta=0.02, progress=False)
    other = fem.modal_analysis(*_plate_and_cups(stiffer), n_modes=6, zeta=0.02, progress=False)
    scaled = nominal.to_modal_model(points=None).with_frequency_scale(s)
    truth = other.to_modal_model(points=None)
    np.testing.assert_allclose(scaled.freq_hz, truth.freq_hz, rtol=1e-9)
    np.testing.assert_allclose(
        scaled.static_shapes, truth.static_shapes, atol=1e-9 * np.abs(truth.static_shapes).max()
    )
    for a, b in (
        (scaled.cups.reaction, truth.cups.reaction),
        (scaled.stress.stress, truth.stress.stress),
    ):
        for name in ("q_map", "v_map", "static_map", "a_map"):
            x, y = np.asarray(getattr(a, name)), np.asarray(getattr(b, name))
            np.testing.assert_allclose(x, y, atol=1e-7 * np.abs(y).max(), err_msg=name)


def _plate_and_cups(material):
    return fem.rectangular_plate(0.6, 0.4, 1e-3, material, 0.04), _cups()


def test_the_static_residual_brings_the_reduced_model_to_the_full_order_transient():
    """During a move the modes a model leaves out respond quasi-statically (the
    mode-acceleration method, jaxflex._deviation.response_shapes): with 4 modes the
    displacement error against the full-order Newmark transient drops from that of the
    truncation to that of the dynamic share of the dropped modes."""
    part = fem.rectangular_plate(0.6, 0.4, 1e-3, "steel", 0.025)
    damping = fem.Rayleigh.from_zeta(0.02, 40.0, 400.0)
    result = fem.modal_analysis(part, _cups(), n_modes=20, zeta=damping, progress=False)
    t = np.arange(31) * DT
    acc = np.outer(np.sin(2 * np.pi * t / 0.3), [0.0, 0.0, 20.0])
    acc[[0, -1]] = 0.0
    model = result.to_modal_model(points=60)
    move = jaxflex.as_move(acc, DT)
    full = fem.transient_reference(
        result, move, points=model.points, substeps=100, output_substeps=10
    )
    fine = upsample(acc, 10)
    four = model.truncate_modes(4)
    without = jaxflex.ModalModel(four.freq_hz, four.zeta, four.gamma, four.shapes, four.points)
    errors = {}
    for name, m in (("with", four), ("without", without)):
        u = np.asarray(jaxflex.simulate(m, fine, DT / 10, displacement=True).displacement)
        errors[name] = np.abs(u - full.displacement_m).max() / np.abs(full.displacement_m).max()
    assert errors["with"] < 0.2 * errors["without"], errors
