"""The animation of a result (optim.animate): its frames are the engine's response.

The press scene of tests/test_optim_cell.py (a 0.6 x 0.4 m plate at all 1 505 FE nodes, 8
modes, through a press opening, 10 mm from the dies, the stress limited) is optimised once
and animated; the ParaView series is read back with meshio (each frame's geometry with
h5py) and checked against
jaxflex.simulate with the rigid path integrated independently (tests/independent.py), the
certified closest approach and the certified stress peak; the model file's surface group
and the fallbacks of models without one are checked on their own.
"""

from __future__ import annotations

import json
import shutil
import xml.etree.ElementTree as ET
from html.parser import HTMLParser
from pathlib import Path

import h5py
import meshio
import numpy as np
import pytest
from cells import PRESS_TOML, press_cell
from conftest import run_jaxflex
from independent import path_positions, static_nodes

import fem
import jaxflex
import optim
from jaxflex.errors import ModelError
from jaxflex.response import Turn, rotation_residual, turning_inputs
from optim.animate import animate
from optim.animate_frames import frame_times, scene_of_result
from optim.animate_surface import mid_surface, reduced, skins
from optim.cli import input_records

DT = 0.01
LIMITS = optim.Limits(2.0, 10.0, 100.0)
THRESHOLD = 5e-4


@pytest.fixture(scope="module")
def fe_plate():
    part = fem.rectangular_plate(0.6, 0.4, 1e-3, "steel", 0.025)
    cups = [fem.SuctionCup(x, y, 0.03) for x in (0.15, 0.45) for y in (0.1, 0.3)]
    return fem.modal_analysis(part, cups, n_modes=8, zeta=0.02, progress=False)


@pytest.fixture(scope="module")
def press(fe_plate, tmp_path_factory):
    """(result, animation, its directory) of the press scene; the result's report records
    its model and cell files (in the directory's parent) as `jaxflex optimize` does."""
    model = fe_plate.to_modal_model()
    result = optim.optimize(
        model,
        None,
        LIMITS,
        DT,
        THRESHOLD,
        constraints=optim.Constraints(
            cell=press_cell(), min_distance_m=0.01, max_stress_pa="yield"
        ),
    )
    inputs = tmp_path_factory.mktemp("inputs")
    model.save(inputs / "plate.npz")
    (inputs / "press.toml").write_text(PRESS_TOML, encoding="utf-8")
    result.inputs = input_records(str(inputs / "plate.npz"), str(inputs / "press.toml"))
    directory = tmp_path_factory.mktemp("press")
    result.save(directory, plots=False)
    return result, animate(result, directory), directory


class _References(HTMLParser):
    """The src and href attributes of a page's elements (a script's text is not parsed)."""

    def __init__(self) -> None:
        super().__init__()
        self.found: list[str] = []

    def handle_starttag(self, tag, attrs) -> None:
        self.found += [value for name, value in attrs if name in ("src", "href") and value]


def outside_references(text: str) -> list[str]:
    parser = _References()
    parser.feed(text)
    return parser.found


def read_frames(series: Path) -> list[tuple[float, meshio.Mesh]]:
    """(time, mesh) of every frame of the XDMF series ``series``: the triangles, times and
    point data read with meshio's TimeSeriesReader, each frame's own geometry (which that
    reader does not read) with h5py from the dataset its grid's Geometry names."""
    grids = ET.parse(series).getroot().find("Domain").find("Grid").findall("Grid")
    out = []
    with (
        meshio.xdmf.TimeSeriesReader(series) as reader,
        h5py.File(series.with_suffix(".h5"), "r") as h5,
    ):
        _, cells = reader.read_points_cells()
        for k, grid in enumerate(grids):
            t, point_data, _ = reader.read_data(k)
            file, dataset = grid.find("Geometry").find("DataItem").text.split(":")
            assert file == series.with_suffix(".h5").name
            out.append((t, meshio.Mesh(h5[dataset][()], cells, point_data=point_data)))
    return out


def mid_positions(mesh: meshio.Mesh) -> np.ndarray:
    """(K, 3) where the engine puts each node: the mean of its two skin points (each the
    rigid pose plus the displacement; the skins lie +-h/2 off the mid-surface)."""
    drawn = mesh.points + mesh.point_data["displacement"]
    node = mesh.point_data["node"]
    out = np.zeros((node.max() + 1, 3))
    np.add.at(out, node, drawn / 2)
    return out


