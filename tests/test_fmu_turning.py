"""The FMU of a turning part (export_fmu(turning=fmu.Turning(...))): the pose as inputs, the
body-frame forcing of jaxflex._turning, the deviation about the current pose's sag.

Along a swivel about the vertical and a tilt about an in-plane axis under gravity (each with
a translation of the pivot), driven by fmpy:

* FMI 2.0 with the inputs linear over each step (the master sets every input's sample and the
  slope to the next sample, fmi2SetRealInputDerivatives): the FMU evaluates the forcing at
  the same pose samples as jaxflex._turning.simulate_turning and advances it by the same exact
  first-order-hold recursion, so the two agree to rounding: a few ulps per step (the
  quaternion round trip of the rotation, the step matrices in C, another summation order),
  accumulated over ~1000 damped steps, far below the 1e-9 of the peak asserted (the bound the
  other FMU tests use for "to rounding").
* FMI 2.0 and 3.0 in fmpy.simulate_fmu with held inputs (FMI 3.0 has no input derivatives):
  the forcing of the samples held over each step; compared with that zero-order hold
  written here with scipy's matrix exponential (exact for a held forcing): to rounding again.
"""

from __future__ import annotations

import struct
import subprocess
import zipfile
import zlib
from dataclasses import replace

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu
from fmpy.fmi1 import FMICallException
from fmpy.validation import validate_fmu
from scipy.linalg import expm
from scipy.spatial.transform import Rotation
from test_turning_cell import newton_euler, skew_turn, stiff_sheet

import fem
import jaxflex
from fmu import export_fmu
from fmu.build import compile_library
from fmu.harness import SANITIZE_FLAGS, compile_harness, resource_location
from fmu.master import Session
from fmu.options import CellOutputs, Fmi, Turning
from fmu.resource import decode_resource
from fmu.toolchain import host_target
from fmu.variables import POSE_INPUT_NAMES
from fmu.verify import read_fmu_resource
from jaxflex import as_move
from jaxflex._cell import Box, Cell, HalfSpace
from jaxflex._collision import distances
from jaxflex._pose import fixed_axis_path, turn_acceleration
from jaxflex._profile import kinematics_at
from jaxflex._turning import (
    Turn,
    body_loads,
    simulate_turning,
    turning_forces,
    turning_inputs,
    turning_settle,
)
from jaxflex._turning_collision import turning_min_distance
from jaxflex._turning_outputs import turning_loads
from jaxflex.cli import main
from jaxflex.errors import InputError, ModelError
from jaxflex.response import rotation_residual

DT = 2e-3
PIVOT = np.array([0.3, 0.2, 0.05])  # m, model frame: near the panel's middle, above it
GRAVITY = np.array([0.0, 0.0, -9.81])
ROUNDING = 1e-9  # of the peak: rounding only (module docstring)


@pytest.fixture(scope="module")
def panel():
    """The curved shell panel on four cups, 6 modes at 30 points, with its rotation data and
    static residual."""
    part = fem.curved_panel(0.6, 0.4, 1e-3, "steel", 0.1, element="shell")
    cups = [fem.SuctionCup(x, y, 0.03) for x in (0.15, 0.45) for y in (0.1, 0.3)]
    result = fem.modal_analysis(part, cups, n_modes=6, zeta=0.02, progress=False)
    return result.to_modal_model(points=30)


def _move(kind):
    """(path, acc): a 90 degree swivel about the vertical or a 30 degree tilt about x, at 3
    rad/s and 20 rad/s^2, while the pivot moves 0.4 m along x (world), then 0.1 s at rest."""
    angle, axis = {"swivel": (90.0, "z"), "tilt": (30.0, "x")}[kind]
    alpha = turn_acceleration(np.radians(angle), 3.0, 20.0, 400.0, DT)
    acc = jaxflex.jerk_limited_move([0.4, 0.0, 0.0], 1.5, 10.0, 200.0, DT).acc
    n = max(len(alpha), len(acc)) + round(0.1 / DT)
    alpha = np.pad(alpha, (0, n - len(alpha)))
    acc = np.pad(acc, ((0, n - len(acc)), (0, 0)))
    start = Rotation.from_euler("z", 20, degrees=True).as_matrix()  # not the identity
    return fixed_axis_path(axis, alpha, DT, start=start), acc


