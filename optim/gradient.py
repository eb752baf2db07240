"""The gradient route: a smooth surrogate minimised by casadi/Ipopt or scipy, driven by JAX.

At a fixed number of steps n the subproblem minimises a soft maximum of the squared
deviations at the pooled (scenario, point, time-after-the-move) rows, in units of the
threshold,

    F = (1 / beta) log sum_r exp(beta |u_r|^2 / limit^2),      max_r <= F <= max_r + log(R) / beta,

(the core's soft maximum, jaxflex.response.soft_max, with its bound; the same one as the smooth
cycle-time bound jaxflex.cycle_time_smooth)

over the same linear kinematic constraints as the exact route. The deviations are exact
Euclidean norms (the LP reaches them through cutting planes) and the soft maximum runs over
every scenario at once (a smooth worst case for the robust mode). With a clearance, the soft
maximum of the deviation during the move (every point, every dt / 8) in units of the
clearance is a non-linear constraint G <= 1 (conservative: G >= the true maximum).

Each smooth term is one jit-compiled ``jax.value_and_grad`` of a vector that is linear in the
variables (the scaled end states, the modal coordinates during the move); its data are
arguments, padded to powers of two, so a search compiles it a handful of times. Casadi sees a
term as a ``casadi.Callback`` whose Jacobian is a second callback (kept alive on the first:
casadi holds only weak references); Ipopt runs with a limited-memory Hessian and its
``stats()['success']`` is reported. scipy's SLSQP gets the same values and gradients in the
interior samples (it works with dense matrices). beta is raised in stages (continuation),
each warm-started from the last. Feasibility and the outer loops are those of the exact route
(optim.search), so the route's answers are certified the same way.

A turning move (optim.turn) is handled as on the exact route: for the turn's fixed schedule
the end states are affine in the translation samples (tied to them by the same rows, with
the turn's own end state as constant: optim.search.add_end_states) and so is the deviation
during the move (optim.turn_clearance: the turn's own coordinates the constant ``offset`` of
the clearance term); each schedule of a length is tried in turn by optim.search.attempt.
"""

from __future__ import annotations

import time

import jax
import jax.numpy as jnp
import numpy as np
import scipy.sparse as sp
from scipy.optimize import LinearConstraint, NonlinearConstraint, minimize

from jaxflex.errors import InputError
from jaxflex.response import integrate, soft_max
from optim.defaults import GRADIENT_SOLVERS as GRADIENT_SOLVERS
from optim.kinematics import add_cuts, add_move, path_cuts
from optim.lp import LPBuilder, SparseMatrix
from optim.ruckig_move import fit_to_grid
from optim.search import Problem, SubResult, add_end_states

BETAS = (20.0, 200.0)
# The surrogate only has to push every row below 1; where many moves achieve ~0 its minimum
# is degenerate and tight tolerances only cost iterations.
IPOPT_TOL = 1e-6
MAX_ITERATIONS = 200
MAX_CUT_ROUNDS = 30


@jax.jit
def soft_max_rows(zhat, scenario, aq, av, mask, beta):
    """Soft maximum of |u_r|^2 / limit^2 over rows r and its gradient w.r.t. ``zhat``.

    zhat: (J, M, 2) scaled end states. scenario: (R,) row -> scenario index.
    aq, av: (R, C, M) so that u_r / limit = aq_r zhat_q + av_r zhat_v. mask: (R,) 0/1.
    """

    def value(z):
        u = jnp.einsum("rcm,rm->rc", aq, z[scenario, :, 0]) + jnp.einsum(
            "rcm,rm->rc", av, z[scenario, :, 1]
        )
        return soft_max(jnp.sum(u * u, axis=-1), beta, mask)

    return jax.value_and_grad(value)(zhat)


@jax.jit
def soft_max_points(q, shapes, mask, beta):
    """Soft maximum over times t and points p of |shapes_p q_t|^2 (shapes in units of the
    limit) and its gradient w.r.t. q (T, M). mask: (T,) 0/1."""

    def value(modal):
        u = jnp.einsum("pcm,tm->tpc", shapes, modal)
        weights = jnp.broadcast_to(mask[:, None], u.shape[:2])
        return soft_max(jnp.sum(u * u, axis=-1), beta, weights)

    return jax.value_and_grad(value)(q)


def _capacity(count: int, minimum: int = 8) -> int:
    return max(minimum, 1 << int(np.ceil(np.log2(max(1, count)))))


