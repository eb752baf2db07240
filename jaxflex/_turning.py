"""The response to moves that turn the part (floating frame of reference).

In the body frame of the gripper (the model frame, origin O) a point r of the part moves by
the elastic displacement u, and the frame by the acceleration a_O of its origin, the angular
velocity w and the angular acceleration alpha (body components; jaxflex._pose). With gravity
g (body components g_b = R^T g, turning with the part) the FE equation reads

    M u'' + C u' + K u = -M [a_O - g_b + alpha x r + w x (w x r)]            (kept)
                         -M [2 w x u' + alpha x u + w x (w x u)]             (neglected)

The first line is the modal forcing this module integrates, through the inertia shape
integrals S (jaxflex._rotation):

    f_m = -Gamma_m . (a_O - g_b) - Gamma_rot,m . alpha - tr(A(w) S_m),   A(w) = w w^T - |w|^2 I,

sampled at the pose samples and advanced by the engine's exact first-order-hold recursion
(jaxflex._engine.forced_states): exact for the sampled forcing, like a straight move. The
translation is the acceleration of a pivot (world components), moved to O by the rigid
rotation terms.

**Deviation about the equilibrium at the current pose**: the part starts at rest sagging
under gravity in its start pose (q_0 = Omega^-2 Gamma g_b(0)), and the deviation is measured
from the static sag of the pose it is in, u_eq(t) = -static_shapes g_b(t), so a part tilted
at B settles to its sag at B. With the mode-acceleration split (jaxflex.model) the deviation
is u - u_eq = Phi p + D a_O + D_rot b with p = q - Omega^-2 Gamma g_b(t), D the static
residual of the translation and D_rot that of the Euler and centrifugal loads
(jaxflex._rotation_residual: the modes left out respond quasi-statically to them too). A
model without the static response to the rotational loads (a file written before it was
stored) leaves that share out (with every mode kept it is zero; with truncated modes it is
the static flexibility of the modes left out times alpha r and w^2 r).

**Neglected terms, bounded.** The second line (Coriolis/gyroscopic 2 w x u', the Euler term
on the deformation alpha x u, spin softening w x (w x u)) is left out and its effect bounded
at any time, whatever the step (jaxflex._turning_bound: the first-order response to the
neglected load of the computed response, exact between samples, its largest displacement
certified, plus a Gronwall remainder of second order; the energy estimate where the model
lacks the modes' couplings).

:func:`simulate_turning` is one compiled function (the response, the deviation and the bound;
the move padded to whole blocks of jaxflex._engine.PAD_STEPS steps, so that the lengths of a
search share a compilation); :func:`turning_inputs` is its NumPy form for the outputs,
peaks and clearance (jaxflex._turning_outputs, turning_peaks, turning_collision).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import partial

import jax
import jax.numpy as jnp
import numpy as np

from jaxflex._deviation import deviation
from jaxflex._engine import forced_states, free_states, padded_steps
from jaxflex._pose import PosePath
from jaxflex._profile import Move, as_move, samples_at
from jaxflex._rotation import LEVI_CIVITA, require_rotation
from jaxflex._rotation_residual import (
    load_coefficients,
    turning_blocks,
    turning_coordinates,
    turning_shapes,
    warn_missing_static,
)
from jaxflex._scalars import check_positive
from jaxflex._settle import (
    PointLayout,
    SettleReport,
    _ForcedMotion,
    point_layout,
    settle_after,
)
from jaxflex._simulate import free_steps, on_device
from jaxflex._turning_bound import bound_data, neglected_terms, principal_axes, turning_window
from jaxflex.defaults import THRESHOLD_M
from jaxflex.errors import InputError

GRAVITY_M_S2 = (0.0, 0.0, -9.81)


def _vector(name: str, value, allowed: str) -> np.ndarray:
    """``value`` as float64 (3,); InputError naming the field ``name`` otherwise."""
    try:
        vector = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        vector = None
    if vector is None or vector.shape != (3,) or not np.isfinite(vector).all():
        raise InputError(f"{name}: three finite numbers, {allowed}; got {value!r}")
    return vector


@dataclass(frozen=True, eq=False)
class Turn:
    """A turning move, what every turning response, output, peak and clearance of the core
    takes (SI units; checked once, when made): the orientation ``path`` (a
    jaxflex._pose.PosePath: rotation, rate and angular acceleration at its samples, step
    ``dt_s``), the world acceleration of the pivot ``acc`` (a jaxflex._profile.Move at the
    path's step, or its samples (n+1, 3) m/s^2 at the path's samples; kept as the samples),
    the pivot ``pivot_m`` (3,) m (model frame: the point the translation moves, the one the
    part turns about) and gravity ``gravity_m_s2`` (3,) m/s^2 (world; (0, 0, 0) for none).
    InputError naming the field otherwise."""

    path: PosePath
    acc: np.ndarray  # given as a Move or samples, kept as the samples
    pivot_m: np.ndarray = (0.0, 0.0, 0.0)  # type: ignore[assignment]  # made (3,) float64
    gravity_m_s2: np.ndarray = GRAVITY_M_S2  # type: ignore[assignment]

    def __post_init__(self) -> None:
        path = self.path
        if not isinstance(path, PosePath):
            raise InputError(
                "path: a jaxflex.response.PosePath (e.g. fixed_axis_path, orientation_path), "
                f"got {type(path).__name__}"
            )
        n, acc = path.n_steps, self.acc
        if isinstance(acc, Move) and not math.isclose(acc.dt_s, path.dt_s, rel_tol=1e-12):
            raise InputError(
                f"acc: the move is sampled every {acc.dt_s} s, the path every {path.dt_s} s"
            )
        acc = as_move(acc, path.dt_s).acc  # numbers, (m, 3), finite: the moves' own checks
        if acc.shape != (n + 1, 3):
            raise InputError(
                f"acc: expected shape ({n + 1}, 3) like the pose path, got {acc.shape}"
            )
        pivot = _vector("pivot_m", self.pivot_m, "m in the model frame")
        gravity = _vector("gravity_m_s2", self.gravity_m_s2, "m/s^2 in the world frame")
        for name, value in (("acc", acc), ("pivot_m", pivot), ("gravity_m_s2", gravity)):
            object.__setattr__(self, name, value)

    @property
    def dt_s(self) -> float:
        """The sample step (s), the path's."""
        return self.path.dt_s

    @property
    def move(self) -> Move:
        """The pivot's translation: ``acc`` at the path's step, as a jaxflex._profile.Move."""
        return Move(self.acc, self.dt_s)


