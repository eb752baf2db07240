"""The linear residual model of the exact route, the polytope, and the exact timing helper."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from conftest import random_model, smooth_move
from hypothesis import given, settings
from hypothesis import strategies as st

import jaxflex
from jaxflex._engine import end_state_map
from jaxflex._settle import analyze_move
from jaxflex._simulate import end_state
from jaxflex.response import upsample
from optim.move_response import MoveResponse
from optim.polytope import ball_normals, support
from optim.residual import ResidualModel


@pytest.mark.parametrize("dt_s", [0.004, 0.01, 0.03])
def test_end_state_map_is_the_jacobian_of_the_scan(dt_s):
    model = random_model(seed=2, n_modes=5, f_max_hz=120.0)
    acc = smooth_move(40, dt_s)
    jac = jax.jacfwd(lambda a: end_state(model, a, dt_s))(jnp.asarray(acc))
    emap = end_state_map(model, 40, dt_s)
    # Both are the same sums of exact propagator products; round-off only.
    np.testing.assert_allclose(emap, np.asarray(jac), rtol=0, atol=1e-13 * np.abs(emap).max())
    np.testing.assert_allclose(
        np.einsum("mikc,kc->mi", emap, acc),
        np.asarray(end_state(model, acc, dt_s)),
        atol=1e-13,
    )


def test_free_response_matches_the_simulation():
    model = random_model(seed=4, n_points=12, n_modes=4)
    dt_s, acc = 0.01, smooth_move(30, 0.01)
    res = jaxflex.simulate(model, acc, dt_s, extend_s=1.0, displacement=True)
    x_end = np.asarray(res.end_state)
    tau = dt_s * np.arange(101)
    u = ResidualModel(model, (0, 1, 2)).displacement(x_end, tau)
    np.testing.assert_allclose(u, np.asarray(res.displacement)[30:], atol=1e-12)


def test_move_response_map_is_the_simulation_during_the_move():
    model = random_model(seed=6, n_points=10, n_modes=4, f_max_hz=60.0)
    dt_s, acc = 0.01, smooth_move(30, 0.01)
    response = MoveResponse(model, (0, 1, 2), 30, dt_s)
    fine = jaxflex.simulate(model, upsample(acc, 8), dt_s / 8)
    # q at every dt / 8 from the tabulated linear map equals the scan at the finer step
    np.testing.assert_allclose(response.modal(acc), np.asarray(fine.q), atol=1e-13)
    # and a tangent row evaluates the projection of the deviation on its direction
    peak = response.peaks(acc, 0.5 * float(np.max(fine.deviation)))[0]
    assert peak.value * 0.5 * float(np.max(fine.deviation)) == pytest.approx(
        float(np.max(fine.deviation))
    )
    row = response.row(peak, (0, 1, 2))
    assert np.sum(row * acc) == pytest.approx(np.linalg.norm(peak.u))


def brute_force_peak(residual, x_end, horizon, samples=200_001):
    tau = np.linspace(0.0, horizon, samples)
    d = np.concatenate(
        [
            np.linalg.norm(residual.displacement(x_end, chunk), axis=-1).max(axis=1)
            for chunk in np.array_split(tau, 50)
        ]
    )
    return tau, d


def test_exceedances_find_the_worst_peak():
    model = random_model(seed=5, n_points=20, n_modes=3, f_min_hz=2.0, f_max_hz=15.0)
    residual = ResidualModel(model, (0, 1, 2))
    dt_s, acc = 0.01, smooth_move(25, 0.01)
    x_end = np.asarray(end_state(model, acc, dt_s))
    tau, d = brute_force_peak(residual, x_end, 6.0)
    limit = 0.5 * d.max()
    peaks = residual.exceedances(x_end, limit, max_peaks=1000)
    assert peaks and all(p.value > 1.0 for p in peaks)
    # the worst reported peak is the true maximum (refined on a 1/256-period grid: the
    # peak lies within 1/512 period of a sample, so the sampled cosine is within
    # (pi / 256)^2 / 2 < 1e-4 of it)
    assert peaks[0].value * limit == pytest.approx(d.max(), rel=1e-4)
    # every brute-force time above 1.01 x limit lies within one lobe of a reported peak
    lobe = 0.5 / np.max(np.asarray(model.freq_hz))
    found = np.array([p.tau_s for p in peaks])
    for t in tau[d > 1.01 * limit][::97]:
        assert np.min(np.abs(found - t)) < lobe
    # each row evaluates the peak's projection on its direction (linear in the end state)
    for peak in peaks[:5]:
        assert np.sum(residual.row(peak) * x_end) == pytest.approx(np.linalg.norm(peak.u))
    assert residual.exceedances(x_end, 1.01 * d.max()) == []


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 10_000), st.sampled_from([2, 3]))
def test_polytope_lies_inside_the_ball(seed, dim):
    # support(u) >= rho |u| for every u  <=>  {c . u <= rho} is inside the unit ball
    _, rho = ball_normals(dim)
    u = np.random.default_rng(seed).normal(size=(2000, dim))
    assert np.all(support(u, dim) >= rho * np.linalg.norm(u, axis=1) * (1 - 1e-12))
    assert rho > (0.99 if dim == 3 else 0.995)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_zero_lead_in_shifts_the_settle_time_and_skipping_the_move_search_keeps_the_cycle(
    seed,
):
    """A part at rest stays at rest: k zero samples before the move delay its settle time by
    exactly k dt (to the 1e-9 s the search locates it to); the cycle time without the search
    during the move (settle=False, what the optimiser asks) is the same."""
    model = random_model(seed=seed, n_points=15, n_modes=4, f_min_hz=1.0, f_max_hz=30.0)
    acc = smooth_move(37 + 5 * seed, 0.01)
    lead = 13
    delayed = np.vstack([np.zeros((lead, 3)), acc])
    for threshold_m in (1e-3, 1e-2, 5e-2):
        direct = analyze_move(model, acc, 0.01, threshold_m)
        shifted = analyze_move(model, delayed, 0.01, threshold_m)
        if direct.settle_time_s > 0:
            assert shifted.settle_time_s - lead * 0.01 == pytest.approx(
                direct.settle_time_s, abs=2e-9
            )
        fast = analyze_move(model, acc, 0.01, threshold_m, settle=False)
        assert fast.cycle_time_s == pytest.approx(direct.cycle_time_s, abs=2e-9)
