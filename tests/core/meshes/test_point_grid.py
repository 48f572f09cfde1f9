"""core.meshes.point_grid: points sorted into square cells."""

import numpy as np
import pytest
from scipy.spatial import cKDTree

from core.meshes.point_grid import (
    CELLS_PER_POINT,
    grid_buckets,
    grid_layout,
    nearest_distances,
    nearest_neighbours,
    within_reach,
)


def test_every_point_is_in_the_cell_that_holds_it():
    rng = np.random.default_rng(1)
    points = rng.uniform([-3.0, 1.0], [5.0, 2.0], (500, 2))
    low, cell, columns, rows = grid_layout(points, 0.3)
    assert cell == 0.3
    start, members = grid_buckets(points, low, cell, columns, rows)
    assert sorted(members.tolist()) == list(range(500))
    cell_of = np.repeat(np.arange(rows * columns), np.diff(start))
    column, row = cell_of % columns, cell_of // columns
    local = points[members] - low
    assert (local[:, 0] >= column * cell).all() and (local[:, 0] <= (column + 1) * cell).all()
    assert (local[:, 1] >= row * cell).all() and (local[:, 1] <= (row + 1) * cell).all()


def test_tiny_cells_are_widened_to_a_few_per_point():
    points = np.random.default_rng(2).uniform(0.0, 1.0, (100, 2))
    _, cell, columns, rows = grid_layout(points, 1e-9)
    assert cell > 1e-9 and columns * rows <= 2 * CELLS_PER_POINT * 100


def test_nearest_distances_match_a_search_of_all_points():
    rng = np.random.default_rng(3)
    points = rng.uniform(0.0, 1.0, (400, 2))
    x = rng.uniform(-0.3, 1.3, (700, 2))
    reach = 0.05
    distance = np.linalg.norm(x[:, None] - points[None], axis=2).min(axis=1)
    expected = np.where(distance <= reach, distance, np.inf)
    found = nearest_distances(points, x, reach)
    assert 100 < np.isfinite(expected).sum() < 650
    np.testing.assert_allclose(found, expected, rtol=1e-15)


def test_within_reach_is_a_nearest_distance_within_reach():
    rng = np.random.default_rng(4)
    points = rng.uniform(0.0, 1.0, (400, 2))
    x = np.vstack([rng.uniform(-0.3, 1.3, (700, 2)), points[:5], [[np.nan, 0.5]]])
    reach = 0.05
    expected = nearest_distances(points, x, reach) <= reach
    assert 100 < expected.sum() < 650 and not expected[-1]
    np.testing.assert_array_equal(within_reach(points, x, reach), expected)


@pytest.mark.parametrize("bound", [np.inf, 0.08])
def test_nearest_neighbours_match_a_k_d_tree(bound):
    rng = np.random.default_rng(4)
    angle = np.sort(rng.uniform(0.0, 2 * np.pi, 600))  # samples along a curve, as in the sizing
    points = np.stack([np.cos(angle) * (1 + 0.3 * np.cos(5 * angle)), np.sin(angle)], axis=1)
    x = np.vstack([points[::7], rng.uniform(-1.5, 1.5, (300, 2))])
    distance, index = nearest_neighbours(points, x, 12, bound)
    expected_distance, expected_index = cKDTree(points).query(x, k=12, distance_upper_bound=bound)
    np.testing.assert_allclose(distance, expected_distance, rtol=1e-15)
    np.testing.assert_array_equal(index, expected_index)
    if np.isfinite(bound):
        assert np.isinf(distance).any() and np.isfinite(distance).any()


def test_a_point_that_is_not_finite_is_refused_before_the_compiled_searches():
    points = np.array([[0.0, 0.0], [1.0, np.nan], [2.0, 1.0]])
    with pytest.raises(RuntimeError, match="not finite"):
        grid_layout(points, 0.5)
    with pytest.raises(RuntimeError, match="not finite"):
        grid_layout(np.array([[np.inf, 0.0], [1.0, 1.0]]), 0.5)
    x = np.array([[np.nan, 0.0], [0.1, 0.0]])
    np.testing.assert_array_equal(nearest_distances(points[[0, 2]], x, 1.0), [np.inf, 0.1])
    distance, index = nearest_neighbours(points[[0, 2]], x, 1)
    assert distance[0, 0] == np.inf and index[0, 0] == 2 and index[1, 0] == 0
