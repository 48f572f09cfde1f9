"""X = A⁻¹ B in compiled code by LAPACK's ``dgesv``, the routine numba's ``np.linalg.solve`` calls.

numba's ``np.linalg.solve`` compiles its shape checks and their messages (string formatting)
into every function that uses it: ~6 CPU-s of compiling for `compiled_integrals.knot_blocks`'
one call. `solve` calls the same ``dgesv`` of SciPy's LAPACK (``scipy.linalg.cython_lapack``,
which numba's own wrapper calls too) on the same column-major copies, so its results are
bit-identical, for under a second of compiling. The routine is reached by a symbol name
(`SYMBOL`, given to LLVM at import), not by its address, so that numba can cache the functions
calling it.
"""

from __future__ import annotations

import numpy as np
from llvmlite import binding
from numba import njit, types
from numba.extending import get_cython_function_address

#: The name under which LLVM resolves ``dgesv`` in compiled code (loaded from numba's cache too).
SYMBOL = "transfinite_warp_dgesv"
binding.add_symbol(SYMBOL, get_cython_function_address("scipy.linalg.cython_lapack", "dgesv"))

_int, _double = types.CPointer(types.int32), types.CPointer(types.float64)
#: dgesv(n, nrhs, a, lda, ipiv, b, ldb, info): Fortran's arguments, all by pointer.
_dgesv = types.ExternalFunction(SYMBOL, types.void(_int, _int, _double, _int, _int, _double, _int, _int))


@njit(cache=True, nogil=True, error_model="numpy")
def solve(matrix, rhs):
    """A⁻¹ B for matrix A (n, n) and rhs B (n, m): (n, m), column-major (numba's 'F' layout, as
    ``np.linalg.solve`` returns it), by LU with partial pivoting.

    Raises ``np.linalg.LinAlgError`` as ``np.linalg.solve`` does: for infs or NaNs in A or B,
    and for an exactly singular A."""
    n, m = rhs.shape
    for i in range(n):
        for j in range(n):
            if not np.isfinite(matrix[i, j]):
                raise np.linalg.LinAlgError("Array must not contain infs or NaNs.")
        for j in range(m):
            if not np.isfinite(rhs[i, j]):
                raise np.linalg.LinAlgError("Array must not contain infs or NaNs.")
    factors = matrix.T.copy()  # column-major A, overwritten by its LU factors
    solution = rhs.T.copy()  # column-major B, overwritten by X
    sizes = np.array([n, m, 0], dtype=np.int32)  # n (also the leading dimensions), m, info
    pivots = np.empty(n, dtype=np.int32)
    _dgesv(
        sizes[0:].ctypes,
        sizes[1:].ctypes,
        factors.ctypes,
        sizes[0:].ctypes,
        pivots.ctypes,
        solution.ctypes,
        sizes[0:].ctypes,
        sizes[2:].ctypes,
    )
    if sizes[2] > 0:
        raise np.linalg.LinAlgError("Matrix is singular to machine precision.")
    return solution.T
