"""The exact route: each "do n steps suffice?" test is one linear program.

Variables: the move (optim.kinematics), each training scenario's modal end state in scaled
units (z_hat = x_end / zscale, so that z_hat ~ 1 means ~threshold deviation) tied to the
samples by the exact linear map, and the epigraph variable s. Rows: kinematics and limits,
z_hat - (E / zscale) a = 0, and for every pooled (scenario, point, time) row
c . u_p(tau) / limit <= s, with c the direction of the deviation at the pooled peak: the
tangent plane of the norm ball there. Generated lazily at the worst peaks, these cuts
converge to the exact Euclidean norm constraint (a second-order cone) and are exact in 1-D.
Minimising s decides feasibility (s <= 1). The final ``polish`` pass minimises
s + POLISH_WEIGHT * TV_a / TV_a,max + JERK_WEIGHT * TV_j / TV_j,max instead (TV_a the total
variation of the acceleration, at most n jmax dt per axis; TV_j that of the jerk, at most
2 n jmax): every row still holds (s <= 1), so the length and the certified cycle times stay
what the search found, and the jerk no longer chatters between its limits as an LP vertex
tends to. Measured on the FE plate (robust, 0.5 mm, 82 steps): jerk changes 40 -> 26, the
margin s 0.356 -> 0.374 (of the threshold), the worst case on an 81 x 5 grid unchanged.
"""

from __future__ import annotations

import numpy as np

from optim.kinematics import add_cuts, add_jerk_tv_objective, add_move, add_tv_objective, path_cuts
from optim.lp import LPBuilder, solve_lp
from optim.search import Problem, SubResult, add_end_states

MAX_CUT_ROUNDS = 30
# Weight of the normalised total variation in the polish pass (the margin it may give up),
# and in the search: there it only breaks ties, so that each LP has one smooth answer
# instead of an arbitrary vertex of a degenerate optimal face (lazy rows then converge).
POLISH_WEIGHT = 0.02
JERK_WEIGHT = 1.0  # the polish's weight of the jerk's total variation (module docstring)
SEARCH_WEIGHT = 1e-4
# The polish pass is the final solve: it keeps this fraction of every limit in reserve, so
# that no solver's feasibility tolerance (Clp's reaches ~3e-9 relative) can break a limit.
POLISH_MARGIN = 1e-7


class LPSubsolver:
    """Subproblem solver of the exact route; ``solver`` is an optim.lp back end. With
    ``polish`` it is the final pass (module docstring): the smoothest move keeping the
    margin, every limit held POLISH_MARGIN inside."""

    clearance_rows = True

    def __init__(
        self, solver: str = "highs", *, polish: bool = False, margin: float = POLISH_MARGIN
    ) -> None:
        self.solver = solver
        self.polish = polish
        self.margin = margin if polish else 0.0
        self.name = f"exact ({solver})"
        self._cuts: dict[int, list] = {}  # path-norm cuts per n (they depend on n)

    def polishing(self, margin: float = POLISH_MARGIN) -> LPSubsolver:
        """The final-pass subsolver of the same back end, keeping ``margin`` of every limit
        in reserve (0: none, for moves that need the exact limits, like the kinematic
        floor; the limits check then decides)."""
        return LPSubsolver(self.solver, polish=True, margin=margin)

    def _build(self, problem: Problem, n_steps: int):
        polish = self.polish
        builder = LPBuilder()
        limits = problem.limits.shrunk(self.margin) if self.margin else problem.limits
        layout = add_move(
            builder, n_steps, problem.dt_s, problem.distance_m, limits, problem.via_rows(n_steps)
        )
        if not polish:
            add_cuts(builder, self._cuts.get(n_steps, []))
        s = builder.variables(1, 0.0, np.inf, 1.0)[0]
        share = POLISH_WEIGHT if polish else SEARCH_WEIGHT
        add_tv_objective(builder, layout, problem.limits, share / (n_steps * len(layout.axes)))
        if polish:
            weight = JERK_WEIGHT / (n_steps * len(layout.axes))
            add_jerk_tv_objective(builder, layout, problem.limits, weight)
        z_cols = add_end_states(builder, problem, layout)
        peaks = problem.clearance_pool.get(n_steps, [])
        if peaks:  # tangent cuts of the clearance during the move (a turn's: with a constant)
            response = problem.move_map(n_steps)
            limit = problem.clearance_limit_m
            coef = np.stack([response.row(pk, layout.axes).T.ravel() for pk in peaks])
            cols = np.broadcast_to(layout.a.ravel(), coef.shape)
            rhs = 1.0 - np.array([response.offset(pk) for pk in peaks]) / limit
            builder.rows(cols, coef / limit, -np.inf, rhs)
        cell_rows = problem.cell_rows.get(n_steps, [])
        if cell_rows:  # distance, cup and stress rows of optim.cell_rows, on the samples
            coef = np.stack([r.coef.T.ravel() for r in cell_rows])
            cols = np.broadcast_to(layout.a.ravel(), coef.shape)
            builder.rows(cols, coef, -np.inf, np.array([r.rhs for r in cell_rows]))
        rows = [r for r in problem.pool if r.scenario in z_cols]
        if rows:
            coef = np.stack(
                [
                    (r.coef * problem.scenarios[r.scenario].zscale).ravel() / problem.limit_m
                    for r in rows
                ]
            )
            cols = np.stack([z_cols[r.scenario] for r in rows])
            builder.rows(
                np.column_stack([cols, np.full(len(rows), s)]),
                np.column_stack([coef, -np.ones(len(rows))]),
                -np.inf,
                0.0,
            )
        return builder, layout, s, limits

    def solve(self, problem: Problem, n_steps: int, warm: np.ndarray) -> SubResult:
        builder, layout, s, limits = self._build(problem, n_steps)
        stats = {"lp_solves": 0, "lp_wall_s": 0.0, "lp_iterations": 0, "rows": 0}
        for _ in range(MAX_CUT_ROUNDS):
            program = builder.program()
            sol = solve_lp(program, self.solver)
            stats["lp_solves"] += 1
            stats["lp_wall_s"] += sol.wall_s
            stats["lp_iterations"] += sol.iterations
            stats["rows"] = int(program.matrix.shape[0])
            stats["variables"] = int(program.matrix.shape[1])
            if sol.status != "optimal":
                return SubResult(sol.status, None, np.inf, stats)
            cuts = path_cuts(layout, sol.x, limits)
            if not cuts:
                return SubResult("solved", layout.acceleration(sol.x), float(sol.x[s]), stats)
            if not self.polish:  # cuts of the shrunk limits are not reused by the others
                self._cuts.setdefault(n_steps, []).extend(cuts)
            add_cuts(builder, cuts)
        return SubResult("failed", None, np.inf, stats)
