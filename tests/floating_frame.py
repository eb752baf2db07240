"""An independent floating-frame reference for turning moves (no jaxflex._turning code).

:class:`FloatingFrame` projects the FE's floating-frame equations on the kept modes, written
here from the mass matrix and the node coordinates of a thin solid: body-frame gravity and
translation, Euler and centrifugal loads of the rigid motion and, with ``full``, the
gyroscopic, Euler-on-deformation and spin-softening couplings phi^T M (e_k x phi). The
projections are computed once from the FE's arrays (the nine unit fields e_j r_i and the
nodal cross products). The orientation is integrated with the modes (R' = R [w]x, w' =
alpha), from the body angular acceleration samples alone (linear between them), by DOP853 at
rtol 1e-10, and the response is read on a grid of its own (``eval_dt_s``), finer than the
samples where the neglected terms' largest effect is wanted between them.

``python tests/floating_frame.py`` prints the bound on the neglected terms against their
true effect (max over every point and the evaluation grid of |u_full - u_kept|) on the
turning scenes of tests/test_turning.py at the sample steps 10 ms and 2 ms, with the
couplings (a posteriori) and without (the energy estimate); ``--panel`` on the built-in
curved panel (fem.scenes, 20 modes; the FE solve takes a minute or two).
"""

from __future__ import annotations

import bisect
import sys

import numpy as np
import scipy.sparse as sp
from scipy.integrate import solve_ivp

DT = 1e-3
G_WORLD = np.array([0.0, 0.0, -9.81])
RATE, ACC, JERK = 3.0, 20.0, 400.0  # rad/s, rad/s^2, rad/s^3: robot rates of issue 26


def skew(v) -> np.ndarray:
    """[v]x (3, 3)."""
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