def body_loads(path: PosePath, acc_m_s2, gravity_m_s2, pivot_m, xp=np):
    """(a_O (n+1, 3), g_b (n+1, 3)) m/s^2 in body components: the acceleration of the model
    frame's origin when the pivot ``pivot_m`` (3,) m (model frame) moves with the world
    acceleration samples ``acc_m_s2`` (n+1, 3), and gravity ``gravity_m_s2`` (3,) (world)."""
    rot = xp.asarray(path.rotation)
    w, alpha = xp.asarray(path.omega_rad_s), xp.asarray(path.alpha_rad_s2)
    c = xp.asarray(pivot_m)
    a_pivot = xp.einsum("kji,kj->ki", rot, xp.asarray(acc_m_s2))
    arm = -c[None]  # from the pivot to the origin
    a_origin = a_pivot + xp.cross(alpha, arm) + xp.cross(w, xp.cross(w, arm))
    gravity = xp.einsum("kji,j->ki", rot, xp.asarray(gravity_m_s2))
    return a_origin, gravity


def turning_forces(model, path: PosePath, a_origin, gravity, xp=np):
    """(n+1, M) modal forces (kg^0.5 m/s^2) of the kept loads (module docstring)."""
    s = xp.asarray(model.rotation.shape_integrals)
    gamma = xp.asarray(model.gamma)
    w, alpha = xp.asarray(path.omega_rad_s), xp.asarray(path.alpha_rad_s2)
    gamma_rot = xp.einsum("kij,mij->mk", xp.asarray(LEVI_CIVITA), s)
    spin = xp.einsum("ki,kj->kij", w, w) - xp.einsum("k,ij->kij", xp.sum(w * w, axis=1), xp.eye(3))
    return -(a_origin - gravity) @ gamma.T - alpha @ gamma_rot.T - xp.einsum("kji,mij->km", spin, s)


