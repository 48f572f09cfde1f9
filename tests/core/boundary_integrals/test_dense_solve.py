"""core.boundary_integrals.dense_solve: SciPy's LAPACK dgesv called from compiled code, bit for
bit the routine numba's np.linalg.solve calls, with np.linalg.solve's errors."""

import numpy as np
import pytest
from scipy.linalg import lapack

from core.boundary_integrals.dense_solve import solve


@pytest.mark.parametrize("size, columns", [(1, 1), (7, 3), (48, 13), (96, 1)])
def test_the_solution_is_lapack_dgesvs_bit_for_bit_in_np_linalg_solves_layout(size, columns):
    rng = np.random.default_rng(size)
    matrix = np.eye(size) + 2.0 * rng.standard_normal((size, size)) / size  # as the knot blocks' I + 2 K*
    rhs = rng.standard_normal((size, columns))
    before = matrix.copy(), rhs.copy()
    solution = solve(matrix, rhs)
    *_, expected, info = lapack.dgesv(matrix, rhs)  # numba's np.linalg.solve calls this routine
    assert solution.shape == (size, columns) and solution.flags.f_contiguous
    assert info == 0 and np.array_equal(solution, expected)
    assert np.array_equal(matrix, before[0]) and np.array_equal(rhs, before[1])  # inputs untouched
    assert np.max(np.abs(matrix @ solution - rhs)) < 1e-12


def test_a_singular_matrix_or_a_nan_raises_as_np_linalg_solve_does():
    singular = np.array([[1.0, 2.0], [2.0, 4.0]])
    with pytest.raises(np.linalg.LinAlgError, match="singular"):
        solve(singular, np.ones((2, 1)))
    for matrix, rhs in (
        (np.array([[1.0, np.nan], [0.0, 1.0]]), np.ones((2, 1))),
        (np.eye(2), np.full((2, 1), np.inf)),
    ):
        with pytest.raises(np.linalg.LinAlgError, match="infs or NaNs"):
            solve(matrix, rhs)
