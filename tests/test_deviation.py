"""The pruned blocked deviation against the dense evaluation: value, arg-max, gradient, memory."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from conftest import random_model, smooth_move
from hypothesis import given, settings
from hypothesis import strategies as st

import jaxflex
from jaxflex._analytic import simply_supported_plate
from jaxflex._blocks import kd_order, point_blocks
from jaxflex._deviation import UNIT_STEPS, blocks_of, deviation, deviation_point, max_norms
from jaxflex._engine import modal_states
from jaxflex._simulate import on_device

EPS64 = np.finfo(np.float64).eps


def dense(model, q):
    """Reference: every point's |u_p(t)| (T, K) in NumPy, then max and first arg-max."""
    u = np.einsum("pcm,tm->tpc", np.asarray(model.shapes), np.asarray(q, dtype=np.float64))
    norms = np.linalg.norm(u, axis=2)
    return norms, norms.max(axis=1), norms.argmax(axis=1)


def check_against_dense(model, q, d, point, rel_tol):
    """d equals the dense max to ``rel_tol`` of the peak; the arg-max point attains it (same
    tolerance), and is the dense arg-max wherever the runner-up is further away than that."""
    norms, d_ref, p_ref = dense(model, q)
    d, point = np.asarray(d, dtype=np.float64), np.asarray(point)
    scale = max(d_ref.max(), 1e-300)
    np.testing.assert_allclose(d, d_ref, rtol=0, atol=rel_tol * scale)
    attained = norms[np.arange(len(point)), point]
    np.testing.assert_allclose(attained, d_ref, rtol=0, atol=rel_tol * scale)
    runner_up = np.sort(norms, axis=1)[:, -2] if norms.shape[1] > 1 else np.zeros(len(d))
    clear = d_ref - runner_up > 2 * rel_tol * scale
    np.testing.assert_array_equal(point[clear], p_ref[clear])


def states(model, acc, dt_s):
    return np.asarray(modal_states(model, acc, dt_s, xp=np)[..., 0])


# Round-off of one |u_p| from a dot product of length M and a sum of 3 squares is at most
# (M + 3) eps relative to |phi| |q| <= the peak times the spread of the shapes (a few), so
# 1e3 eps is a generous bound for M <= 40.
TOL64 = 1e3 * EPS64


# Few model sizes (each compiles once); the moves and shapes vary freely.
@settings(max_examples=12, deadline=None)
@given(
    seed=st.integers(0, 10_000),
    size=st.sampled_from([(1, 1), (65, 3), (300, 8)]),
    n_steps=st.sampled_from([1, 31, 32, 100]),
)
def test_pruned_equals_dense_on_random_models(seed, size, n_steps):
    n_points, n_modes = size
    model = random_model(seed=seed, n_points=n_points, n_modes=n_modes)
    rng = np.random.default_rng(seed)
    acc = rng.normal(size=(n_steps + 1, 3))
    q = states(model, acc, 0.01)
    d, point = max_norms(blocks_of(model), q)
    check_against_dense(model, q, d, point, TOL64)


