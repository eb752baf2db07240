"""The FMU's outputs over every point, evaluated over blocks of points with bounds
(fmu/c/jxf_blocks.c): the same numbers as the evaluation of every point.

At each step the part FMU evaluates the deviation (and, when read, the distance to the
obstacles) only in the blocks of points whose bounds can beat the largest deviation (the
smallest distance) found. The reference is the same FMU built from its own sources with
-DJXF_EVERY_POINT: every point evaluated at every step, nothing skipped. Each point's value
is computed by the same code in both builds, so the outputs agree to the last bit where the
pruning is exact; the assertions allow the issue's 1e-15 relative. The FMU's log says how
many blocks it evaluated, so the tests also check that the bounds did skip most of them
(else the comparison would prove nothing), and the FMI 3.0 arrays, evaluated when read, give
every point: they equal the reference's, and min_distance is their minimum.
"""

from __future__ import annotations

import re
import shutil
import zipfile

import numpy as np
import pytest
from conftest import random_model
from hypothesis import given, settings
from hypothesis import strategies as st

import fem
import jaxflex
from fem.scenes import default_gripper
from fmu import export_fmu
from fmu.build import compile_library
from fmu.master import Session
from fmu.options import CellOutputs, Fmi, Turning
from fmu.toolchain import host_target
from fmu.variables import POSE_INPUT_NAMES
from jaxflex._cell import Box, Cell, HalfSpace, TriangleMesh, rotation_from_degrees

DT = 0.01
REL = 1e-15  # the tolerance; the builds agree bit for bit
SCALARS = ("deviation", "settled", "settle_time", "min_distance")
ARRAYS = ("displaced_points", "point_distances")
LOGGED = re.compile(r"the deviation evaluated (\d+) of (\d+) blocks")

pytestmark = pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc is not installed")


@pytest.fixture(scope="module")
def part():
    """A 0.8 x 0.5 m, 1 mm steel plate on four cups, 8 modes at every one of its 1645 FE
    nodes (52 blocks), with its static and rotational residuals (fem)."""
    plate = fem.rectangular_plate(0.8, 0.5, 1e-3, "steel", 0.025)
    result = fem.modal_analysis(plate, default_gripper(0.8, 0.5), n_modes=8, zeta=0.02)
    return result.to_modal_model()


@pytest.fixture(scope="module")
def cell():
    """A floor 2 cm under the plate (parallel to it: every block nearly as close), a turned
    post beside its path and a wall triangle ahead."""
    return Cell(
        obstacles=(
            HalfSpace([0, 0, 1], -0.02, "floor"),
            Box([1.3, 0.25, 0.1], [0.2, 0.2, 0.4], rotation_from_degrees([0, 0, 30]), "post"),
            TriangleMesh([[1.6, -1, -1], [1.6, 1, -1], [1.6, 0, 2]], [[0, 1, 2]], "wall"),
        ),
        start_m=[0.0, 0.0, 0.0],
        end_m=[0.3, 0.0, 0.05],
    )


def _pair(result, folder):
    """The FMU extracted twice: as written (pruned) and with its library rebuilt from its
    sources with -DJXF_EVERY_POINT (the reference)."""
    folders = {}
    for kind in ("pruned", "every_point"):
        folders[kind] = folder / kind
        with zipfile.ZipFile(result.fmu_path) as zf:
            zf.extractall(folders[kind])
    platform = host_target().folder(result.fmi_version)
    library = folders["every_point"] / "binaries" / platform / f"{result.model_identifier}.so"
    compile_library(
        host_target(),
        folders["every_point"] / "sources",
        result.fmi_version,
        library,
        extra_flags=("-DJXF_EVERY_POINT",),
    )
    return folders


def _run(folder, drive, n_steps, start_values=None):
    """Step the FMU in ``folder`` ``n_steps`` times (``drive(session, k)`` sets the inputs
    before step k): every output of SCALARS and ARRAYS it has after each step, and the
    (evaluated, offered) blocks its log reports when it is freed."""
    with Session(folder, unzip_dir=folder, debug=True) as session:
        session.start(0.0, start_values)
        names = [n for n in (*SCALARS, *ARRAYS) if n in session.variables]
        rows = []
        for k in range(n_steps):
            drive(session, k)
            session.step(k * DT, DT)
            rows.append({name: np.asarray(session.get(name), float) for name in names})
    logged = [LOGGED.search(text) for _, text in session.messages]
    counts = next(tuple(map(int, hit.groups())) for hit in logged if hit)
    return rows, counts


def _assert_same(pruned, every_point):
    for k, (got, want) in enumerate(zip(pruned, every_point, strict=True)):
        for name, value in want.items():
            scale = np.max(np.abs(value)) if value.size else 0.0
            diff = np.max(np.abs(got[name] - value)) if value.size else 0.0
            assert diff <= REL * scale, (k, name, diff, scale)
        if "point_distances" in got:  # the scalar is the minimum of the array, exactly
            assert got["min_distance"] == got["point_distances"].min(), k


def _replay(session, k):
    """Nothing to set: the FMU replays its embedded move."""


