"""The core's soft maximum (jaxflex.response.soft_max), the one the smooth cycle-time bound
and the gradient route share: its bound max <= S <= max + log(R) / s held against NumPy's
maximum of the rows, and its gradient against the closed form (the softmax weights)."""

from __future__ import annotations

import math

import jax
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from jaxflex.response import soft_max


@settings(max_examples=40, deadline=None)
@given(
    values=st.lists(st.floats(-50.0, 50.0), min_size=1, max_size=30),
    sharpness=st.sampled_from([1.0, 20.0, 200.0]),
    data=st.data(),
)
def test_soft_max_lies_between_the_maximum_and_its_excess(values, sharpness, data):
    v = np.array(values)
    mask = np.array(
        data.draw(st.lists(st.sampled_from([0.0, 1.0]), min_size=v.size, max_size=v.size))
    )
    mask[data.draw(st.integers(0, v.size - 1))] = 1.0  # at least one row counts
    exact = float(np.max(v[mask == 1]))
    count = int(mask.sum())
    soft = float(soft_max(v, sharpness, mask))
    # float64 round-off of a log-sum-exp: a few ulps of the largest term, relative
    slack = 1e-12 * max(1.0, abs(exact))
    # the bound of the module docstring: at most log(R) / s above the maximum of R rows
    assert exact - slack <= soft <= exact + math.log(count) / sharpness + slack


def test_soft_max_gradient_is_the_softmax_weights():
    rng = np.random.default_rng(3)
    v, mask, sharpness = rng.normal(size=12), (rng.random(12) > 0.3).astype(float), 7.0
    grad = np.asarray(jax.grad(lambda x: soft_max(x, sharpness, mask))(v))
    weights = mask * np.exp(sharpness * (v - v.max()))
    np.testing.assert_allclose(grad, weights / weights.sum(), rtol=1e-12, atol=1e-15)
