"""The cell (obstacles, path, pose) and the certified minimum distance of the deforming part."""

from __future__ import annotations

import json

import meshio
import numpy as np
import pytest
from conftest import random_model
from hypothesis import given, settings
from hypothesis import strategies as st

import jaxflex
from jaxflex import as_move
from jaxflex._cell import Box, Cell, HalfSpace, TriangleMesh, Via, rotation_from_degrees
from jaxflex._collision import distances, gravity_offset, min_distance
from jaxflex._engine import states_at
from jaxflex._profile import kinematics_at
from optim.cell_file import load_cell

DT = 0.01
coords = st.floats(-2.0, 2.0)
point3 = st.tuples(coords, coords, coords).map(np.array)


@settings(max_examples=80, deadline=None)
@given(p=point3, angles=st.tuples(st.floats(0, 360), st.floats(0, 360), st.floats(0, 360)))
def test_box_distance(p, angles):
    """Signed distance of a rotated box: outside, |p - closest| with the closest point on
    the box; inside, minus the distance to the nearest face (closed form in box axes)."""
    rotation = rotation_from_degrees(angles)
    box = Box([0.1, -0.2, 0.3], [0.8, 0.5, 1.2], rotation)
    d, c = box.closest(p[None])
    local = (p - box.centre_m) @ rotation
    half = box.size_m / 2
    if (np.abs(local) <= half).all():
        assert d[0] == pytest.approx(-np.min(half - np.abs(local)), abs=1e-12)
    else:
        outside = np.maximum(np.abs(local) - half, 0)
        assert d[0] == pytest.approx(np.linalg.norm(outside), abs=1e-12)
        assert np.linalg.norm(p - c[0]) == pytest.approx(d[0], abs=1e-12)
    on_box = np.abs((c[0] - box.centre_m) @ rotation)
    assert (on_box <= half + 1e-12).all() and np.isclose(on_box / half, 1.0).any()


@settings(max_examples=60, deadline=None)
@given(p=point3, corners=st.lists(point3, min_size=3, max_size=3))
def test_triangle_distance_against_sampling(p, corners):
    """The closest point on a triangle (Voronoi regions) is at least as close as any of
    5 000 points sampled on it, and no farther than the sampling's resolution."""
    a, b, c = corners
    if np.linalg.norm(np.cross(b - a, c - a)) < 1e-3:
        return
    mesh = TriangleMesh(np.array([a, b, c]), [[0, 1, 2]])
    d, nearest = mesh.closest(p[None])
    u, v = np.meshgrid(np.linspace(0, 1, 100), np.linspace(0, 1, 100))
    keep = u + v <= 1
    samples = a + u[keep, None] * (b - a) + v[keep, None] * (c - a)
    sampled = np.linalg.norm(samples - p, axis=1).min()
    spacing = max(np.linalg.norm(b - a), np.linalg.norm(c - a), np.linalg.norm(c - b)) / 99
    assert d[0] <= sampled + 1e-12
    assert d[0] >= sampled - spacing
    assert np.linalg.norm(nearest[0] - p) == pytest.approx(d[0], abs=1e-12)


def test_half_space():
    floor = HalfSpace([0, 0, 2.0], 0.5, "floor")
    d, c = floor.closest(np.array([[1.0, 2.0, 3.0], [0.0, 0.0, 0.0]]))
    np.testing.assert_allclose(d, [2.5, -0.5])
    np.testing.assert_allclose(c, [[1, 2, 0.5], [0, 0, 0.5]])


@pytest.fixture(scope="module")
def scene():
    model = random_model(n_points=25, n_modes=4, f_min_hz=2.0, f_max_hz=15.0)
    model = model.posed(rotation_from_degrees([0, 0, 30]), [0.0, 0.0, 1.0])
    acc = jaxflex.jerk_limited_move([1.2, 0.3, -0.4], 2, 10, 100, DT).acc
    obstacles = (
        Box([1.0, 0.8, 1.2], [0.4, 0.3, 0.6], rotation_from_degrees([0, 10, 0]), "post"),
        HalfSpace([0, 0, 1], 0.0, "floor"),
        TriangleMesh([[2.0, -1, 0], [2.0, 2, 0], [2.0, 0.5, 3]], [[0, 1, 2]], "wall"),
    )
    return model, acc, obstacles


def dense_distances(model, obstacles, acc, until_s, step_s=1e-4):
    """The 0.1 ms grid of the tests: (times (T,), distances (T, K) of every point to the
    nearest obstacle)."""
    t = np.arange(0.0, until_s, step_s)
    q = states_at(model, as_move(acc, DT), t)[..., 0]
    u = np.einsum("kcm,tm->tkc", np.asarray(model.shapes), q)
    base = np.asarray(model.points) + gravity_offset(model, [0, 0, -9.81])
    points = base[None] + kinematics_at(as_move(acc, DT), t)[0][:, None] + u
    d, _, _ = distances(obstacles, points.reshape(-1, 3))
    return t, d.reshape(points.shape[:2])


