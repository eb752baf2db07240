"""Built-in scenes, export for viewing, pictures and the ``jaxflex model`` command."""

from __future__ import annotations

import meshio
import numpy as np
import pytest

import fem
import jaxflex
from jaxflex.cli import main


@pytest.fixture(scope="module")
def small_result():
    part = fem.rectangular_plate(0.6, 0.4, mesh_size=0.03)
    return fem.modal_analysis(
        part, fem.default_gripper(0.6, 0.4, 0.03), 6, zeta=fem.Rayleigh.from_zeta(0.02, 40, 300)
    )


def test_default_plate_model():
    model = fem.default_model("plate")
    assert model.n_modes == 20
    # every FE node, with the plate's edges (the distance covers the whole part)
    assert model.n_points == int(model.meta["mesh"]["n_nodes"])
    points = np.asarray(model.points)
    np.testing.assert_allclose(points.min(axis=0)[:2], [0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(points.max(axis=0)[:2], [1.5, 0.8], atol=1e-12)
    assert model.static_shapes is not None
    assert model.meta["scene"] == "plate"
    assert model.meta["part"]["width_m"] == 1.5 and len(model.meta["gripper"]) == 4
    # 4 cups at 22 %/78 %: the part is held (first mode well above 1 Hz, ~7.5 Hz)
    assert 5.0 < model.freq_hz[0] < 10.0
    assert np.all(model.zeta == 0.02)


def test_panel_scene_is_curved_and_held():
    part, cups = fem.scene("panel", mesh_size=0.08)
    assert part.kind == "solid" and len(cups) == 4
    crown = part.surface_point([[0.75, 0.4]])[0, 2]
    corner = part.surface_point([[0.0, 0.0]])[0, 2]
    assert crown - corner > 0.1  # sag of both arcs: 0.11 m + 0.07 m
    with pytest.raises(jaxflex.InputError, match="scene"):
        fem.scene("door")


def test_export_modes_vtu_roundtrip(small_result, tmp_path):
    path = tmp_path / "modes.vtu"
    fem.export_modes(small_result, path, n_modes=3)
    mesh = meshio.read(path)
    np.testing.assert_allclose(mesh.points, small_result.system.nodes)
    np.testing.assert_allclose(mesh.point_data["mode_02"], small_result.node_shapes()[:, :, 1])
    assert "mode_04" not in mesh.point_data
    assert [p.name for p in tmp_path.iterdir()] == ["modes.vtu"]  # no temporary file left


def test_export_modes_and_transient_xdmf(small_result, tmp_path):
    fem.export_modes(small_result, tmp_path / "modes.xdmf")
    acc = np.zeros((11, 3))
    acc[1:-1, 2] = 2.0
    transient = fem.transient_reference(small_result, jaxflex.as_move(acc, 0.01), substeps=5)
    fem.export_transient(small_result, transient, tmp_path / "move.xdmf")
    with meshio.xdmf.TimeSeriesReader(str(tmp_path / "move.xdmf")) as reader:
        points, _ = reader.read_points_cells()
        np.testing.assert_allclose(points, transient.points)
        assert reader.num_steps == len(transient.t_s)
        t, point_data, _ = reader.read_data(5)
    assert t == pytest.approx(transient.t_s[5])
    np.testing.assert_allclose(point_data["displacement"], transient.displacement_m[5])
    with pytest.raises(jaxflex.InputError, match="suffix"):
        fem.export_modes(small_result, tmp_path / "modes.txt")


def test_plot_part(small_result, tmp_path):
    fem.plot_part(small_result, tmp_path / "part.png", n_modes=3)
    assert (tmp_path / "part.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    panel_part = fem.curved_panel(0.5, 0.3, radius_x=1.0, radius_y=0.6, mesh_size=0.05)
    panel = fem.modal_analysis(panel_part, fem.default_gripper(0.5, 0.3, 0.04), 2)
    assert panel.rigid_freq_hz.size == 0 and panel.freq_hz[0] > 1.0
    fem.plot_part(panel, tmp_path / "panel.png", n_modes=2)
    assert (tmp_path / "panel.png").stat().st_size > 1000


def test_cli_model_from_mesh_file(tmp_path, capsys):
    points = np.array([[0, 0], [0.4, 0], [0.4, 0.3], [0, 0.3], [0.2, 0.15]], dtype=float)
    tris = np.array([[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]])
    mesh = meshio.Mesh(np.column_stack([points, np.zeros(5)]), [("triangle", tris)])
    for _ in range(3):  # refine by splitting each triangle into four
        p, t = mesh.points, mesh.cells_dict["triangle"]
        edges = {}
        new_points = list(p)
        new_tris = []
        for a, b, c in t:
            mids = []
            for i, j in ((a, b), (b, c), (c, a)):
                key = (min(i, j), max(i, j))
                if key not in edges:
                    edges[key] = len(new_points)
                    new_points.append((p[i] + p[j]) / 2)
                mids.append(edges[key])
            ab, bc, ca = mids
            new_tris += [[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]
        mesh = meshio.Mesh(np.array(new_points), [("triangle", np.array(new_tris))])
    meshio.write(tmp_path / "part.vtu", mesh)
    out = tmp_path / "m.npz"
    code = main([
        "model", "--mesh", str(tmp_path / "part.vtu"), "--thickness", "1e-3",
        "--material", "aluminium", "--cups", "0.1,0.1,0.04", "0.3,0.1,0.04", "0.2,0.22,0.04",
        "--n-modes", "5", "--points", "all", "-o", str(out), "--plot", str(tmp_path / "p.png"),
        "--quiet",
    ])  # fmt: skip
    assert code == 0
    text = capsys.readouterr().out
    assert "freq [Hz]" in text and "timings" in text and "residual" in text
    model = jaxflex.load_model(out)
    assert model.n_modes == 5 and model.meta["material"]["name"] == "aluminium"
    assert (tmp_path / "p.png").exists()


def test_cli_model_errors(tmp_path, capsys):
    code = main(["model", "--scene", "plate", "--cups", "0.1,0.1,0.04", "-o", str(tmp_path / "x")])
    assert code == 2
    assert "at least 3 non-collinear" in capsys.readouterr().err
    code = main(["model", "--mesh", str(tmp_path / "none.msh"), "--thickness", "1e-3",
                 "--cups", "0.1,0.1,0.04", "-o", str(tmp_path / "x")])  # fmt: skip
    assert code == 2
    assert "does not exist" in capsys.readouterr().err
