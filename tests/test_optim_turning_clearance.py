"""``optimize --rotate ... --clearance``: the deviation during a turning move limited
(optim.turn_clearance).

The optimised move is integrated independently: scipy's solve_ivp (DOP853, rtol 1e-10) of
the modal equations with the turning forcing written out here from the model's rotation data
(jaxflex._rotation's definitions: Gamma, the inertia shape integrals S, the orientation by
scipy's Rotation), every dt / 32, and its deviation about the sag of the current pose must
stay within the clearance plus the allowance between the dt / 8 samples the clearance is held
at (derived below). The affine map the LP uses is checked against the turning engine."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

import optim
from jaxflex.response import as_move, max_norms, turning_blocks
from optim.move_response import ClearancePeak, MoveResponse
from optim.search import active_components
from optim.turn import TurnSchedule, TurnSpec
from optim.turn_clearance import TurnMoveResponse

DT = 0.01
THRESHOLD = 5e-4
LIMITS = optim.Limits(vmax=2.0, amax=10.0, jmax=100.0)
PIVOT = (0.6, 0.4, 0.0)  # the middle of the cups
FINE = 32  # the independent check's samples per step
HELD = 8  # the clearance's samples per step (optim.move_response.SUBSTEPS)


@pytest.fixture(scope="module")
def plate(turning_plate):
    return turning_plate


def test_affine_map_is_the_turning_engines(plate):
    """The LP's view of the deviation (optim.turn_clearance.TurnMoveResponse: the straight
    map of the turned samples plus the turn alone, static residuals of the translation and
    the rotation included) equals jaxflex.simulate_turning's deviation at the samples for
    random translation samples (round-off), and a cut's row and offset give c . u exactly
    at another move (it is affine in the samples)."""
    spec = TurnSpec.of(optim.Rotation("x", 30.0, pivot_m=PIVOT))
    n = 90
    alpha = TurnSchedule(spec, DT).angular_acc(n)
    straight = MoveResponse(plate, active_components(plate), n, DT)
    response = TurnMoveResponse(straight, spec, alpha)
    rng = np.random.default_rng(2)
    acc = rng.normal(size=(n + 1, 3))
    coords = response.modal(acc)
    d = max_norms(turning_blocks(plate), coords)[0]
    engine = spec.response(plate, alpha, as_move(acc, DT)).deviation_m
    assert np.abs(d[::HELD] - engine).max() <= 1e-9 * engine.max()
    j, point = 8 * 40 + 3, 17  # between two samples
    u = response.shapes[point] @ coords[j]
    peak = ClearancePeak(j, point, u, 1.0)
    other = rng.normal(size=(n + 1, 3))
    expected = (u / np.linalg.norm(u)) @ (response.shapes[point] @ response.modal(other)[j])
    got = np.sum(response.row(peak, (0, 1, 2)) * other) + response.offset(peak)
    assert got == pytest.approx(expected, rel=1e-9, abs=1e-12 * np.abs(coords).max())


def _turn_samples(alpha: np.ndarray):
    """(rate (n+1,) rad/s, angle (n+1,) rad) at the samples: alpha linear between them, so
    the rate and the angle are its exact integrals."""
    rate = np.concatenate([[0.0], np.cumsum(DT * (alpha[1:] + alpha[:-1]) / 2)])
    step = DT * rate[:-1] + DT**2 * (2 * alpha[:-1] + alpha[1:]) / 6
    return rate, np.concatenate([[0.0], np.cumsum(step)])


def _reference(model, spec: TurnSpec, alpha: np.ndarray, acc: np.ndarray):
    """(d (T,) m, max_p |u_p''| (T,) m/s^2) every DT / FINE during the move,
    independently: the modal equations q'' + 2 zeta w q' + w^2 q = f(t) from rest sagging
    under gravity, f written from the model's data at the pose samples and linear between
    them (the turning engine's sampled forcing):

        f_m = -Gamma_m . (a_O - g_b) - sum_ij B_ji S_m[i, j],  B = [alpha]x + w w^T - |w|^2 I

    (jaxflex._rotation: the modal load of the field B r; the body frame's turn about the
    fixed axis), a_O = R^T a + alpha x (-c) + w x (w x (-c)) the origin's acceleration with
    the pivot c, g_b = R^T g. The deviation about the sag of the current pose is
    u_p = Phi_p (q - Omega^-2 Gamma g_b), g_b linear between the samples."""
    n = acc.shape[0] - 1
    axis = np.asarray(spec.axis)
    rate, angle = _turn_samples(alpha)
    rot = Rotation.from_rotvec(angle[:, None] * axis).as_matrix()  # (n+1, 3, 3) body to world
    w, a_rot = rate[:, None] * axis, alpha[:, None] * axis
    arm = -np.asarray(spec.pivot_m)
    a_origin = np.einsum("kji,kj->ki", rot, acc)
    a_origin += np.cross(a_rot, arm) + np.cross(w, np.cross(w, arm))
    g_body = np.einsum("kji,j->ki", rot, np.asarray(spec.gravity_m_s2))
    skew = np.zeros((n + 1, 3, 3))
    skew[:, 0, 1], skew[:, 0, 2], skew[:, 1, 2] = -a_rot[:, 2], a_rot[:, 1], -a_rot[:, 0]
    skew -= np.transpose(skew, (0, 2, 1))
    b = skew + np.einsum("ki,kj->kij", w, w) - np.einsum("k,ij->kij", (w * w).sum(1), np.eye(3))
    s = np.asarray(model.rotation.shape_integrals)
    gamma = np.asarray(model.gamma)
    force = -(a_origin - g_body) @ gamma.T - np.einsum("kji,mij->km", b, s)
    omega, zeta = 2 * np.pi * np.asarray(model.freq_hz), np.asarray(model.zeta)
    m, grid = omega.size, DT * np.arange(n + 1)

    def modal_acc(t, q, v):
        f = np.array([np.interp(t, grid, force[:, i]) for i in range(m)])
        return f - 2 * zeta * omega * v - omega**2 * q

    def rhs(t, y):
        return np.concatenate([y[m:], modal_acc(t, y[:m], y[m:])])

    t = DT / FINE * np.arange(n * FINE + 1)
    q0 = gamma @ g_body[0] / omega**2
    sol = solve_ivp(
        rhs, (0.0, t[-1]), np.concatenate([q0, np.zeros(m)]), "DOP853", t_eval=t,
        rtol=1e-10, atol=1e-14,
    )  # fmt: skip
    assert sol.success, sol.message
    q, v = sol.y[:m].T, sol.y[m:].T
    g_lin = np.column_stack([np.interp(t, grid, g_body[:, c]) for c in range(3)])
    phi = np.asarray(model.shapes)  # (K, 3, M)
    u = np.einsum("kcm,tm->tkc", phi, q - g_lin @ gamma.T / omega**2)
    qdd = np.array([modal_acc(ti, qi, vi) for ti, qi, vi in zip(t, q, v, strict=True)])
    # g_lin is linear between the samples: u_p'' = Phi_p q''
    curvature = np.linalg.norm(np.einsum("kcm,tm->tkc", phi, qdd), axis=2).max(axis=1)
    return np.linalg.norm(u, axis=2).max(axis=1), curvature


@pytest.mark.slow
def test_clearance_limits_the_turning_move(plate):
    """A 30-degree tilt about x while lifted 1 m, with a clearance half the unconstrained
    optimum's peak during the move: the constrained move is longer, its reported peak
    (every dt / 8) meets the clearance, and the independent integration every dt / 32
    stays within it plus the allowance between the dt / 8 samples."""
    # without the static residuals: the reference's deviation is then Phi_p p alone (the
    # affine map with them is checked against the engine above)
    bare = plate._replace(
        static_shapes=None, rotation=plate.rotation.replace(static_shapes=None)
    )  # fmt: skip
    args = (bare, (0.0, 0.0, 1.0), LIMITS, DT, THRESHOLD)
    turn = {"rotation": optim.Rotation("x", 30.0, pivot_m=PIVOT)}
    free = optim.optimize(*args, **turn)
    clearance = 0.5 * free.deviation["peak_during_move_m"]
    result = optim.optimize(*args, constraints=optim.Constraints(clearance_m=clearance), **turn)
    assert result.n_steps > free.n_steps  # the clearance is active: it costs time here
    assert result.cycle_time_s == pytest.approx(result.n_steps * DT)
    assert result.constraint_check.ok
    reported = result.deviation["peak_during_move_m"]
    assert reported <= clearance
    assert result.report()["clearance_m"] == clearance
    assert f"(clearance {clearance * 1e3:g} mm)" in result.summary()
    alpha = np.zeros(result.n_steps + 1)
    alpha[: result.angular_acc.size] = result.angular_acc
    d, curvature = _reference(bare, result.turn, alpha, result.acc)
    # the same samples every dt / 8: the engine's exact sampled-forcing response (the ODE
    # solver's rtol 1e-10 well inside 1e-6)
    held = d[:: FINE // HELD]
    assert reported == pytest.approx(held.max(), rel=1e-6)
    # between two of them (h = dt / 8 apart) |u_p| exceeds the larger end by at most
    # h^2 / 8 sup |u_p''| (the linear interpolant's error); sup |u_p''| over the step is
    # taken as twice its largest value every dt / 32 (u_p'' is smooth within a step and
    # varies by O(omega h) ~ 10 % over one; the factor covers it)
    h = DT / HELD
    allowance = h**2 / 8 * 2 * curvature.max() / clearance  # 0.3 % here
    assert allowance < 0.01
    assert d.max() <= clearance * (1 + allowance)