def test_every_frame_is_the_engines_response(press, fe_plate):
    """Every frame on the sample grid: the node positions that part.xdmf draws (rigid pose
    plus displacement) equal the posed model's points, its sag under gravity, the rigid
    path (integrated here in closed form, tests/independent.py) and jaxflex.simulate's
    displacement, to 1e-12 m (float64 rounding of positions of metres: 2e-16 relative);
    the sag agrees with a direct FE solve to 1e-9 m (the model's static shapes)."""
    result, animation, _ = press
    frames = read_frames(animation.series)
    times = np.array([t for t, _ in frames])
    setup = result.cell
    model = setup.model
    expected_t, _ = frame_times(scene_of_result(result))
    assert np.array_equal(times, expected_t)
    assert times[-1] >= result.cycle_time_s
    on_grid = np.abs(times / DT - np.rint(times / DT)) < 1e-9
    k = np.rint(times[on_grid] / DT).astype(int)
    response = jaxflex.simulate(
        model, result.move, displacement=True, extend_s=times[-1] - result.move.duration_s
    )
    sag = model.static_displacement(-setup.gravity_m_s2)
    path = path_positions(result.acc, DT, times[on_grid])
    worst = 0.0
    for j, (_, mesh) in enumerate(f for f, g in zip(frames, on_grid, strict=True) if g):
        expected = model.points + sag + path[j] + np.asarray(response.displacement[k[j]])
        worst = max(worst, float(np.abs(mid_positions(mesh) - expected).max()))
    assert worst <= 1e-12
    fe_sag = static_nodes(fe_plate, -setup.gravity_m_s2)
    assert np.abs(sag - fe_sag).max() <= 1e-9


def test_the_closest_frame_is_the_certified_witness(press):
    """The certified closest approach (report: its time, point and distance) is a frame of
    its own; there the point's distance field is the certified distance (to 1e-9 m: the
    same positions evaluated by another route), no point is closer by more than the
    certificate's tolerance (1e-6 m), and report.json's where_m is that point's position
    then (start_m where it started)."""
    result, animation, _ = press
    (distance,) = [c for c in result.constraints if "distance" in c["name"]]
    frames = read_frames(animation.series)
    time, mesh = min(frames, key=lambda f: abs(f[0] - distance["time_s"]))
    assert time == distance["time_s"]
    field = mesh.point_data["distance_m"]
    at_point = field[mesh.point_data["node"] == distance["item"]]
    assert np.abs(at_point - distance["peak"]).max() <= 1e-9
    assert field.min() >= distance["peak"] - 1e-6
    assert np.abs(mid_positions(mesh)[distance["item"]] - distance["where_m"]).max() <= 1e-9
    assert distance["start_m"] == result.cell.model.points[distance["item"]].tolist()


def test_the_stress_field_holds_the_certified_peak(press):
    """No frame draws more von Mises stress than the certified peak (within the peak's
    tolerance, 1e-6 relative), and a frame lies within half a frame's spacing of the
    certified peak's time (the certificate scans every dt / 8 during the move,
    optim.cell_rows.check_times, so the peak may fall between the frames' samples)."""
    result, animation, _ = press
    (stress,) = [c for c in result.constraints if "stress" in c["name"]]
    frames = read_frames(animation.series)
    largest = max(float(mesh.point_data["von_mises_pa"].max()) for _, mesh in frames)
    assert largest <= stress["peak"] * (1 + 1e-6)
    times = np.array([t for t, _ in frames])
    nearest = int(np.argmin(abs(times - stress["time_s"])))
    spacing = np.diff(times)[min(nearest, len(times) - 2)]
    assert abs(times[nearest] - stress["time_s"]) <= spacing / 2 + 1e-12