class SmoothTerm:
    """A soft maximum F(v) of a vector v = map @ x + offset affine in the NLP variables x
    (``offset`` zero unless given: a turn's own response), with a cached value_and_grad
    (casadi asks for the value and the gradient separately)."""

    def __init__(self, linear_map: sp.csr_matrix, offset: np.ndarray | None = None) -> None:
        self.map = linear_map
        self.offset = np.zeros(linear_map.shape[0]) if offset is None else offset
        self.evaluations = 0
        self.jax_s = 0.0
        self._last = None

    def _evaluate(self, v: np.ndarray, beta: float) -> tuple[float, np.ndarray]:
        raise NotImplementedError

    def value_and_grad(self, v: np.ndarray, beta: float) -> tuple[float, np.ndarray]:
        key = (beta, v.tobytes())
        if self._last is None or self._last[0] != key:
            start = time.perf_counter()
            result = self._evaluate(v, beta)
            self.evaluations += 1
            self.jax_s += time.perf_counter() - start
            self._last = (key, result)
        return self._last[1]


class RowTerm(SmoothTerm):
    """The pooled residual rows of the training scenarios (the objective)."""

    def __init__(self, problem: Problem, z_slice: slice, n_vars: int) -> None:
        size = z_slice.stop - z_slice.start
        select = sp.csr_matrix(
            (np.ones(size), (np.arange(size), np.arange(z_slice.start, z_slice.stop))),
            shape=(size, n_vars),
        )
        super().__init__(select)
        slot = {s: k for k, s in enumerate(problem.training)}
        rows = [r for r in problem.pool if r.scenario in slot]
        n_modes, dim = problem.model.n_modes, len(problem.components)
        r_cap = _capacity(len(rows), 64)
        aq, av = np.zeros((r_cap, dim, n_modes)), np.zeros((r_cap, dim, n_modes))
        scen, mask = np.zeros(r_cap, dtype=np.int32), np.zeros(r_cap)
        for k, row in enumerate(rows):
            s = problem.scenarios[row.scenario]
            p11, p12 = s.residual.propagator_rows(np.array([row.peak.tau_s]))
            shape = s.residual.shapes[row.peak.point]  # (C, M)
            aq[k] = shape * (p11[0] * s.zscale[:, 0]) / problem.limit_m
            av[k] = shape * (p12[0] * s.zscale[:, 1]) / problem.limit_m
            scen[k], mask[k] = slot[row.scenario], 1.0
        self.n_scenarios, self.n_modes = len(problem.training), n_modes
        self.j_cap = _capacity(self.n_scenarios, 1)
        self.args = tuple(jnp.asarray(x) for x in (scen, aq, av, mask))
        self.count = len(rows)

    def _evaluate(self, v, beta):
        if self.count == 0:  # no row yet (a clearance alone drives the NLP)
            return 0.0, np.zeros_like(v)
        z = np.zeros((self.j_cap, self.n_modes, 2))
        z[: self.n_scenarios] = v.reshape(self.n_scenarios, self.n_modes, 2)
        value, grad = soft_max_rows(jnp.asarray(z), *self.args, beta)
        return float(value), np.asarray(grad)[: self.n_scenarios].ravel()

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


class ClearanceTerm(SmoothTerm):
    """The deviation of the nominal model during the move, every dt / 8 (the constraint);
    with a turn, that of its active schedule: affine in the translation samples, the turn's
    own coordinates the constant (optim.turn_clearance)."""

    def __init__(self, problem: Problem, layout, n_vars: int) -> None:
        response = problem.move_map(layout.n_steps)
        smap = response.sample_map(layout.axes)  # (T, M, n+1, d)
        t_len, n_modes = smap.shape[:2]
        cols = layout.a.T  # (n+1, d): variable index of each sample
        dense = smap.reshape(t_len * n_modes, -1)
        super().__init__(
            sp.csr_matrix(
                (
                    dense.ravel(),
                    (
                        np.repeat(np.arange(dense.shape[0]), dense.shape[1]),
                        np.tile(cols.ravel(), dense.shape[0]),
                    ),
                ),
                shape=(dense.shape[0], n_vars),
            ),
            response.rest.ravel(),
        )
        self.t_len, self.n_modes = t_len, n_modes
        self.t_cap = _capacity(t_len, 256)
        mask = np.zeros(self.t_cap)
        mask[:t_len] = 1.0
        self.args = (jnp.asarray(response.shapes / problem.clearance_limit_m), jnp.asarray(mask))

    def _evaluate(self, v, beta):
        q = np.zeros((self.t_cap, self.n_modes))
        q[: self.t_len] = v.reshape(self.t_len, self.n_modes)
        value, grad = soft_max_points(jnp.asarray(q), *self.args, beta)
        return float(value), np.asarray(grad)[: self.t_len].ravel()


