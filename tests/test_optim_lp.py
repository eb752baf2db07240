"""optim.lp: the compressed-column matrix against dense NumPy, and the back ends against a
program whose optimum is known in closed form."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from optim.lp import LinearProgram, LPBuilder, SparseMatrix, solve_lp

SOLVERS = ("highs", "casadi", "casadi-highs")


@settings(max_examples=60, deadline=None)
@given(
    rows=st.integers(1, 6),
    cols=st.integers(1, 6),
    entries=st.lists(
        st.tuples(st.integers(0, 5), st.integers(0, 5), st.floats(-1e3, 1e3)), max_size=40
    ),
)
def test_entries_at_the_same_place_are_summed_as_dense_numpy_sums_them(rows, cols, entries):
    entries = [(r % rows, c % cols, v) for r, c, v in entries]
    dense = np.zeros((rows, cols))
    for r, c, v in entries:
        dense[r, c] += v
    r, c, v = (np.array(x) for x in zip(*entries, strict=True)) if entries else ([], [], [])
    matrix = SparseMatrix.from_entries(r, c, v, (rows, cols))
    # summed in another order than the loop: equal to round-off of the sums
    np.testing.assert_allclose(matrix.toarray(), dense, rtol=1e-12, atol=1e-9)
    assert matrix.start[-1] == matrix.nnz and np.all(np.diff(matrix.start) >= 0)
    for j in range(cols):  # rows ascending within each column, each at most once
        assert np.all(np.diff(matrix.index[matrix.start[j] : matrix.start[j + 1]]) > 0)
    keep = matrix.data > 0  # a selection of the stored entries: exactly those values
    whole = matrix.toarray()
    np.testing.assert_array_equal(matrix.kept(keep).toarray(), np.where(whole > 0, whole, 0.0))
    np.testing.assert_array_equal(matrix.to_scipy().toarray(), matrix.toarray())


@pytest.mark.parametrize("solver", SOLVERS)
def test_each_back_end_finds_the_closed_form_optimum_of_two_sided_rows(solver):
    """maximise sum x over 0 <= x_i <= 1 with 0.5 <= x_i + x_{i+1} <= 1.5 (two-sided rows)
    and the equality x_0 = 0.25: the sum is x_0 plus three pairs, at most 0.25 + 3 x 1.5,
    attained (0.25, 1, 0.5, 1, 0.5, 1, 0.5); infeasible when x_0 = 2 is asked too."""
    n = 7
    builder = LPBuilder()
    x = builder.variables(n, lo=0.0, hi=1.0, cost=-1.0)
    builder.rows(np.column_stack([x[:-1], x[1:]]), np.ones((n - 1, 2)), 0.5, 1.5)
    builder.rows([[x[0]]], [[1.0]], 0.25, 0.25)
    solution = solve_lp(builder.program(), solver)
    assert solution.status == "optimal"
    assert solution.objective == pytest.approx(-4.75, abs=1e-9)
    pairs = solution.x[:-1] + solution.x[1:]
    assert solution.x[0] == pytest.approx(0.25, abs=1e-9)
    assert np.all(pairs >= 0.5 - 1e-9) and np.all(pairs <= 1.5 + 1e-9)
    builder.rows([[x[0]]], [[1.0]], 2.0, 2.0)
    assert solve_lp(builder.program(), solver).status == "infeasible"


def test_a_program_without_variables_is_solved_as_it_is():
    empty = LinearProgram(
        cost=np.zeros(0),
        matrix=SparseMatrix.from_entries([], [], [], (0, 0)),
        row_lo=np.zeros(0),
        row_hi=np.zeros(0),
        var_lo=np.zeros(0),
        var_hi=np.zeros(0),
    )
    assert solve_lp(empty).status == "optimal"
