"""Moves that turn the part: the inertia data against closed forms, frames, refusals, and
the response and settle time against an independent floating-frame integration of the FE's
equations on the kept modes (every inertial term; a full-order reference was too slow to
integrate at tight tolerance here)."""

from __future__ import annotations

import numpy as np
import pytest
from floating_frame import ACC, DT, JERK, RATE, floating_frame_deviation
from scipy.spatial.transform import Rotation

import fem
import jaxflex
from fem.rotation_integrals import linear_fields
from jaxflex._pose import fixed_axis_path, orientation_path, turn_acceleration
from jaxflex._rotation import LEVI_CIVITA
from jaxflex._turning import Turn, simulate_turning, turning_motion, turning_settle
from jaxflex.errors import InputError, ModelError


def _rigid_participation(result):
    """Gamma_rot of the rigid rotations (as 'modes', unnormalised) through the linear fields:
    eps_kij R_l^T M (e_j r_i), which must be the inertia tensor J_lk about the origin."""
    system = result.system
    fields = linear_fields(system).reshape(system.n_dof, 9)
    rotations = system.outputs.rigid_motion(np.zeros(3))[:, 3:]
    integrals = (rotations.T @ (system.M @ fields)).reshape(3, 3, 3)
    return np.einsum("kij,lij->lk", LEVI_CIVITA, integrals)


@pytest.mark.parametrize("element", ["morley", "hex2"])
def test_rigid_rotation_participation_is_the_inertia(element):
    """A flat 0.4 x 0.3 m steel sheet, its corner at the origin: the rotational participation
    of its rigid rotations equals its inertia tensor in closed form (rho t: integrals of
    y^2, x^2, x y over the rectangle, + t^2/12 through the thickness of the solid), to 1e-9
    (the consistent mass integrates these quadratics exactly: only round-off remains). The
    plate has no in-plane DOFs: its in-plane row and column are not checked."""
    width, height, t = 0.4, 0.3, 1e-3
    part = fem.rectangular_plate(width, height, t, "steel", 0.1, element=element)
    cups = [fem.SuctionCup(x, y, 0.03) for x in (0.1, 0.3) for y in (0.08, 0.22)]
    result = fem.modal_analysis(part, cups, n_modes=4, zeta=0.02, progress=False)
    mass = 7850.0 * width * height * t
    through = t**2 / 12 if element == "hex2" else 0.0
    z0 = result.system.nodes[0, 2]
    expected = mass * np.array(
        [
            [height**2 / 3 + through + z0**2, -width * height / 4, 0.0],
            [-width * height / 4, width**2 / 3 + through + z0**2, 0.0],
            [0.0, 0.0, (width**2 + height**2) / 3],
        ]
    )
    got = _rigid_participation(result)
    stored = result.to_modal_model(points=8).rotation
    block = slice(0, 3) if element == "hex2" else slice(0, 2)
    scale = np.abs(expected).max()
    assert np.abs(got[block, block] - expected[block, block]).max() <= 1e-9 * scale
    assert np.abs(stored.inertia_kg_m2 - expected).max() <= 1e-9 * scale
    assert stored.mass_kg == pytest.approx(mass, rel=1e-12)
    assert np.allclose(stored.centre_m, [width / 2, height / 2, z0], atol=1e-12)


def _turn_about_z(model):
    alpha = turn_acceleration(np.pi / 2, RATE, ACC, JERK, DT)
    path = fixed_axis_path("z", alpha, DT)
    return simulate_turning(model, Turn(path, np.zeros((len(alpha), 3))), extend_s=0.2)


def test_flat_plate_turned_about_its_normal_does_not_bend():
    """A Kirchhoff plate swivelled 90 degrees about its normal (through its corner, far off
    its centre): every load is in its plane, so it does not bend (round-off: 1e-12 of the
    curved panel's peak) and the neglected terms vanish too (its deflection turned about its
    normal stays along it: G = P_zz = 0, a bound of exactly 0); the curved shell panel on
    the same cups does bend, far beyond its bound."""
    cups = [fem.SuctionCup(x, y, 0.03) for x in (0.15, 0.45) for y in (0.1, 0.3)]
    plate = fem.rectangular_plate(0.6, 0.4, 1e-3, "steel", 0.05)
    shell = fem.curved_panel(0.6, 0.4, 1e-3, "steel", 0.05, element="shell")
    flat = fem.modal_analysis(plate, cups, n_modes=10, zeta=0.02, progress=False)
    curved = fem.modal_analysis(shell, cups, n_modes=10, zeta=0.02, progress=False)
    flat_response = _turn_about_z(flat.to_modal_model())
    curved_response = _turn_about_z(curved.to_modal_model())
    peak = curved_response.deviation_m.max()
    assert flat_response.neglected_bound_m == 0.0
    assert flat_response.deviation_m.max() <= 1e-12 * peak
    # measured: 7.0 um against an a-posteriori bound of 0.08 nm (the energy estimate: 1.4 um)
    assert peak > 3 * curved_response.neglected_bound_m