def _inputs(path, acc):
    """(n+1, 13) the FMU's inputs at the samples: ax, ay, az, quat_w..z, omega_x..z,
    alpha_x..z."""
    quat = Rotation.from_matrix(path.rotation).as_quat(scalar_first=True)
    return np.hstack([acc, quat, path.omega_rad_s, path.alpha_rad_s2])


NAMES = ("ax", "ay", "az", *POSE_INPUT_NAMES)


@pytest.fixture(scope="module")
def fmus(panel, tmp_path_factory):
    folder = tmp_path_factory.mktemp("turning")
    return {
        v: export_fmu(
            panel, folder / f"turn{v}.fmu", fmi=Fmi(v, windows=False),
            turning=Turning(PIVOT, gravity_m_s2=GRAVITY),
        )
        for v in (2, 3)
    }  # fmt: skip


def test_exported_fmus_validate_and_take_the_pose(fmus):
    for version, result in fmus.items():
        assert result.compiler_messages == ""
        assert validate_fmu(str(result.fmu_path)) == []
        md = read_model_description(str(result.fmu_path))
        inputs = [v.name for v in md.modelVariables if v.causality == "input"]
        assert inputs == list(NAMES), version
        starts = {v.name: float(v.start) for v in md.modelVariables if v.causality == "input"}
        assert starts["quat_w"] == 1.0 and starts["omega_x"] == 0.0
        # the panel's cups: their utilisation is an output of the turning part too
        assert "cup_utilisation" in {v.name for v in md.modelVariables}


@pytest.mark.parametrize("kind", ["swivel", "tilt"])
def test_linear_inputs_agree_with_simulate_turning(panel, fmus, kind):
    """The FMU's deviation (with the static response to the rotational loads, R = 12
    residual coordinates) equals jaxflex's to rounding; without that response it would
    differ by the quasi-static share of the modes left out (measured before it was carried:
    4.7 % of the peak for the swivel, 8.4 % for the tilt of this 6-mode panel)."""
    path, acc = _move(kind)
    reference = simulate_turning(panel, Turn(path, acc, pivot_m=PIVOT, gravity_m_s2=GRAVITY))
    samples = _inputs(path, acc)
    rates = np.diff(samples, axis=0) / DT
    got = []
    with Session(fmus[2].fmu_path) as session:
        session.start(0.0, dict(zip(NAMES, samples[0], strict=True)))
        got.append(session.get("deviation"))
        for k in range(len(samples) - 1):
            session.set_inputs(samples[k], rates[k], names=NAMES)
            session.step(k * DT, DT)
            got.append(session.get("deviation"))
    peak = reference.deviation_m.max()
    assert peak > 2e-6  # the moves bend the part (measured: 5 um swivel, 12 um tilt)
    assert got[0] == 0.0  # at rest in its start pose, sagging
    assert np.abs(np.array(got) - reference.deviation_m).max() <= ROUNDING * peak


