"""The trajectory source of a turning move and the SSP package of a turning part.

* The source's outputs at the communication points against the jaxflex._pose.PosePath
  evaluated here (the rotation matrices, the angular velocity and acceleration, the pivot's
  acceleration), and independent kinematic checks between the samples: the quaternion stays
  a unit quaternion and its central finite difference gives the angular velocity the source
  outputs (omega_body = 2 vec(q* q')).
* The package in Ecos / libcosim (values held over each step) against the exact zero-order
  hold written with scipy's matrix exponential (tests/test_fmu_turning.py), and in fmu.master
  with the source's derivatives forwarded to the part (FMI 2.0) against
  jaxflex.simulate_turning, both to the rounding of the double-precision recursion (see
  ``rounding``).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
import zipfile

import numpy as np
import pytest
from fmpy.validation import validate_fmu
from scipy.spatial.transform import Rotation
from test_fmu_turning import (  # noqa: F401  (panel: the fixture)
    DT,
    GRAVITY,
    PIVOT,
    _held_reference,
    optimised_swivel,
    panel,
)

import jaxflex
from fmu import importers
from fmu.crosscheck import crosscheck_ssp
from fmu.master import Session, run_chained
from fmu.options import Fmi, Turning
from fmu.source import export_source_fmu
from fmu.ssp import SSD_FILE, export_ssp, steps_for
from fmu.variables import POSE_INPUT_NAMES
from jaxflex._pose import PosePath, fixed_axis_path, turn_acceleration
from jaxflex.cli import main
from jaxflex.errors import InputError
from jaxflex.response import Turn, simulate_turning

NAMES = ("ax", "ay", "az", *POSE_INPUT_NAMES)
EPS = np.finfo(np.float64).eps
JERK = 400.0  # rad/s^3, the turn's jerk limit (turn_acceleration below)


def _move():
    """(path, acc): a 30 degree tilt about y at 3 rad/s and 20 rad/s^2 from a start tilted 25
    degrees about x (gravity then loads the part from the first sample on), while the pivot
    moves 0.3 m along x; at rest 0.05 s after."""
    alpha = turn_acceleration(np.radians(30.0), 3.0, 20.0, JERK, DT)
    acc = jaxflex.jerk_limited_move([0.3, 0.0, 0.0], 1.5, 10.0, 200.0, DT).acc
    n = max(len(alpha), len(acc)) + round(0.05 / DT)
    alpha = np.pad(alpha, (0, n - len(alpha)))
    acc = np.pad(acc, ((0, n - len(acc)), (0, 0)))
    start = Rotation.from_euler("x", 25, degrees=True).as_matrix()
    return fixed_axis_path("y", alpha, DT, start=start), acc


def _at_rest(path: PosePath, acc: np.ndarray, n_samples: int) -> tuple[PosePath, np.ndarray]:
    """The move padded to ``n_samples`` samples at rest in its last pose."""
    extra = n_samples - len(acc)
    rot = np.concatenate([path.rotation, np.repeat(path.rotation[-1:], extra, axis=0)])
    zeros = np.zeros((extra, 3))
    padded = PosePath(
        rot,
        np.vstack([path.omega_rad_s, zeros]),
        np.vstack([path.alpha_rad_s2, zeros]),
        path.dt_s,
    )
    return padded, np.vstack([acc, zeros])


def rounding(model, reference: np.ndarray, n_steps: int) -> float:
    """Tolerance (m) of "equal to rounding" for deviations over ``n_steps`` steps: each step
    of the double-precision recursion (the forcing of 13 inputs, the quaternion's rotation,
    the 2 x 2 step, the sum over modes) adds a few ulps, 64 allowed, of the modal state it
    carries, and a stable (damped) recursion adds them up at most linearly over the steps.
    The state carries the part's sag under gravity, and the deviation is its difference from
    the sag of the current pose, so the bound scales with the larger of the sag and the
    deviation's peak."""
    omega = 2 * np.pi * np.asarray(model.freq_hz)
    modal_sag = np.asarray(model.gamma) @ GRAVITY / omega**2
    sag_m = float(np.linalg.norm(np.asarray(model.shapes) @ modal_sag, axis=1).max())
    peak = float(np.abs(reference).max())
    return 64 * EPS * n_steps * max(sag_m, peak)


@pytest.fixture(scope="module")
def sources(tmp_path_factory):
    folder = tmp_path_factory.mktemp("turning_source")
    path, acc = _move()
    return (
        path,
        acc,
        {
            v: export_source_fmu(
                folder / f"source{v}.fmu", jaxflex.as_move(acc, DT), v, pose=path, windows=False
            )
            for v in (2, 3)
        },
    )


