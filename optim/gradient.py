"""The gradient route: a smooth surrogate minimised by casadi/Ipopt or scipy, driven by JAX.

At a fixed number of steps n the subproblem minimises a soft maximum of the squared
deviations at the pooled (scenario, point, time-after-the-move) rows, in units of the
threshold,

    F = (1 / beta) log sum_r exp(beta |u_r|^2 / limit^2),      max_r <= F <= max_r + log(R) / beta,

over the same linear kinematic constraints as the exact route. The deviations are exact
Euclidean norms (the LP reaches them through cutting planes) and the soft maximum runs over
every scenario at once (a smooth worst case for the robust mode). F and its gradient come from one
jit-compiled ``jax.value_and_grad``; the rows' data are arguments, padded to powers of two,
so a search compiles it a handful of times. Casadi sees F as a ``casadi.Callback`` with a
Jacobian callback (kept alive on the object), Ipopt runs with a limited-memory Hessian;
scipy's SLSQP takes F with ``jac=True``. beta is raised in stages (continuation), each
stage warm-started from the last. Feasibility (max_r <= 1) and the outer loops are those of
the exact route (optim.search), so the route's answers are certified the same way.
"""

from __future__ import annotations

import time
from functools import partial

import jax
import jax.numpy as jnp
import numpy as np

from jaxflex.errors import InputError
from optim.kinematics import add_cuts, add_move, path_cuts
from optim.lp import LPBuilder
from optim.profiles import integrate
from optim.ruckig_move import fit_to_grid
from optim.search import Problem, SubResult, add_end_states

GRADIENT_SOLVERS = ("ipopt", "slsqp")
BETAS = (20.0, 200.0)
# The surrogate only has to push every row below 1; where many moves achieve ~0 its minimum
# is degenerate and tight tolerances only cost iterations.
IPOPT_TOL = 1e-6
MAX_ITERATIONS = 200
MAX_CUT_ROUNDS = 30


@partial(jax.jit, static_argnames=())
def soft_max_rows(zhat, scenario, aq, av, mask, beta):
    """Soft maximum of |u_r|^2 / limit^2 over rows r and its gradient w.r.t. ``zhat``.

    zhat: (J, M, 2) scaled end states. scenario: (R,) row -> scenario index.
    aq, av: (R, C, M) so that u_r / limit = aq_r zhat_q + av_r zhat_v. mask: (R,) 0/1.
    """

    def value(z):
        u = jnp.einsum("rcm,rm->rc", aq, z[scenario, :, 0]) + jnp.einsum(
            "rcm,rm->rc", av, z[scenario, :, 1]
        )
        r = jnp.sum(u * u, axis=-1)
        return jax.nn.logsumexp(beta * r, b=mask) / beta

    return jax.value_and_grad(value)(zhat)


def _capacity(count: int, minimum: int = 8) -> int:
    return max(minimum, 1 << int(np.ceil(np.log2(max(1, count)))))


class RowData:
    """The pooled rows of the training scenarios as padded JAX arrays."""

    def __init__(self, problem: Problem) -> None:
        slot = {s: k for k, s in enumerate(problem.training)}
        rows = [r for r in problem.pool if r.scenario in slot]
        n_modes = problem.model.n_modes
        dim = len(problem.components)
        r_cap = _capacity(len(rows), 64)
        aq = np.zeros((r_cap, dim, n_modes))
        av = np.zeros((r_cap, dim, n_modes))
        scen = np.zeros(r_cap, dtype=np.int32)
        mask = np.zeros(r_cap)
        for k, row in enumerate(rows):
            s = problem.scenarios[row.scenario]
            p11, p12 = s.residual.propagator_rows(np.array([row.peak.tau_s]))
            shape = s.residual.shapes[row.peak.point]  # (C, M)
            aq[k] = shape * (p11[0] * s.zscale[:, 0]) / problem.limit_m
            av[k] = shape * (p12[0] * s.zscale[:, 1]) / problem.limit_m
            scen[k] = slot[row.scenario]
            mask[k] = 1.0
        self.n_scenarios = len(problem.training)
        self.j_cap = _capacity(self.n_scenarios, 1)
        self.n_modes = n_modes
        self.args = tuple(jnp.asarray(x) for x in (scen, aq, av, mask))
        self.count = len(rows)
        self.evaluations = 0
        self.jax_s = 0.0
        self._last = None

    def value_and_grad(self, z_flat: np.ndarray, beta: float) -> tuple[float, np.ndarray]:
        """F and dF/dz for the training scenarios' scaled end states, flattened (J M 2,).
        The last evaluation is cached (casadi asks for value and gradient separately)."""
        key = (beta, z_flat.tobytes())
        if self._last is not None and self._last[0] == key:
            return self._last[1]
        start = time.perf_counter()
        z = np.zeros((self.j_cap, self.n_modes, 2))
        z[: self.n_scenarios] = z_flat.reshape(self.n_scenarios, self.n_modes, 2)
        value, grad = soft_max_rows(jnp.asarray(z), *self.args, beta)
        grad = np.asarray(grad)[: self.n_scenarios].ravel()
        self.evaluations += 1
        self.jax_s += time.perf_counter() - start
        self._last = (key, (float(value), grad))
        return self._last[1]

    def max_row(self, z_flat: np.ndarray) -> float:
        """max_r |u_r| / limit (the hard maximum the surrogate approximates)."""
        z = z_flat.reshape(self.n_scenarios, self.n_modes, 2)
        scen, aq, av, mask = (np.asarray(x) for x in self.args)
        k = int(mask.sum())
        if k == 0:
            return 0.0
        u = np.einsum("rcm,rm->rc", aq[:k], z[scen[:k], :, 0]) + np.einsum(
            "rcm,rm->rc", av[:k], z[scen[:k], :, 1]
        )
        return float(np.sqrt(np.max(np.sum(u * u, axis=-1))))


