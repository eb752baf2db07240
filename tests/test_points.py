"""Voxel downsampling with key points."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.distance import pdist

from jaxflex._points import downsample_to_count, voxel_downsample
from jaxflex.errors import InputError


def plate_nodes(n=60, m=40):
    x, y = np.meshgrid(np.linspace(0, 1.5, n), np.linspace(0, 0.8, m), indexing="ij")
    return np.stack([x.ravel(), y.ravel(), 0.01 * np.sin(x.ravel())], axis=1)


def test_one_node_per_voxel_nearest_to_the_centre():
    nodes = np.array(
        [[0.1, 0.1, 0.1], [0.45, 0.5, 0.5], [0.9, 0.9, 0.9], [1.5, 0.5, 0.5], [1.2, 0.5, 0.5]]
    )
    picked = voxel_downsample(nodes, 1.0, min_distance_m=0)
    # voxel [0,1)^3 centre (0.5,0.5,0.5): node 1; voxel [1,2)x[0,1)^2 centre (1.5,.5,.5): node 3
    assert picked.tolist() == [1, 3]


@settings(max_examples=30, deadline=None)
@given(voxel=st.floats(0.02, 0.5), seed=st.integers(0, 100))
def test_min_distance_holds_and_keys_survive(voxel, seed):
    rng = np.random.default_rng(seed)
    nodes = rng.uniform([0, 0, 0], [1.5, 0.8, 0.05], size=(800, 3))
    keys = nodes[rng.choice(800, 3, replace=False)]
    picked = voxel_downsample(nodes, voxel, key_points=keys)
    key_idx = [int(np.argmin(np.linalg.norm(nodes - k, axis=1))) for k in keys]
    assert set(key_idx) <= set(picked.tolist())
    others = np.setdiff1d(picked, key_idx)
    if len(others) > 1:
        assert pdist(nodes[others]).min() >= 0.5 * voxel * (1 - 1e-9)
    assert len(np.unique(picked)) == len(picked)


def test_downsample_to_about_1000_points():
    nodes = plate_nodes(150, 80)
    picked = downsample_to_count(nodes, 1000, key_points=[[0.75, 0.4, 0.0]])
    assert 900 <= len(picked) <= 1100


def test_key_point_off_the_part_is_rejected():
    with pytest.raises(InputError, match="key_points: point 0"):
        voxel_downsample(plate_nodes(), 0.05, key_points=[[5.0, 5.0, 0.0]])


def test_bad_arguments():
    with pytest.raises(InputError, match="voxel_size_m"):
        voxel_downsample(plate_nodes(), 0.0)
    with pytest.raises(InputError, match="nodes"):
        voxel_downsample(np.zeros((4, 2)), 0.1)