def _held_reference(model, path, acc):
    """Deviation at t_1 .. t_n for the forcing of each sample held over the next step: the
    exact zero-order hold (scipy's matrix exponential, per mode), the state started at rest
    in the first pose, the deviation about the sag of the held pose, with the static
    residuals' shares D a_O + D_rot b (b of the held sample, written here from the rates)."""
    a_origin, gravity = body_loads(path, acc, GRAVITY, PIVOT)
    force = turning_forces(model, path, a_origin, gravity)
    omega = 2 * np.pi * np.asarray(model.freq_hz)
    sag = gravity @ np.asarray(model.gamma).T / omega**2
    steps = []
    for w, z in zip(omega, np.asarray(model.zeta), strict=True):
        a = np.array([[0.0, 1.0], [-(w**2), -2 * z * w]])
        phi = expm(a * DT)
        steps.append((phi, np.linalg.solve(a, phi - np.eye(2))[:, 1]))
    q = np.stack([sag[0], np.zeros_like(sag[0])], axis=1)
    coords = []
    for k in range(len(acc) - 1):
        q = np.stack([phi @ x + g * f for (phi, g), x, f in zip(steps, q, force[k], strict=True)])
        w, alpha = path.omega_rad_s[k], path.alpha_rad_s2[k]
        b = np.outer(w, w) - w @ w * np.eye(3)  # b[i, j] = B_ji, B = [alpha]_x + w w^T - |w|^2
        b += np.array(
            [[0, alpha[2], -alpha[1]], [-alpha[2], 0, alpha[0]], [alpha[1], -alpha[0], 0]]
        )
        coords.append(np.concatenate([q[:, 0] - sag[k], a_origin[k], b.reshape(9)]))
    shapes = np.concatenate(
        [np.asarray(model.shapes), np.asarray(model.static_residual), rotation_residual(model)],
        axis=2,
    )
    u = np.einsum("pcm,km->kpc", shapes, np.array(coords))
    return np.linalg.norm(u, axis=2).max(axis=1)


@pytest.mark.parametrize("version", [2, 3])
@pytest.mark.parametrize("kind", ["swivel", "tilt"])
def test_held_inputs_in_fmpy_are_the_exact_zero_order_hold(panel, fmus, version, kind):
    path, acc = _move(kind)
    samples = _inputs(path, acc)
    signal = np.zeros(len(samples), dtype=[("time", float)] + [(n, float) for n in NAMES])
    signal["time"] = DT * np.arange(len(samples))
    for i, name in enumerate(NAMES):
        signal[name] = samples[:, i]
    outputs = ["deviation"] + (["displaced_points"] if version == 3 else [])
    result = simulate_fmu(
        str(fmus[version].fmu_path), input=signal, output=outputs, output_interval=DT,
        stop_time=DT * (len(samples) - 1),
    )  # fmt: skip
    expected = _held_reference(panel, path, acc)
    got = result["deviation"][1 : len(expected) + 1]
    assert len(got) == len(expected)
    peak = expected.max()
    assert np.abs(got - expected).max() <= ROUNDING * peak
    if version == 3:  # body-frame coordinates: the points plus their deviation
        moved = result["displaced_points"][1 : len(expected) + 1] - np.asarray(panel.points)
        assert np.abs(np.linalg.norm(moved, axis=2).max(axis=1) - got).max() <= ROUNDING * peak


def test_without_rotation_data_turning_is_refused(panel, tmp_path):
    bare = panel._replace(rotation=None)
    with pytest.raises(ModelError, match="inertia shape integrals"):
        export_fmu(bare, tmp_path / "bare.fmu", fmi=Fmi(windows=False), turning=Turning())
    assert not (tmp_path / "bare.fmu").exists()


def test_straight_fmus_keep_their_variables(panel, tmp_path):
    """Without turning the FMU has the inputs ax, ay, az only (the connections of existing
    projects), whatever rotation data the model carries."""
    result = export_fmu(panel, tmp_path / "straight.fmu", fmi=Fmi(windows=False))
    md = read_model_description(str(result.fmu_path))
    assert [v.name for v in md.modelVariables if v.causality == "input"] == ["ax", "ay", "az"]
    assert result.counts.turning == 0


def test_a_zero_quaternion_is_refused_with_the_state_kept(fmus):
    with Session(fmus[3].fmu_path) as session:
        session.start(0.0)
        session.step(0.0, DT)
        before = session.get("deviation")
        session.set("quat_w", 0.0)
        with pytest.raises(FMICallException):
            session.step(DT, DT)
        assert session.get("deviation") == before
        assert any("no direction" in text for _, text in session.messages)