def gravity_coordinates(model, gravity, xp=np):
    """(T, M) Omega^-2 Gamma g_b: the modal sag under gravity ``gravity`` (T, 3) (body)."""
    omega = 2.0 * np.pi * xp.asarray(model.freq_hz)
    return (xp.asarray(gravity) @ xp.asarray(model.gamma).T) / omega**2


def _turning_coordinates(model, path, acc, gravity_m_s2, pivot_m, dt_s, xp):
    a_origin, gravity = body_loads(path, acc, gravity_m_s2, pivot_m, xp)
    force = turning_forces(model, path, a_origin, gravity, xp)
    sag = gravity_coordinates(model, gravity, xp)
    x0 = xp.stack([sag[0], xp.zeros_like(sag[0])], axis=-1)
    states = forced_states(model, force, dt_s, x0=x0, xp=xp)
    return states, sag, a_origin, gravity, force


@dataclass(frozen=True)
class TurningResponse:
    """Response to a turning move (SI units).

    t_s (T,); q, qd (T, M): the modal deviation coordinates p = q - Omega^-2 Gamma g_b and
    the modal velocity; deviation_m (T,) from the equilibrium at the current pose;
    acc_body_m_s2, gravity_body_m_s2 (n+1, 3): the frame origin's acceleration and gravity
    in body components at the move's samples; neglected_bound_m: bound on what the
    gyroscopic, Euler-on-deformation and spin-softening terms change at any point at any
    time (module docstring), neglected_energy: its energy-norm bound E (kg^0.5 m/s).
    """

    t_s: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    deviation_m: np.ndarray
    acc_body_m_s2: np.ndarray
    gravity_body_m_s2: np.ndarray
    neglected_bound_m: float
    neglected_energy: float

    @property
    def end_state(self) -> np.ndarray:
        """(M, 2) deviation state at the end of the move (free vibration afterwards)."""
        n = self.acc_body_m_s2.shape[0] - 1
        return np.stack([self.q[n], self.qd[n]], axis=-1)


def require_turn(turn) -> Turn:
    """``turn`` if it is a :class:`Turn`; InputError naming it otherwise."""
    if not isinstance(turn, Turn):
        raise InputError(
            f"turn: a jaxflex.Turn(path, acc, pivot_m, gravity_m_s2), got {type(turn).__name__}"
        )
    return turn


def check_ends_at_rest(turn: Turn) -> None:
    """InputError unless the move ends at rest (the free vibration may follow it)."""
    path = turn.path
    rate_scale = 1e-9 * max(1.0, float(np.abs(path.omega_rad_s).max()))
    if (
        np.abs(path.omega_rad_s[-1]).max() > rate_scale
        or turn.acc[-1].any()
        or path.alpha_rad_s2[-1].any()
    ):
        raise InputError("extend_s: the move must end at rest (acceleration and rate 0)")


@dataclass(frozen=True)
class TurningInputs:
    """The inputs of the turning response at the samples t_s (T,) s: q, qd (T, M) total
    modal state, base (T, 3) a_O - g_b, coefficients (T, 9) of the rotational loads
    (their static residual's), gravity_body_m_s2 (T, 3) g_b (m/s^2, 1/s^2)."""

    t_s: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    base: np.ndarray
    coefficients: np.ndarray
    gravity_body_m_s2: np.ndarray | None = None


