"""An independent floating-frame reference for turning moves (no jaxflex.turning code).

:func:`floating_frame_deviation` projects the FE's floating-frame equations on the kept
modes, written here from the mass matrix and the node coordinates of a thin solid: body-frame
gravity and translation, Euler and centrifugal loads of the rigid motion and, with ``full``,
the gyroscopic, Euler-on-deformation and spin-softening couplings phi^T M (e_k x phi). The
orientation is integrated with the modes (R' = R [w]x, w' = alpha), from the body angular
acceleration samples alone (linear between them), by DOP853 at rtol 1e-10.

``python tests/floating_frame.py`` prints the bound on the neglected terms against their
true effect (full - kept) on the turning scenes of tests/test_turning.py, with the couplings
(a posteriori) and without (the energy estimate).
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

DT = 1e-3
G_WORLD = np.array([0.0, 0.0, -9.81])
RATE, ACC, JERK = 3.0, 20.0, 400.0  # rad/s, rad/s^2, rad/s^3: robot rates of issue 26


def skew(v) -> np.ndarray:
    """[v]x (3, 3)."""
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def floating_frame_deviation(
    result, model, alpha_body, t_end, *, full, acc_world=None, start=None, dt_s=DT
):
    """Deviation (T,) m from the sag of the current pose at t = k dt_s up to ``t_end``:
    ``result`` a thin solid's fem.ModalResult (its modes, mass matrix, nodes), ``model`` its
    ModalModel (frequencies, damping, shapes at the points); ``alpha_body`` (n+1, 3) body
    angular acceleration samples (rad/s^2, linear in between, zero after), from rest at
    orientation ``start`` (3, 3) body to world (default identity); ``acc_world`` (n+1, 3)
    translation samples of the origin (world, linear in between, zero after)."""
    system = result.system
    phi = result.basis @ result.vectors  # (n_dof, M) full-DOF modes
    mass = system.M
    rho = system.outputs.layer.points  # (N, 3): the thin solid's DOFs are x, y, z per node
    n_nodes = len(rho)
    cross = [np.kron(np.eye(n_nodes), skew(e)) for e in np.eye(3)]
    coupling = [phi.T @ (mass @ (x @ phi)) for x in cross]
    spin = [[phi.T @ (mass @ (xk @ (xl @ phi))) for xl in cross] for xk in cross]
    load_t = phi.T @ (mass @ system.rigid)  # (M, 3)
    omega = 2 * np.pi * np.asarray(model.freq_hz)
    zeta = np.asarray(model.zeta)
    m = omega.size
    alpha_body = np.asarray(alpha_body, float)
    grid = dt_s * np.arange(len(alpha_body))
    acc_world = np.zeros((1, 3)) if acc_world is None else np.asarray(acc_world, float)
    acc_grid = dt_s * np.arange(len(acc_world))

    def rhs(t, y):
        eta, deta = y[:m], y[m : 2 * m]
        rot, w = y[2 * m : 2 * m + 9].reshape(3, 3), y[-3:]
        alpha = np.array([np.interp(t, grid, alpha_body[:, c], right=0.0) for c in range(3)])
        a = np.array([np.interp(t, acc_grid, acc_world[:, c], right=0.0) for c in range(3)])
        field = np.cross(alpha, rho) + np.cross(w, np.cross(w, rho))
        force = -phi.T @ (mass @ field.reshape(-1)) + load_t @ (rot.T @ (G_WORLD - a))
        force -= 2 * zeta * omega * deta + omega**2 * eta
        if full:
            force -= sum(
                2 * w[k] * coupling[k] @ deta + alpha[k] * coupling[k] @ eta for k in range(3)
            )
            force -= sum(w[k] * w[j] * spin[k][j] @ eta for k in range(3) for j in range(3))
        return np.concatenate([deta, force, (rot @ skew(w)).reshape(-1), alpha])

    rot0 = np.eye(3) if start is None else np.asarray(start, float)
    y0 = np.concatenate(
        [load_t @ (rot0.T @ G_WORLD) / omega**2, np.zeros(m), rot0.ravel(), [0.0] * 3]
    )
    t_eval = dt_s * np.arange(round(t_end / dt_s) + 1)
    sol = solve_ivp(
        rhs, (0.0, t_eval[-1]), y0, "DOP853", t_eval=t_eval, rtol=1e-10, atol=1e-14
    )  # fmt: skip
    assert sol.success, sol.message
    etas = sol.y[:m].T
    rot = sol.y[2 * m : 2 * m + 9].T.reshape(-1, 3, 3)
    sag = np.einsum("kji,j,mi->km", rot, G_WORLD, load_t) / omega**2
    u = np.einsum("pcm,km->kpc", np.asarray(model.shapes), etas - sag)
    return np.linalg.norm(u, axis=2).max(axis=1)


def _scenes():
    """The turning scenes of tests/test_turning.py: (name, path, world translation)."""
    from scipy.spatial.transform import Rotation

    import jaxflex
    from jaxflex.pose import fixed_axis_path, orientation_path, turn_acceleration

    for name, axis, angle_deg in (
        ("swivel 90 deg about z", "z", 90.0),
        ("tilt 30 deg about x", "x", 30.0),
        ("skew axis (0.3, 0, 1), 90 deg", (0.3, 0.0, 1.0), 90.0),
    ):
        alpha = turn_acceleration(np.radians(angle_deg), RATE, ACC, JERK, DT)
        yield name, fixed_axis_path(axis, alpha, DT), np.zeros((len(alpha), 3))
    goals = [np.zeros(3), [0.0, 0.0, np.pi / 2]]
    goals.append(Rotation.from_euler("ZX", [90, 30], degrees=True).as_matrix())
    path = orientation_path(goals, RATE, ACC, JERK, DT)
    travel = jaxflex.jerk_limited_move([0.5, 0.0, 0.2], 1.0, 5.0, 50.0, DT)
    acc = np.zeros((path.n_steps + 1, 3))
    acc[: len(travel)] = travel
    yield "combined: swivel, tilt, 0.5 m travel", path, acc


def bound_table(extra_scenes=()) -> list[tuple[str, float, float, float, float]]:
    """(scene, peak deviation, true effect max |full - kept|, a-posteriori bound, energy
    bound) in m on the cantilever of tests/test_turning.py (4 modes, 0.3 s of free decay)."""
    import fem
    from jaxflex.turning import simulate_turning

    part = fem.curved_panel(0.3, 0.2, 2e-3, "steel", 0.1, radius_x=0.6, radius_y=None)
    result = fem.modal_analysis(part, [fem.ClampedEdge("left")], n_modes=4, zeta=0.02)
    model = result.to_modal_model(points="all")._replace(static_shapes=None)
    energy_only = model._replace(rotation=model.rotation.replace(gyroscopic=None, spin=None))
    rows = []
    for name, path, acc in (*_scenes(), *extra_scenes):
        response = simulate_turning(model, path, acc, extend_s=0.3)
        old = simulate_turning(energy_only, path, acc, extend_s=0.3).neglected_bound_m
        args = (result, model, path.alpha_rad_s2, response.t_s[-1])
        full = floating_frame_deviation(*args, full=True, acc_world=acc)
        kept = floating_frame_deviation(*args, full=False, acc_world=acc)
        effect = float(np.abs(full - kept).max())
        rows.append((name, float(full.max()), effect, response.neglected_bound_m, old))
    return rows


if __name__ == "__main__":
    print("| scene | peak | true effect | bound (a posteriori) | ratio | energy bound | ratio |")
    print("|---|---|---|---|---|---|---|")
    for name, peak, effect, bound, old in bound_table():
        print(
            f"| {name} | {peak * 1e6:.1f} um | {effect * 1e9:.2f} nm | {bound * 1e9:.2f} nm | "
            f"{bound / effect:.2f} | {old * 1e9:.0f} nm | {old / effect:.0f} |"
        )