def test_export_command_with_turning(panel, tmp_path, capsys):
    """`jaxflex export --turning --pivot`: the FMU validates and says what its inputs are; a
    model file without rotation data gets one line and exit status 2, no FMU."""
    panel.save(tmp_path / "panel.npz")
    panel._replace(rotation=None).save(tmp_path / "bare.npz")
    out = tmp_path / "t.fmu"
    argv = ["export", str(tmp_path / "panel.npz"), "--turning", "--pivot", "0.3", "0.2", "0"]
    assert main([*argv, "--fmi", "3", "--windows", "no", "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert "fmpy validation: clean" in text and "quat_w..quat_z (body to world)" in text
    bare = ["export", str(tmp_path / "bare.npz"), "--turning", "-o", str(tmp_path / "b.fmu")]
    assert main(bare) == 2
    err = capsys.readouterr().err
    assert err.startswith("jaxflex export: error: turning moves need") and err.count("\n") == 1
    assert not (tmp_path / "b.fmu").exists()


def test_without_turning_the_pose_inputs_give_the_straight_response(panel, fmus):
    """The turning FMU held in a fixed pose (the identity: gravity along -z of the model, as
    for a straight move) and driven by a translation only gives jaxflex.simulate's deviation
    of the straight move (another code path of jaxflex: the state about the rest sag, the
    static residual's share D a), to rounding; its resource says what it was exported with."""
    acc = jaxflex.jerk_limited_move([0.3, -0.2, 0.1], 1.5, 10.0, 200.0, DT).acc
    reference = np.asarray(jaxflex.simulate(panel, acc, DT).deviation)
    rates = np.diff(acc, axis=0) / DT
    got = []
    with Session(fmus[2].fmu_path) as session:
        session.start(0.0)
        got.append(session.get("deviation"))
        for k in range(len(acc) - 1):
            session.set_inputs(acc[k], rates[k])
            session.step(k * DT, DT)
            got.append(session.get("deviation"))
    assert np.abs(np.array(got) - reference).max() <= ROUNDING * reference.max()
    stored = read_fmu_resource(fmus[3].fmu_path).turning
    assert np.array_equal(stored.pivot_m, PIVOT) and np.array_equal(stored.gravity_m_s2, GRAVITY)


@pytest.mark.parametrize("version", [2, 3])
def test_turning_fmu_under_sanitizers(fmus, version, tmp_path):
    """The turning FMU's C built with ASan and UBSan, driven by the C harness with its pose
    inputs (a turn about z): the life-cycle checks pass (NaN input refused, state kept, reset
    and re-run identical, two instances independent), a long run is clean, and damaged
    turning resources (the turning field cleared, a NaN in the inertia shape integrals, the
    payload cut short) are refused with a logged reason, the intact one accepted."""
    folder = tmp_path / "x"
    with zipfile.ZipFile(fmus[version].fmu_path) as zf:
        zf.extractall(folder)
    library = tmp_path / "asan.so"
    compile_library(host_target(), folder / "sources", version, library, extra_flags=SANITIZE_FLAGS)
    harness = compile_harness(version, tmp_path / "harness", sanitize=True, turning=True)
    token = fmus[version].token
    location = resource_location(version, folder / "resources")
    for mode in (["check", "50", repr(DT)], ["bench", "400", repr(DT), "3"]):
        proc = subprocess.run(
            [str(harness), str(library), location, token, *mode], capture_output=True, text=True
        )
        assert proc.returncode == 0, proc.stderr[-3000:]
    data = (folder / "resources" / "jaxflex_model.bin").read_bytes()
    body = bytearray(data[:-8])
    cases = {"intact": bytes(body)}
    cases["turning field cleared"] = bytes(body[:124] + bytes(4) + body[128:])
    m, c = fmus[version].counts.modes, fmus[version].counts.cups
    at = len(body) - 8 * (9 * m + 6 + 54 * c)  # the first inertia shape integral
    cases["NaN shape integral"] = bytes(body[:at] + struct.pack("<d", np.nan) + body[at + 8 :])
    cases["cut short"] = bytes(body[:-8])
    lines = []
    for i, content in enumerate(cases.values()):
        (tmp_path / f"c{i}").mkdir()
        (tmp_path / f"c{i}" / "jaxflex_model.bin").write_bytes(
            content + struct.pack("<II", zlib.crc32(content), 0)
        )
        lines.append(resource_location(version, tmp_path / f"c{i}"))
    (tmp_path / "list.txt").write_text("\n".join(lines) + "\n", encoding="utf-8")
    argv = [str(harness), str(library), "-", token, "fuzz", "20", repr(DT), "-"]
    proc = subprocess.run([*argv, str(tmp_path / "list.txt")], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[-3000:]
    outcome = dict(zip(cases, proc.stdout.splitlines(), strict=True))
    assert outcome.pop("intact").split()[::3] == ["accepted", "0"]  # no faults
    for label, line in outcome.items():
        refused, logged = line.split()
        assert (refused, int(logged) > 0) == ("refused", True), label


# ---- the embedded move of poses (export_fmu(..., move, turning=Turning(pose=...))) ---------


@pytest.fixture(scope="module")
def embedded(panel, tmp_path_factory):
    """Turning FMUs with the swivel and the tilt embedded (FMI 2.0 and 3.0)."""
    folder = tmp_path_factory.mktemp("embedded")
    out = {}
    for kind in ("swivel", "tilt"):
        path, acc = _move(kind)
        for version in (2, 3):
            out[kind, version] = export_fmu(
                panel, folder / f"{kind}{version}.fmu", jaxflex.as_move(acc, DT),
                fmi=Fmi(version, windows=False),
                turning=Turning(PIVOT, gravity_m_s2=GRAVITY, pose=path),
            )  # fmt: skip
    return out


@pytest.mark.parametrize("version", [2, 3])
@pytest.mark.parametrize("kind", ["swivel", "tilt"])
def test_embedded_turning_move_agrees_with_simulate_turning(panel, embedded, version, kind):
    """The FMU replays its move of poses by itself (use_embedded_trajectory, no inputs): at
    communication steps of one sample, of two samples (the FMU splits each step at the sample
    between) and of 2.5 samples (communication points between samples: the forcing there is
    linear between the samples', as jaxflex's recursion assumes), its deviation at every
    communication point on a sample equals simulate_turning's to rounding (the same bound as
    the inputs' test above); the free vibration after the move too."""
    path, acc = _move(kind)
    result = embedded[kind, version]
    assert result.compiler_messages == "" and validate_fmu(str(result.fmu_path)) == []
    reference = simulate_turning(
        panel, Turn(path, acc, pivot_m=PIVOT, gravity_m_s2=GRAVITY), extend_s=0.1
    )
    peak = reference.deviation_m.max()
    stop = (len(reference.t_s) - 1) * DT
    for interval in (DT, 2 * DT, 2.5 * DT):
        run = simulate_fmu(
            str(result.fmu_path), start_values={"use_embedded_trajectory": True},
            output_interval=interval, stop_time=stop, output=["deviation"],
        )  # fmt: skip
        k = np.round(run["time"] / DT).astype(int)
        on_sample = np.abs(run["time"] - k * DT) < 1e-9 * DT
        assert on_sample.sum() >= len(run["time"]) // 2
        got = run["deviation"][on_sample]
        assert got[0] == 0.0  # at rest, sagging in the move's first pose
        assert np.abs(got - reference.deviation_m[k[on_sample]]).max() <= ROUNDING * peak


def test_embedded_move_in_the_resource_and_case(panel, embedded):
    """The resource holds the move's samples (translation and the poses: quaternion, angular
    velocity and acceleration) as given, its checksum and lengths checked on reading; the
    case beside the FMU has jaxflex's exact cycle time of the turning move and the input CSV
    the 13 inputs."""
    path, acc = _move("tilt")
    result = embedded["tilt", 3]
    stored = read_fmu_resource(result.fmu_path)
    assert np.array_equal(stored.acc, acc) and stored.dt_s == DT
    quat = Rotation.from_matrix(path.rotation).as_quat(scalar_first=True)
    poses = stored.turning.pose_samples
    assert poses.shape == (len(acc), 10)
    assert np.array_equal(poses[:, 4:], np.hstack([path.omega_rad_s, path.alpha_rad_s2]))
    assert np.abs(poses[:, :4] - quat).max() <= 1e-15
    settle = turning_settle(panel, Turn(path, acc, pivot_m=PIVOT, gravity_m_s2=GRAVITY), 5e-4)
    assert result.case["cycle_time_s"] == settle.cycle_time_s
    header = result.input_csv.read_text().split("\n", 1)[0].split(",")
    assert header == ["time", *NAMES]


def test_damaged_embedded_poses_are_refused(embedded, tmp_path):
    """A resource whose pose samples lost a quaternion (zero) is refused by the reader in
    Python and by the FMU at instantiation, with the CRC recomputed (so only the value
    check can catch it)."""
    result = embedded["swivel", 2]
    folder = tmp_path / "x"
    with zipfile.ZipFile(result.fmu_path) as zf:
        zf.extractall(folder)
    resource = folder / "resources" / "jaxflex_model.bin"
    body = bytearray(resource.read_bytes()[:-8])
    counts = result.counts  # the poses, then the cups' and stresses' maps end the resource
    at = len(body) - 8 * (10 * counts.trajectory + 54 * (counts.cups + counts.stress))
    body[at : at + 32] = bytes(32)
    resource.write_bytes(bytes(body) + struct.pack("<II", zlib.crc32(bytes(body)), 0))
    with pytest.raises(jaxflex.ModelFileError, match="quaternion is zero"):
        decode_resource(resource.read_bytes())
    with pytest.raises(Exception, match="instantiate"):  # fmpy: the FMU returned NULL
        Session(folder, unzip_dir=folder)


def test_inconsistent_embedded_moves_are_refused(panel, tmp_path):
    """A pose path that does not fit the trajectory (length, step), is missing, or does not
    end at rest is refused naming ``pose``, before anything is written."""
    path, acc = _move("swivel")
    moving = replace(path, omega_rad_s=path.omega_rad_s.copy())
    moving.omega_rad_s[-1] = (0.0, 0.0, 1.0)
    cases = {
        "pose: .* samples": (path, acc[:-1]),
        "pose: sampled every": (replace(path, dt_s=1e-3), acc),
        "pose: a turning part's embedded move needs": (None, acc),
        "pose: the turn must start and end at rest": (moving, acc),
    }
    for message, (pose, samples) in cases.items():
        with pytest.raises(InputError, match=message):
            export_fmu(
                panel, tmp_path / "bad.fmu", jaxflex.as_move(samples, DT),
                fmi=Fmi(windows=False), turning=Turning(pose=pose),
            )  # fmt: skip
    with pytest.raises(InputError, match=r"pose: the orientation path of an embedded"):
        export_fmu(panel, tmp_path / "bad.fmu", turning=Turning(pose=path))
    assert not (tmp_path / "bad.fmu").exists()


def optimised_swivel(model, folder):
    """(model file, run folder, `jaxflex export` arguments up to the output): `jaxflex
    optimize --rotate z 90 --pivot 0.3 0.2 0.05` of ``model`` saved in ``folder``."""
    model_file, run = folder / "panel.npz", folder / "run"
    model.save(model_file)
    limits = ["--vmax", "1.5", "--amax", "10", "--jmax", "200", "--dt", "0.01"]
    turn = ["--rotate", "z", "90", "--pivot", "0.3", "0.2", "0.05"]
    optimize = ["optimize", str(model_file), "--distance", "0.4", "0", "0", *limits, *turn]
    assert main([*optimize, "--threshold", "2e-6", "--no-plots", "-o", str(run)]) == 0
    return model_file, run, ["export", str(model_file), "--trajectory", str(run), "--windows", "no"]


@pytest.mark.slow
def test_export_command_embeds_an_optimised_turning_move(panel, tmp_path, capsys):
    """`jaxflex optimize --rotate z 90 --pivot ...` then `jaxflex export --turning
    --trajectory RUN`: the FMU plays the optimised swivel by itself and the command's own
    check (fmpy against jaxflex.simulate_turning) passes; the same run without --turning,
    with another pivot, or its trajectory.csv without report.json is refused (exit status 2,
    one line naming the option, no FMU)."""
    model_file, run, export = optimised_swivel(panel, tmp_path)
    capsys.readouterr()
    out = tmp_path / "swivel.fmu"
    assert main([*export, "--turning", "--fmi", "3", "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert "deviation vs jaxflex.simulate_turning" in text and text.rstrip().endswith("OK")
    relative = float(text.split("relative ")[1].split()[0])
    assert relative <= ROUNDING
    bare = tmp_path / "bare"
    bare.mkdir()
    (bare / "trajectory.csv").write_bytes((run / "trajectory.csv").read_bytes())
    refused = {
        "--turning": [*export, "-o", str(tmp_path / "a.fmu")],
        "--pivot": [*export, "--turning", "--pivot", "0", "0", "0", "-o", str(tmp_path / "b.fmu")],
        "report.json's turn": [
            "export", str(model_file), "--trajectory", str(bare / "trajectory.csv"),
            "--turning", "-o", str(tmp_path / "c.fmu"),
        ],
    }  # fmt: skip
    for name, argv in refused.items():
        assert main(argv) == 2, name
        err = capsys.readouterr().err
        assert name in err and err.count("\n") == 1, err
    assert not any((tmp_path / f"{c}.fmu").exists() for c in "abc")


# ---- the cell's outputs of a turning part (cups, stresses, distances) -------------------


def _world_points(model, path, acc):
    """(n+1, K, 3) every point's position in the cell at the move's samples, written here:
    c + s + R (x - c + u), u the whole elastic displacement (modes, static residual of the
    translation and of the rotational loads) of jaxflex._turning's state, s the pivot's
    exact path."""
    inputs = turning_inputs(model, Turn(path, acc, pivot_m=PIVOT, gravity_m_s2=GRAVITY))
    u = (
        np.einsum("kcm,tm->tkc", np.asarray(model.shapes), inputs.q)
        + np.einsum("kcm,tm->tkc", np.asarray(model.static_residual), inputs.base)
        + np.einsum("kcm,tm->tkc", rotation_residual(model), inputs.coefficients)
    )
    s = kinematics_at(as_move(acc, DT), inputs.t_s)[0]
    local = np.asarray(model.points)[None] - PIVOT + u
    return PIVOT + s[:, None] + np.einsum("tab,tkb->tka", path.rotation, local)


OBSTACLES = (
    Box(np.array([1.15, 0.2, 0.0]), np.array([0.1, 0.1, 0.2]), name="post"),
    HalfSpace(np.array([0.0, 0.0, 1.0]), -0.15, name="floor"),
)
HALF = 0.5e-3  # m: half the 1 mm sheet


@pytest.mark.parametrize("kind", ["swivel", "tilt"])
def test_cell_outputs_of_the_turning_part_agree_with_jaxflex(panel, kind, tmp_path):
    """The turning panel with its move embedded, posed in a cell (a post and a floor) with
    stresses: at every communication point on a sample (steps of 1 and 2.5 samples) the cup
    utilisations and von Mises stresses equal jaxflex._turning_outputs.turning_loads' and
    every point's distance the distance of its position written here (_world_points), to
    rounding (1e-9 of the peak, as above); the smallest distance over the samples lies above
    the certified lower bound of jaxflex._turning_collision's minimum over the whole move and
    above its minimum by at most what a point travels in half a sample (< 3.5 m/s: 1.5 m/s
    of the pivot, 3 rad/s x 0.6 m)."""
    path, acc = _move(kind)
    cell = Cell(obstacles=OBSTACLES, end_m=np.array([0.4, 0.0, 0.0]), thickness_m=2 * HALF)
    loads = turning_loads(panel, Turn(path, acc, pivot_m=PIVOT, gravity_m_s2=GRAVITY))
    world = _world_points(panel, path, acc)
    want = distances(OBSTACLES, world.reshape(-1, 3))[0].reshape(world.shape[:2]) - HALF
    certified = turning_min_distance(
        panel,
        OBSTACLES,
        Turn(path, acc, pivot_m=PIVOT, gravity_m_s2=GRAVITY),
        half_thickness_m=HALF,
    )
    stop = (len(acc) - 1) * DT
    names = ["cup_utilisations", "point_stresses", "point_distances", "min_distance"]
    result = export_fmu(
        panel, tmp_path / "cell.fmu", jaxflex.as_move(acc, DT), fmi=Fmi(3, windows=False),
        outputs=CellOutputs(cell, stress=True), turning=Turning(PIVOT, pose=path),
    )  # fmt: skip
    assert result.counts.cups == 4 and result.counts.obstacles == 2
    for interval in (DT, 2.5 * DT):
        run = simulate_fmu(
            str(result.fmu_path), start_values={"use_embedded_trajectory": True},
            output_interval=interval, stop_time=stop, output=names,
        )  # fmt: skip
        k = np.round(run["time"] / DT).astype(int)
        on = np.abs(run["time"] - k * DT) < 1e-9 * DT
        for got, ref in (
            (run["cup_utilisations"], loads.utilisation),
            (run["point_stresses"], loads.von_mises_pa),
            (run["point_distances"], want),
        ):
            assert np.abs(got[on] - ref[k[on]]).max() <= ROUNDING * np.abs(ref).max()
        assert np.array_equal(run["min_distance"], run["point_distances"].min(axis=1))
    sampled = float(want.min())
    assert certified.bound_m <= sampled <= certified.distance_m + 3.5 * DT / 2


def test_turning_fmu_cups_carry_newton_euler(tmp_path):
    """A stiff part (first mode in the hundreds of kHz) turned about a skew axis from a tilted
    start while its pivot moves, the move embedded: the FMU's cup reactions (FMI 3.0
    cup_reactions) add up, at every sample, to Newton-Euler in closed form (force m (a_c -
    g), moment J alpha + w x J w + m c x (a_O - g) about the gripper origin,
    tests/test_turning_cell.py) to 1e-6 of the peak. The steel is 1e4 times stiffer (first
    mode 26 kHz: the dynamic remainder (w_move / omega_1)^2 is ~1e-8 of the load), not 1e6
    as there: the export's case summary computes the turning bound, whose set-up grows with
    omega_max dt (58 s for the 1e6 sheet at dt = 1 ms on the loaded machine, 14 s here)."""
    result, model = stiff_sheet(1e4)
    path, acc, pivot = skew_turn()
    exported = export_fmu(
        model, tmp_path / "stiff.fmu", jaxflex.as_move(acc, path.dt_s),
        fmi=Fmi(3, windows=False), turning=Turning(pivot, pose=path),
    )  # fmt: skip
    stop = (len(acc) - 1) * path.dt_s
    run = simulate_fmu(
        str(exported.fmu_path), start_values={"use_embedded_trajectory": True},
        output_interval=path.dt_s, stop_time=stop, output=["cup_reactions"],
    )  # fmt: skip
    reactions = np.asarray(run["cup_reactions"]).reshape(len(run["time"]), -1, 6)
    force, moment = newton_euler(result, path, acc, pivot, len(acc))
    centres = np.asarray(model.cups.centre_m)
    got_force = reactions[..., :3].sum(axis=1)
    got_moment = (reactions[..., 3:] + np.cross(centres[None], reactions[..., :3])).sum(axis=1)
    assert np.abs(got_force - force).max() <= 1e-6 * np.abs(force).max()
    assert np.abs(got_moment - moment).max() <= 1e-6 * np.abs(moment).max()