def test_min_distance_against_a_dense_grid(scene):
    """Certified: the 0.1 ms grid over the move and 6 s of settling finds nothing below the
    bound, and the minimum found is attained (a grid value within the grid's resolution,
    max speed 2 m/s x 0.05 ms, above it) by the point named, at the time named (its grid
    value at the nearest sample: which point and time among near-equal minima is not
    asked)."""
    model, acc, obstacles = scene
    found = min_distance(model, obstacles, as_move(acc, DT), atol=1e-6)
    t, d = dense_distances(model, obstacles, acc, 6.0 + acc.shape[0] * DT)
    dense, resolution = d.min(), 2.0 * 5e-5
    assert found.bound_m <= dense
    assert found.distance_m <= dense + 1e-6
    assert found.distance_m >= dense - resolution - 1e-6
    at = int(np.argmin(np.abs(t - found.time_s)))
    assert d[at, found.point] <= dense + resolution + 1e-6
    assert found.obstacle_name == "post"


def test_cell_files(tmp_path):
    mesh_path = tmp_path / "wall.vtu"
    meshio.write_points_cells(
        mesh_path,
        np.array([[2000.0, -1000, 0], [2000, 2000, 0], [2000, 500, 3000]]),
        [("triangle", [[0, 1, 2]])],
    )
    text = """
gravity_m_s2 = [0, 0, -9.81]
[part]
start_m = [0.0, 0.0, 0.3]
rotation_deg = [0, 0, 90]
[path]
end_m = [2.0, 0.0, 0.6]
via = [{position_m = [1.0, 0.0, 0.8], mode = "blend", tolerance_m = 0.05},
       {position_m = [1.5, 0.0, 0.8], mode = "stop"}]
[[obstacles]]
type = "box"
name = "lower die"
centre_m = [2.3, 0.0, 0.3]
size_m = [1.2, 1.2, 0.5]
[[obstacles]]
type = "half_space"
normal = [0, 0, 1]
offset_m = 0
[[obstacles]]
type = "mesh"
name = "wall"
path = "wall.vtu"
scale = 0.001
"""
    (tmp_path / "cell.toml").write_text(text)
    cell = load_cell(tmp_path / "cell.toml")
    assert [o.name for o in cell.obstacles] == ["lower die", "obstacles[1]", "wall"]
    np.testing.assert_allclose(cell.obstacles[2].vertices[0], [2.0, -1.0, 0.0])
    np.testing.assert_allclose(cell.distance_m, [2.0, 0.0, 0.3])
    np.testing.assert_allclose(cell.rotation @ [1, 0, 0], [0, 1, 0], atol=1e-12)
    assert [v.mode for v in cell.via] == ["blend", "stop"]
    data = {
        "part": {"start_m": [0, 0, 0]},
        "path": {"end_m": [1, 0, 0]},
        "obstacles": [{"type": "box", "centre_m": [0, 0, -1], "size_m": [1, 1, 1]}],
    }
    (tmp_path / "cell.json").write_text(json.dumps(data))
    assert len(load_cell(tmp_path / "cell.json").obstacles) == 1


@pytest.mark.parametrize(
    "change, message",
    [
        ({"path": {}}, r"cell\.path\.end_m"),
        ({"obstacles": [{"type": "cone"}]}, r"obstacles\[0\].*type"),
        ({"obstacles": [{"type": "box", "centre_m": [0, 0, 0]}]}, "size_m"),
        ({"obstacles": [{"type": "box", "centre_m": [0, 0, 0], "size_m": [1, 0, 1]}]}, "size_m"),
        ({"obstacles": [{"type": "box", "colour": "red"}]}, "colour"),
        (
            {"path": {"end_m": [1, 0, 0], "via": [{"position_m": [0, 0, 1], "mode": "blend"}]}},
            "tolerance_m",
        ),
        (
            {"path": {"end_m": [1, 0, 0], "via": [{"position_m": [0, 0, 1], "mode": "jump"}]}},
            "via.mode",
        ),
        ({"robots": 2}, "robots"),
    ],
)
def test_cell_errors_name_the_field(tmp_path, change, message):
    data = {"part": {"start_m": [0, 0, 0]}, "path": {"end_m": [1, 0, 0]}, **change}
    (tmp_path / "bad.json").write_text(json.dumps(data))
    with pytest.raises(jaxflex.InputError, match=message):
        load_cell(tmp_path / "bad.json")


def test_cell_objects():
    cell = Cell(
        obstacles=(HalfSpace([0, 0, 1], 0.0),),
        start_m=[0, 0, 1],
        end_m=[1, 0, 1],
        via=(Via([0.5, 0, 1.5], "stop"),),
    )
    offsets = cell.via_offsets()
    np.testing.assert_allclose(offsets[0][0], [0.5, 0, 0.5])
    assert offsets[0][1] == "stop"
    with pytest.raises(jaxflex.InputError, match="obstacles"):
        Cell(obstacles=("wall",), end_m=[1, 0, 0])
