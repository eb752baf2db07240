"""Orientations at a cell's via points (optim.turn_via): a tilt about x with the part tilted
about y at a blended via point.

The returned move is checked from what it writes and from scipy, not from the optimiser's
bookkeeping: the orientations from the cell file's angles by scipy.spatial.transform
(extrinsic x, y, z), the geodesic angles of both segments from them; the trajectory.csv's
turn columns (the angle turned along the path) reach the first segment's angle at rest at a
sample where the written position is within the via point's tolerance; the returned
PosePath's rotation there is the via orientation and at the end the turn's; the same
PosePath integrated independently (R' = R [w]x, scipy's solve_ivp on the angular velocity
written in the path) ends in the same orientations; the angular limits hold on the path's
rate, acceleration and jerk (norms, every sample and step); the cycle time is re-timed by
jaxflex._turning.simulate_turning on the path and translation sampled 10 x finer, scanned
sample by sample."""

from __future__ import annotations

import json

import numpy as np
import pytest
import scipy.integrate
from conftest import run_jaxflex
from scipy.spatial.transform import Rotation

import jaxflex
import optim
from jaxflex._pose import fixed_axis_path, joined_paths
from jaxflex._trajectory_io import TURN_COLUMNS
from jaxflex._turning import Turn, simulate_turning
from optim.cell_file import cell_from_dict
from optim.turn_via import reported_path

DT = 0.01
THRESHOLD = 5e-4
LIMITS = optim.Limits(vmax=2.0, amax=10.0, jmax=100.0)
PIVOT = (0.6, 0.4, 0.0)  # the middle of the cups
ANGULAR = (3.0, 20.0, 200.0)  # rad/s, rad/s^2, rad/s^3 (optim.turn.ANGULAR_LIMITS)
VIA_M, TOLERANCE_M, VIA_DEG = (0.0, 0.0, 0.5), 0.1, (0.0, 20.0, 0.0)
FINE = 10


@pytest.fixture(scope="module")
def plate(turning_plate):
    return turning_plate


def _cell(via_extra: dict):
    via = {"position_m": list(VIA_M), "mode": "blend", "tolerance_m": TOLERANCE_M, **via_extra}
    return cell_from_dict(
        {"path": {"end_m": [0.6, 0.0, 0.6], "via": [via]}, "part": {"thickness_m": 1e-3}}
    )


def _optimise(model, cell, **extra):
    return optim.optimize(
        model,
        None,
        LIMITS,
        DT,
        THRESHOLD,
        constraints=optim.Constraints(cell=cell),
        rotation=optim.Rotation("x", 30.0, angular_limits=ANGULAR, pivot_m=PIVOT),
        **extra,
    )


def _read_csv(path):
    header = path.read_text().split("\n", 1)[0].split(",")
    table = np.loadtxt(path, delimiter=",", skiprows=1)
    return {name: table[:, i] for i, name in enumerate(header)}