def test_models_without_inertia_data_refuse_turning(tmp_path):
    """A model without the rotation group (an R1 import, an .rst result, an older file) says
    what turning moves need; the group survives a file round trip and mode truncation."""
    part = fem.rectangular_plate(0.6, 0.4, 1e-3, "steel", 0.08)
    cups = [fem.SuctionCup(x, y, 0.03) for x in (0.15, 0.45) for y in (0.1, 0.3)]
    model = fem.modal_analysis(part, cups, n_modes=6, zeta=0.02, progress=False).to_modal_model(
        points=30
    )
    model.save(tmp_path / "m.npz")
    again = jaxflex.load_model(tmp_path / "m.npz")
    assert np.array_equal(again.rotation.shape_integrals, model.rotation.shape_integrals)
    assert again.truncate_modes(3).rotation.shape_integrals.shape == (3, 3, 3)
    bare = model._replace(rotation=None)
    bare.save(tmp_path / "bare.npz")
    with pytest.raises(ModelError, match="inertia shape integrals"):
        _turn_about_z(jaxflex.load_model(tmp_path / "bare.npz"))


def test_posed_model_turns_like_the_original():
    """The inertia data expressed in another frame (ModalModel.posed: a rotation and an
    offset) give the same deviation for the same physical turn about the same physical
    axis through the same point. The models carry no static residual: the translation's
    residual D a_O depends on where the frame's origin is (the Euler and centrifugal loads'
    quasi-static residual, which would make it frame-independent, is not modelled: 1.6 % of
    the peak here with it)."""
    part = fem.curved_panel(0.6, 0.4, 1e-3, "steel", 0.1, element="shell")
    cups = [fem.SuctionCup(x, y, 0.03) for x in (0.15, 0.45) for y in (0.1, 0.3)]
    model = fem.modal_analysis(part, cups, n_modes=8, zeta=0.02, progress=False).to_modal_model(
        points=40
    )
    model = model._replace(static_shapes=None)
    rot = Rotation.from_rotvec([0.3, -0.2, 0.5]).as_matrix()
    offset = np.array([0.2, -0.1, 0.3])
    posed = model.posed(rot, offset)
    alpha = turn_acceleration(np.radians(40), RATE, ACC, JERK, DT)
    axis = np.array([0.2, 0.5, 1.0]) / np.linalg.norm([0.2, 0.5, 1.0])
    pivot = np.array([0.1, 0.2, 0.0])
    acc = np.zeros((len(alpha), 3))
    gravity = np.array([0.0, 0.0, -9.81])
    here = simulate_turning(model, Turn(fixed_axis_path(axis, alpha, DT), acc, pivot_m=pivot))
    there = simulate_turning(
        posed,
        Turn(
            fixed_axis_path(rot @ axis, alpha, DT, start=rot.T),
            acc,
            pivot_m=rot @ pivot + offset,
            gravity_m_s2=gravity,
        ),
    )
    assert np.abs(here.deviation_m - there.deviation_m).max() <= 1e-9 * here.deviation_m.max()


@pytest.fixture(scope="module")
def cantilever():
    """A 0.3 x 0.2 m, 2 mm steel thin solid curved along x (radius 0.6 m), clamped on its
    left edge, its 4 lowest modes (49-381 Hz), 2 % damping."""
    part = fem.curved_panel(0.3, 0.2, 2e-3, "steel", 0.1, radius_x=0.6, radius_y=None)
    result = fem.modal_analysis(part, [fem.ClampedEdge("left")], n_modes=4, zeta=0.02)
    return result, result.to_modal_model(points="all")._replace(static_shapes=None)


