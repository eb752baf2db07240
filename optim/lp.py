"""Sparse linear programs: a small builder and two independent solver back ends.

    minimise cost . x   subject to   row_lo <= A x <= row_hi,   var_lo <= x <= var_hi

Back ends: scipy's HiGHS (``linprog(method="highs")``) and casadi's conic interface (COIN-OR
Clp by default, or casadi's own HiGHS build), so the exact route can be cross-checked with a
second solver.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.optimize import linprog

from jaxflex.errors import BudgetError, InputError
from jaxflex.runtime import current_budget
from jaxflex.stdout import silenced_stdout
from optim.defaults import LP_SOLVERS as LP_SOLVERS

# Feasibility tolerance asked of every back end (absolute, on rows of O(1) scale); the
# limits check allows 1e-9 relative, so a returned vertex meets it with room to spare.
TOLERANCE = 1e-9
# a matrix entry times its variable's bound below this is dropped (_negligible_dropped)
NEGLIGIBLE = 1e-15


@dataclass
class LinearProgram:
    cost: np.ndarray
    matrix: sp.csr_matrix
    row_lo: np.ndarray
    row_hi: np.ndarray
    var_lo: np.ndarray
    var_hi: np.ndarray


@dataclass(frozen=True)
class LPSolution:
    status: str  # "optimal", "infeasible" or "failed"
    x: np.ndarray | None
    objective: float
    wall_s: float
    iterations: int
    message: str


class LPBuilder:
    """Collects variables (with bounds and cost) and sparse rows (two-sided bounds)."""

    def __init__(self) -> None:
        self._lo: list[np.ndarray] = []
        self._hi: list[np.ndarray] = []
        self._cost: list[np.ndarray] = []
        self._data: list[np.ndarray] = []
        self._rows: list[np.ndarray] = []
        self._cols: list[np.ndarray] = []
        self._row_lo: list[np.ndarray] = []
        self._row_hi: list[np.ndarray] = []
        self.n_vars = 0
        self.n_rows = 0

    def variables(self, count: int, lo=-np.inf, hi=np.inf, cost=0.0) -> np.ndarray:
        """Add ``count`` variables; returns their indices."""
        idx = np.arange(self.n_vars, self.n_vars + count)
        self._lo.append(np.broadcast_to(np.asarray(lo, float), (count,)).copy())
        self._hi.append(np.broadcast_to(np.asarray(hi, float), (count,)).copy())
        self._cost.append(np.broadcast_to(np.asarray(cost, float), (count,)).copy())
        self.n_vars += count
        return idx

    def set_bounds(self, idx, lo, hi) -> None:
        lo_all, hi_all = np.concatenate(self._lo), np.concatenate(self._hi)
        lo_all[idx], hi_all[idx] = lo, hi
        self._lo, self._hi = [lo_all], [hi_all]

    def rows(self, cols, vals, lo, hi) -> None:
        """Add R rows: ``cols`` and ``vals`` (R, k) give k coefficients per row; ``lo``/``hi``
        (R,) or scalars bound each row."""
        cols, vals = np.atleast_2d(cols), np.atleast_2d(np.asarray(vals, float))
        cols, vals = np.broadcast_arrays(cols, vals)
        count = cols.shape[0]
        if count == 0:
            return
        self._rows.append(np.repeat(np.arange(self.n_rows, self.n_rows + count), cols.shape[1]))
        self._cols.append(cols.ravel())
        self._data.append(vals.ravel())
        self._row_lo.append(np.broadcast_to(np.asarray(lo, float), (count,)).copy())
        self._row_hi.append(np.broadcast_to(np.asarray(hi, float), (count,)).copy())
        self.n_rows += count

    def dense_rows(self, block: np.ndarray, cols: np.ndarray, lo, hi) -> None:
        """Add rows ``block`` (R, len(cols)) acting on variables ``cols``."""
        self.rows(np.broadcast_to(cols, block.shape), block, lo, hi)

    def program(self) -> LinearProgram:
        """The program collected so far (one with no variables: a move whose every axis is
        at rest)."""

        def cat(parts: list[np.ndarray], dtype=float) -> np.ndarray:
            return np.concatenate(parts) if parts else np.zeros(0, dtype)

        matrix = sp.csr_matrix(
            (cat(self._data), (cat(self._rows, int), cat(self._cols, int))),
            shape=(self.n_rows, self.n_vars),
        )
        return LinearProgram(
            cost=cat(self._cost),
            matrix=matrix,
            row_lo=cat(self._row_lo),
            row_hi=cat(self._row_hi),
            var_lo=cat(self._lo),
            var_hi=cat(self._hi),
        )


def _negligible_dropped(lp: LinearProgram) -> sp.csr_matrix:
    """``lp``'s matrix without the entries whose largest contribution to their row, |a_ij|
    max(|var_lo_j|, |var_hi_j|), is below NEGLIGIBLE: together less than a thousandth of the
    feasibility tolerance in any row of up to 10^3 variables. The residual rows carry
    entries down to 1e-20 (modes decayed over a long settling), with which HiGHS can stall
    for minutes on a program it otherwise solves in 0.3 s; the move the LP proposes is
    certified afterwards whatever the program held."""
    a = lp.matrix.tocoo()
    reach = np.maximum(np.abs(lp.var_lo), np.abs(lp.var_hi))[a.col]
    unbounded = np.isinf(reach)  # its entries are kept, but a stored zero (0 inf: nan)
    contribution = np.abs(a.data) * np.where(unbounded, 1.0, reach)
    keep = (a.data != 0) & (unbounded | (contribution >= NEGLIGIBLE))
    return sp.csr_matrix((a.data[keep], (a.row[keep], a.col[keep])), shape=a.shape)


def _time_left_s() -> float | None:
    """The seconds of the process's time budget left, as a solver's time limit (at least
    10 ms), None without a limit: --max-time holds inside a long LP too."""
    left_s = current_budget().remaining_s()
    return max(left_s, 0.01) if math.isfinite(left_s) else None


def _out_of_time(lp: LinearProgram, wall_s: float) -> BudgetError:
    """The error of an LP stopped by its time limit, naming the program's size."""
    return BudgetError(
        f"time: a linear program of the search ({lp.matrix.shape[0]} rows, "
        f"{lp.cost.size} variables) ran out of {current_budget().time_limit_text()} after "
        f"{wall_s:.1f} s"
    )