def _ipopt(program, z_slice, data: RowData, x0: np.ndarray, beta: float):
    import casadi as ca

    n_z = z_slice.stop - z_slice.start

    class Gradient(ca.Callback):
        def __init__(self):
            ca.Callback.__init__(self)
            self.construct("surrogate_grad", {})

        def get_n_in(self):
            return 2

        def get_n_out(self):
            return 1

        def get_sparsity_in(self, i):
            return ca.Sparsity.dense(n_z, 1) if i == 0 else ca.Sparsity.dense(1, 1)

        def get_sparsity_out(self, i):
            return ca.Sparsity.dense(1, n_z)

        def eval(self, arg):
            _, grad = data.value_and_grad(np.asarray(arg[0]).ravel(), beta)
            return [ca.DM(grad).T]

    class Surrogate(ca.Callback):
        def __init__(self):
            ca.Callback.__init__(self)
            self.jacobians = []  # casadi keeps only weak references: hold every one here
            self.construct("surrogate", {})

        def get_n_in(self):
            return 1

        def get_n_out(self):
            return 1

        def get_sparsity_in(self, i):
            return ca.Sparsity.dense(n_z, 1)

        def get_sparsity_out(self, i):
            return ca.Sparsity.dense(1, 1)

        def has_jacobian(self):
            return True

        def get_jacobian(self, name, inames, onames, opts):
            self.jacobians.append(Gradient())
            return self.jacobians[-1]

        def eval(self, arg):
            value, _ = data.value_and_grad(np.asarray(arg[0]).ravel(), beta)
            return [value]

    surrogate = Surrogate()
    x = ca.MX.sym("x", program.cost.size)
    g = ca.mtimes(ca.DM(program.matrix.tocsc()), x)
    nlp = {"x": x, "f": surrogate(x[z_slice.start : z_slice.stop]), "g": g}
    options = {
        "print_time": False,
        "ipopt": {
            "print_level": 0,
            "sb": "yes",
            "hessian_approximation": "limited-memory",
            "tol": IPOPT_TOL,
            "acceptable_tol": 1e-3,
            "acceptable_iter": 5,
            "bound_relax_factor": 0.0,
            "max_iter": MAX_ITERATIONS,
        },
    }
    solver = ca.nlpsol("gradient_route", "ipopt", nlp, options)
    res = solver(
        x0=x0, lbx=program.var_lo, ubx=program.var_hi, lbg=program.row_lo, ubg=program.row_hi
    )
    stats = solver.stats()
    return np.asarray(res["x"]).ravel(), {
        "success": bool(stats["success"]),
        "return_status": str(stats.get("return_status", "")),
        "iterations": int(stats.get("iter_count", 0)),
    }


def _sample_map(problem: Problem, layout, z_slice, size: int) -> np.ndarray:
    """T (size, d (n-1)): every variable as a linear function of the interior samples
    a_1..a_{n-1} of each axis (velocity, position and end states follow exactly)."""
    n, h = layout.n_steps, problem.dt
    eye = np.eye(n + 1)[:, 1:-1]  # unit moves of the interior samples
    vel = np.vstack([np.zeros((1, n - 1)), np.cumsum(0.5 * h * (eye[:-1] + eye[1:]), axis=0)])
    dx = h * vel[:-1] + h * h / 6.0 * (2.0 * eye[:-1] + eye[1:])
    pos = np.vstack([np.zeros((1, n - 1)), np.cumsum(dx, axis=0)])
    d = len(layout.axes)
    t = np.zeros((size, d * (n - 1)))
    z_rows = []
    for i in range(d):
        cols = slice(i * (n - 1), (i + 1) * (n - 1))
        t[layout.a[i], cols], t[layout.v[i], cols], t[layout.x[i], cols] = eye, vel, pos
    for j in problem.training:
        emap = problem.end_map(j, n)[:, :, 1:-1, list(layout.axes)]  # (M, 2, n-1, d)
        e = np.transpose(emap, (0, 1, 3, 2)).reshape(emap.shape[0] * 2, -1)
        z_rows.append(e / problem.scenarios[j].zscale.reshape(-1, 1))
    t[z_slice] = np.vstack(z_rows)
    return t


