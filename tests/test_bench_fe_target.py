"""Reduced modal model against the full-order FE transient on the curved panel (docs/design.md
target: R^2 >= 0.99999, L-inf <= 0.2 % of the peak, settle time within 10 ms). The plate is
checked on the quick bench run (tests/test_bench.py)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from fem.bench.accuracy import TARGETS, agreement_by_modes, settle_threshold
from fem.bench.fe import build_scene, fe_reference
from fem.bench.metrics import settle_from_samples
from fmu.bench.suite import SMALL_PANEL


@pytest.mark.slow
def test_panel_reduced_model_against_full_order_fe():
    """Small curved panel (0.6 x 0.4 m, built-in curvature, four 80 mm cups, one-layer Hex2
    thin solid, ~13k DOFs on the mesh that follows the cups' rims; first mode ~300 Hz), the
    bench's knot move (0.3, 0, 1) with 100 ms knots, reference = Richardson-extrapolated
    Newmark at omega_1 h = 0.5 (its plain fine run differs from it by 0.15 % of the peak).

    With the static residual of the FE's static solve (the modes left out respond
    quasi-statically: jaxflex._deviation.response_shapes) 60 and 200 modes agree to 1e-6 of
    the peak: the modes have converged, and what is left (L-inf 0.31 %, R^2 0.9999913 /
    0.9999974, measured) is the reference's. R^2 and settle time meet the target; L-inf is
    above 0.2 % (reported as not met in docs/bench.md)."""
    spec = replace(
        SMALL_PANEL,
        n_modes=200,
        mode_counts=(60, 200),
        fe_factors=(),
        output_per_base=1,
        omega1_h=0.5,
    )
    result, damping, _ = build_scene(spec, progress=False)
    ref = fe_reference(result, damping, spec, progress=False)
    model = result.to_modal_model(points=ref.points, zeta=damping)
    threshold_m = settle_threshold(ref.t_s, ref.deviation_m, spec.rest_s)
    settle_ref = settle_from_samples(ref.t_s, ref.deviation_m, threshold_m)
    rows = agreement_by_modes(model, ref, spec, threshold_m, settle_ref)
    fine_row = rows[-1]
    assert min(fine_row["deviation_r2"], fine_row["displacement_r2"]) >= TARGETS["r2"]
    assert abs(fine_row["settle_error_s"]) <= TARGETS["settle_error_s"]
    # with the static residual even 60 modes are as close as the reference is to itself: the
    # model's L-inf is within the reference's own step error, bounded by the difference of its
    # runs at h and 2 h (Newmark's error at h is a third of it in the asymptotic range, up to
    # all of it for the high modes Newmark integrates at omega h >> 1; measured on the mesh
    # that follows the cups' rims: model 0.31 %, runs 0.46 % apart); and 60 and 200 modes agree
    fine, coarse = ref.runs[1][0], ref.runs[2][0]
    reference_error = np.abs(fine - coarse).max() / np.abs(ref.displacement_m).max()
    for row in rows:
        worst = max(row["deviation_linf_rel_peak"], row["displacement_linf_rel_peak"])
        assert worst <= reference_error, (worst, reference_error)
    few, many = (row["displacement_linf_rel_peak"] for row in rows)
    assert abs(few - many) < 1e-4
