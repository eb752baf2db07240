"""Reduced modal model (jaxflex.simulate) against the full-order Newmark transient."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

import fem
import jaxflex
from fem.transient import agreement
from jaxflex.response import upsample

DT = 0.01
N_STEPS = 30  # a 0.3 s move, then 0.3 s of free decay
MODE_COUNTS = (5, 10, 20, 40, 80)


def _smooth_move() -> np.ndarray:
    """One sine period of acceleration along z (1 m of travel) and x (no plate response)."""
    t = np.arange(N_STEPS + 1) * DT
    duration = N_STEPS * DT
    shape = 2 * np.pi / duration**2 * np.sin(2 * np.pi * t / duration)
    acc = np.outer(shape, [0.3, 0.0, 1.0])
    acc[[0, -1]] = 0.0
    return acc


@pytest.fixture(scope="module")
def reference():
    part = fem.rectangular_plate(0.6, 0.4, mesh_size=0.025)
    cups = fem.default_gripper(0.6, 0.4, 0.03)
    damping = fem.Rayleigh.from_zeta(0.02, 40.0, 400.0)
    result = fem.modal_analysis(part, cups, max(MODE_COUNTS), zeta=damping)
    # h = 1e-4 s: omega h <= 0.07 up to the 10th mode (Newmark period error ~4e-4)
    full = fem.transient_reference(
        result,
        jaxflex.as_move(_smooth_move(), DT),
        points=120,
        extend_s=0.3,
        substeps=100,
        output_substeps=10,
    )
    return result, full


@pytest.mark.slow
def test_reduced_model_matches_full_order_transient(reference):
    result, full = reference
    acc = np.concatenate([_smooth_move(), np.zeros((30, 3))])
    fine = upsample(acc, 10)
    curve = {}
    for n_modes in MODE_COUNTS:
        model = result.to_modal_model(points=full.points).truncate_modes(n_modes)
        response = jaxflex.simulate(model, fine, DT / 10, displacement=True)
        curve[n_modes] = agreement(full.displacement_m, np.asarray(response.displacement))
    print("\nmodes  R^2          max error / peak")
    for n_modes, a in curve.items():
        print(f"{n_modes:5d}  {a['r2']:.8f}  {a['max_error_rel_peak']:.2e}")
    # the target, with enough modes: R^2 >= 0.9999 and max error <= 0.5 % of the peak
    # (measured with the modes alone at 40 modes: R^2 0.999993, 0.35 %). With the static
    # residual (the modes left out respond quasi-statically) what remains is the dynamic
    # share of the modes left out and Newmark's period error at h = 1e-4 s (measured: 5 / 10
    # / 20 / 40 / 80 modes 0.34 / 0.10 / 0.056 / 0.040 / 0.040 %)
    assert curve[40]["r2"] >= 0.9999 and curve[40]["max_error_rel_peak"] <= 5e-3
    assert curve[80]["r2"] >= 0.99999 and curve[80]["max_error_rel_peak"] <= 2e-3
    # more modes, no larger error (up to the reference's own 1e-4)
    errors = [curve[n]["max_error_rel_peak"] for n in MODE_COUNTS]
    assert all(b <= a + 1e-4 for a, b in itertools.pairwise(errors)), errors


def test_transient_reference_shapes_and_rest(reference):
    _, full = reference
    # 60 sample intervals (move + decay), 10 outputs each, about 120 voxel-reduced points
    assert full.displacement_m.shape == (601, len(full.points), 3)
    assert 108 <= len(full.points) <= 132
    assert full.t_s[0] == 0.0 and full.t_s[-1] == pytest.approx(0.6)
    np.testing.assert_allclose(full.displacement_m[0], 0.0)
    # a Kirchhoff plate moves along z only
    assert np.abs(full.displacement_m[:, :, :2]).max() == 0.0
    assert full.deviation_m.max() > 1e-4
    # the response decays after the move (Rayleigh damping, >= 2 % in the band)
    late = full.deviation_m[full.t_s > 0.5].max()
    assert late < 0.5 * full.deviation_m.max()


def test_transient_needs_rayleigh_damping():
    part = fem.rectangular_plate(0.3, 0.2, mesh_size=0.03)
    result = fem.modal_analysis(part, fem.default_gripper(0.3, 0.2, 0.03), 4, zeta=0.02)
    with pytest.raises(jaxflex.InputError, match="Rayleigh"):
        fem.transient_reference(result, jaxflex.as_move(_smooth_move(), DT))