def _integrated_rotations(path, times):
    """R(t) at ``times`` from R' = R [w]x (w body components, linear between the samples of
    the angular acceleration: w from the written samples' exact quadratic), solve_ivp."""
    omega, alpha, dt = np.asarray(path.omega_rad_s), np.asarray(path.alpha_rad_s2), path.dt_s
    n = len(omega) - 1

    def w(t):
        k = min(int(t // dt), n - 1)
        tau = t - k * dt
        return omega[k] + alpha[k] * tau + (alpha[k + 1] - alpha[k]) * tau**2 / (2 * dt)

    def rhs(t, y):
        r = y.reshape(3, 3)
        wx = np.array([[0, -w(t)[2], w(t)[1]], [w(t)[2], 0, -w(t)[0]], [-w(t)[1], w(t)[0], 0]])
        return (r @ wx).ravel()

    sol = scipy.integrate.solve_ivp(
        rhs, (0.0, times[-1]), np.eye(3).ravel(), t_eval=times, rtol=1e-11, atol=1e-12,
        max_step=dt / 4,
    )  # fmt: skip
    return sol.y.T.reshape(-1, 3, 3)


def test_move_reaches_the_via_orientation_at_the_via_point(plate, tmp_path):
    """(module docstring) The tilt about y at the via point, then on to the 30-degree tilt
    about x: the via orientation is reached at rest at the via point, the end orientation
    at the end, within the angular limits, and the certified cycle time holds."""
    result = _optimise(plate, _cell({"rotation_deg": list(VIA_DEG)}))
    assert all(result.objective_s <= b.score() for b in result.baselines.entries)
    via = Rotation.from_euler("xyz", VIA_DEG, degrees=True)  # the part's axes, cell frame
    end = Rotation.from_rotvec(np.radians(30.0) * np.array([1.0, 0.0, 0.0]))
    first = via.magnitude()
    second = (via.inv() * end).magnitude()
    result.save(tmp_path, plots=False)
    written = _read_csv(tmp_path / "trajectory.csv")
    angle, rate = written[TURN_COLUMNS[0]], written[TURN_COLUMNS[1]]
    # the path's angle: first segment then second, at rest between them (round-off 1e-9)
    at_via = np.flatnonzero((np.abs(angle - first) < 1e-9) & (np.abs(rate) < 1e-9))
    assert at_via.size > 0
    assert angle[-1] == pytest.approx(first + second, abs=1e-9)
    position = np.column_stack([written["x_m"], written["y_m"], written["z_m"]])
    gap = np.abs(position[at_via] - VIA_M).max(axis=1)
    assert gap.min() <= TOLERANCE_M * (1 + 1e-9)
    k = int(at_via[np.argmin(gap)])
    # the PosePath the turning engine takes: the via orientation there, the turn's at the end
    path = result.turn.path(result.angular_acc, DT)
    assert np.abs(path.rotation[k] - via.as_matrix()).max() <= 1e-9
    assert np.abs(path.rotation[-1] - end.as_matrix()).max() <= 1e-9
    # integrated independently from the path's angular velocity (solve_ivp's tolerance)
    integrated = _integrated_rotations(path, DT * np.array([k, result.n_steps]))
    assert np.abs(integrated[0] - via.as_matrix()).max() <= 1e-7
    assert np.abs(integrated[1] - end.as_matrix()).max() <= 1e-7
    # angular limits (Euclidean norms) at every sample; the jerk on every step
    rate_limit, acc_limit, jerk_limit = ANGULAR
    assert np.linalg.norm(path.omega_rad_s, axis=1).max() <= rate_limit * (1 + 1e-9)
    assert np.linalg.norm(path.alpha_rad_s2, axis=1).max() <= acc_limit * (1 + 1e-9)
    jerk = np.diff(path.alpha_rad_s2, axis=0) / DT
    assert np.linalg.norm(jerk, axis=1).max() <= jerk_limit * (1 + 1e-9)
    # the rate between samples: the path sampled FINE x finer within the limit
    axes = [via.as_rotvec() / first, (via.inv() * end).as_rotvec() / second]
    fine = _fine_path(result.angular_acc, k, axes)
    assert np.abs(fine.rotation[k * FINE] - via.as_matrix()).max() <= 1e-9
    assert np.linalg.norm(fine.omega_rad_s, axis=1).max() <= rate_limit * (1 + 1e-9)
    _check_cycle_time(plate, result, fine)


def _fine_path(alpha: np.ndarray, k: int, axes):
    """The same continuous turn sampled FINE x finer: the first segment about ``axes[0]`` up
    to the via sample ``k``, the second about ``axes[1]`` (body axes) from there."""
    pieces, start = [], np.eye(3)
    for axis, (lo, hi) in zip(axes, ((0, k), (k, len(alpha) - 1)), strict=True):
        t = np.arange((hi - lo) * FINE + 1) / FINE
        samples = np.interp(t, np.arange(hi - lo + 1), alpha[lo : hi + 1])
        pieces.append(fixed_axis_path(axis, samples, DT / FINE, start=start))
        start = pieces[-1].rotation[-1]
    return joined_paths(pieces)


def _check_cycle_time(model, result, fine_path) -> None:
    """The deviation from simulate_turning on the profiles FINE x finer stays below the
    threshold after the certified cycle time plus one coarse sample (the fine evaluation
    turns the part between the coarse samples, an O(dt^2) change of the body-frame loads:
    tests/test_optim_turning.py) and, unless the cycle ends with the transfer, exceeds it
    within one coarse sample before."""
    n = result.n_steps
    t = np.arange(n * FINE + 1) / FINE
    acc = np.column_stack([np.interp(t, np.arange(n + 1), result.acc[:, c]) for c in range(3)])
    spec = result.turn
    turn = Turn(fine_path, acc, pivot_m=spec.pivot_m, gravity_m_s2=spec.gravity_m_s2)
    response = simulate_turning(model, turn, extend_s=2.0)
    above = np.flatnonzero(response.deviation_m > THRESHOLD)
    settle = 0.0 if above.size == 0 else float(response.t_s[above[-1]])
    assert settle <= result.cycle_time_s + DT
    if result.settle_time_s > result.transfer_time_s:
        assert settle >= result.cycle_time_s - DT


@pytest.mark.parametrize(
    ("via_extra", "rotate", "message"),
    [
        ({"rotation_deg": [0, 20]}, True, r"via\[0\]\.rotation_deg: three numbers"),
        ({"rotation_deg": [0, "20", 0]}, True, r"via\[0\]\.rotation_deg: expected a number"),
        ({"rotation_deg": [0, float("nan"), 0]}, True, r"via\[0\]\.rotation_deg: finite"),
        ({"quaternion": [1, 0, 0, 0]}, True, r"via\[0\]: \['quaternion'\].*rotation_deg ="),
        ({"rotation_deg": [0, 20, 0]}, False, r"via\[0\]\.rotation_deg: .*needs a turning"),
    ],
)
def test_bad_via_orientations_name_the_field(plate, via_extra, rotate, message):
    """Bad input is an InputError naming the field and the allowed form."""
    with pytest.raises(jaxflex.InputError, match=message):
        cell = _cell(via_extra)
        if rotate:
            _optimise(plate, cell)
        else:
            optim.optimize(
                plate, None, LIMITS, DT, THRESHOLD, constraints=optim.Constraints(cell=cell)
            )


def test_command_takes_via_orientations(plate, tmp_path):
    """`jaxflex optimize --cell --rotate` with a via orientation names the segments in its
    summary and report (20 deg about y, then on to the 30-degree tilt about x); a malformed
    via orientation exits with status 2 and one line naming the field; `jaxflex export
    --turning` embeds the move (one fixed-axis turn per segment), its FMU agrees with jaxflex
    (the export's own verification) and its pose inputs pass through the via orientation and
    end at the tilt (scipy's rotations from the angles, not the optimiser's)."""
    model_file = tmp_path / "plate.npz"
    plate.save(model_file)
    via = '{position_m = [0, 0, 0.5], mode = "blend", tolerance_m = 0.1, rotation_deg = %s}'
    cells = {}
    for name, angles in (("good", "[0, 20, 0]"), ("bad", "[0, 20]")):
        cells[name] = tmp_path / f"{name}.toml"
        cells[name].write_text(f"[path]\nend_m = [0.6, 0, 0.6]\nvia = [{via % angles}]\n")
    args = ["--threshold", "5e-4", "--rotate", "x", "30", "--pivot", "0.6", "0.4", "0"]
    out = tmp_path / "opt"
    proc = run_jaxflex(
        "optimize", str(model_file), "--cell", str(cells["good"]), *args, "--no-plots",
        "-o", str(out),
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    assert "through the via orientations: 20 deg about (0, 1, 0) then" in proc.stdout
    segments = json.loads((out / "report.json").read_text())["turn"]["via_turns"]
    assert segments[0]["angle_deg"] == pytest.approx(20.0, abs=1e-9)
    bad = run_jaxflex(
        "optimize", str(model_file), "--cell", str(cells["bad"]), *args, "-o", str(tmp_path / "bad")
    )
    assert bad.returncode == 2
    assert "cell.path.via[0].rotation_deg: three numbers" in bad.stderr
    assert len(bad.stderr.strip().splitlines()) == 1
    fmu = str(tmp_path / "part.fmu")
    export = run_jaxflex(
        "export", str(model_file), "--turning", "--trajectory", str(out), "-o", fmu
    )
    assert export.returncode == 0, export.stderr
    assert "fmpy validation: clean" in export.stdout
    assert export.stdout.rstrip().endswith("OK")
    table = np.genfromtxt(tmp_path / "part_input.csv", delimiter=",", names=True)
    quat = np.column_stack([table[f"quat_{c}"] for c in "xyzw"])  # scipy's order
    rotations = Rotation.from_quat(quat).as_matrix()
    via_rotation = Rotation.from_euler("xyz", VIA_DEG, degrees=True).as_matrix()
    assert min(np.abs(r - via_rotation).max() for r in rotations) < 1e-9  # round-off
    end = Rotation.from_euler("x", 30, degrees=True).as_matrix()
    np.testing.assert_allclose(rotations[-1], end, atol=1e-9)


def test_a_reported_turn_through_via_orientations_is_rebuilt_and_checked():
    """optim.turn_via.reported_path (jaxflex export's reading of report.json): two segments
    about y then x, each a triangle pulse pair of angular acceleration from rest to rest; the
    orientation at the boundary and the end against the closed-form angles (the angle of a
    turn from rest: integral of (T - t) alpha(t) dt, by a fine trapezoid), and a report
    whose angle does not match the samples refused."""
    dt_s, amplitude = 0.05, 40.0
    pulse = amplitude * np.array([0.0, 1.0, 0.0, -1.0, 0.0])
    alpha = np.concatenate([pulse, pulse[1:]])  # 8 steps, the boundary at sample 4
    t = np.linspace(0.0, 4 * dt_s, 40_001)
    profile = np.interp(t, dt_s * np.arange(5), pulse)
    angle_rad = np.trapezoid((t[-1] - t) * profile, t)  # error ~ h^2: far below 1e-9 rad
    angle_deg = float(np.degrees(angle_rad))
    segments = [
        {"axis": [0.0, 1.0, 0.0], "angle_deg": angle_deg, "ends_at_fraction": 0.5},
        {"axis": [1.0, 0.0, 0.0], "angle_deg": angle_deg, "ends_at_fraction": 1.0},
    ]
    path = reported_path({"via_turns": segments}, alpha, dt_s)
    first = Rotation.from_rotvec([0.0, angle_rad, 0.0])
    end = first * Rotation.from_rotvec([angle_rad, 0.0, 0.0])  # the second about the body x
    assert np.abs(path.rotation[4] - first.as_matrix()).max() <= 1e-9
    assert np.abs(path.rotation[-1] - end.as_matrix()).max() <= 1e-9
    segments[1] = {**segments[1], "angle_deg": segments[1]["angle_deg"] + 1.0}
    with pytest.raises(jaxflex.InputError, match="segment 1 of the via orientations"):
        reported_path({"via_turns": segments}, alpha, dt_s)