@pytest.mark.parametrize("version", [2, 3])
def test_straight_part_outputs_equal_every_point(part, cell, tmp_path, version):
    """The plate moved by its embedded move in the cell, then settling: deviation, settled,
    settle time and min_distance (FMI 3.0: and every point's displaced position and
    distance, read every step) equal the every-point build's at every step, while the
    pruned build evaluated less than a fifth of the blocks."""
    acc = np.zeros((61, 3))
    acc[1:60] = np.sin(np.linspace(0, 2 * np.pi, 59))[:, None] * [4.0, -2.0, 6.0]
    result = export_fmu(
        part,
        tmp_path / f"p{version}.fmu",
        jaxflex.as_move(acc, DT),
        fmi=Fmi(version, windows=False),
        threshold_m=1e-4,
        outputs=CellOutputs(cell),
    )
    folders = _pair(result, tmp_path)
    start = {"use_embedded_trajectory": True}
    pruned, (evaluated, offered) = _run(folders["pruned"], _replay, 120, start)
    reference, (all_evaluated, all_offered) = _run(folders["every_point"], _replay, 120, start)
    _assert_same(pruned, reference)
    assert all_evaluated == all_offered  # the reference evaluated every block
    assert evaluated < offered / 5, (evaluated, offered)
    settled = [bool(row["settled"]) for row in pruned]
    assert not all(settled) and settled[-1]  # beyond the threshold while moving, then settled


def _turn(session, k):
    """A 0.4 rad turn about the vertical with a tilt, while the pivot accelerates."""
    s = min(k / 60.0, 1.0)
    angle, rate = 0.4 * (s - np.sin(2 * np.pi * s) / (2 * np.pi)), 0.0
    if k < 60:
        rate = 0.4 * (1 - np.cos(2 * np.pi * s)) / (60 * DT)
    axis = np.array([0.2, 0.0, 1.0]) / np.hypot(0.2, 1.0)
    quat = [np.cos(angle / 2), *(np.sin(angle / 2) * axis)]
    alpha = 0.4 * 2 * np.pi * np.sin(2 * np.pi * s) / (60 * DT) ** 2 if k < 60 else 0.0
    acc = [3.0 * np.sin(np.pi * s), -1.0, 2.0] if k < 60 else [0.0, 0.0, 0.0]
    pose = [*quat, *(rate * axis), *(alpha * axis)]
    session.set_inputs([*acc, *pose], names=("ax", "ay", "az", *POSE_INPUT_NAMES))


@pytest.mark.parametrize("version", [2, 3])
def test_turning_part_outputs_equal_every_point(part, cell, tmp_path, version):
    """The same plate as a turning part in the cell, its pose set every step: its
    deviation (about the sag of the current pose), settled flag and min_distance (the
    blocks' bounds turned with the part) equal the every-point build's."""
    result = export_fmu(
        part, tmp_path / f"t{version}.fmu", fmi=Fmi(version, windows=False), threshold_m=5e-5,
        outputs=CellOutputs(cell), turning=Turning([0.4, 0.25, 0.0]),
    )  # fmt: skip
    folders = _pair(result, tmp_path)
    pruned, (evaluated, offered) = _run(folders["pruned"], _turn, 100)
    reference, _ = _run(folders["every_point"], _turn, 100)
    _assert_same(pruned, reference)
    assert evaluated < offered / 2, (evaluated, offered)
    assert not all(bool(row["settled"]) for row in pruned)  # the turn deforms the part


def _nearly_rigid(n_points: int = 400, n_modes: int = 6):
    """Every point displaces almost alike: shapes constant over the part but for a smooth
    variation of 1e-7 of them, so the blocks' maxima differ by next to nothing and a bound
    that undercut any block's true maximum would leave the wrong one out."""
    rng = np.random.default_rng(11)
    points = rng.uniform(size=(n_points, 3)) * [1.0, 0.6, 0.01]
    wave = np.sin(points @ rng.normal(size=(3, n_modes)) * 3.0)  # (K, M) smooth in X
    base = rng.normal(size=(3, n_modes))
    shapes = base[None] * (1.0 + 1e-7 * wave[:, None, :])
    model = random_model(11, n_points=n_points, n_modes=n_modes)
    return model.__class__(
        freq_hz=model.freq_hz, zeta=model.zeta, gamma=model.gamma, shapes=shapes, points=points
    )


@pytest.fixture(scope="module")
def random_pairs(part, tmp_path_factory):
    """FMI 2.0 pairs (pruned, every point) of the plate, of a nearly rigid part (the bounds
    must be tight) and of a model with random shapes (no spatial order: no bound excludes a
    block, the FMU evaluates them all)."""
    root = tmp_path_factory.mktemp("pruning_pairs")
    scattered = random_model(7, n_points=300, n_modes=10)
    pairs = {}
    for name, model in (("plate", part), ("rigid", _nearly_rigid()), ("scattered", scattered)):
        result = export_fmu(model, root / f"{name}.fmu", fmi=Fmi(windows=False), threshold_m=1e-4)
        pairs[name] = _pair(result, root / name)
    return pairs


@settings(max_examples=12, deadline=None)
@given(
    name=st.sampled_from(["plate", "rigid", "scattered"]),
    samples=st.lists(
        st.tuples(*[st.floats(-20.0, 20.0, allow_nan=False)] * 3), min_size=3, max_size=25
    ),
)
def test_any_inputs_give_the_every_point_outputs(random_pairs, name, samples):
    """Arbitrary accelerations (held over 10 ms steps, with their slopes to the next
    sample): the deviation, settled flag and settle time equal the every-point build's."""
    acc = np.array([*samples, (0.0, 0.0, 0.0)])

    def drive(session, k):
        session.set_inputs(acc[k], (acc[k + 1] - acc[k]) / DT)

    folders = random_pairs[name]
    pruned, _ = _run(folders["pruned"], drive, len(samples))
    reference, _ = _run(folders["every_point"], drive, len(samples))
    _assert_same(pruned, reference)