def test_the_files_open_and_the_page_is_self_contained(press, tmp_path):
    """part.h5 holds the triangles once and takes under 0.3 of its arrays' bytes;
    cell.vtu (three obstacles: 12 + 12 + 2 triangles) and path.vtu open in meshio; the
    path runs from A through the via point's tolerance to B; the page inlines everything
    (no src or href to anything outside it), under 20 MB, and states its reduction."""
    result, animation, directory = press
    cell = meshio.read(animation.directory / "cell.vtu")
    assert len(cell.cells_dict["triangle"]) == 26
    assert sorted(set(cell.cell_data["obstacle"][0])) == [0, 1, 2]
    path = meshio.read(animation.directory / "path.vtu")
    start, end = press_cell().start_m, press_cell().end_m
    assert np.allclose(path.points[0], start, atol=1e-12)
    assert np.allclose(path.points[len(animation.frames.t_s) - 1], end, atol=1e-12)
    text = animation.page.read_text(encoding="utf-8")
    assert animation.page_bytes <= 20e6
    assert outside_references(text) == []
    assert "reduced for size" in text
    with h5py.File(animation.directory / "part.h5", "r") as h5:
        raw = []
        h5.visititems(lambda _, item: raw.append(getattr(item, "nbytes", 0)))
        assert h5["topology"].shape == (len(skins(mid_surface(result.cell.model)).triangles), 3)
    grids = ET.parse(animation.series).getroot().iter("Grid")
    named = {g.find("Topology/DataItem").text for g in grids if g.find("Topology") is not None}
    assert named == {"part.h5:/topology"}
    # once each: the triangles and node indices; a frame's float64 arrays, each node's values
    # the same on both skins (side by side) stored about once by gzip: 0.26 of the raw bytes
    # here (0.37 with the skins one after the other; 0.21 for the README's press scene)
    assert animation.series.with_suffix(".h5").stat().st_size <= 0.3 * sum(raw)
    manifest = json.loads((animation.directory / "manifest.json").read_text())
    assert manifest["kind"] == "jaxflex.animation"
    members = {"part.xdmf", "part.h5", "cell.vtu", "path.vtu", "animation.html"}
    assert set(manifest["files"]) == members
    copy = tmp_path / "again"
    shutil.copytree(directory, copy)
    result.save(copy, plots=False)  # a new result is not the animation's: removed
    assert not (copy / "animation").exists()
    assert animation.series.is_file()


def test_the_command_animates_a_result_directory(press, tmp_path):
    """`jaxflex animate RESULT_DIR` reads the model and cell files the report records and
    writes the same frames as optim.animate in memory, removing the series an earlier
    jaxflex wrote there (part.pvd over part_NNNN.vtu); a model file changed since is
    refused naming --model (exit 2)."""
    result, animation, directory = press
    copy = tmp_path / "press"
    copy.mkdir()
    for name in ("trajectory.csv", "report.json", "manifest.json"):
        (copy / name).write_bytes((directory / name).read_bytes())
    earlier = [copy / "animation" / name for name in ("part.pvd", "part_0000.vtu")]
    earlier[0].parent.mkdir()
    for path in earlier:
        path.write_text("an earlier series", encoding="utf-8")
    done = run_jaxflex("animate", str(copy), "-q")
    assert done.returncode == 0, done.stderr
    assert "animation:" in done.stdout
    assert not any(path.exists() for path in earlier)
    again = read_frames(copy / "animation" / "part.xdmf")
    first = read_frames(animation.series)
    assert [t for t, _ in again] == [t for t, _ in first]
    for (_, a), (_, b) in zip(again, first, strict=True):
        assert np.array_equal(a.points, b.points)
        assert np.array_equal(a.point_data["displacement"], b.point_data["displacement"])
    model_file = Path(result.inputs["model"]["path"])
    changed = tmp_path / "changed.npz"
    jaxflex.load_model(model_file).with_damping(0.03).save(changed)
    refused = run_jaxflex("animate", str(copy), "--model", str(changed))
    assert refused.returncode == 2
    assert "--model" in refused.stderr and "SHA-256" in refused.stderr
    # a settling of 1e9 s would be 1e11 frames (745 GiB for their times alone): planned
    # and refused before any array is made, naming what to change
    endless = run_jaxflex("animate", str(copy), "--after", "1e9")
    assert endless.returncode == 2, endless.stderr
    assert "Traceback" not in endless.stderr
    assert "memory: the animation (100000" in endless.stderr and "--after" in endless.stderr


def test_the_model_file_carries_the_mesh(fe_plate, tmp_path):
    """A model at every FE node carries the mesh's triangles (its area is the plate's), the
    file keeps them, a point selection keeps the triangles it keeps whole, and indices out
    of range are refused naming the field."""
    model = fe_plate.to_modal_model()
    corners = model.points[model.surface]
    area = 0.5 * np.linalg.norm(
        np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1
    )
    assert area.sum() == pytest.approx(0.6 * 0.4, rel=1e-12)
    model.save(tmp_path / "m.npz")
    again = jaxflex.load_model(tmp_path / "m.npz")
    assert np.array_equal(again.surface, model.surface)
    first = model.surface[0]
    picked = model.select_points(first)
    assert picked.surface.tolist() == [[0, 1, 2]]
    assert fe_plate.to_modal_model(points=100).surface is None
    with pytest.raises(ModelError, match="surface"):
        model._replace(surface=[[0, 1, model.n_points]])