def test_pruned_equals_dense_on_a_smooth_part_and_prunes():
    """A simply supported plate at 4000 grid points: blocks are patches, most tiles pruned."""
    model = simply_supported_plate(n_modes=20, points=4000)
    acc = smooth_move(300, 0.005)
    q = states(model, acc, 0.005)
    blocks = blocks_of(model)
    d, point = max_norms(blocks, q)
    check_against_dense(model, q, d, point, TOL64)
    from jaxflex._deviation import _alive_tiles

    padded = np.zeros((-(-q.shape[0] // UNIT_STEPS) * UNIT_STEPS, q.shape[1]))
    padded[: q.shape[0]] = q
    alive = np.asarray(_alive_tiles(blocks, jnp.asarray(padded)))
    assert alive.mean() < 0.5  # the bound is tight on a smooth field


@pytest.mark.slow
def test_pruned_equals_dense_on_the_fe_plate_at_every_node():
    from fem.scenes import default_model

    model = default_model("plate", n_modes=20, n_points=None)
    assert model.n_points > 3000
    dt = 0.005
    acc = smooth_move(160, dt)
    q = states(model, acc, dt)
    d, point = max_norms(blocks_of(model), q)
    check_against_dense(model, q, d, point, TOL64)


def test_points_tied_at_the_maximum_give_the_lowest_index():
    base = random_model(seed=4, n_points=200, n_modes=5)
    shapes = np.array(base.shapes)
    copies = [17, 3, 150, 199, 64]  # identical shapes, the lowest index is 3
    shapes[copies] = 3.0 * shapes[0]
    model = base._replace(shapes=shapes)
    q = states(model, smooth_move(64, 0.01), 0.01)
    d, point = max_norms(blocks_of(model), q)
    moving = d > 0
    assert (point[moving] == 3).all()
    check_against_dense(model, q, d, point, TOL64)


def test_a_single_dominant_point():
    base = random_model(seed=5, n_points=500, n_modes=6)
    shapes = np.array(base.shapes) * 1e-3
    shapes[321] = np.array(base.shapes)[321] * 10.0
    model = base._replace(shapes=shapes)
    q = states(model, smooth_move(100, 0.01), 0.01)
    d, point = max_norms(blocks_of(model), q)
    assert (point[d > 0] == 321).all()
    check_against_dense(model, q, d, point, TOL64)


def test_all_zero_response():
    model = random_model(seed=6, n_points=100)
    q = np.zeros((50, model.n_modes))
    d, point = max_norms(blocks_of(model), q)
    assert (d == 0).all() and (point == 0).all()
    blocks = blocks_of(model)
    value, grad = jax.value_and_grad(lambda q: jnp.sum(deviation(blocks, q)))(jnp.asarray(q))
    assert float(value) == 0.0 and (np.asarray(grad) == 0).all()


def test_float32_equals_dense_to_float32_round_off():
    model = simply_supported_plate(n_modes=12, points=900)
    acc = smooth_move(200, 0.005)
    q = states(model, acc, 0.005)
    _, blocks32 = on_device(model, "float32")
    d, point = max_norms(blocks32, q.astype(np.float32))
    # float32 inputs (shapes and q rounded, 2 x 2^-24 relative) and float32 arithmetic over
    # M = 12 modes: a relative error of ~(2 + M + 3) 2^-24 ~ 1e-6 of the peak, times 10
    check_against_dense(model, q, d, point, 1e-5)


def test_gradient_against_finite_differences():
    model = simply_supported_plate(n_modes=8, points=500)
    dt = 0.01
    acc = smooth_move(80, dt)

    def peak_sum(a):
        return jnp.sum(jaxflex.simulate(model, a, dt).deviation ** 2)

    grad = np.asarray(jax.grad(peak_sum)(jnp.asarray(acc)))
    rng = np.random.default_rng(1)
    for _ in range(3):
        direction = rng.normal(size=acc.shape)
        h = 1e-6
        fd = (peak_sum(acc + h * direction) - peak_sum(acc - h * direction)) / (2 * h)
        # central difference: error O(h^2) plus the arg-max switching points, where d is
        # still continuous: agreement to 1e-6 relative
        assert float(fd) == pytest.approx(float(np.sum(grad * direction)), rel=1e-6)


def test_gradient_with_respect_to_the_shapes_matches_the_dense_form():
    model = random_model(seed=8, n_points=150, n_modes=5)
    q = jnp.asarray(states(model, smooth_move(40, 0.01), 0.01)[1:])  # d > 0 everywhere
    shapes = jnp.asarray(model.shapes)
    points = jnp.asarray(model.points)
    weights = jnp.linspace(0.5, 1.5, q.shape[0])

    def pruned(s):
        return jnp.sum(weights * deviation(point_blocks(s, points), q))

    def reference(s):
        u = jnp.einsum("pcm,tm->tpc", s, q)
        return jnp.sum(weights * jnp.sqrt(jnp.max(jnp.sum(u * u, axis=2), axis=1)))

    np.testing.assert_allclose(
        np.asarray(jax.grad(pruned)(shapes)), np.asarray(jax.grad(reference)(shapes)), atol=1e-12
    )


def _largest_intermediate(jaxpr) -> int:
    """Largest array (elements) any equation of ``jaxpr`` or its sub-jaxprs produces."""
    largest = 0
    for eqn in jaxpr.eqns:
        for var in eqn.outvars:
            largest = max(largest, int(np.prod(var.aval.shape, dtype=np.int64)))
        for param in eqn.params.values():
            inner = getattr(param, "jaxpr", param)
            if hasattr(inner, "eqns"):
                largest = max(largest, _largest_intermediate(inner))
    return largest


@pytest.mark.parametrize("n_points", [2_000, 8_000])
def test_memory_of_the_blocked_path_does_not_grow_with_steps_times_points(n_points):
    """No intermediate holds (T, K): the largest is O(T K / b + T M) for b = 64 points a block."""
    n_modes, n_steps = 10, 1024
    shapes = jax.ShapeDtypeStruct((n_points, 3, n_modes), jnp.float64)
    blocks = jax.eval_shape(point_blocks, shapes, jax.ShapeDtypeStruct((n_points, 3), jnp.float64))
    q = jax.ShapeDtypeStruct((n_steps, n_modes), jnp.float64)
    jaxpr = jax.make_jaxpr(deviation_point)(blocks, q).jaxpr
    largest = _largest_intermediate(jaxpr)
    n_blocks = blocks.radius.shape[0]
    assert largest <= 3 * n_steps * n_blocks + n_steps * n_modes
    assert largest < n_steps * n_points / 10


def test_kd_blocks_hold_every_point_once_and_bound_their_members():
    model = random_model(seed=9, n_points=333, n_modes=4)
    order = np.asarray(kd_order(jnp.asarray(model.points), 64))
    assert sorted(order[order < 333].tolist()) == list(range(333))
    blocks = blocks_of(model)
    index = np.asarray(blocks.index)
    assert sorted(index[index < 333].tolist()) == list(range(333))
    np.testing.assert_array_equal(index.ravel()[np.asarray(blocks.slot)], np.arange(333))
    shapes = np.asarray(model.shapes)
    centres = np.asarray(blocks.centres).reshape(4, 3, -1).transpose(2, 1, 0)  # (nB, 3, M)
    for b, members in enumerate(index):
        members = members[members < 333]
        spread = np.linalg.norm(shapes[members] - centres[b], axis=1)  # (b, M)
        assert (spread <= np.asarray(blocks.radius)[b] * (1 + 1e-12)).all()


def test_blocks_built_with_numpy_equal_the_traceable_ones():
    """A concrete model's blocks are built with NumPy (nothing to compile), a traced one's
    with jax.numpy: both stable sorts and the same arithmetic, so the same blocks (the
    traced path is what vmap over a robust grid of models uses)."""
    model = random_model(seed=4, n_points=517, n_modes=5)
    shapes, points = np.asarray(model.shapes), np.asarray(model.points)
    concrete = point_blocks(shapes, points)
    traced = jax.jit(point_blocks)(jnp.asarray(shapes), jnp.asarray(points))
    for name in ("index", "slot"):
        np.testing.assert_array_equal(getattr(concrete, name), getattr(traced, name))
    for name in ("shapes", "centres", "radius"):
        # the same float64 operations; XLA may fuse the sums differently: 1e-13 relative
        np.testing.assert_allclose(getattr(concrete, name), getattr(traced, name), rtol=1e-13)
