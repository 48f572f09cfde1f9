"""The two-grid solve of the coarse double-layer system (core.boundary_integrals.two_grid)."""

from __future__ import annotations

import numpy as np
import pytest
from support.shapes import SHAPES, random_polygon_cage

import core
from core.boundary_integrals import compiled_integrals, poisson, two_grid
from core.curves import examples


def coarse_system(curve: core.ClosedBSpline) -> tuple[np.ndarray, np.ndarray]:
    """The coarse system matrix (K, K) and right-hand sides (K, n + 1) `poisson` solves for `curve`."""
    captured = {}
    solve = two_grid.solve

    def capture(matrix, rhs):
        captured["system"] = matrix.copy(), rhs.copy()
        return solve(matrix, rhs)

    poisson.solved_densities.cache_clear()
    try:
        two_grid.solve = capture
        poisson.densities(poisson.centred(curve, np.zeros((1, 2)))[0])
    finally:
        two_grid.solve = solve
        poisson.solved_densities.cache_clear()
    return captured["system"]


CAGES = {
    "blob": lambda: core.ClosedBSpline(examples.blob()),
    "F polygon": lambda: core.ClosedBSpline(SHAPES["F polygon"]),
    "corner cage 645": lambda: random_polygon_cage(645),  # a 5.7° spike: slower steps
}


@pytest.mark.parametrize("combined", [False, True], ids=["every column", "5 combined"])
@pytest.mark.parametrize("name", CAGES)
def test_agrees_with_the_lu_to_its_rounding(name, combined, monkeypatch):
    """Every basis function's right-hand side, or 5 combinations (a certificate's: x and y of a target
    and of the source, and the sum), which take the `FEW_COLUMNS_ORDER` grid."""
    matrix, rhs = coarse_system(CAGES[name]())
    if combined:
        mix = np.random.default_rng(6).normal(size=(rhs.shape[1], 5))
        rhs = np.ascontiguousarray(rhs @ mix)
    lu = two_grid.solve_in_place(matrix.copy(), rhs)
    factored = []
    lu_instead = lambda m, r: factored.append(m.shape) or np.linalg.solve(m, r)  # noqa: E731
    monkeypatch.setattr(two_grid, "solve_in_place", lu_instead)
    kept = matrix.copy()
    x = two_grid.solve(matrix, rhs)
    assert factored == []  # iterated, not the LU
    np.testing.assert_array_equal(matrix, kept)  # and the matrix untouched
    assert np.abs(x - lu).max() <= 1e-13 * np.abs(lu).max()  # measured <= 2.7e-14 (the corner cage)
    # Backward error: measured <= 3.6e-15 (the LU's <= 4.5e-16).
    residual = np.abs(rhs - kept @ x).max()
    assert residual <= 1e-14 * np.abs(kept).sum(axis=1).max() * np.abs(x).max()


def test_a_system_the_coarse_grid_misses_falls_back_to_the_lu(monkeypatch):
    # Rough noise off the diagonal: not a second-kind operator, and the iteration does not
    # contract; the answer is still the solution.
    rng = np.random.default_rng(3)
    size = 20 * 16
    matrix = np.eye(size) + rng.normal(scale=2.0 / np.sqrt(size), size=(size, size))
    rhs = rng.normal(size=(size, 3))
    expected = np.linalg.solve(matrix, rhs)
    factored = []
    lu = two_grid.solve_in_place
    monkeypatch.setattr(two_grid, "solve_in_place", lambda m, r: factored.append(m.shape) or lu(m, r))
    np.testing.assert_allclose(two_grid.solve(matrix.copy(), rhs), expected, rtol=0, atol=1e-10)
    assert factored == [(size, size)]


