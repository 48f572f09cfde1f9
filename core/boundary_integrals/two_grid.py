"""Two-grid solve of a second-kind Nyström system on Gauss–Legendre panels.

The coarse equation of `poisson` is (I + K) ρ = b with K compact but near the compressed
knots: K maps every density to a smooth one.  So the error of any approximate solve that is
exact on smooth densities is K applied to something, smooth, and one coarser grid catches it
(Atkinson and Brakhage's two-grid iteration for second-kind equations).  The coarse grid here
is the same panels with `COARSE_ORDER` Gauss–Legendre nodes instead of `ORDER`:

    Π = per panel, the interpolation from the coarse nodes to the fine ones   (ORDER, COARSE_ORDER)
    Ρ = per panel, the L² projection back, W_c^-1 Π^T W_f                       (COARSE_ORDER, ORDER)
    A_c = Ρ A Π                                                            (Galerkin coarse matrix)
    M r = r + Π (A_c^-1 Ρ r - Ρ r)       (A^-1 on the panels' polynomials of degree < COARSE_ORDER,
                                          the identity on the rest, where A = I + K is ~ I)

and x ← x + M (b - A x) from x = M b.  Each step multiplies the error by ~1e-5 on the test
shapes (the bench's blob: 1e-5, 5e-10, 5e-15 after one, two, three steps; the F polygon, the
hook, the starfish alike; random corner cages by 0.05-0.25 a step), so two or three steps of one
product A x each (2 K² m flops) replace an LU (2/3 K³): for the blob's K = 560 unknowns and
m = 13 right-hand sides 3.8 -> 2.4 ms (two steps), for the F polygon's 1,552 67 -> 34 ms, the
whole solve of a smooth cage of 120 control points 1.2 -> 0.55 s.  The LU of A_c is 1/8 of A's.

With few right-hand sides (`FEW_COLUMNS`: a map's derivatives from its densities combined first,
`poisson.combined_densities`) a step costs little and the LU of A_c most of the solve: the coarse
grid then has `FEW_COLUMNS_ORDER` nodes a panel, an LU 19x shorter, at the cost of a step or so
more (a 200-point five-lobed cage, K = 6,400 and 5 right-hand sides: LU 1.5 s -> 0.1 s, 2 steps either
way, the same solution to 5e-15).  Where that does not contract, the `COARSE_ORDER` grid is tried.

A system that does not contract so (a cage the coarse grid does not resolve) falls back to the
LU of A, which the iteration leaves as it was.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import lu_factor, lu_solve

from core.boundary_integrals import compiled_integrals
from core.boundary_integrals.gauss_legendre import NODES, ORDER, WEIGHTS
from core.boundary_integrals.scratch_arrays import scratch

#: Gauss–Legendre nodes a panel on the coarse grid: with 6 the blob takes a step more than with 8
#: (its coarse LU shorter, as fast in all), with 10 none fewer.
COARSE_ORDER = 8
#: Right-hand sides at most that take the coarser grid of `FEW_COLUMNS_ORDER` nodes a panel first.
FEW_COLUMNS = 16
FEW_COLUMNS_ORDER = 3
#: Rows of A a block of the coarse matrix's product takes, times K (its scratch: ROWS / 2 numbers).
ROWS = 32_768
#: A step must shrink the last one's size at least this much, or the iteration is not worth it.
CONTRACTION = 0.5
#: Stop once the error left, predicted from the last step's size s and contraction ρ as
#: s ρ / (1 - ρ), is below this fraction of the solution.  The prediction is cautious: the bench
#: blob stops after two steps predicting 2.5e-14 and is off the LU's solution by 4.9e-15 (a third
#: step: 1.1e-15, as the LU is off its own rounding); random corner cage 645 by 2.7e-14.  Far
#: below the discretisation's own error (G agrees with finer solves to ~1e-12).
TOLERANCE = 1e-13
#: A step this small against the solution is rounding: stop there even if it shrank no more.
ROUNDING = 1e-14


def _grids(order: int) -> tuple[np.ndarray, np.ndarray]:
    """Π (ORDER, order) and Ρ (order, ORDER) of the module docstring, `order` coarse nodes a panel."""
    nodes, weights = np.polynomial.legendre.leggauss(order)
    coarse = np.polynomial.legendre.legvander(nodes, order - 1)
    fine = np.polynomial.legendre.legvander(NODES, order - 1)
    prolong = np.linalg.solve(coarse.T, fine.T).T  # fine values of the coarse interpolant
    restrict = prolong.T * WEIGHTS[None, :] / weights[:, None]
    return np.ascontiguousarray(prolong), np.ascontiguousarray(restrict)


_GRIDS = {order: _grids(order) for order in (COARSE_ORDER, FEW_COLUMNS_ORDER)}


def solve(matrix: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """matrix^-1 rhs, shape (K, m), for a C-ordered second-kind system matrix (K, K) on panels
    of `ORDER` Gauss–Legendre nodes (unknowns panel by panel); `matrix` is not changed but
    where the two-grid iteration does not contract (then it is overwritten by its LU)."""
    orders = (FEW_COLUMNS_ORDER, COARSE_ORDER) if rhs.shape[1] <= FEW_COLUMNS else (COARSE_ORDER,)
    for order in orders:
        x = _iterated(matrix, rhs, order)
        if x is not None:
            return x
    return solve_in_place(matrix, rhs)


def _iterated(matrix: np.ndarray, rhs: np.ndarray, order: int) -> np.ndarray | None:
    """`solve`'s two-grid iteration on a coarse grid of `order` nodes a panel: matrix^-1 rhs (K, m),
    or None where it does not contract (`matrix` is not changed)."""
    size, columns = rhs.shape
    panels = size // ORDER
    coarse_size = panels * order
    prolong, restrict = _GRIDS[order]
    coarse = _galerkin(matrix, scratch("coarse matrix", (coarse_size, coarse_size)), prolong, restrict)
    factors = lu_factor(coarse.T, overwrite_a=True, check_finite=False)  # Fortran order: no copy
    product = scratch("two-grid product", (size, columns))  # A x of each step

    def precondition(residual: np.ndarray) -> np.ndarray:
        by_panel = residual.reshape(panels, ORDER, columns)
        projected = np.matmul(restrict, by_panel)
        solved = lu_solve(factors, projected.reshape(coarse_size, columns), trans=1, check_finite=False)
        correction = solved.reshape(panels, order, columns) - projected
        return (by_panel + np.matmul(prolong, correction)).reshape(size, columns)

    x = precondition(rhs)
    # An LU of A costs 2/3 K^3, a step 2 K^2 m: the iteration may take that many steps.
    budget = max(2, size // (3 * columns))
    last = np.inf
    for taken in range(1, budget + 1):
        step = precondition(rhs - _product(matrix, x, product))
        x += step
        scale, length = np.abs(x).max(), np.abs(step).max()
        if not np.isfinite(length):
            break
        if length == 0.0:
            return x
        if taken == 1:  # no rate yet
            last = length
            continue
        rate = min(length / last, 1.0)
        if rate < 1.0 and length * rate / (1.0 - rate) <= TOLERANCE * scale:
            return x
        if rate > CONTRACTION or taken + _steps_left(length, rate, scale) > budget:
            if length <= ROUNDING * scale:
                return x
            break
        last = length
    return None


def _galerkin(
    matrix: np.ndarray, coarse: np.ndarray, prolong: np.ndarray, restrict: np.ndarray
) -> np.ndarray:
    """Ρ A Π (the module docstring) into `coarse` (P c, P c) for A = `matrix` (P ORDER, P ORDER),
    C-ordered, Π = `prolong` (ORDER, c) and Ρ = `restrict` (c, ORDER): compiled on every thread
    (`compiled_integrals.galerkin_matrix`) where at hand, else numpy."""
    found = compiled_integrals.run_compiled(
        compiled_integrals.galerkin_matrix,
        lambda: (matrix, restrict, prolong, coarse),
        items=matrix.shape[0] // ORDER,
    )
    if found is not None:
        return coarse
    size = matrix.shape[0]
    panels = size // ORDER
    order = restrict.shape[0]
    # A few row panels at a time: Ρ on their rows, then Π on every panel of those (one product
    # each, written into A_c's rows).  One product over all rows made A Π, K^2 / 2 numbers of
    # fresh memory, whose page faults took a third of the bench blob's solve.
    rows = max(1, ROWS // size)
    for first in range(0, panels, rows):
        last = min(panels, first + rows)
        restricted = np.matmul(restrict, matrix[first * ORDER : last * ORDER].reshape(-1, ORDER, size))
        written = coarse[first * order : last * order].reshape(-1, order)
        np.matmul(restricted.reshape(-1, ORDER), prolong, out=written)
    return coarse


def _product(matrix: np.ndarray, x: np.ndarray, out: np.ndarray) -> np.ndarray:
    """matrix @ x into `out` (K, m): compiled on every thread (`compiled_integrals.rows_product`)
    where at hand, else one BLAS call."""
    found = compiled_integrals.run_compiled(
        compiled_integrals.rows_product, lambda: (matrix, x, out), items=matrix.shape[0]
    )
    return np.matmul(matrix, x, out=out) if found is None else out


def _steps_left(length: float, rate: float, scale: float) -> float:
    """Steps until a step of `length` shrinking by `rate` a step is within `TOLERANCE` of `scale`."""
    if rate <= 0.0 or length <= TOLERANCE * scale:
        return 1.0
    return np.log(TOLERANCE * scale / length) / np.log(rate)


def solve_in_place(matrix: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """matrix^-1 rhs, shape (K, m), for a C-ordered matrix (K, K), which it overwrites.

    LAPACK factors the matrix's transpose where it lies (Fortran order: no copy) and solves
    with the factors transposed.  Copying a C-ordered matrix into Fortran order took as long
    as the LU itself for the 560 unknowns of the bench's blob (6.9 -> 3.8 ms), 20 % of the
    knot blocks' solves.
    """
    factors = lu_factor(matrix.T, overwrite_a=True, check_finite=False)
    return lu_solve(factors, rhs, trans=1, check_finite=False)