def turning_inputs(model, turn: Turn, *, extend_s: float = 0.0) -> TurningInputs:
    """The :class:`TurningInputs` of the turning move ``turn``; with ``extend_s`` (s) the
    free vibration after the move follows (the move must end at rest), whole steps. NumPy."""
    require_rotation(model)
    path = require_turn(turn).path
    states, _, a_origin, gravity, _ = _turning_coordinates(
        model, path, turn.acc, turn.gravity_m_s2, turn.pivot_m, path.dt_s, np
    )
    q, qd = states[..., 0], states[..., 1]
    base = a_origin - gravity
    b = load_coefficients(path.omega_rad_s, path.alpha_rad_s2)
    if extend_s:
        check_ends_at_rest(turn)
        n_free = free_steps(extend_s, path.dt_s)
        tau = path.dt_s * np.arange(1, n_free + 1)
        omega = np.asarray(model.omega_rad_s)
        sag = (gravity[-1] @ np.asarray(model.gamma).T) / omega**2  # rest in the final pose
        free = free_states(model, states[-1] - np.stack([sag, 0 * sag], -1), tau, np)
        q = np.concatenate([q, sag + free[..., 0]])
        qd = np.concatenate([qd, free[..., 1]])
        base = np.concatenate([base, np.broadcast_to(-gravity[-1], (n_free, 3))])
        b = np.concatenate([b, np.zeros((n_free, 9))])
        gravity = np.concatenate([gravity, np.broadcast_to(gravity[-1], (n_free, 3))])
    return TurningInputs(path.dt_s * np.arange(q.shape[0]), q, qd, base, b, gravity)


@partial(jax.jit, static_argnames=("dt_s", "window", "free_pad"))
def _simulate_turning(model, blocks, bound, samples, loads, sizes, dt_s, window, free_pad):
    """The response, deviation and neglected-terms bound of a padded move (module docstring):
    ``samples`` (N+1, 18) the rotation, rate, angular and translational acceleration of
    each sample (:func:`simulate_turning`), of which n = ``sizes[0]`` steps are the move, then
    ``sizes[1]`` of ``free_pad`` steps of free vibration; ``loads`` (5, 3) gravity (world),
    the pivot and the path's principal axes; the bound on the window of ``sizes[2]`` and
    ``window`` steps (jaxflex._turning_bound). Device model, blocks and bound data. (rows
    (N+1, 2 M + 6) of p, p', a_O and g_b; the free vibration (F, M, 2); the deviation
    (N+1+F,); the bound and its energy (2,))."""
    n_steps, n_free = sizes[0], sizes[1]
    gravity_m_s2, pivot_m = loads[0], loads[1]
    path = PosePath(samples[:, :9].reshape(-1, 3, 3), samples[:, 9:12], samples[:, 12:15], dt_s)
    acc = samples[:, 15:]
    states, sag, a_origin, gravity, force = _turning_coordinates(
        model, path, acc, gravity_m_s2, pivot_m, path.dt_s, jnp
    )
    terms = neglected_terms(
        bound, path.omega_rad_s, path.alpha_rad_s2, states, force, n_steps,
        (sizes[2], window, loads[2:].T),
    )  # fmt: skip
    # about the sag of the current pose: p = q - Omega^-2 Gamma g_b, and p' = q' + Omega^-2
    # Gamma (w x g_b) (gravity seen from the turning frame; at rest after the move)
    p_q = states[..., 0] - sag
    p_qd = states[..., 1] + gravity_coordinates(model, jnp.cross(path.omega_rad_s, gravity), jnp)
    b = load_coefficients(path.omega_rad_s, path.alpha_rad_s2, jnp)
    moving = (jnp.arange(p_q.shape[0]) <= n_steps)[:, None]
    coords = jnp.where(moving, turning_coordinates(model, p_q, a_origin, b, jnp), 0.0)
    # after the move: free vibration about the final pose's sag (a_O = g_b, b = 0)
    end = jnp.stack([p_q[n_steps], states[n_steps, :, 1]], axis=-1)
    free = free_states(model, end, path.dt_s * jnp.arange(1, free_pad + 1, dtype=acc.dtype))
    rest = jnp.zeros((free_pad, 12), acc.dtype)
    free_coords = turning_coordinates(model, free[..., 0], rest[:, :3], rest[:, 3:], jnp)
    free_coords = jnp.where((jnp.arange(free_pad) < n_free)[:, None], free_coords, 0.0)
    # the bound's candidates evaluated with the rest (the modes are the shapes' first columns)
    count, extra = terms.candidates.shape[0], coords.shape[1] - terms.candidates.shape[1]
    candidates = jnp.pad(terms.candidates, ((0, 0), (0, extra)))
    dev = deviation(blocks, jnp.concatenate([coords, free_coords, candidates]))
    neglected = terms.bound(jnp.max(dev[dev.shape[0] - count :], initial=0.0))
    rows = jnp.concatenate([p_q, p_qd, a_origin, gravity], axis=1)
    return rows, free, dev[: dev.shape[0] - count], jnp.stack(neglected)