@pytest.mark.parametrize(("axis", "angle_deg"), [("z", 90.0), ("x", 30.0), ((0.3, 0.0, 1.0), 90.0)])
def test_against_floating_frame_reference(cantilever, axis, angle_deg):
    """A swivel about the vertical, a tilt about an in-plane axis under gravity and a turn
    about a skew axis, at 3 rad/s and 20 rad/s^2, during the move and 0.3 s after: with
    every term the reference stays within 0.5 % of its peak and within the reported bound
    (plus the sampling error); with the kept terms only it agrees to 1e-4 of the peak (the
    first-order hold of the sampled forcing: O(dt^2) of a forcing that varies over ~0.1 s);
    the a-posteriori bound covers the neglected terms' true effect and is within twice it."""
    result, model = cantilever
    alpha = turn_acceleration(np.radians(angle_deg), RATE, ACC, JERK, DT)
    path = fixed_axis_path(axis, alpha, DT)
    response = simulate_turning(model, Turn(path, np.zeros((len(alpha), 3))), extend_s=0.3)
    args = (result, model, path.alpha_rad_s2, response.t_s[-1])
    full = floating_frame_deviation(*args, full=True)
    kept = floating_frame_deviation(*args, full=False)
    peak = full.max()
    sampling = 1e-4 * peak
    assert np.abs(response.deviation_m - kept).max() <= sampling
    assert np.abs(response.deviation_m - full).max() <= 5e-3 * peak
    # the bound holds for the continuous neglected load at any step (jaxflex._turning_bound;
    # tests/test_turning_bound.py checks it at 10 ms and 2 ms against a finer reading of the
    # reference) and the reference is integrated at rtol 1e-10 and read at the samples only:
    # 1e-6 of the peak covers its rounding; measured bound / effect 1.4-1.9, held to 2 so
    # that it stays tight
    effect = np.abs(full - kept).max()
    assert effect <= response.neglected_bound_m + 1e-6 * peak
    assert response.neglected_bound_m <= 2.0 * effect + 1e-6 * peak


def test_turning_settle_time_against_the_reference(cantilever):
    """The settle time of a 90 degree swivel about the vertical, certified from the end state
    (jaxflex._turning.turning_settle), against the last exceedance of the independent
    floating-frame integration with every term, sampled at DT: within one sample (the
    reference is sampled; the neglected terms move the curve by < 5e-3 of its peak, a shift
    of the crossing far below DT where the envelope decays at sigma = zeta omega_1)."""
    result, model = cantilever
    alpha = turn_acceleration(np.pi / 2, RATE, ACC, JERK, DT)
    path = fixed_axis_path("z", alpha, DT)
    turn = Turn(path, np.zeros((len(alpha), 3)))
    response = simulate_turning(model, turn, extend_s=0.6)
    full = floating_frame_deviation(result, model, path.alpha_rad_s2, response.t_s[-1], full=True)
    n = path.n_steps
    # a threshold the residual vibration crosses after the move (certified from the end
    # state), and one crossed inside the move (sampled)
    for threshold in (0.3 * full[n], 0.2 * full.max()):
        report = turning_settle(model, turn, threshold, response=response)
        last = response.t_s[np.flatnonzero(full > threshold)[-1]]
        assert last - DT <= report.settle_time_s <= last + DT, threshold
        assert report.cycle_time_s == max(report.settle_time_s, n * DT)
    assert (
        report.settle_time_s
        < n * DT
        < turning_settle(model, turn, 0.3 * full[n], response=response).settle_time_s
    )
    # without a response the door simulates the move itself (no free vibration after it):
    # the report depends only on the move's samples, so it is the same
    assert turning_settle(model, turn, threshold) == report


def test_combined_move_through_orientations_against_the_reference(cantilever):
    """The combined move of the issue: a swivel of 90 degrees about the vertical, then a
    30 degree tilt about the part's own x axis (jaxflex._pose.orientation_path through three
    orientations), while the gripper travels 0.5 m along x and 0.2 m up (a jerk-limited
    move, at rest once it arrives), and 0.3 s of free decay: against the independent
    integration, as the single turns (1e-4 of the peak with the kept terms: the sampled
    forcing; 0.5 % with every term), and the reported bound covers the neglected terms
    (within twice their effect)."""
    result, model = cantilever
    goals = [
        np.zeros(3),
        [0.0, 0.0, np.pi / 2],
        Rotation.from_euler("ZX", [90, 30], degrees=True).as_matrix(),
    ]
    path = orientation_path(goals, RATE, ACC, JERK, DT)
    travel = jaxflex.jerk_limited_move([0.5, 0.0, 0.2], 1.0, 5.0, 50.0, DT).acc
    acc = np.zeros((path.n_steps + 1, 3))
    acc[: len(travel)] = travel
    response = simulate_turning(model, Turn(path, acc), extend_s=0.3)
    args = (result, model, path.alpha_rad_s2, response.t_s[-1])
    full = floating_frame_deviation(*args, full=True, acc_world=acc)
    kept = floating_frame_deviation(*args, full=False, acc_world=acc)
    peak = full.max()
    assert np.abs(response.deviation_m - kept).max() <= 1e-4 * peak
    assert np.abs(response.deviation_m - full).max() <= 5e-3 * peak
    effect = np.abs(full - kept).max()  # measured 20 nm against a bound of 33 nm at 10 ms
    assert effect <= response.neglected_bound_m + 1e-6 * peak
    assert response.neglected_bound_m <= 2.0 * effect + 1e-6 * peak