def _casadi_term(term: SmoothTerm, beta: float, name: str):
    """``term`` as a casadi Callback with an exact Jacobian callback."""
    import casadi as ca  # ~0.1 s: only for Ipopt

    size = term.map.shape[0]

    class Gradient(ca.Callback):
        def __init__(self):
            ca.Callback.__init__(self)
            self.construct(f"{name}_grad", {})

        def get_n_in(self):
            return 2

        def get_n_out(self):
            return 1

        def get_sparsity_in(self, i):
            return ca.Sparsity.dense(size, 1) if i == 0 else ca.Sparsity.dense(1, 1)

        def get_sparsity_out(self, i):
            return ca.Sparsity.dense(1, size)

        def eval(self, arg):
            return [ca.DM(term.value_and_grad(np.asarray(arg[0]).ravel(), beta)[1]).T]

    class Value(ca.Callback):
        def __init__(self):
            ca.Callback.__init__(self)
            self.jacobians = []  # casadi keeps only weak references: hold every one here
            self.construct(name, {})

        def get_n_in(self):
            return 1

        def get_n_out(self):
            return 1

        def get_sparsity_in(self, i):
            return ca.Sparsity.dense(size, 1)

        def get_sparsity_out(self, i):
            return ca.Sparsity.dense(1, 1)

        def has_jacobian(self):
            return True

        def get_jacobian(self, name, inames, onames, opts):
            self.jacobians.append(Gradient())
            return self.jacobians[-1]

        def eval(self, arg):
            return [term.value_and_grad(np.asarray(arg[0]).ravel(), beta)[0]]

    return Value()


def _ipopt(program, objective: SmoothTerm, clearance, x0: np.ndarray, beta: float):
    import casadi as ca  # ~0.1 s: only for Ipopt

    x = ca.MX.sym("x", program.cost.size)
    f_cb = _casadi_term(objective, beta, "surrogate")
    g = [ca.mtimes(program.matrix.to_casadi(), x)]
    lbg, ubg = [program.row_lo], [program.row_hi]
    callbacks = [f_cb]

    def argument(term: SmoothTerm):
        return ca.mtimes(SparseMatrix.from_scipy(term.map).to_casadi(), x) + ca.DM(term.offset)

    if clearance is not None:
        callbacks.append(_casadi_term(clearance, beta, "clearance"))
        g.append(callbacks[-1](argument(clearance)))
        lbg.append([-np.inf])
        ubg.append([1.0])
    nlp = {"x": x, "f": f_cb(argument(objective)), "g": ca.vertcat(*g)}
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
        x0=x0,
        lbx=program.var_lo,
        ubx=program.var_hi,
        lbg=np.concatenate(lbg),
        ubg=np.concatenate(ubg),
    )
    stats = solver.stats()
    return np.asarray(res["x"]).ravel(), {
        "success": bool(stats["success"]),
        "return_status": str(stats.get("return_status", "")),
        "iterations": int(stats.get("iter_count", 0)),
    }


def _sample_map(problem: Problem, layout, z_slice, size: int) -> tuple[np.ndarray, np.ndarray]:
    """(T (size, d (n-1)), c (size,)): every variable x = T y + c as an affine function of
    the interior samples y = a_1..a_{n-1} of each axis (velocity, position and end states
    follow exactly; c the turn's own end state, zero for a straight move)."""
    n, h = layout.n_steps, problem.dt_s
    eye = np.eye(n + 1)[:, 1:-1]  # unit moves of the interior samples
    vel = np.vstack([np.zeros((1, n - 1)), np.cumsum(0.5 * h * (eye[:-1] + eye[1:]), axis=0)])
    dx = h * vel[:-1] + h * h / 6.0 * (2.0 * eye[:-1] + eye[1:])
    pos = np.vstack([np.zeros((1, n - 1)), np.cumsum(dx, axis=0)])
    d = len(layout.axes)
    t = np.zeros((size, d * (n - 1)))
    z_rows, z_offsets = [], []
    for i in range(d):
        cols = slice(i * (n - 1), (i + 1) * (n - 1))
        t[layout.a[i], cols], t[layout.v[i], cols], t[layout.x[i], cols] = eye, vel, pos
    for j in problem.training:
        emap = problem.end_map(j, n)[:, :, 1:-1, list(layout.axes)]  # (M, 2, n-1, d)
        e = np.transpose(emap, (0, 1, 3, 2)).reshape(emap.shape[0] * 2, -1)
        zscale = problem.scenarios[j].zscale.reshape(-1)
        z_rows.append(e / zscale[:, None])
        z_offsets.append(problem.end_offset(j, n).reshape(-1) / zscale)
    t[z_slice] = np.vstack(z_rows)
    constant = np.zeros(size)
    constant[z_slice] = np.concatenate(z_offsets)
    return t, constant


