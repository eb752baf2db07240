"""The modal scan: independent ODE solution, linearity, transforms, stability, bad input."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from closed_forms import piecewise_linear_response
from conftest import random_model, smooth_move
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

import jaxflex
from jaxflex._convolution import convolve_unit_response, deviation_from_displacement, unit_response
from jaxflex.response import upsample


def test_multi_mode_against_solve_ivp():
    model = random_model(
        seed=3, n_points=12, n_modes=5, f_min_hz=1.0, f_max_hz=20.0, zeta=(0.0, 0.1)
    )
    dt_s, n = 0.02, 60
    acc = smooth_move(n, dt_s) + np.outer(np.sin(np.arange(n + 1)), [0.5, 0.2, -0.3])
    acc[[0, -1]] = 0.0
    omega, zeta = 2 * np.pi * model.freq_hz, model.zeta
    t_samples = dt_s * np.arange(n + 1)

    def rhs(t, y):
        a = np.array([np.interp(t, t_samples, acc[:, c]) for c in range(3)])
        q, v = y[: model.n_modes], y[model.n_modes :]
        return np.concatenate([v, -model.gamma @ a - 2 * zeta * omega * v - omega**2 * q])

    sol = solve_ivp(
        rhs,
        (0, n * dt_s),
        np.zeros(2 * model.n_modes),
        t_eval=t_samples,
        method="DOP853",
        rtol=1e-12,
        atol=1e-15,
        max_step=dt_s / 4,  # breakpoints of a(t) every dt
    )
    q_ref = sol.y[: model.n_modes].T
    r = jaxflex.simulate(model, acc, dt_s)
    # DOP853 at rtol 1e-12 over ~1 s: global error well below 1e-9 of the peak
    np.testing.assert_allclose(np.asarray(r.q), q_ref, rtol=0, atol=1e-9 * np.abs(q_ref).max())


@settings(max_examples=25, deadline=None)
@given(
    seed=st.integers(0, 10_000),
    alpha=st.floats(-3, 3, allow_nan=False),
    beta=st.floats(-3, 3, allow_nan=False),
)
def test_superposition(seed, alpha, beta):
    rng = np.random.default_rng(seed)
    model = random_model(seed=seed % 7)
    a1, a2 = rng.normal(size=(2, 41, 3))
    dt_s = 0.01
    sim = lambda a: np.asarray(jaxflex.simulate(model, a, dt_s, displacement=True).displacement)  # noqa: E731
    combined = sim(alpha * a1 + beta * a2)
    separate = alpha * sim(a1) + beta * sim(a2)
    scale = max(np.abs(separate).max(), np.abs(sim(a1)).max(), 1e-300)
    np.testing.assert_allclose(
        combined, separate, rtol=0, atol=1e-12 * scale * (1 + abs(alpha) + abs(beta))
    )


def test_scan_and_direct_convolution_agree_to_round_off(small_model):
    dt_s, n = 0.01, 120
    acc = smooth_move(n, dt_s)
    r1 = unit_response(small_model, dt_s, n)
    direct = convolve_unit_response(r1, acc)
    scan = np.asarray(jaxflex.simulate(small_model, acc, dt_s, displacement=True).displacement)
    np.testing.assert_allclose(direct, scan, rtol=0, atol=1e-12 * np.abs(scan).max())
    np.testing.assert_allclose(
        deviation_from_displacement(direct),
        np.asarray(jaxflex.simulate(small_model, acc, dt_s).deviation),
        rtol=1e-12,
        atol=1e-300,
    )


@pytest.mark.parametrize("dt_s", [0.01, 0.025])
def test_stability_from_half_hertz_to_two_kilohertz(dt_s):
    """Modes 0.5 Hz .. 2 kHz in one model at coarse steps: every modal coordinate equals the
    closed form, however many periods fit in one step (2 kHz: 20 to 50)."""
    freq = np.geomspace(0.5, 2000.0, 12)
    m = len(freq)
    model = jaxflex.ModalModel(
        freq_hz=freq,
        zeta=np.full(m, 0.01),
        gamma=np.tile([0.0, 0.0, 1.0], (m, 1)),
        shapes=np.ones((1, 3, m)),
        points=np.zeros((1, 3)),
    )
    n = 200
    acc = smooth_move(n, dt_s, distance=(0, 0, 1.0))
    r = jaxflex.simulate(model, acc, dt_s, extend_s=5.0)
    t = np.asarray(r.t)
    for i, f in enumerate(freq):
        expected = -piecewise_linear_response(t, acc[:, 2], dt_s, 2 * np.pi * f, 0.01)
        scale = np.abs(expected).max()
        np.testing.assert_allclose(np.asarray(r.q)[:, i], expected, rtol=0, atol=1e-10 * scale)


def test_extension_equals_zero_padding(small_model):
    dt_s, n = 0.01, 50
    acc = smooth_move(n, dt_s)
    extended = jaxflex.simulate(small_model, acc, dt_s, extend_s=0.3)
    padded = jaxflex.simulate(small_model, np.vstack([acc, np.zeros((30, 3))]), dt_s)
    np.testing.assert_allclose(np.asarray(extended.q), np.asarray(padded.q), rtol=0, atol=1e-13)
    np.testing.assert_allclose(np.asarray(extended.t), np.asarray(padded.t), rtol=1e-14)
    assert extended.n_steps == n


def test_upsampled_profile_gives_the_same_samples(small_model):
    dt_s, n, f = 0.02, 30, 8
    acc = smooth_move(n, dt_s)
    coarse = np.asarray(jaxflex.simulate(small_model, acc, dt_s).q)
    fine = np.asarray(jaxflex.simulate(small_model, upsample(acc, f), dt_s / f).q)
    np.testing.assert_allclose(fine[::f], coarse, rtol=0, atol=1e-12 * np.abs(coarse).max())


def test_vmap_over_profiles_and_models(small_model):
    dt_s, n = 0.01, 40
    accs = np.stack([smooth_move(n, dt_s), 2 * smooth_move(n, dt_s, distance=(1, 0, 0))])
    batched = jax.vmap(lambda a: jaxflex.simulate(small_model, a, dt_s).deviation)(
        jnp.asarray(accs)
    )
    for i in range(2):
        np.testing.assert_allclose(
            batched[i], jaxflex.simulate(small_model, accs[i], dt_s).deviation, rtol=1e-13
        )
    models = [small_model, small_model.with_frequency_scale(1.1).with_damping(0.05)]
    stacked = jax.tree_util.tree_map(lambda *x: jnp.stack(x), *models)
    per_model = jax.vmap(lambda m: jaxflex.simulate(m, accs[0], dt_s).deviation)(stacked)
    for i, m in enumerate(models):
        np.testing.assert_allclose(
            per_model[i], jaxflex.simulate(m, accs[0], dt_s).deviation, rtol=1e-13
        )


def test_gradient_matches_finite_differences(small_model):
    dt_s, n = 0.01, 40
    acc = jnp.asarray(smooth_move(n, dt_s))

    def objective(a):
        return jnp.sum(jaxflex.simulate(small_model, a, dt_s).deviation ** 2)

    grad = np.asarray(jax.grad(objective)(acc))
    rng = np.random.default_rng(1)
    for _ in range(5):
        k, c = rng.integers(1, n), rng.integers(0, 3)
        e = np.zeros_like(acc)
        e[k, c] = 1e-6
        fd = (objective(acc + e) - objective(acc - e)) / 2e-6
        # objective is piecewise quadratic (max switches point only at isolated a); central
        # differences are exact for quadratics up to round-off ~ eps * |f| / 1e-6
        assert grad[k, c] == pytest.approx(
            float(fd), rel=1e-6, abs=1e-9 * abs(float(objective(acc)))
        )


def test_gradient_with_respect_to_model_parameters(small_model):
    dt_s, n = 0.01, 40
    acc = jnp.asarray(smooth_move(n, dt_s))

    def objective(scale, zeta):
        m = jaxflex.ModalModel.tree_unflatten(
            small_model.tree_flatten()[1],
            (
                small_model.freq_hz * scale,
                small_model.zeta * 0 + zeta,
                small_model.gamma,
                small_model.shapes,
                small_model.points,
            ),
        )
        return jnp.sum(jaxflex.simulate(m, acc, dt_s).deviation)

    g_scale, g_zeta = jax.grad(objective, argnums=(0, 1))(1.0, 0.03)
    h = 1e-6
    assert float(g_scale) == pytest.approx(
        float((objective(1 + h, 0.03) - objective(1 - h, 0.03)) / (2 * h)), rel=1e-5
    )
    assert float(g_zeta) == pytest.approx(
        float((objective(1.0, 0.03 + h) - objective(1.0, 0.03 - h)) / (2 * h)), rel=1e-5
    )


def test_float32_on_request(small_model):
    dt_s, n = 0.01, 100
    acc = smooth_move(n, dt_s)
    d64 = np.asarray(jaxflex.simulate(small_model, acc, dt_s).deviation)
    r32 = jaxflex.simulate(small_model, acc, dt_s, dtype="float32")
    assert r32.deviation.dtype == jnp.float32
    # float32 round-off (6e-8) accumulated over 100 steps of a contracting recursion
    np.testing.assert_allclose(
        np.asarray(r32.deviation, dtype=float), d64, rtol=0, atol=2e-5 * d64.max()
    )


@pytest.mark.parametrize(
    ("acc", "dt_s", "message"),
    [
        (np.zeros((10, 2)), 0.01, "shape"),
        (np.zeros((1, 3)), 0.01, "shape"),
        (np.array([[0, 0, 0], [np.nan, 0, 0], [0, 0, 0]]), 0.01, "sample 1"),
        (np.array([[0, 0, 0], [0, np.inf, 0], [0, 0, 0]]), 0.01, "axis y"),
        (np.zeros((10, 3)), 0.0, "dt"),
        (np.zeros((10, 3)), -0.01, "dt"),
        (np.zeros((10, 3)), float("nan"), "dt"),
        (np.array([["a", "b", "c"]] * 3), 0.01, "numeric"),
    ],
)
def test_bad_input_is_named(small_model, acc, dt_s, message):
    with pytest.raises(jaxflex.InputError, match=message):
        jaxflex.simulate(small_model, acc, dt_s)


def test_bad_dtype(small_model):
    with pytest.raises(ValueError, match="dtype"):
        jaxflex.simulate(small_model, np.zeros((5, 3)), 0.01, dtype="float16")


@pytest.mark.parametrize("not_a_model", [None, "plate.npz", {"freq_hz": [5.0]}])
def test_every_door_of_a_model_refuses_what_is_not_one(not_a_model):
    """A path, a dict or None where a ModalModel belongs is refused by name at the door,
    not an AttributeError from inside the engine."""
    acc = smooth_move(20, 0.01)
    for call in (
        lambda: jaxflex.simulate(not_a_model, acc, 0.01),
        lambda: jaxflex.analyze_move(not_a_model, acc, 0.01, 1e-3),
        lambda: jaxflex.cycle_time(not_a_model, acc, 0.01, 1e-3),
    ):
        with pytest.raises(jaxflex.InputError, match=r"^model: expected a jaxflex\.ModalModel"):
            call()
