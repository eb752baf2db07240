"""Independent references for the tests: computations that share no code with jaxflex's.

* :func:`modal_states_lsim`: the modal coordinates by scipy.signal.lsim (matrix exponential
  of each mode's state space, input linear between the samples it is given), on a fine grid
  of the piecewise-linear acceleration;
* :func:`path_positions`: the rigid path, integrating the piecewise-linear acceleration
  segment by segment in closed form;
* :func:`static_nodes`: the exact static displacement of every FE node under a constant base
  acceleration, by a direct sparse solve of the FE stiffness (scipy.sparse.linalg.spsolve);
* :func:`box_distance`, :func:`half_space_distance`: signed distances written from their
  definitions;
* :func:`skin_points`: the two skins of a flat sheet, +-h/2 along its normal.

SI units throughout.
"""

from __future__ import annotations

import numpy as np
import scipy.signal
import scipy.sparse.linalg


def fine_acceleration(acc: np.ndarray, dt_s: float, t_s: np.ndarray) -> np.ndarray:
    """(T, 3) the piecewise-linear acceleration through samples ``acc`` (n+1, 3) at k dt_s,
    zero after the last sample."""
    grid = dt_s * np.arange(len(acc))
    return np.column_stack([np.interp(t_s, grid, acc[:, c], right=0.0) for c in range(3)])


def modal_states_lsim(
    freq_hz, zeta, gamma, acc, dt_s: float, t_s: np.ndarray, *, velocities: bool = False
) -> np.ndarray:
    """(T, M) modal coordinates q_i'' + 2 zeta w q_i' + w^2 q_i = -gamma_i . a(t) from rest at
    t = 0, at the times ``t_s`` (an evenly spaced grid from 0 that contains every sample time
    k dt_s of the move, so the input is exactly linear between its points): one state-space
    system of all modes (inputs a_x, a_y, a_z) through scipy.signal.lsim. With
    ``velocities``: (T, M, 2), the coordinates and their rates."""
    omega = 2 * np.pi * np.asarray(freq_hz, dtype=float)
    z = np.asarray(zeta, dtype=float)
    m = omega.size
    a = np.zeros((2 * m, 2 * m))
    a[np.arange(m), m + np.arange(m)] = 1.0
    a[m + np.arange(m), np.arange(m)] = -(omega**2)
    a[m + np.arange(m), m + np.arange(m)] = -2 * z * omega
    b = np.vstack([np.zeros((m, 3)), -np.asarray(gamma, dtype=float)])
    system = scipy.signal.StateSpace(a, b, np.eye(2 * m), np.zeros((2 * m, 3)))
    _, y, _ = scipy.signal.lsim(system, fine_acceleration(acc, dt_s, t_s), t_s, interp=True)
    y = np.asarray(y).reshape(len(t_s), 2, m)
    return np.moveaxis(y, 1, 2) if velocities else y[:, 0]


def output_peak_lsim(model, outputs, functional, acc, dt_s: float, until_s: float, gravity):
    """The largest value of ``functional`` over the items of ``outputs`` (a jaxflex
    LinearOutputs of ``model``: y = Q q + V q' + A a - S g) on a 0.1 ms grid to ``until_s``,
    the modal states by :func:`modal_states_lsim`."""
    t = 1e-4 * np.arange(round(until_s / 1e-4) + 1)
    x = modal_states_lsim(model.freq_hz, model.zeta, model.gamma, acc, dt_s, t, velocities=True)
    a = fine_acceleration(acc, dt_s, t)
    rest = -np.asarray(outputs.static_map) @ np.asarray(gravity, dtype=float)
    items = np.arange(functional.n_items)
    best = -np.inf
    for chunk in np.array_split(np.arange(len(t)), max(1, len(t) // 400)):
        y = x[chunk, :, 0] @ np.asarray(outputs.q_map).T
        y += x[chunk, :, 1] @ np.asarray(outputs.v_map).T
        y += a[chunk] @ np.asarray(outputs.a_map).T + rest
        best = max(
            best, float(functional.values(y.reshape(len(chunk), len(items), -1), items).max())
        )
    return best


def path_positions(acc: np.ndarray, dt_s: float, t_s: np.ndarray) -> np.ndarray:
    """(T, 3) position of the rigid path from rest at the origin: on each step the
    acceleration is a + j tau, so v and x follow by integrating twice; held after the end."""
    acc = np.asarray(acc, dtype=float)
    n = len(acc) - 1
    x, v = np.zeros((n + 1, 3)), np.zeros((n + 1, 3))
    for k in range(n):
        a, j = acc[k], (acc[k + 1] - acc[k]) / dt_s
        x[k + 1] = x[k] + v[k] * dt_s + a * dt_s**2 / 2 + j * dt_s**3 / 6
        v[k + 1] = v[k] + a * dt_s + j * dt_s**2 / 2
    out = np.empty((len(t_s), 3))
    for i, t in enumerate(t_s):
        k = min(int(t // dt_s), n - 1)
        tau = min(t - k * dt_s, dt_s)
        if t >= n * dt_s:
            out[i] = x[n]
            continue
        a, j = acc[k], (acc[k + 1] - acc[k]) / dt_s
        out[i] = x[k] + v[k] * tau + a * tau**2 / 2 + j * tau**3 / 6
    return out


def static_nodes(result, acceleration_m_s2, solve=None) -> np.ndarray:
    """(N, 3) every node's static displacement (m) under the constant base acceleration
    (3,): K_ff z = -(M R)_free a, by one direct sparse solve (``solve(rhs)``: a caller's
    own factorisation of K_ff by scipy, to solve with it again; default spsolve)."""
    load = -(np.asarray(result.load) @ np.asarray(acceleration_m_s2, dtype=float))
    z = solve(load) if solve else scipy.sparse.linalg.spsolve(result.K_free.tocsc(), load)
    return (result.observation @ z).reshape(-1, 3)


def box_distance(points: np.ndarray, centre, size) -> np.ndarray:
    """(N,) signed distance of points (N, 3) to an axis-aligned box (negative inside)."""
    d = np.abs(points - np.asarray(centre)) - np.asarray(size) / 2
    outside = np.sqrt(np.sum(np.maximum(d, 0.0) ** 2, axis=1))
    return np.where((d <= 0).all(axis=1), d.max(axis=1), outside)


def half_space_distance(points: np.ndarray, normal, offset) -> np.ndarray:
    n = np.asarray(normal, dtype=float)
    return points @ (n / np.linalg.norm(n)) - offset


def skin_points(mid: np.ndarray, normal, thickness_m: float) -> np.ndarray:
    """(..., 2 P, 3) both skins of a flat sheet whose mid-surface points are ``mid``
    (..., P, 3), at +-thickness / 2 along the unit ``normal`` (3,)."""
    n = np.asarray(normal, dtype=float) / np.linalg.norm(normal)
    half = 0.5 * thickness_m * n
    return np.concatenate([mid + half, mid - half], axis=-2)
