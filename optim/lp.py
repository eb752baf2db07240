"""Sparse linear programs: a small builder and two independent solver back ends.

    minimise cost . x   subject to   row_lo <= A x <= row_hi,   var_lo <= x <= var_hi

Back ends: HiGHS through its own Python binding (highspy: the rows go in two-sided as they
are; importing it costs ~0.02 s of CPU where scipy.optimize costs ~0.25 s at every command)
and casadi's conic interface (COIN-OR Clp by default, or casadi's own HiGHS build), so the
exact route can be cross-checked with a second solver.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from jaxflex.errors import BudgetError, InputError
from jaxflex.runtime import current_budget
from jaxflex.stdout import silenced_stdout
from optim.defaults import LP_SOLVERS as LP_SOLVERS

# Feasibility tolerance asked of every back end (absolute, on rows of O(1) scale); the
# limits check allows 1e-9 relative, so a returned vertex meets it with room to spare.
TOLERANCE = 1e-9
# a matrix entry times its variable's bound below this is dropped (_negligible_dropped)
NEGLIGIBLE = 1e-15


@dataclass(frozen=True)
class SparseMatrix:
    """A sparse matrix of ``shape`` (R, C) in compressed columns: column j holds the values
    ``data[start[j]:start[j + 1]]`` in the rows ``index[...]`` (ascending); stored zeros are
    kept. The layout HiGHS and casadi take as it is."""

    shape: tuple[int, int]
    start: np.ndarray  # (C + 1,) int32
    index: np.ndarray  # (nnz,) int32
    data: np.ndarray  # (nnz,) float64

    @classmethod
    def from_entries(cls, rows, cols, values, shape: tuple[int, int]) -> SparseMatrix:
        """The matrix with ``values`` at (``rows``, ``cols``) (each (nnz,)); entries at the
        same place are summed."""
        rows, cols = np.asarray(rows, np.int64), np.asarray(cols, np.int64)
        values = np.asarray(values, np.float64)
        order = np.lexsort((rows, cols))
        rows, cols, values = rows[order], cols[order], values[order]
        first = np.ones(rows.size, dtype=bool)
        first[1:] = (rows[1:] != rows[:-1]) | (cols[1:] != cols[:-1])
        if not first.all():
            values = np.add.reduceat(values, np.flatnonzero(first))
            rows, cols = rows[first], cols[first]
        start = np.zeros(shape[1] + 1, dtype=np.int32)
        np.cumsum(np.bincount(cols, minlength=shape[1]), out=start[1:])
        return cls(shape, start, rows.astype(np.int32), values)

    @classmethod
    def from_scipy(cls, matrix) -> SparseMatrix:
        """The same matrix as a scipy.sparse one (stored zeros kept)."""
        csc = matrix.tocsc(copy=True)
        csc.sort_indices()
        start, index = csc.indptr.astype(np.int32), csc.indices.astype(np.int32)
        return cls(csc.shape, start, index, np.asarray(csc.data, np.float64))

    @classmethod
    def from_dense(cls, matrix) -> SparseMatrix:
        """The nonzero entries of the dense ``matrix`` (R, C)."""
        matrix = np.asarray(matrix, np.float64)
        rows, cols = np.nonzero(matrix)
        return cls.from_entries(rows, cols, matrix[rows, cols], matrix.shape)

    @property
    def nnz(self) -> int:
        return int(self.data.size)

    def columns(self) -> np.ndarray:
        """(nnz,) the column of each stored entry."""
        return np.repeat(np.arange(self.shape[1]), np.diff(self.start))

    def kept(self, keep: np.ndarray) -> SparseMatrix:
        """The matrix of the stored entries where ``keep`` (nnz,) bool is True."""
        kept_before = np.concatenate([[0], np.cumsum(keep, dtype=np.int64)])  # (nnz + 1,)
        start = kept_before[self.start].astype(self.start.dtype)
        return SparseMatrix(self.shape, start, self.index[keep], self.data[keep])

    def toarray(self) -> np.ndarray:
        dense = np.zeros(self.shape)
        dense[self.index, self.columns()] = self.data
        return dense

    def to_casadi(self):
        """The same matrix as a casadi DM of the same pattern (stored zeros kept), built from
        the compressed columns: ~4x less CPU than casadi's conversion of a scipy matrix (0.4 s
        for a clearance map of 576 000 entries)."""
        import casadi as ca  # ~0.1 s: only for the casadi back ends and Ipopt

        pattern = ca.Sparsity(*self.shape, self.start.tolist(), self.index.tolist())
        return ca.DM(pattern, self.data)

    def to_scipy(self):
        """The same matrix as a scipy.sparse CSC matrix (imported here: ~0.1 s)."""
        import scipy.sparse as sp

        return sp.csc_matrix((self.data, self.index, self.start), shape=self.shape)


@dataclass
class LinearProgram:
    cost: np.ndarray
    matrix: SparseMatrix
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

        matrix = SparseMatrix.from_entries(
            cat(self._rows, int), cat(self._cols, int), cat(self._data), (self.n_rows, self.n_vars)
        )
        return LinearProgram(
            cost=cat(self._cost),
            matrix=matrix,
            row_lo=cat(self._row_lo),
            row_hi=cat(self._row_hi),
            var_lo=cat(self._lo),
            var_hi=cat(self._hi),
        )


def _negligible_dropped(lp: LinearProgram) -> SparseMatrix:
    """``lp``'s matrix without the entries whose largest contribution to their row, |a_ij|
    max(|var_lo_j|, |var_hi_j|), is below NEGLIGIBLE: together less than a thousandth of the
    feasibility tolerance in any row of up to 10^3 variables. The residual rows carry
    entries down to 1e-20 (modes decayed over a long settling), with which HiGHS can stall
    for minutes on a program it otherwise solves in 0.3 s; the move the LP proposes is
    certified afterwards whatever the program held."""
    a = lp.matrix
    reach = np.maximum(np.abs(lp.var_lo), np.abs(lp.var_hi))[a.columns()]
    unbounded = np.isinf(reach)  # its entries are kept, but a stored zero (0 inf: nan)
    contribution = np.abs(a.data) * np.where(unbounded, 1.0, reach)
    return a.kept((a.data != 0) & (unbounded | (contribution >= NEGLIGIBLE)))


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
    import highspy  # ~0.02 s: only for this back end

    a = _negligible_dropped(lp)
    program = highspy.HighsLp()
    program.num_col_, program.num_row_ = a.shape[1], a.shape[0]
    program.col_cost_, program.col_lower_, program.col_upper_ = lp.cost, lp.var_lo, lp.var_hi
    program.row_lower_, program.row_upper_ = lp.row_lo, lp.row_hi
    matrix = program.a_matrix_
    matrix.format_ = highspy.MatrixFormat.kColwise
    matrix.num_col_, matrix.num_row_ = a.shape[1], a.shape[0]
    matrix.start_, matrix.index_, matrix.value_ = a.start, a.index, a.data
    with silenced_stdout():  # HiGHS prints its banner on the C-level stdout when made
        highs = highspy.Highs()
    options = {
        "output_flag": False,
        "primal_feasibility_tolerance": TOLERANCE,
        "dual_feasibility_tolerance": TOLERANCE,
    }
    left_s = _time_left_s()
    if left_s is not None:
        options["time_limit"] = left_s
    for name, value in options.items():
        highs.setOptionValue(name, value)
    start = time.perf_counter()
    highs.passModel(program)
    highs.run()
    wall = time.perf_counter() - start
    model_status = highs.getModelStatus()
    if model_status == highspy.HighsModelStatus.kTimeLimit:
        raise _out_of_time(lp, wall)
    status = {
        highspy.HighsModelStatus.kOptimal: "optimal",
        highspy.HighsModelStatus.kInfeasible: "infeasible",
    }.get(model_status, "failed")
    info = highs.getInfo()
    return LPSolution(
        status=status,
        x=np.array(highs.getSolution().col_value) if status == "optimal" else None,
        objective=float(info.objective_function_value) if status == "optimal" else np.inf,
        wall_s=wall,
        iterations=int(info.simplex_iteration_count) + max(0, int(info.ipm_iteration_count)),
        message=highs.modelStatusToString(model_status),
    )


def _solve_casadi(lp: LinearProgram, plugin: str) -> LPSolution:
    import casadi as ca  # ~0.1 s: only for the casadi back ends

    a = _negligible_dropped(lp).to_casadi()
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
    """Solve with ``solver``: "highs" (highspy), "casadi" (casadi + Clp) or "casadi-highs".
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