def _slsqp(program, objective: SmoothTerm, clearance, x0: np.ndarray, beta: float, sample_map):
    """SLSQP over the interior samples only (it works with dense matrices, so the sparse
    variables v, x, z are eliminated through ``sample_map``, x = T y + c)."""
    t, c = sample_map
    matrix = program.matrix.to_scipy()
    rows = np.vstack([matrix @ t, t])
    shift = np.concatenate([matrix @ c, c])
    lo = np.concatenate([program.row_lo, program.var_lo]) - shift
    hi = np.concatenate([program.row_hi, program.var_hi]) - shift
    trivial = np.all(np.abs(rows) <= 1e-14, axis=1)  # recursions: satisfied identically
    rows, lo, hi = rows[~trivial], lo[~trivial], hi[~trivial]
    eq = lo == hi
    keep = ~eq & (np.isfinite(lo) | np.isfinite(hi))
    constraints = [
        LinearConstraint(rows[eq], lo[eq], hi[eq]),
        LinearConstraint(rows[keep], lo[keep], hi[keep]),
    ]
    f_map, f_0 = objective.map @ t, objective.map @ c + objective.offset
    if clearance is not None:
        g_map, g_0 = clearance.map @ t, clearance.map @ c + clearance.offset
        constraints.append(
            NonlinearConstraint(
                lambda y: clearance.value_and_grad(g_map @ y + g_0, beta)[0],
                -np.inf,
                1.0,
                jac=lambda y: (g_map.T @ clearance.value_and_grad(g_map @ y + g_0, beta)[1])[None],
            )
        )
    y0 = np.linalg.lstsq(t, x0 - c, rcond=None)[0]

    def fun(y):
        value, grad = objective.value_and_grad(f_map @ y + f_0, beta)
        return value, f_map.T @ grad

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
    return t @ res.x + c, info


class GradientSubsolver:
    """Subproblem solver of the gradient route; ``solver`` is "ipopt" or "slsqp"."""

    clearance_rows = False  # the whole clearance grid is in the NLP already

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
        vel, pos = integrate(warm, problem.dt_s)
        for i, c in enumerate(layout.axes):
            x0[layout.a[i]], x0[layout.v[i]], x0[layout.x[i]] = warm[:, c], vel[:, c], pos[:, c]
        z = [problem.end_state(j, warm) / problem.scenarios[j].zscale for j in problem.training]
        x0[z_slice] = np.concatenate([zz.ravel() for zz in z])
        return x0

    def solve(self, problem: Problem, n_steps: int, warm: np.ndarray) -> SubResult:
        builder = LPBuilder()
        layout = add_move(builder, n_steps, problem.dt_s, problem.distance_m, problem.limits)
        add_cuts(builder, self._cuts.get(n_steps, []))
        first = builder.n_vars
        add_end_states(builder, problem, layout)
        z_slice = slice(first, builder.n_vars)
        objective = RowTerm(problem, z_slice, builder.n_vars)
        clearance = None
        if problem.clearance_m is not None:
            clearance = ClearanceTerm(problem, layout, builder.n_vars)
        stats = {
            "nlp_solves": 0,
            "nlp_wall_s": 0.0,
            "iterations": 0,
            "success": True,
            "rows": objective.count,
        }
        x = self._start(problem, layout, z_slice, warm, builder.n_vars)
        sample_map = None
        if self.solver == "slsqp":
            sample_map = _sample_map(problem, layout, z_slice, builder.n_vars)
        for _ in range(MAX_CUT_ROUNDS):
            program = builder.program()
            start = time.perf_counter()
            for beta in BETAS if objective.count or clearance is not None else ():
                if sample_map is None:
                    x, info = _ipopt(program, objective, clearance, x, beta)
                else:
                    x, info = _slsqp(program, objective, clearance, x, beta, sample_map)
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
        terms = [objective] if clearance is None else [objective, clearance]
        stats["jax_evaluations"] = sum(t.evaluations for t in terms)
        stats["jax_s"] = sum(t.jax_s for t in terms)
        # Snap the NLP's answer (interior-point tolerances) exactly onto the limits and
        # boundary conditions: the closest grid move in L1, a change of solver-tolerance size.
        acc = fit_to_grid(layout.acceleration(x), problem.dt_s, problem.distance_m, problem.limits)
        if acc is None:
            return SubResult("infeasible", None, np.inf, stats)
        z = [problem.end_state(j, acc) / problem.scenarios[j].zscale for j in problem.training]
        value = objective.max_row(np.concatenate([v.ravel() for v in z]))
        return SubResult("solved", acc, value, stats)