def _slsqp(program, z_slice, data: RowData, x0: np.ndarray, beta: float, sample_map):
    """SLSQP over the interior samples only (it works with dense matrices, so the sparse
    variables v, x, z are eliminated through ``sample_map``)."""
    from scipy.optimize import LinearConstraint, minimize

    t = sample_map
    rows = np.vstack([program.matrix @ t, t])
    lo = np.concatenate([program.row_lo, program.var_lo])
    hi = np.concatenate([program.row_hi, program.var_hi])
    trivial = np.all(np.abs(rows) <= 1e-14, axis=1)  # recursions: satisfied identically
    rows, lo, hi = rows[~trivial], lo[~trivial], hi[~trivial]
    eq = lo == hi
    keep = ~eq & (np.isfinite(lo) | np.isfinite(hi))
    constraints = [
        LinearConstraint(rows[eq], lo[eq], hi[eq]),
        LinearConstraint(rows[keep], lo[keep], hi[keep]),
    ]
    t_z = t[z_slice]
    y0 = np.linalg.lstsq(t, x0, rcond=None)[0]

    def fun(y):
        value, grad_z = data.value_and_grad(t_z @ y, beta)
        return value, t_z.T @ grad_z

    res = minimize(
        fun,
        y0,
        jac=True,
        method="SLSQP",
        constraints=constraints,
        options={"maxiter": MAX_ITERATIONS, "ftol": 1e-10},
    )
    info = {
        "success": bool(res.success),
        "return_status": str(res.message),
        "iterations": int(res.nit),
    }
    return t @ res.x, info


class GradientSubsolver:
    """Subproblem solver of the gradient route; ``solver`` is "ipopt" or "slsqp"."""

    def __init__(self, solver: str = "ipopt") -> None:
        if solver not in GRADIENT_SOLVERS:
            raise InputError(
                f"solver: the gradient route accepts {GRADIENT_SOLVERS}, got {solver!r}"
            )
        self.solver = solver
        self.name = f"gradient ({solver})"
        self._cuts: dict[int, list] = {}

    def _start(self, problem: Problem, layout, z_slice, warm: np.ndarray, size: int):
        """Initial point: the warm move's samples, exact kinematics and end states."""
        x0 = np.zeros(size)
        vel, pos = integrate(warm, problem.dt)
        for i, c in enumerate(layout.axes):
            x0[layout.a[i]], x0[layout.v[i]], x0[layout.x[i]] = warm[:, c], vel[:, c], pos[:, c]
        z = [problem.end_state(j, warm) / problem.scenarios[j].zscale for j in problem.training]
        x0[z_slice] = np.concatenate([zz.ravel() for zz in z])
        return x0

    def solve(self, problem: Problem, n_steps: int, warm: np.ndarray, polish: bool) -> SubResult:
        builder = LPBuilder()
        layout = add_move(builder, n_steps, problem.dt, problem.distance, problem.limits)
        add_cuts(builder, self._cuts.get(n_steps, []))
        first = builder.n_vars
        add_end_states(builder, problem, layout)
        z_slice = slice(first, builder.n_vars)
        data = RowData(problem)
        stats = {
            "nlp_solves": 0,
            "nlp_wall_s": 0.0,
            "iterations": 0,
            "success": True,
            "rows": data.count,
        }
        x = self._start(problem, layout, z_slice, warm, builder.n_vars)
        sample_map = None
        if self.solver == "slsqp":
            sample_map = _sample_map(problem, layout, z_slice, builder.n_vars)
        for _ in range(MAX_CUT_ROUNDS):
            program = builder.program()
            start = time.perf_counter()
            for beta in BETAS if data.count else ():
                if sample_map is None:
                    x, info = _ipopt(program, z_slice, data, x, beta)
                else:
                    x, info = _slsqp(program, z_slice, data, x, beta, sample_map)
                stats["nlp_solves"] += 1
                stats["iterations"] += info["iterations"]
                stats["success"] &= info["success"]
                stats["return_status"] = info["return_status"]
            stats["nlp_wall_s"] += time.perf_counter() - start
            cuts = path_cuts(layout, x, problem.limits)
            if not cuts:
                break
            self._cuts.setdefault(n_steps, []).extend(cuts)
            add_cuts(builder, cuts)
        stats["jax_evaluations"], stats["jax_s"] = data.evaluations, data.jax_s
        # Snap the NLP's answer (interior-point tolerances) exactly onto the limits and
        # boundary conditions: the closest grid move in L1, a change of solver-tolerance size.
        acc = fit_to_grid(layout.acceleration(x), problem.dt, problem.distance, problem.limits)
        if acc is None:
            return SubResult("infeasible", None, np.inf, stats)
        z = [problem.end_state(j, acc) / problem.scenarios[j].zscale for j in problem.training]
        return SubResult("solved", acc, data.max_row(np.concatenate([v.ravel() for v in z])), stats)
