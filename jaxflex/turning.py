"""The response to moves that turn the part (floating frame of reference).

In the body frame of the gripper (the model frame, origin O) a point r of the part moves by
the elastic displacement u, and the frame by the acceleration a_O of its origin, the angular
velocity w and the angular acceleration alpha (body components; jaxflex.pose). With gravity
g (body components g_b = R^T g, turning with the part) the FE equation reads

    M u'' + C u' + K u = -M [a_O - g_b + alpha x r + w x (w x r)]            (kept)
                         -M [2 w x u' + alpha x u + w x (w x u)]             (neglected)

The first line is the modal forcing this module integrates, through the inertia shape
integrals S (jaxflex.rotation):

    f_m = -Gamma_m . (a_O - g_b) - Gamma_rot,m . alpha - tr(A(w) S_m),   A(w) = w w^T - |w|^2 I,

sampled at the pose samples and advanced by the engine's exact first-order-hold recursion
(jaxflex.engine.forced_states): exact for the sampled forcing, like a straight move. The
translation is the acceleration of a pivot (world components), moved to O by the rigid
rotation terms.

**Deviation about the equilibrium at the current pose**: the part starts at rest sagging
under gravity in its start pose (q_0 = Omega^-2 Gamma g_b(0)), and the deviation is measured
from the static sag of the pose it is in, u_eq(t) = -static_shapes g_b(t), so a part tilted
at B settles to its sag at B. With the mode-acceleration split (jaxflex.model) the deviation
is u - u_eq = Phi p + D a_O + D_rot b with p = q - Omega^-2 Gamma g_b(t), D the static
residual of the translation and D_rot that of the Euler and centrifugal loads
(jaxflex.rotation_residual: the modes left out respond quasi-statically to them too). A
model without the static response to the rotational loads (a file written before it was
stored) leaves that share out (with every mode kept it is zero; with truncated modes it is
the static flexibility of the modes left out times alpha r and w^2 r).

**Neglected terms, bounded.** The second line (Coriolis/gyroscopic 2 w x u', the Euler term
on the deformation alpha x u, spin softening w x (w x u)) is left out and its effect bounded
(:func:`neglected_bound`). In the kept modes the full equation is the kept one plus the
neglected modal load, linear in the modal state x = (q, q') (total q, the sag included):

    N(t) x = -(2 G(w) q' + (G(alpha) + P(w)) q),   G(v) = sum_k v_k G_k,  P(w) = sum_kl w_k w_l P_kl

with the couplings G_k = phi^T M X_k phi, P_kl = phi^T M X_k X_l phi (jaxflex.rotation; X_k:
u -> e_k x u). The error e = q_full - q of the kept-terms response q obeys
e'' + 2 Z Omega e' + Omega^2 e = N (x + e_x), e(0) = 0. Split e = y + d:

* **first order, a posteriori**: y'' + 2 Z Omega y' + Omega^2 y = N x along the computed
  states, integrated by the engine's exact recursion (exact for the sampled load, like the
  kept forcing), its displacement |Phi_p y| taken at every point and sample; after the last
  sample y vibrates freely and a point moves at most F E_y(end), E_y = sqrt(|y'|^2 +
  |Omega y|^2) the energy norm (it only decays) and F = max_p sqrt(sum_m |phi_m(p)|^2 /
  omega_m^2) (Cauchy-Schwarz over the modes);
* **second order, Gronwall**: d obeys the full equation forced by N y_x, with its own
  neglected load N d feeding back. With E = sqrt(|d'|^2 + |Omega d|^2), the damping taking
  energy out, d'.G(w) d' = d'.G_sym(w) d' (G_k is skew where the mass matrix commutes with
  the nodal cross product: the thin solid, the plate) and |(G(alpha) + P(w)) d| <=
  |(G(alpha) + P(w)) Omega^-1| E: E' <= |N y_x| + c(t) E with c = 2 |G_sym(w)| +
  |(G(alpha) + P(w)) Omega^-1| (spectral norms), so E(t) <= exp(int c) int |N y_x|: second
  order in the rates (y is already the small effect), and a point moves at most F E.

The bound is max over points and samples of |Phi_p y| (and F E_y(end)) plus F E. No small-
gain condition is needed (the feedback enters through exp(int c), near 1 at robot rates:
int c ~ |w|^2 T / omega_1 for a turn of T s). Measured against an independent floating-
frame integration with every term (tests/test_turning.py; ``python
tests/floating_frame.py``): 1.03-1.24 times the true effect. **Fallback**: a model without
the couplings (a file written before them, a deck or ANSYS import) gets the energy estimate
alone, with norms instead of the couplings:
the gyroscopic load of e does no work, the other two are at most (|alpha| + |w|^2) |e|_M <=
(|alpha| + |w|^2) / omega_1 E, so E' <= G(t) + c(t) E with G = 2 |w| |q'| + (|alpha| +
|w|^2) |q| and c = (|alpha| + |w|^2) / omega_1, E(t) <= exp(int c) int G, a point moving at
most F E; it counts the whole sag as spinning in every direction and is 350-70 000 times
the true effect on those scenes. Both integrals take the larger of the two samples of each
step (the path's rates are smooth between samples).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import jax
import jax.numpy as jnp
import numpy as np

from jaxflex.deviation import deviation
from jaxflex.engine import forced_states, free_states
from jaxflex.errors import InputError
from jaxflex.pose import PosePath
from jaxflex.rotation import LEVI_CIVITA, require_rotation
from jaxflex.rotation_residual import (
    load_coefficients,
    turning_blocks,
    turning_coordinates,
    warn_missing_static,
)
from jaxflex.settle import settle_after

GRAVITY_M_S2 = (0.0, 0.0, -9.81)


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
    return states, sag, a_origin, gravity


@jax.jit
def _turning_deviation(model, blocks, path, acc, gravity_m_s2, pivot_m, dt_s):
    states, sag, a_origin, _ = _turning_coordinates(
        model, path, acc, gravity_m_s2, pivot_m, dt_s, jnp
    )
    b = load_coefficients(path.omega_rad_s, path.alpha_rad_s2, jnp)
    return deviation(blocks, turning_coordinates(model, states[..., 0] - sag, a_origin, b, jnp))


def turning_deviation(model, path: PosePath, acc, *, gravity_m_s2=GRAVITY_M_S2, pivot_m=(0, 0, 0)):
    """d (n+1,) m at the samples of the turning move (JAX, compiled once per length): the
    kernel of :func:`simulate_turning`, for timing and batches. Concrete ``model``."""
    require_rotation(model)
    blocks = turning_blocks(model)
    device_path = jax.tree_util.tree_map(jnp.asarray, path)
    return _turning_deviation(
        model,
        blocks,
        device_path,
        jnp.asarray(acc, jnp.float64),
        jnp.asarray(gravity_m_s2, jnp.float64),
        jnp.asarray(pivot_m, jnp.float64),
        path.dt_s,
    )


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


def neglected_load(rotation, path: PosePath, states: np.ndarray) -> np.ndarray:
    """(n+1, M) modal load of the neglected terms -(2 G(w) q' + (G(alpha) + P(w)) q) along
    the modal states ``states`` (n+1, M, 2) of ``path`` (``rotation``'s couplings: module
    docstring), kg^0.5 m/s^2."""
    gyro, spin = np.asarray(rotation.gyroscopic), np.asarray(rotation.spin)
    w, alpha = path.omega_rad_s, path.alpha_rad_s2
    q, v = states[..., 0], states[..., 1]
    load = 2.0 * np.einsum("tk,kmn,tn->tm", w, gyro, v) + np.einsum("tk,kmn,tn->tm", alpha, gyro, q)
    return -(load + np.einsum("tk,tl,klmn,tn->tm", w, w, spin, q))


def _step_integral(values: np.ndarray, dt_s: float) -> float:
    """int of a nonnegative sampled rate (n+1,) with the larger sample of each step."""
    return float(np.maximum(values[:-1], values[1:]).sum() * dt_s)


def _largest_displacement(shapes: np.ndarray, q: np.ndarray, block: int = 256) -> float:
    """max over the points and samples of |Phi_p q_t| (m): ``shapes`` (K, 3, M), modal
    coordinates ``q`` (T, M); one matrix product per block of samples."""
    flat = shapes.reshape(-1, shapes.shape[2])  # (3 K, M)
    largest = 0.0
    for start in range(0, q.shape[0], block):
        u = (flat @ q[start : start + block].T).reshape(shapes.shape[0], 3, -1)
        largest = max(largest, float(np.sqrt(np.einsum("kct,kct->kt", u, u).max())))
    return largest


def neglected_bound(model, path: PosePath, states: np.ndarray) -> tuple[float, float]:
    """(bound on any point's displacement change, m; energy-norm bound, kg^0.5 m/s) of the
    neglected terms for the computed total modal states ``states`` (T, M, 2) at the samples
    of ``path`` and of the free vibration after it (T >= n+1): a posteriori through the
    couplings where the model has them, else the energy estimate (module docstring)."""
    omega = 2.0 * np.pi * np.asarray(model.freq_hz)
    flex = np.sqrt(np.max(np.sum(np.asarray(model.shape_norms) ** 2 / omega**2, axis=1)))
    w = np.linalg.norm(path.omega_rad_s, axis=1)
    alpha = np.linalg.norm(path.alpha_rad_s2, axis=1)
    n = path.n_steps
    rotation = model.rotation
    if rotation.gyroscopic is None:  # the energy estimate alone
        q_norm = np.linalg.norm(states[: n + 1, :, 0], axis=1)
        v_norm = np.linalg.norm(states[: n + 1, :, 1], axis=1)
        load = 2.0 * w * v_norm + (alpha + w**2) * q_norm
        growth = (alpha + w**2) / omega.min()
        energy = math.exp(_step_integral(growth, path.dt_s)) * _step_integral(load, path.dt_s)
        return float(energy * flex), float(energy)
    # first order: y, the response to the neglected load of the computed states (exact for
    # the sampled load, like the kept one), at every point and sample, and after the last
    # sample within its energy (free vibration: the energy only decays)
    force = np.zeros(states.shape[:2])
    force[: n + 1] = neglected_load(rotation, path, states[: n + 1])
    y = forced_states(model, force, path.dt_s, xp=np)
    first = _largest_displacement(np.asarray(model.shapes), y[..., 0])
    energy_y = np.sqrt(np.sum(y[..., 1] ** 2 + (omega * y[..., 0]) ** 2, axis=1))
    first = max(first, flex * float(energy_y[-1]))
    # second order: delta = e - y obeys the full equation forced by N y, its own neglected
    # load N delta feeding back (Gronwall, module docstring)
    remainder = np.linalg.norm(neglected_load(rotation, path, y[: n + 1]), axis=1)
    gyro = np.einsum("tk,kmn->tmn", path.omega_rad_s, np.asarray(rotation.gyroscopic))
    stiff = np.einsum("tk,kmn->tmn", path.alpha_rad_s2, np.asarray(rotation.gyroscopic))
    stiff = stiff + np.einsum("tk,tl,klmn->tmn", path.omega_rad_s, path.omega_rad_s, rotation.spin)
    growth = 2.0 * np.linalg.norm(0.5 * (gyro + gyro.transpose(0, 2, 1)), ord=2, axis=(1, 2))
    growth = growth + np.linalg.norm(stiff / omega[None, None, :], ord=2, axis=(1, 2))
    energy_delta = math.exp(_step_integral(growth, path.dt_s)) * _step_integral(
        remainder, path.dt_s
    )
    return first + flex * energy_delta, float(energy_y.max()) + energy_delta


def check_ends_at_rest(path: PosePath, acc: np.ndarray) -> None:
    """InputError unless the move ends at rest (the free vibration may follow it)."""
    rate_scale = 1e-9 * max(1.0, float(np.abs(path.omega_rad_s).max()))
    if (
        np.abs(path.omega_rad_s[-1]).max() > rate_scale
        or acc[-1].any()
        or path.alpha_rad_s2[-1].any()
    ):
        raise InputError("extend_s: the move must end at rest (acceleration and rate 0)")


@dataclass(frozen=True)
class TurningInputs:
    """The inputs of the turning response at the samples t_s (T,) s: q, qd (T, M) total
    modal state, base (T, 3) a_O - g_b, coefficients (T, 9) of the rotational loads
    (jaxflex.rotation_residual), gravity_body_m_s2 (T, 3) g_b (m/s^2, 1/s^2)."""

    t_s: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    base: np.ndarray
    coefficients: np.ndarray
    gravity_body_m_s2: np.ndarray | None = None


def turning_inputs(
    model, path: PosePath, acc, *, gravity_m_s2=GRAVITY_M_S2, pivot_m=(0.0, 0.0, 0.0), extend_s=0.0
) -> TurningInputs:
    """The :class:`TurningInputs` for the turning ``path`` while the pivot ``pivot_m`` (model
    frame, m) moves with world accelerations ``acc`` ((n+1, 3) m/s^2) under ``gravity_m_s2``
    (world); with ``extend_s`` the free vibration after the move follows (the path must end
    at rest), whole steps. NumPy."""
    require_rotation(model)
    acc = np.asarray(acc, dtype=np.float64)
    n = path.n_steps
    if acc.shape != (n + 1, 3):
        raise InputError(f"acc: expected shape ({n + 1}, 3) like the pose path, got {acc.shape}")
    gravity_world = np.asarray(gravity_m_s2, float)
    states, _, a_origin, gravity = _turning_coordinates(
        model, path, acc, gravity_world, np.asarray(pivot_m, float), path.dt_s, np
    )
    q, qd = states[..., 0], states[..., 1]
    base = a_origin - gravity
    b = load_coefficients(path.omega_rad_s, path.alpha_rad_s2)
    if extend_s:
        check_ends_at_rest(path, acc)
        n_free = int(np.ceil(extend_s / path.dt_s - 1e-9))
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


def simulate_turning(
    model,
    path: PosePath,
    acc,
    *,
    gravity_m_s2=GRAVITY_M_S2,
    pivot_m=(0.0, 0.0, 0.0),
    extend_s: float = 0.0,
) -> TurningResponse:
    """Response of ``model`` (with jaxflex.rotation data) to the turning ``path`` while the
    pivot ``pivot_m`` (model frame, m) moves with world acceleration samples ``acc``
    ((n+1, 3) m/s^2 at the path's dt_s), under ``gravity_m_s2`` (world, default -9.81 m/s^2
    along z; (0, 0, 0) for none). With ``extend_s`` the free vibration after the move
    follows (whole steps; the path must end at rest). NumPy (nothing to compile)."""
    rotation = require_rotation(model)
    if model.static_shapes is not None and rotation.static_shapes is None:
        warn_missing_static("deviation")
    inputs = turning_inputs(
        model, path, acc, gravity_m_s2=gravity_m_s2, pivot_m=pivot_m, extend_s=extend_s
    )
    n = path.n_steps
    gravity = inputs.gravity_body_m_s2
    bound, energy = neglected_bound(model, path, np.stack([inputs.q, inputs.qd], axis=-1))
    # about the sag of the current pose: p = q - Omega^-2 Gamma g_b, and p' = q' + Omega^-2
    # Gamma (w x g_b) (gravity seen from the turning frame; at rest after the move)
    omega_rad_s = np.zeros_like(gravity)
    omega_rad_s[: n + 1] = path.omega_rad_s
    p_q = inputs.q - gravity_coordinates(model, gravity)
    p_qd = inputs.qd + gravity_coordinates(model, np.cross(omega_rad_s, gravity))
    a_origin = inputs.base + gravity  # the deviation's static residual takes a_O alone
    coords = turning_coordinates(model, p_q, a_origin, inputs.coefficients)
    dev = np.asarray(deviation(turning_blocks(model), jnp.asarray(coords)))
    return TurningResponse(
        t_s=inputs.t_s,
        q=p_q,
        qd=p_qd,
        deviation_m=dev,
        acc_body_m_s2=a_origin[: n + 1],
        gravity_body_m_s2=gravity[: n + 1],
        neglected_bound_m=bound,
        neglected_energy=energy,
    )


def turning_settle(path: PosePath, model, response: TurningResponse, threshold_m: float):
    """Exact settle and cycle time (jaxflex.settle.SettleReport) of the turning move of
    ``response`` (from :func:`simulate_turning` on ``path``): after the move the part, at rest
    in its final pose, vibrates freely about its sag there, so the certified search of a
    straight move applies to the end state; a settling inside the move is sampled."""
    n = path.n_steps
    return settle_after(
        model, response.end_state, n * path.dt_s, threshold_m, response.deviation_m[: n + 1]
    )