class FloatingFrame:
    """The kept modes of a thin solid's fem.ModalResult ``result`` (its modes, mass matrix
    and nodes) with the frequencies, damping and point shapes of its ModalModel ``model``."""

    def __init__(self, result, model) -> None:
        system = result.system
        phi = result.basis @ result.vectors  # (n_dof, M) full-DOF modes
        weighted = system.M @ phi  # M phi (the mass matrix is symmetric)
        rho = system.outputs.layer.points  # (N, 3): the thin solid's DOFs are x, y, z per node
        cross = [sp.kron(sp.eye(len(rho)), sp.csr_matrix(skew(e))).tocsr() for e in np.eye(3)]
        self.coupling = np.array([weighted.T @ (x @ phi) for x in cross])  # (3, M, M)
        self.spin = np.array([[weighted.T @ (xk @ (xl @ phi)) for xl in cross] for xk in cross])
        fields = np.zeros((3, 3, *rho.shape))  # [i, j]: the field e_j r_i
        for i in range(3):
            for j in range(3):
                fields[i, j, :, j] = rho[:, i]
        self.fields = np.einsum("dm,ijd->mij", weighted, fields.reshape(3, 3, -1))
        self.load_t = weighted.T @ system.rigid  # (M, 3)
        self.omega = 2 * np.pi * np.asarray(model.freq_hz)
        self.zeta = np.asarray(model.zeta)
        self.shapes = np.asarray(model.shapes)

    def _rhs(self, alpha_body, acc_world, dt_s: float, full: bool):
        """The right-hand side of the modes, the orientation and the rate (state: eta, eta',
        R row by row, w), the samples linear between them and zero after the last. Written
        for speed (it is called some 10^5 times a run): the samples' linear pieces looked up
        by bisection, and every term one product with a projection flattened beforehand."""
        m, omega, zeta = self.omega.size, self.omega, self.zeta
        damping, stiffness = 2 * zeta * omega, omega**2
        # [w]x row by row = cross @ w; the rigid field B = [alpha]x + w w^T - |w|^2 I row by
        # row = field @ (alpha, w w^T row by row), its load -sum_ij B_ji fields[m, i, j]
        cross = np.stack([skew(e).ravel() for e in np.eye(3)], axis=1)  # (9, 3)
        field = np.hstack([cross, np.eye(9) - np.outer(np.eye(3).ravel(), np.eye(3).ravel())])
        rigid = self.fields.transpose(0, 2, 1).reshape(m, 9) @ field  # (M, 12)
        couplings = np.concatenate([self.coupling, self.spin.reshape(9, m, m)]).reshape(12, -1)
        gyroscopic = 2 * self.coupling.reshape(3, -1)
        load_t = self.load_t

        def pieces(samples):  # (times, last time, values (n, 3), slopes (n, 3))
            samples = np.asarray(samples, float)
            times = dt_s * np.arange(len(samples))
            slopes = np.zeros_like(samples)
            slopes[:-1] = np.diff(samples, axis=0) / np.diff(times)[:, None]
            return times.tolist(), times[-1], samples, slopes

        alpha_pieces, acc_pieces = pieces(alpha_body), pieces(acc_world)
        zero = np.zeros(3)

        def at(t, table):  # np.interp(t, times, values, right=0.0) of each column
            times, last, values, slopes = table
            if t > last:
                return zero
            k = max(bisect.bisect_right(times, t) - 1, 0)
            return values[k] + slopes[k] * (t - times[k])

        def rhs(t, y):
            eta, deta = y[:m], y[m : 2 * m]
            rot, w = y[2 * m : 2 * m + 9].reshape(3, 3), y[-3:]
            alpha, a = at(t, alpha_pieces), at(t, acc_pieces)
            rates = np.concatenate([alpha, (w[:, None] * w).ravel()])
            force = load_t @ ((G_WORLD - a) @ rot) - rigid @ rates
            force -= damping * deta + stiffness * eta
            if full:  # gyroscopic, Euler-on-deformation and spin-softening couplings
                force -= (w @ gyroscopic).reshape(m, m) @ deta
                force -= (rates @ couplings).reshape(m, m) @ eta
            return np.concatenate([deta, force, (rot @ (cross @ w).reshape(3, 3)).ravel(), alpha])

        return rhs

    def run(self, alpha_body, t_end, *, full, acc_world=None, start=None, dt_s=DT, eval_dt_s=None):
        """(t (T,), modal coordinates about the sag of the current pose (T, M)) every
        ``eval_dt_s`` (default ``dt_s``) up to ``t_end``: ``alpha_body`` (n+1, 3) body angular
        acceleration samples (rad/s^2, linear in between, zero after) at step ``dt_s``, from
        rest at orientation ``start`` (3, 3) body to world (default identity); ``acc_world``
        (n+1, 3) translation samples of the origin (world, linear in between, zero after)."""
        m = self.omega.size
        alpha_body = np.asarray(alpha_body, float)
        acc_world = np.zeros((1, 3)) if acc_world is None else np.asarray(acc_world, float)
        rot0 = np.eye(3) if start is None else np.asarray(start, float)
        sag0 = self.load_t @ (rot0.T @ G_WORLD) / self.omega**2
        y0 = np.concatenate([sag0, np.zeros(m), rot0.ravel(), [0.0] * 3])
        step = dt_s if eval_dt_s is None else eval_dt_s
        t_eval = step * np.arange(round(t_end / step) + 1)
        sol = solve_ivp(
            self._rhs(alpha_body, acc_world, dt_s, full), (0.0, t_eval[-1]), y0, "DOP853",
            t_eval=t_eval, rtol=1e-10, atol=1e-14,
        )  # fmt: skip
        assert sol.success, sol.message
        rot = sol.y[2 * m : 2 * m + 9].T.reshape(-1, 3, 3)
        sag = np.einsum("kji,j,mi->km", rot, G_WORLD, self.load_t) / self.omega**2
        return t_eval, sol.y[:m].T - sag

    def deviation(self, coordinates, chunk: int = 256) -> np.ndarray:
        """(T,) max over the points of |u_p| for modal ``coordinates`` (T, M), m: the
        displacements of ``chunk`` rows at a time as one product with the shapes."""
        shapes = self.shapes.reshape(-1, self.shapes.shape[-1])  # (3 P, M)
        peaks = [np.zeros(0)]
        for begin in range(0, len(coordinates), chunk):
            u = (shapes @ coordinates[begin : begin + chunk].T).reshape(len(shapes) // 3, 3, -1)
            peaks.append(np.sqrt(np.einsum("pct,pct->pt", u, u).max(axis=0)))
        return np.concatenate(peaks)

    def largest(self, coordinates, chunk: int = 256) -> float:
        """max over the points and rows of |u_p| for modal ``coordinates`` (T, M), m."""
        return float(self.deviation(coordinates, chunk).max(initial=0.0))

    def neglected_effect(self, alpha_body, t_end, *, eval_dt_s, **kwargs) -> tuple[float, float]:
        """(peak deviation with every term, m; max over the points and the evaluation grid
        of |u_full - u_kept|, m: the true effect of the neglected terms)."""
        _, full = self.run(alpha_body, t_end, full=True, eval_dt_s=eval_dt_s, **kwargs)
        _, kept = self.run(alpha_body, t_end, full=False, eval_dt_s=eval_dt_s, **kwargs)
        return float(self.deviation(full).max()), self.largest(full - kept)


def floating_frame_deviation(
    result, model, alpha_body, t_end, *, full, acc_world=None, start=None, dt_s=DT
):
    """Deviation (T,) m from the sag of the current pose at t = k dt_s up to ``t_end``
    (:meth:`FloatingFrame.run` at the samples)."""
    frame = FloatingFrame(result, model)
    _, coordinates = frame.run(
        alpha_body, t_end, full=full, acc_world=acc_world, start=start, dt_s=dt_s
    )
    return frame.deviation(coordinates)


def scenes(dt_s: float, rate=RATE, acc=ACC, jerk=JERK):
    """The turning scenes of tests/test_turning.py at step ``dt_s``: (name, path, world
    translation): a swivel, a tilt, a turn about a skew axis, and the combined move (a swivel
    then a tilt through orientations while the gripper travels)."""
    from scipy.spatial.transform import Rotation

    import jaxflex
    from jaxflex._pose import fixed_axis_path, orientation_path, turn_acceleration

    for name, axis, angle_deg in (
        ("swivel 90 deg about z", "z", 90.0),
        ("tilt 30 deg about x", "x", 30.0),
        ("skew axis (0.3, 0, 1), 90 deg", (0.3, 0.0, 1.0), 90.0),
    ):
        alpha = turn_acceleration(np.radians(angle_deg), rate, acc, jerk, dt_s)
        yield name, fixed_axis_path(axis, alpha, dt_s), np.zeros((len(alpha), 3))
    goals = [np.zeros(3), [0.0, 0.0, np.pi / 2]]
    goals.append(Rotation.from_euler("ZX", [90, 30], degrees=True).as_matrix())
    path = orientation_path(goals, rate, acc, jerk, dt_s)
    travel = jaxflex.jerk_limited_move([0.5, 0.0, 0.2], 1.0, 5.0, 50.0, dt_s).acc
    translation = np.zeros((path.n_steps + 1, 3))
    translation[: len(travel)] = travel
    yield "combined: swivel, tilt, 0.5 m travel", path, translation


def panel_scenes(dt_s: float):
    """The curved panel's scenes of jaxflex demo at step ``dt_s`` (limits 2 rad/s, 10
    rad/s^2, 100 rad/s^3; 2 m/s, 10 m/s^2, 100 m/s^3): (name, path, world translation): a
    swivel of 90 degrees about the vertical while the gripper travels 1 m along x, a tilt of
    30 degrees about x while it lifts 1 m, and the combined move of :func:`scenes` (a swivel
    then a tilt through orientations while it travels 0.5 m)."""
    import jaxflex
    from jaxflex._pose import fixed_axis_path, turn_acceleration

    for name, axis, angle_deg, distance in (
        ("swivel 90 deg about z, 1 m along x", "z", 90.0, (1.0, 0.0, 0.0)),
        ("tilt 30 deg about x, 1 m up", "x", 30.0, (0.0, 0.0, 1.0)),
    ):
        turn = turn_acceleration(np.radians(angle_deg), 2.0, 10.0, 100.0, dt_s)
        travel = jaxflex.jerk_limited_move(distance, 2.0, 10.0, 100.0, dt_s).acc
        samples = max(turn.size, len(travel))
        alpha, acc = np.zeros(samples), np.zeros((samples, 3))
        alpha[: turn.size], acc[: len(travel)] = turn, travel
        yield name, fixed_axis_path(axis, alpha, dt_s), acc
    yield from (scene for scene in scenes(dt_s) if scene[0].startswith("combined"))


def built_in_panel(mesh_size_m: float | None = None, n_modes: int = 20):
    """(fem.ModalResult, ModalModel) of the built-in curved panel (fem.scenes: 1.5 x 0.8 m,
    1 mm steel, radii 2.5 m / 1.2 m, four cups) at every node, 2 % damping; without the
    discretisation estimate (a second FE analysis on a coarser mesh: the reference and the
    engine share this mesh, whatever its error)."""
    import fem

    part, cups = fem.scene("panel", mesh_size=mesh_size_m)
    result = fem.modal_analysis(part, cups, n_modes=n_modes, zeta=0.02, error_estimate=False)
    return result, result.to_modal_model(points="all")


def cantilever():
    """(fem.ModalResult, ModalModel) of tests/test_turning.py's cantilever: a 0.3 x 0.2 m,
    2 mm steel thin solid curved along x (radius 0.6 m), clamped on its left edge, its 4
    lowest modes (49-381 Hz), 2 % damping, every node, no static residual."""
    import fem

    part = fem.curved_panel(0.3, 0.2, 2e-3, "steel", 0.1, radius_x=0.6, radius_y=None)
    result = fem.modal_analysis(part, [fem.ClampedEdge("left")], n_modes=4, zeta=0.02)
    return result, result.to_modal_model(points="all")._replace(static_shapes=None)


def bound_table(result, model, moves, extend_s: float = 0.3, eval_dt_s: float = 1e-4):
    """(scene, peak deviation, true effect, a-posteriori bound, energy bound) in m for the
    ``moves`` (name, path, translation) and ``extend_s`` s of free decay."""
    from jaxflex._turning import Turn, simulate_turning

    frame = FloatingFrame(result, model)
    energy_only = model._replace(rotation=model.rotation.replace(gyroscopic=None, spin=None))
    rows = []
    for name, path, acc in moves:
        response = simulate_turning(model, Turn(path, acc), extend_s=extend_s)
        old = simulate_turning(energy_only, Turn(path, acc), extend_s=extend_s).neglected_bound_m
        peak, effect = frame.neglected_effect(
            path.alpha_rad_s2,
            response.t_s[-1],
            eval_dt_s=eval_dt_s,
            acc_world=acc,
            dt_s=path.dt_s,
        )
        rows.append((name, peak, effect, response.neglected_bound_m, old))
    return rows


if __name__ == "__main__":
    panel = "--panel" in sys.argv
    result, model = built_in_panel() if panel else cantilever()
    moves, eval_dt_s = (panel_scenes, 2.5e-4) if panel else (scenes, 1e-4)
    print("| step | scene | peak | true effect | bound | ratio | energy bound | ratio |")
    print("|---|---|---|---|---|---|---|---|")
    for dt in (0.01, 0.002):
        rows = bound_table(result, model, moves(dt), eval_dt_s=eval_dt_s)
        for name, peak, effect, bound, old in rows:
            print(
                f"| {dt * 1e3:g} ms | {name} | {peak * 1e6:.1f} um | {effect * 1e9:.3g} nm | "
                f"{bound * 1e9:.3g} nm | {bound / effect:.2f} | {old * 1e9:.3g} nm | "
                f"{old / effect:.0f} |"
            )
