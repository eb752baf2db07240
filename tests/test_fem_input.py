"""Bad input gets clear errors; mesh files through meshio."""

from __future__ import annotations

import meshio
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import fem
from fem.mesh.meshing import graded_coordinates
from jaxflex.errors import InputError

PLATE = fem.rectangular_plate(0.6, 0.4, mesh_size=0.03)
THREE = fem.default_gripper(0.6, 0.4, 0.03)[:3]


@pytest.mark.parametrize(
    ("supports", "message"),
    [
        ([fem.SuctionCup(0.7, 0.2, 0.03), *THREE], "off the part"),
        ([fem.SuctionCup(0.02, 0.2, 0.03), *THREE], "overhangs"),
        ([fem.SuctionCup(0.2, 0.2, 0.03), fem.SuctionCup(0.24, 0.2, 0.03),
          fem.SuctionCup(0.4, 0.3, 0.03)], "overlap"),
        (fem.default_gripper(0.6, 0.4, 0.03)[:2], "at least 3 non-collinear"),
        ([fem.SuctionCup(x, 0.2, 0.03) for x in (0.1, 0.3, 0.5)], "collinear"),
        ([], "0 cup"),
        ([fem.PointSupport(0.7, 0.1)], "off the part"),
    ],
)  # fmt: skip
def test_bad_gripper_layouts(supports, message):
    with pytest.raises(InputError, match=message):
        fem.modal_analysis(PLATE, supports, 4)


@pytest.mark.parametrize(
    ("factory", "message"),
    [
        (lambda: fem.rectangular_plate(thickness=0.0), "thickness"),
        (lambda: fem.rectangular_plate(width=-1.0), "width"),
        (lambda: fem.rectangular_plate(mesh_size=float("nan")), "mesh_size"),
        (lambda: fem.rectangular_plate(material="wood"), "unknown preset"),
        (lambda: fem.rectangular_plate(material={"E_pa": 1e9, "nu": 0.6, "rho": 1}), "Poisson"),
        (lambda: fem.rectangular_plate(material={"E_pa": 1e9}), "missing"),
        (lambda: fem.rectangular_plate(element="quad"), "element"),
        (lambda: fem.curved_panel(radius_y=0.3), "radius_y"),
        (lambda: fem.SuctionCup(0.1, 0.1, 0.0), "radius"),
        (lambda: fem.ClampedEdge("middle"), "side"),
        (lambda: fem.modal_analysis(PLATE, fem.ClampedEdge(), 0), "n_modes"),
        (lambda: fem.modal_analysis("plate", fem.ClampedEdge(), 3), "part"),
        (lambda: fem.modal_analysis(PLATE, [fem.ClampedEdge(), "cup"], 3), r"supports\[1\]"),
    ],
)
def test_bad_parameters(factory, message):
    with pytest.raises(InputError, match=message):
        factory()


def test_modal_model_points_off_the_part():
    result = fem.modal_analysis(PLATE, fem.ClampedEdge(), 3)
    with pytest.raises(InputError, match="off the part"):
        result.to_modal_model(points=[[0.3, 0.2], [0.9, 0.2]])
    with pytest.raises(InputError, match="nearest node"):
        result.to_modal_model(points=[[0.3, 0.2, 0.5]])


def test_unreadable_and_wrong_meshes(tmp_path):
    with pytest.raises(InputError, match="does not exist"):
        fem.read_mesh(tmp_path / "missing.msh", thickness=1e-3)
    garbage = tmp_path / "garbage.vtu"
    garbage.write_text("this is not a mesh")
    with pytest.raises(InputError, match="cannot read"):
        fem.read_mesh(garbage, thickness=1e-3)
    points = np.array([[0, 0, 0], [1000, 0, 0], [0, 1000, 0]], dtype=float)
    mm = tmp_path / "mm.vtu"
    meshio.write(mm, meshio.Mesh(points, [("triangle", np.array([[0, 1, 2]]))]))
    with pytest.raises(InputError, match="metres"):
        fem.read_mesh(mm, thickness=1e-3)
    tilted = tmp_path / "tilted.vtu"
    meshio.write(
        tilted,
        meshio.Mesh(
            points * 1e-3 + [[0, 0, 0], [0, 0, 0.5], [0, 0, 0]],
            [("triangle", np.array([[0, 1, 2]]))],
        ),
    )
    # triangles off the plane z = const are a shell; a plate formulation is refused by name
    assert fem.read_mesh(tilted, thickness=1e-3).element == "shell"
    with pytest.raises(InputError, match="flat plate in a plane z = const"):
        fem.read_mesh(tilted, thickness=1e-3, element="morley")
    with pytest.raises(InputError, match="thickness"):
        fem.read_mesh(mm, scale=1e-3)