def padded_samples(turn: Turn, n_steps: int) -> np.ndarray:
    """(n_steps + 1, 18) the rotation, rate, angular and translational acceleration samples
    of ``turn``, extended to ``n_steps`` steps (>= n) at rest in the final pose."""
    path = turn.path
    rotation = np.asarray(path.rotation).reshape(-1, 9)
    rows = np.hstack([rotation, path.omega_rad_s, path.alpha_rad_s2, turn.acc])
    padded = np.zeros((n_steps + 1, rows.shape[1]))
    padded[: rows.shape[0]] = rows
    padded[rows.shape[0] :, :9] = rotation[-1]
    return padded


def simulate_turning(model, turn: Turn, *, extend_s: float = 0.0) -> TurningResponse:
    """Response of ``model`` (with its rotation data, jaxflex.response.RotationalInertia)
    to the turning move ``turn`` (its path, the pivot's world acceleration samples, the
    pivot and gravity). With ``extend_s`` (s) the free vibration after the move follows
    (whole steps; the move must end at rest). One compiled function per model size and
    block of PAD_STEPS steps (module docstring)."""
    rotation = require_rotation(model)
    if model.static_shapes is not None and rotation.static_shapes is None:
        warn_missing_static("deviation")
    path = require_turn(turn).path
    n, n_free = path.n_steps, 0
    if extend_s:
        check_ends_at_rest(turn)
        n_free = free_steps(extend_s, path.dt_s)
    steps, free_pad = padded_steps(n), padded_steps(n_free) if n_free else 0
    start, window = turning_window(path.omega_rad_s, path.alpha_rad_s2, steps)
    axes = principal_axes(path.omega_rad_s[start : start + window + 1],
                          path.alpha_rad_s2[start : start + window + 1])  # fmt: skip
    device, _ = on_device(model)
    out = _simulate_turning(
        device,
        turning_blocks(model),
        bound_data(model, path.dt_s),
        padded_samples(turn, steps),
        np.vstack([turn.gravity_m_s2, turn.pivot_m, axes.T]),
        np.array([n, n_free, start]),
        path.dt_s,
        window,
        free_pad,
    )
    rows, free, dev, (bound, energy) = jax.device_get(out)
    m = model.n_modes
    return TurningResponse(
        t_s=path.dt_s * np.arange(n + 1 + n_free),
        q=np.concatenate([rows[: n + 1, :m], free[:n_free, :, 0]]),
        qd=np.concatenate([rows[: n + 1, m : 2 * m], free[:n_free, :, 1]]),
        deviation_m=np.concatenate([dev[: n + 1], dev[steps + 1 : steps + 1 + n_free]]),
        acc_body_m_s2=rows[: n + 1, 2 * m : 2 * m + 3],
        gravity_body_m_s2=rows[: n + 1, 2 * m + 3 :],
        neglected_bound_m=float(bound),
        neglected_energy=float(energy),
    )


@dataclass(frozen=True)
class TurningMotion:
    """The kept response of a turning move at its samples, what the searches between them
    start from (jaxflex._turning_peaks, turning_collision, :func:`turning_settle`): the
    :class:`TurningInputs` of the move's samples, the total modal ``states`` (n+1, M, 2), the
    turning ``force`` (n+1, M) (linear between samples) and ``end_state`` (M, 2), the
    deviation state about the final pose's sag (the free vibration after the move)."""

    inputs: TurningInputs
    states: np.ndarray
    force: np.ndarray
    end_state: np.ndarray