@pytest.mark.parametrize("version", [2, 3])
def test_source_outputs_the_pose_path_at_the_samples(sources, version):
    """At every sample time (a host stepping by the sample step; the last 0.01 s after the
    move, at rest in the last pose): the pivot's acceleration, the orientation (as a rotation
    matrix: q and -q are the same), omega and alpha of the PosePath, to rounding; the first
    derivatives reach the next sample at the end of the step (the first-order hold)."""
    path, acc, fmus = sources
    result = fmus[version]
    assert result.outputs == NAMES and validate_fmu(str(result.fmu_path)) == []
    n = len(acc) + 5
    padded, padded_acc = _at_rest(path, acc, n)
    got, rates = [], []
    with Session(result.fmu_path) as source:
        source.start(0.0)
        for k in range(n):
            got.append([source.get(name) for name in NAMES])
            rates.append(source.output_rates(NAMES))
            source.step(k * DT, DT)
    got, rates = np.array(got), np.array(rates)
    quat = got[:, 3:7]
    assert np.abs(np.linalg.norm(quat, axis=1) - 1).max() <= 4 * EPS
    rot = Rotation.from_quat(quat, scalar_first=True).as_matrix()
    assert np.abs(rot - padded.rotation).max() <= 1e-14
    assert np.array_equal(got[:, :3], padded_acc)  # printed with 17 digits: exact
    assert np.array_equal(got[:, 7:10], padded.omega_rad_s)
    assert np.array_equal(got[:, 10:], padded.alpha_rad_s2)
    reached = got[:-1] + DT * rates[:-1]
    scale = np.maximum(1.0, np.abs(got).max(axis=0))
    assert (np.abs(reached - got[1:]) <= 1e-12 * scale).all()
    assert not rates[len(acc) :].any()  # at rest after the move


def test_source_between_samples_turns_as_the_kinematics_say(sources):
    """At communication points a third of a sample apart (most between samples): a unit
    quaternion; omega equal to 2 vec(q* q') of the quaternion's central difference, within
    the difference's truncation error h^2 / 6 max |2 q'''|, where for a turn about a fixed
    axis |q'''| <= j / 2 + 3 w a / 4 + w^3 / 8 (w, a, j the turn's limits 3 rad/s, 20
    rad/s^2, 400 rad/s^3); the acceleration and alpha linear between the samples."""
    path, acc, fmus = sources
    h = DT / 3
    n = 3 * (len(acc) - 1)
    got = []
    with Session(fmus[2].fmu_path) as source:
        source.start(0.0)
        for k in range(n + 1):
            got.append([source.get(name) for name in NAMES])
            source.step(k * h, h)
    got = np.array(got)
    quat = got[:, 3:7]
    assert np.abs(np.linalg.norm(quat, axis=1) - 1).max() <= 1e-14
    dq = (quat[2:] - quat[:-2]) / (2 * h)
    conj = quat[1:-1] * np.array([1.0, -1.0, -1.0, -1.0])
    # vector part of the Hamilton product q* dq
    omega_fd = 2 * (
        conj[:, :1] * dq[:, 1:] + dq[:, :1] * conj[:, 1:] + np.cross(conj[:, 1:], dq[:, 1:])
    )
    bound = h**2 / 6 * 2 * (JERK / 2 + 3 * 3.0 * 20.0 / 4 + 3.0**3 / 8)
    assert np.abs(omega_fd - got[1:-1, 7:10]).max() <= bound
    assert np.abs(got[1:-1, 8]).max() > 2.5  # a real turn (30 degrees: 2.76 rad/s at most)
    t = h * np.arange(n + 1)
    grid = DT * np.arange(len(acc))
    for i, column in ((0, acc[:, 0]), (11, path.alpha_rad_s2[:, 1])):
        assert np.allclose(got[:, i], np.interp(t, grid, column), rtol=0, atol=1e-12)


def test_pose_of_another_length_is_refused(tmp_path):
    path, acc = _move()
    with pytest.raises(InputError, match="pose:"):
        export_source_fmu(
            tmp_path / "s.fmu", jaxflex.as_move(acc[:-1], DT), 2, pose=path, windows=False
        )
    assert not (tmp_path / "s.fmu").exists()