def test_models_without_a_mesh_are_drawn_from_their_points(fe_plate):
    """A voxel-reduced model (no mesh) is triangulated in its plane, covering most of the
    plate and nothing outside it; points that span no plane stay a point cloud; the page's
    reduction keeps real points and triangles over them."""
    model = fe_plate.to_modal_model(points=200)
    mid = mid_surface(model)
    assert mid.kind == "triangulated"
    corners = model.points[mid.triangles]
    area = (
        0.5
        * np.linalg.norm(
            np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1
        ).sum()
    )
    span = np.ptp(model.points[:, :2], axis=0).prod()
    assert 0.8 * span <= area <= span * (1 + 1e-9)
    rng = np.random.default_rng(1)
    cloud = model._replace(points=rng.uniform(-1, 1, (model.n_points, 3)))
    assert mid_surface(cloud).kind == "points"
    full = mid_surface(fe_plate.to_modal_model())
    small = reduced(fe_plate.to_modal_model().points, full, 300)
    assert small.n_vertices <= 300
    assert len(small.triangles) and small.triangles.max() < small.n_vertices
    both = skins(full)
    assert both.n_vertices == 2 * full.n_vertices
    assert set(np.unique(both.side)) == {-1, 1}


def test_a_turning_move_ends_at_rest_in_its_final_pose(turning_plate, tmp_path):
    """A tilt (30 deg about x, lifted 0.3 m): every frame (all on the sample grid) draws
    the turning engine's state as the FMU tests write the positions out (1e-12 m); the
    first frame is the part hanging at rest (points plus the model's sag), and the last
    one, after the cycle time, the part turned rigidly about the pivot with the sag of its
    final pose, within the threshold (the deviation stays below it after the cycle time):
    statics, not the engine."""
    pivot = turning_plate.points.mean(axis=0)
    result = optim.optimize(
        turning_plate,
        [0, 0, 0.3],
        LIMITS,
        DT,
        THRESHOLD,
        rotation=optim.Rotation("x", 30, pivot_m=pivot),
    )
    animation = animate(result, tmp_path)
    frames = read_frames(animation.series)
    gravity = np.array([0.0, 0.0, -9.81])
    # every frame: c + s + R (x - c + u), u the whole elastic displacement of the turning
    # engine's state (modes, the static residuals of the translation and the rotational
    # loads; jaxflex._turning), written here as tests/test_fmu_turning.py does
    path = result.turn.path(result.angular_acc, DT)
    times = np.array([t for t, _ in frames])
    extend = times[-1] - result.move.duration_s
    inputs = turning_inputs(turning_plate, Turn(path, result.acc, pivot_m=pivot), extend_s=extend)
    u = (
        np.einsum("kcm,tm->tkc", np.asarray(turning_plate.shapes), inputs.q)
        + np.einsum("kcm,tm->tkc", np.asarray(turning_plate.static_residual), inputs.base)
        + np.einsum("kcm,tm->tkc", rotation_residual(turning_plate), inputs.coefficients)
    )
    k = np.rint(times / DT).astype(int)
    n = result.n_steps
    rotation = np.asarray(path.rotation)[np.minimum(k, n)]
    s = path_positions(result.acc, DT, times)
    local = turning_plate.points[None] - pivot + u[k]
    expected = pivot + s[:, None] + np.einsum("tab,tkb->tka", rotation, local)
    drawn = np.stack([mid_positions(mesh) for _, mesh in frames])
    assert np.abs(drawn - expected).max() <= 1e-12
    first = mid_positions(frames[0][1])
    sag = turning_plate.static_displacement(-gravity)
    assert np.abs(first - (turning_plate.points + sag)).max() <= 1e-12
    angle = np.radians(30)
    r = np.array([[1, 0, 0], [0, np.cos(angle), -np.sin(angle)], [0, np.sin(angle), np.cos(angle)]])
    rest = turning_plate.static_displacement(-(r.T @ gravity))
    end = pivot + np.array([0, 0, 0.3]) + (turning_plate.points - pivot + rest) @ r.T
    assert frames[-1][0] > result.cycle_time_s
    assert np.linalg.norm(mid_positions(frames[-1][1]) - end, axis=1).max() <= THRESHOLD