def turning_motion(model, turn: Turn) -> TurningMotion:
    """The :class:`TurningMotion` of the turning move ``turn``. NumPy."""
    inputs = turning_inputs(model, turn)
    gravity = inputs.gravity_body_m_s2
    force = turning_forces(model, turn.path, inputs.base + gravity, gravity)
    sag = gravity_coordinates(model, gravity[-1:])[0]
    end_state = np.stack([inputs.q[-1] - sag, inputs.qd[-1]], axis=-1)
    return TurningMotion(inputs, np.stack([inputs.q, inputs.qd], axis=-1), force, end_state)


def turning_layout(model) -> PointLayout:
    """The jaxflex._settle.PointLayout of a concrete model's turning shapes (jaxflex.
    rotation_residual), built once per model."""
    cache = model.__dict__.setdefault("_turning_blocks", {})
    if "layout" not in cache:
        cache["layout"] = point_layout(turning_shapes(model), turning_blocks(model))
    return cache["layout"]


class _TurningDeviation(_ForcedMotion):
    """The deviation during a turning move for the certified settle search (jaxflex._settle):
    the kept total state exact between samples (the forcing linear between them), less the
    sag of the pose, plus the static residuals' shares of a_O and b: the sag, a_O and b
    linear between samples like the forcing, so that only the modes add curvature."""

    def __init__(self, model, path: PosePath, response: TurningResponse) -> None:
        n, dt = path.n_steps, path.dt_s
        gravity, a_origin = response.gravity_body_m_s2, response.acc_body_m_s2
        self.sag = gravity_coordinates(model, gravity)
        coefficients = load_coefficients(path.omega_rad_s, path.alpha_rad_s2)
        self.linear = np.hstack([a_origin, coefficients])
        spin = gravity_coordinates(model, np.cross(path.omega_rad_s, gravity))
        states = np.stack([response.q[: n + 1] + self.sag, response.qd[: n + 1] - spin], -1)
        force = turning_forces(model, path, a_origin, gravity)
        super().__init__(model, as_move(a_origin, dt), states, force, turning_layout(model))

    def coordinates(self, q: np.ndarray, t: np.ndarray) -> np.ndarray:
        sag = samples_at(self.sag, self.dt_s, t)
        linear = samples_at(self.linear, self.dt_s, t)
        return turning_coordinates(self.model, q - sag, linear[:, :3], linear[:, 3:])


def turning_settle(
    model,
    turn: Turn,
    threshold_m: float = THRESHOLD_M,
    *,
    response: TurningResponse | None = None,
) -> SettleReport:
    """Exact transfer, settle and cycle time (s) of the turning move ``turn`` against
    ``threshold_m`` (m), as :func:`jaxflex.analyze_move` of a straight move: after the move
    the part, at rest in its final pose, vibrates freely about its sag there, so the certified
    search of a straight move applies to the end state; a settling inside the move is searched
    the same way between the samples (the last crossing to 1e-9 s, never before it).
    ``response``: ``simulate_turning(model, turn)`` if the caller has it (any ``extend_s``),
    so that it is not computed again."""
    path = require_turn(turn).path
    threshold_m = check_positive("threshold_m", threshold_m)
    if response is None:
        response = simulate_turning(model, turn)
    wanted = f"response: simulate_turning's response to this turn ({path.n_steps} steps)"
    if not isinstance(response, TurningResponse):
        raise InputError(f"{wanted}, got a {type(response).__name__}")
    if len(response.acc_body_m_s2) != path.n_steps + 1:
        raise InputError(f"{wanted}, got one of {len(response.acc_body_m_s2) - 1} steps")
    during = _TurningDeviation(model, path, response)
    return settle_after(model, response.end_state, path.n_steps * path.dt_s, threshold_m, during)