def _solve_highs(lp: LinearProgram) -> LPSolution:
    a = _negligible_dropped(lp)
    eq = lp.row_lo == lp.row_hi
    upper = ~eq & np.isfinite(lp.row_hi)
    lower = ~eq & np.isfinite(lp.row_lo)
    a_ub = sp.vstack([a[upper], -a[lower]]).tocsr()
    b_ub = np.concatenate([lp.row_hi[upper], -lp.row_lo[lower]])
    options = {
        "primal_feasibility_tolerance": TOLERANCE,
        "dual_feasibility_tolerance": TOLERANCE,
    }
    left_s = _time_left_s()
    if left_s is not None:
        options["time_limit"] = left_s
    start = time.perf_counter()
    res = linprog(
        lp.cost,
        A_ub=a_ub if a_ub.shape[0] else None,
        b_ub=b_ub if a_ub.shape[0] else None,
        A_eq=a[eq] if eq.any() else None,
        b_eq=lp.row_lo[eq] if eq.any() else None,
        bounds=np.column_stack([lp.var_lo, lp.var_hi]),
        method="highs",
        options=options,
    )
    wall = time.perf_counter() - start
    if res.status == 1 and "time" in str(res.message).lower():
        raise _out_of_time(lp, wall)
    status = {0: "optimal", 2: "infeasible"}.get(res.status, "failed")
    return LPSolution(
        status=status,
        x=res.x if status == "optimal" else None,
        objective=float(res.fun) if status == "optimal" else np.inf,
        wall_s=wall,
        iterations=int(getattr(res, "nit", 0) or 0),
        message=str(res.message),
    )


def _solve_casadi(lp: LinearProgram, plugin: str) -> LPSolution:
    import casadi as ca  # ~0.1 s: only for the casadi back ends

    a = ca.DM(_negligible_dropped(lp).tocsc())
    n = lp.cost.size
    options = {"verbose": False, "print_time": False, "error_on_fail": False}
    left_s = _time_left_s()
    if plugin == "highs":
        options["highs"] = {
            "output_flag": False,
            "primal_feasibility_tolerance": TOLERANCE,
            "dual_feasibility_tolerance": TOLERANCE,
        } | ({} if left_s is None else {"time_limit": left_s})
    else:
        options["clp"] = {"PrimalTolerance": TOLERANCE, "DualTolerance": TOLERANCE} | (
            {} if left_s is None else {"MaxWallSeconds": left_s}
        )
    solver = ca.conic("lp", plugin, {"a": a.sparsity(), "h": ca.Sparsity(n, n)}, options)
    start = time.perf_counter()
    with silenced_stdout():  # Clp logs to the C-level stdout and has no option to stop it
        res = solver(g=lp.cost, a=a, lba=lp.row_lo, uba=lp.row_hi, lbx=lp.var_lo, ubx=lp.var_hi)
    wall = time.perf_counter() - start
    stats = solver.stats()
    message = str(stats.get("return_status", ""))
    if left_s is not None and not stats.get("success", False) and "time" in message.lower():
        raise _out_of_time(lp, wall)  # Clp: "stopped on iterations or time" (no iteration cap)
    if stats.get("success", False):
        status = "optimal"
    elif "infeas" in message.lower():
        status = "infeasible"
    else:
        status = "failed"
    x = np.asarray(res["x"]).ravel() if status == "optimal" else None
    return LPSolution(
        status=status,
        x=x,
        objective=float(res["cost"]) if status == "optimal" else np.inf,
        wall_s=wall,
        iterations=max(0, int(stats.get("iter_count", 0) or 0)),
        message=message,
    )


def solve_lp(lp: LinearProgram, solver: str = "highs") -> LPSolution:
    """Solve with ``solver``: "highs" (scipy), "casadi" (casadi + Clp) or "casadi-highs".
    A program without variables (and so without rows) is solved as it is: optimal, empty."""
    if solver not in LP_SOLVERS:
        raise InputError(f"solver: the exact route accepts {LP_SOLVERS}, got {solver!r}")
    if lp.cost.size == 0:
        return LPSolution("optimal", np.zeros(0), 0.0, 0.0, 0, "no variables")
    if solver == "highs":
        return _solve_highs(lp)
    if solver == "casadi":
        return _solve_casadi(lp, "clp")
    return _solve_casadi(lp, "highs")