def _swivel_fields() -> dict:
    path = fixed_axis_path("z", turn_acceleration(np.pi / 2, RATE, ACC, JERK, DT), DT)
    return {"path": path, "acc": np.zeros((path.n_steps + 1, 3))}


@pytest.mark.parametrize(
    ("field", "value", "says"),
    [
        ("path", "z", "a jaxflex.response.PosePath"),
        ("acc", np.zeros((3, 3)), r"expected shape \(\d+, 3\) like the pose path, got \(3, 3\)"),
        ("acc", "fast", r"must be a numeric array of shape \(n\+1, 3\), got dtype <U4"),
        ("acc", np.nan, r"expected acceleration samples of shape \(n\+1, 3\) in m/s\^2"),
        ("pivot_m", (0.1, 0.2), r"three finite numbers, m in the model frame; got \(0.1, 0.2\)"),
        ("pivot_m", "middle", "three finite numbers"),
        ("gravity_m_s2", (0.0, 0.0, np.inf), r"three finite numbers, m/s\^2 in the world frame"),
    ],
)
def test_a_turn_is_checked_once_naming_the_field(field, value, says):
    """jaxflex.Turn refuses what cannot be a turning move, naming the field, what is allowed
    and what was given (the turning functions take it without checking again)."""
    fields = _swivel_fields()
    with pytest.raises(InputError, match=rf"^{field}: .*{says}"):
        jaxflex.Turn(**{**fields, field: value})


def test_the_turning_functions_refuse_what_is_not_a_turn(cantilever):
    """What is not a jaxflex.Turn (None, the fields as a dict) is refused by name before any
    work, not an AttributeError from deep inside."""
    for turn in (None, _swivel_fields()):
        for call in (jaxflex.simulate_turning, turning_motion, jaxflex.turning_settle):
            with pytest.raises(InputError, match=r"^turn: a jaxflex\.Turn\(path, acc, "):
                call(cantilever[1], turn)


def test_turning_settle_refuses_the_response_of_another_move(cantilever):
    """A response given to turning_settle must be simulate_turning's to the same turn: one of
    a shorter turn is refused naming both step counts, not searched from its end state."""
    model = cantilever[1]
    turn = Turn(**_swivel_fields())
    short = fixed_axis_path("z", turn_acceleration(0.1, RATE, ACC, JERK, DT), DT)
    other = jaxflex.simulate_turning(model, Turn(short, np.zeros((short.n_steps + 1, 3))))
    n, m = turn.path.n_steps, short.n_steps
    assert m < n
    says = rf"^response: .* to this turn \({n} steps\), got one of {m} steps$"
    with pytest.raises(InputError, match=says):
        jaxflex.turning_settle(model, turn, 1e-3, response=other)
    with pytest.raises(InputError, match=r"^response: .*got a dict$"):
        jaxflex.turning_settle(model, turn, 1e-3, response={})


def test_a_turn_refuses_samples_that_are_not_finite():
    fields = _swivel_fields()
    fields["acc"][3, 1] = np.nan
    says = r"^acc: sample 3 \(axis y\) is nan; every sample must be finite"
    with pytest.raises(InputError, match=says):
        jaxflex.Turn(**fields)


def test_a_turn_takes_a_move_at_the_path_step():
    """A Move of the pivot's acceleration gives the turn its samples (Turn.move gives them
    back at the path's step); a Move at another step is refused naming both steps."""
    fields = _swivel_fields()
    samples = np.linspace(0.0, 1.0, 3 * len(fields["acc"])).reshape(-1, 3)
    turn = Turn(fields["path"], jaxflex.as_move(samples, DT))
    np.testing.assert_array_equal(turn.acc, samples)
    assert turn.move.dt_s == DT and np.array_equal(turn.move.acc, samples)
    with pytest.raises(InputError, match=rf"^acc: the move is sampled every {2 * DT} s"):
        Turn(fields["path"], jaxflex.as_move(samples, 2 * DT))


def test_a_turn_holds_float64_arrays():
    """Lists and tuples become float64 arrays of the documented shapes; the defaults are the
    origin and -9.81 m/s^2 along z."""
    fields = _swivel_fields()
    turn = Turn(fields["path"], fields["acc"].astype(int).tolist(), pivot_m=[1, 0, 0])
    assert turn.acc.dtype == np.float64 and turn.acc.shape == fields["acc"].shape
    assert turn.pivot_m.tolist() == [1.0, 0.0, 0.0] and turn.pivot_m.dtype == np.float64
    assert turn.gravity_m_s2.tolist() == [0.0, 0.0, -9.81]
    assert turn.dt_s == DT