@pytest.mark.parametrize(
    ("order", "columns"),
    [(two_grid.COARSE_ORDER, two_grid.FEW_COLUMNS + 1), (two_grid.FEW_COLUMNS_ORDER, two_grid.FEW_COLUMNS)],
)
def test_exact_on_smooth_densities_in_one_application(order, columns, monkeypatch):
    # A = I + K with K mapping into the coarse grid's polynomials: the first preconditioned
    # application is already the solution, and the iteration stops at once (its first step and a
    # second to see that the first changed nothing beyond rounding).
    rng = np.random.default_rng(4)
    panels = 12
    prolong, restrict = two_grid._GRIDS[order]
    projection = np.kron(np.eye(panels), prolong @ restrict)  # onto degree < order a panel
    matrix = np.eye(panels * 16) + projection @ rng.normal(scale=0.05, size=(panels * 16,) * 2) @ projection
    rhs = rng.normal(size=(panels * 16, columns))
    products = []
    product = two_grid._product
    monkeypatch.setattr(two_grid, "_product", lambda *arguments: products.append(1) or product(*arguments))
    np.testing.assert_allclose(two_grid.solve(matrix, rhs), np.linalg.solve(matrix, rhs), rtol=0, atol=1e-13)
    assert len(products) <= 2
    np.testing.assert_array_equal(two_grid.solve(matrix, np.zeros_like(rhs)), 0.0)


def test_few_columns_the_coarser_grid_misses_take_the_finer_one(monkeypatch):
    """A = I + K with K smooth to degree < COARSE_ORDER but not < FEW_COLUMNS_ORDER a panel, strong
    enough that the coarser grid's iteration does not contract: the `COARSE_ORDER` grid's does."""
    rng = np.random.default_rng(7)
    panels = 12
    prolong, restrict = two_grid._GRIDS[two_grid.COARSE_ORDER]
    projection = np.kron(np.eye(panels), prolong @ restrict)
    matrix = np.eye(panels * 16) + projection @ rng.normal(scale=0.5, size=(panels * 16,) * 2) @ projection
    rhs = rng.normal(size=(panels * 16, 3))
    tried = []
    iterated = two_grid._iterated
    monkeypatch.setattr(
        two_grid,
        "_iterated",
        lambda m, r, order: tried.append((order, iterated(m, r, order) is None)) or iterated(m, r, order),
    )
    np.testing.assert_allclose(two_grid.solve(matrix, rhs), np.linalg.solve(matrix, rhs), rtol=0, atol=1e-12)
    assert tried[0] == (two_grid.FEW_COLUMNS_ORDER, True)
    assert tried[-1] == (two_grid.COARSE_ORDER, False)


def test_the_compiled_products_equal_numpys(monkeypatch):
    # The Galerkin matrix and the residual products on every numba thread, and the numpy ones
    # (measured: the blob's solutions bit-identical).
    matrix, rhs = coarse_system(CAGES["blob"]())
    coarse_size = matrix.shape[0] // 16 * two_grid.COARSE_ORDER
    results = {}
    for mode in ("numpy", "compiled"):
        monkeypatch.setattr(compiled_integrals, "mode", mode)
        galerkin = two_grid._galerkin(
            matrix, np.full((coarse_size, coarse_size), np.nan), *two_grid._GRIDS[two_grid.COARSE_ORDER]
        )
        product = two_grid._product(matrix, rhs, np.full_like(rhs, np.nan))
        results[mode] = galerkin, product, two_grid.solve(matrix, rhs)
    for numpy_result, compiled_result in zip(results["numpy"], results["compiled"], strict=True):
        assert np.abs(compiled_result - numpy_result).max() <= 1e-14 * np.abs(numpy_result).max()


@pytest.mark.parametrize("runs", [1, 2, 3, 7, 10])
def test_the_rows_product_covers_every_row_in_any_number_of_runs(runs):
    rng = np.random.default_rng(5)
    matrix, x = rng.normal(size=(7, 5)), rng.normal(size=(5, 3))
    out = np.full((7, 3), np.nan)
    for first in range(runs):
        compiled_integrals.rows_product(matrix, x, out, first, runs)
    np.testing.assert_allclose(out, matrix @ x, rtol=1e-15, atol=1e-15)