def _grid(width, height, nx, ny):
    x, y = np.meshgrid(np.linspace(0, width, nx + 1), np.linspace(0, height, ny + 1), indexing="ij")
    idx = np.arange(x.size).reshape(x.shape)
    quads = np.column_stack(
        [idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()]
    )
    return np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)]), quads


def test_mesh_files_give_the_same_model_as_built_in_parts(tmp_path):
    # the same rectangle as triangles (plate), quads (mid-surface) and one-layer hexahedra
    points, quads = _grid(0.4, 0.3, 8, 6)
    tris = np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])
    meshio.write(tmp_path / "tri.vtu", meshio.Mesh(points, [("triangle", tris)]))
    # a clockwise quad among counter-clockwise ones: orientation is repaired
    quads_mixed = quads.copy()
    quads_mixed[3] = quads_mixed[3][::-1]
    meshio.write(tmp_path / "quad.vtu", meshio.Mesh(points, [("quad", quads_mixed)]))
    h = 2e-3
    n = len(points)
    hexes = np.column_stack([quads, quads + n])
    offset = np.array([0, 0, h / 2])
    solid_points = np.concatenate([points - offset, points + offset])
    meshio.write(tmp_path / "hex.vtu", meshio.Mesh(solid_points, [("hexahedron", hexes)]))
    edge = fem.ClampedEdge("x0")

    plate = fem.modal_analysis(fem.read_mesh(tmp_path / "tri.vtu", thickness=h), edge, 4)
    built_in = fem.modal_analysis(fem.rectangular_plate(0.4, 0.3, h, mesh_size=0.05), edge, 4)
    np.testing.assert_allclose(plate.freq_hz, built_in.freq_hz, rtol=2e-2)  # diagonals differ
    # flat quads are the plate again (split as the built-in plate's grid cells are)
    quad_part = fem.read_mesh(tmp_path / "quad.vtu", thickness=h)
    assert quad_part.element == "morley"
    np.testing.assert_allclose(
        fem.modal_analysis(quad_part, edge, 4).freq_hz, plate.freq_hz, rtol=2e-2
    )
    shell = fem.modal_analysis(
        fem.read_mesh(tmp_path / "quad.vtu", thickness=h, element="hex2"), edge, 4
    )
    solid = fem.modal_analysis(fem.read_mesh(tmp_path / "hex.vtu"), edge, 4)
    assert solid.part.thickness_m == pytest.approx(h)
    # same model, other DOF numbering: round-off of a thin solid (cond ~1e9) ~1e-7
    np.testing.assert_allclose(shell.freq_hz, solid.freq_hz, rtol=1e-6)
    flat_solid = fem.modal_analysis(
        fem.rectangular_plate(0.4, 0.3, h, element="hex2", mesh_size=0.05), edge, 4
    )
    np.testing.assert_allclose(shell.freq_hz, flat_solid.freq_hz, rtol=1e-6)
    with pytest.raises(InputError, match="differs"):
        fem.read_mesh(tmp_path / "hex.vtu", thickness=5e-3)
    with pytest.raises(InputError, match="element"):
        fem.read_mesh(tmp_path / "tri.vtu", thickness=h, element="hex2")


@settings(max_examples=40, deadline=None)
@given(
    st.floats(0.2, 2.0),
    st.floats(0.01, 0.05),
    st.lists(st.floats(0.0, 1.0), min_size=0, max_size=3),
    st.floats(0.1, 0.9),
)
def test_graded_coordinates_property(length, size, centres, fine_fraction):
    fine = size * fine_fraction
    bands = [(c * length - 0.03, c * length + 0.03) for c in centres]
    x = graded_coordinates(length, size, bands, fine)
    assert x[0] == 0.0 and x[-1] == length
    spacing = np.diff(x)
    assert np.all(spacing > 0)
    # never coarser than the base size (slack: the count is rounded up, so spacing shrinks)
    assert spacing.max() <= size * (1 + 1e-9)
    for lo, hi in bands:
        inside = (x[:-1] >= max(lo, 0)) & (x[1:] <= min(hi, length))
        assert np.all(spacing[inside] <= fine * 1.05 + 1e-12)
    # smooth grading: neighbours differ by less than the growth allows
    assert np.all(spacing[1:] / spacing[:-1] < 1 + 0.3 * 2 + 1e-9)
