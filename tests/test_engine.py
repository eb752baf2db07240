"""The response engine: both backends, every way of asking for states, and the batch path.

Each way of evaluating the response is checked against an independent one: the NumPy loop
against the JAX scan, states between samples against the recursion on a finer grid
(jaxflex.response.upsample is exact for piecewise-linear input), the linear maps against the
recursion, the zero-order hold against a sum of closed-form step responses. Agreement is
to round-off: every path evaluates the same exact formulas (differences ~1e-15 relative;
1e-11 leaves room for the ~n accumulated roundings of a 1000-step recursion).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from closed_forms import step_response
from conftest import random_model, smooth_move
from hypothesis import given, settings
from hypothesis import strategies as st

import jaxflex
from jaxflex import _engine as engine
from jaxflex._deviation import deviation_curve, deviation_curves, point_norms
from jaxflex._profile import as_move
from jaxflex.response import upsample

RTOL = 1e-11


def _close(a, b, rtol=RTOL):
    scale = max(float(np.max(np.abs(b))), 1e-300)
    assert float(np.max(np.abs(np.asarray(a) - np.asarray(b)))) <= rtol * scale


@settings(max_examples=15, deadline=None)
@given(
    seed=st.integers(0, 10_000),
    n_steps=st.integers(2, 60),
    dt_s=st.sampled_from([1e-3, 0.01, 0.025]),
    hold=st.sampled_from(engine.HOLDS),
)
def test_numpy_loop_equals_jax_scan(seed, n_steps, dt_s, hold):
    model = random_model(seed, n_points=4, n_modes=5, f_max_hz=400.0)
    acc = np.random.default_rng(seed).normal(size=(n_steps + 1, 3))
    x0 = np.random.default_rng(seed + 1).normal(size=(5, 2))
    with_np = engine.modal_states(model, acc, dt_s, x0=x0, hold=hold, xp=np)
    with_jax = engine.modal_states(model, acc, dt_s, x0=x0, hold=hold)
    _close(with_np, with_jax)


def test_states_between_samples_equal_the_recursion_on_a_finer_grid(small_model):
    dt_s, factor = 0.01, 8
    acc = smooth_move(30, dt_s)
    fine = engine.modal_states(small_model, engine.upsample(acc, factor, np), dt_s / factor, xp=np)
    t = dt_s / factor * np.arange(fine.shape[0])
    states = engine.modal_states(small_model, acc, dt_s, xp=np)
    force = engine.modal_forces(small_model, acc, np)
    _close(engine.states_between(small_model, states, force, dt_s, t), fine)


def test_states_at_continue_as_free_vibration(small_model):
    dt_s = 0.01
    acc = smooth_move(25, dt_s)
    longer = engine.rest_padded(acc, 150)  # the move ends at 0.25 s, rest until 1.5 s
    reference = engine.modal_states(small_model, longer, dt_s, xp=np)
    on_grid = engine.states_at(small_model, as_move(acc, dt_s), dt_s * np.arange(longer.shape[0]))
    _close(on_grid, reference)


@pytest.mark.parametrize("dt_s", [0.004, 0.01])
def test_state_map_reproduces_the_substep_states(small_model, dt_s):
    n, substeps = 20, 4
    acc = np.random.default_rng(3).normal(size=(n + 1, 3))
    coef = engine.state_map(small_model, n, dt_s, substeps)  # (n S + 1, M, n+1)
    q = np.einsum("tmi,im->tm", coef, engine.modal_forces(small_model, acc, np))
    fine = engine.modal_states(small_model, engine.upsample(acc, substeps, np), dt_s / substeps)
    _close(q, np.asarray(fine)[..., 0])


def test_end_state_map_is_the_last_row_of_the_recursion(small_model):
    n, dt_s = 33, 0.01
    acc = np.random.default_rng(4).normal(size=(n + 1, 3))
    emap = engine.end_state_map(small_model, n, dt_s)
    _close(np.einsum("mikc,kc->mi", emap, acc), engine.modal_states(small_model, acc, dt_s)[-1])


@pytest.mark.parametrize(("omega", "zeta"), [(2 * np.pi * 3.0, 0.02), (2 * np.pi * 40.0, 0.0)])
def test_zero_hold_is_a_staircase_of_step_responses(omega, zeta):
    """Each held sample a_k acts over [t_k, t_k+1): a sum of closed-form step responses."""
    dt_s, n = 0.01, 40
    model = jaxflex.ModalModel(
        [omega / (2 * np.pi)], [zeta], [[0.0, 0.0, 1.0]], [[[0.0], [0.0], [1.0]]], [[0, 0, 0]]
    )
    a = np.random.default_rng(5).normal(size=n + 1)
    acc = np.zeros((n + 1, 3))
    acc[:, 2] = a
    t = dt_s * np.arange(n + 1)
    jumps = np.diff(np.concatenate([[0.0], a[:-1]]))  # held value changes at t_k
    expected = -sum(c * step_response(t - k * dt_s, omega, zeta) for k, c in enumerate(jumps))
    q = jaxflex.simulate(model, acc, dt_s, hold="zero").q[:, 0]
    _close(q, expected, rtol=1e-9)  # the closed form sums ~40 terms of its own round-off


def test_padding_to_blocks():
    assert engine.padded_steps(1) == engine.PAD_STEPS
    assert engine.padded_steps(engine.PAD_STEPS) == engine.PAD_STEPS
    assert engine.padded_steps(engine.PAD_STEPS + 1) == 2 * engine.PAD_STEPS
    acc = smooth_move(10, 0.01)
    padded = engine.rest_padded(acc, 15)
    assert padded.shape == (16, 3) and np.all(padded[11:] == 0) and np.all(padded[:11] == acc)
    with pytest.raises(jaxflex.InputError, match="n_steps"):
        engine.rest_padded(acc, 5)


def test_rest_padding_does_not_change_the_move_or_its_settle_time(small_model):
    """A part at rest stays at rest: zeros after the move continue the free vibration."""
    dt_s = 0.01
    acc = smooth_move(30, dt_s)
    longer = engine.rest_padded(acc, engine.padded_steps(30))
    a = jaxflex.simulate(small_model, acc, dt_s, extend_s=(longer.shape[0] - 31) * dt_s)
    b = jaxflex.simulate(small_model, longer, dt_s)
    _close(a.deviation, b.deviation)


def test_batch_deviation_equals_one_simulation_per_model():
    models = [random_model(seed, n_points=12, n_modes=4) for seed in range(3)]
    accs = np.stack([smooth_move(20, 0.01, (s, 1.0, 0.5)) for s in (0.1, 0.2, 0.3)])
    batch = np.asarray(jaxflex.batch_deviation(jaxflex.stack_models(models), accs, 0.01))
    for b, model in enumerate(models):
        _close(batch[b], jaxflex.simulate(model, accs[b], 0.01).deviation)
    with pytest.raises(jaxflex.InputError, match="accs"):
        jaxflex.batch_deviation(jaxflex.stack_models(models), accs[:2], 0.01)


def test_models_differing_only_in_meta_share_compiled_code_and_stack(small_model):
    """meta and labels are not part of the pytree structure: no recompilation, and vmap
    over stacked models works although their meta differ."""
    other = small_model.with_meta(source="elsewhere", note="different meta")
    assert jax.tree_util.tree_structure(other) == jax.tree_util.tree_structure(small_model)
    compiled = jax.jit(lambda m: jnp.sum(m.freq_hz))
    compiled(small_model)
    compiled(other)
    assert compiled._cache_size() == 1
    stacked = jaxflex.stack_models([small_model, other])
    assert stacked.freq_hz.shape == (2, small_model.n_modes)
    acc = jnp.asarray(smooth_move(20, 0.01))
    dev = jax.vmap(lambda m: jaxflex.simulate(m, acc, 0.01).deviation)(stacked)
    _close(dev[1], jaxflex.simulate(other, acc, 0.01).deviation)
    # device_put keeps the description
    assert jax.device_put(other).meta["note"] == "different meta"


def test_stack_models_refuses_models_of_different_size(small_model):
    with pytest.raises(jaxflex.ModelError, match="equal size"):
        jaxflex.stack_models([small_model, small_model.truncate_modes(3)])
    with pytest.raises(jaxflex.ModelError, match="at least one"):
        jaxflex.stack_models([])


def test_numpy_deviation_forms_agree_with_the_jax_one(small_model):
    acc = smooth_move(30, 0.01)
    res = jaxflex.simulate(small_model, acc, 0.01, extend_s=0.5)
    q = np.asarray(res.q)
    shapes = np.asarray(small_model.shapes)
    curves = deviation_curves(shapes, q, subsets=[np.arange(5)])
    _close(curves.all, res.deviation)
    _close(point_norms(shapes, q).max(axis=0), res.deviation)
    _close(curves.subsets[0], point_norms(shapes[:5], q).max(axis=0))
    norms = point_norms(shapes, q)
    # the point named attains the largest norm (which one among equal norms is not asked)
    columns = np.arange(norms.shape[1])
    np.testing.assert_allclose(norms[curves.argmax, columns], norms.max(axis=0), rtol=1e-12)


def test_deviation_curve_samples_the_exact_response(small_model):
    dt_s, substeps = 0.01, 4
    acc = smooth_move(20, dt_s)
    t, d = deviation_curve(small_model, as_move(acc, dt_s), 0.6, substeps)
    assert t[-1] >= 0.6 and np.allclose(np.diff(t), dt_s / substeps)
    fine = jaxflex.simulate(
        small_model, engine.upsample(acc, substeps), dt_s / substeps, extend_s=t[-1] - 0.2
    )
    _close(d, np.asarray(fine.deviation)[: d.size])


def test_simulate_raises_the_projects_input_error(small_model):
    acc = smooth_move(10, 0.01)
    for kwargs, field in (
        ({"dt_s": 0.0}, "dt_s"),
        ({"dt_s": 0.01, "dtype": "float16"}, "dtype"),
        ({"dt_s": 0.01, "hold": "cubic"}, "hold"),
    ):
        with pytest.raises(jaxflex.InputError, match=field):
            jaxflex.simulate(small_model, acc, **kwargs)
    with pytest.raises(jaxflex.InputError, match="factor"):
        upsample(acc, 0)