@pytest.fixture(scope="module")
def packages(panel, tmp_path_factory):  # noqa: F811
    folder = tmp_path_factory.mktemp("turning_ssp")
    path, acc = _move()
    return path, acc, {
        v: export_ssp(
            panel, folder / f"case{v}.ssp", jaxflex.as_move(acc, DT),
            fmi=Fmi(v, windows=False), threshold_m=2e-6,
            turning=Turning(PIVOT, gravity_m_s2=GRAVITY, pose=path),
        )
        for v in (2, 3)
    }  # fmt: skip


def test_package_connects_every_pose_signal(packages):
    for result in packages[2].values():
        with zipfile.ZipFile(result.ssp_path) as zf:
            ssd = ET.fromstring(zf.read(SSD_FILE))
        connection = "{http://ssp-standard.org/SSP1/SystemStructureDescription}Connection"
        pairs = [(c.get("startConnector"), c.get("endConnector")) for c in ssd.iter(connection)]
        assert pairs == [(name, name) for name in NAMES]


def _master_run(folder, n_steps: int) -> np.ndarray:
    """The package's FMI 2.0 FMUs in fmu.master, the source's derivatives forwarded."""
    with (
        Session(folder / "resources/trajectory.fmu") as source,
        Session(folder / "resources/part.fmu") as part,
    ):
        source.start(0.0)
        part.start(0.0, {name: source.get(name) for name in NAMES})
        return run_chained(source, part, DT, n_steps, forward_rates=True, names=NAMES)["deviation"]


@pytest.mark.parametrize("version", [2, 3])
def test_package_in_hosts_agrees_with_jaxflex(panel, packages, version, tmp_path):  # noqa: F811
    """Ecos and libcosim hold the source's values over each step: the exact zero-order hold
    of the pose samples (scipy, tests/test_fmu_turning.py); fmu.master forwarding the
    source's derivatives (FMI 2.0): jaxflex.simulate_turning. Both to rounding; the
    crosscheck of `jaxflex export --ssp` says the same."""
    path, acc, results = packages
    result = results[version]
    n_steps = steps_for(result.stop_time_s, DT)
    padded, padded_acc = _at_rest(path, acc, n_steps + 1)
    held = _held_reference(panel, padded, padded_acc)  # at t_1 .. t_n
    runs = {}
    if importers.ecospy_unavailable() is None:
        runs["ecos"] = importers.ecos_ssp(result.ssp_path, n_steps, DT)
    if version == 2 and importers.libcosimpy_unavailable() is None:
        runs["libcosim"] = importers.libcosim_ssp(result.ssp_path, n_steps, DT)
    for host, out in runs.items():
        k = np.rint(out["time"] / DT).astype(int)
        got, ref = out["part.deviation"][k > 0], held[k[k > 0] - 1]
        assert len(got) == n_steps, host
        assert np.abs(got - ref).max() <= rounding(panel, held, n_steps), host
    if version == 2:
        linear = simulate_turning(
            panel, Turn(padded, padded_acc, pivot_m=PIVOT, gravity_m_s2=GRAVITY)
        ).deviation_m
        with zipfile.ZipFile(result.ssp_path) as zf:
            zf.extractall(tmp_path)
        got = _master_run(tmp_path, n_steps)
        assert np.abs(got - linear).max() <= rounding(panel, linear, n_steps)
        # the held run lags the first-order hold by about half a step
        assert np.abs(held - linear[1:]).max() > 1e-3 * linear.max()
    report = crosscheck_ssp(result.ssp_path, part_model=panel)
    assert report.ok, report.summary()
    assert {r.host for r in report.runs} >= {"jaxflex-master", *(["ecospy"] if runs else [])}


def test_crosscheck_of_a_turning_package_needs_its_model(packages):
    with pytest.raises(InputError, match="part_model"):
        crosscheck_ssp(packages[2][2].ssp_path)


@pytest.mark.slow
def test_export_command_writes_the_turning_package(panel, tmp_path, capsys):  # noqa: F811
    """`jaxflex optimize --rotate z 90` then `jaxflex export --turning --trajectory RUN --ssp
    case.ssp`: the package of the turning part and its source, checked in the hosts against
    jaxflex (exit status 0, every host within rounding); without --turning refused."""
    _, _, export = optimised_swivel(panel, tmp_path)
    capsys.readouterr()
    out = tmp_path / "case.ssp"
    assert main([*export, "--turning", "--ssp", str(out)]) == 0
    text = capsys.readouterr().out
    assert "13 signals connected" in text and text.rstrip().endswith("OK"), text
    assert "jaxflex-master: deviation vs jaxflex.simulate_turning" in text
    assert main([*export, "--ssp", str(tmp_path / "straight.ssp")]) == 2
    assert "--turning" in capsys.readouterr().err
