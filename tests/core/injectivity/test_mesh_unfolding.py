"""core.injectivity.mesh_unfolding: a few free vertices move, by little, and no triangle is turned over."""

from __future__ import annotations

import numpy as np
from scipy.spatial import Delaunay

from core.injectivity.mesh_unfolding import MARGIN, unfold_triangles


def doubled_areas(points, triangles):
    a, b, c = points[triangles[:, 0]], points[triangles[:, 1]], points[triangles[:, 2]]
    return (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])


def grid_mesh(size: int = 9):
    """A square grid's Delaunay triangles (counter-clockwise), its border fixed."""
    axis = np.linspace(0.0, 1.0, size)
    vertices = np.stack(np.meshgrid(axis, axis), axis=-1).reshape(-1, 2)
    triangles = Delaunay(vertices).simplices
    flip = doubled_areas(vertices, triangles) < 0
    triangles[flip] = triangles[flip][:, ::-1]
    free = np.all((vertices > 0) & (vertices < 1), axis=1)
    return vertices, triangles, free


def unit_square(points):
    return np.all((points > 0) & (points < 1), axis=1)


def test_a_vertex_beyond_a_chord_moves_back_by_little_more_than_its_overshoot():
    # A fan around (0, 0.4) over the chord from (-1, 0) to (1, 0): the centre's image is 0.01 below it.
    ring = np.array([[-1.0, 0.0], [1.0, 0.0], [1.0, 1.0], [-1.0, 1.0]])
    vertices = np.vstack([[0.0, 0.4], ring])
    triangles = np.array([[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 1]])
    images = vertices.copy()
    images[0] = [0.1, -0.01]
    free = np.array([True, False, False, False, False])
    unfolded, moves = unfold_triangles(vertices, images, triangles, free)
    assert np.all(doubled_areas(unfolded, triangles) > 0)
    np.testing.assert_array_equal(unfolded[1:], images[1:])
    # The ring is unchanged, so the identity's position (0, 0.4) gives every triangle determinant 1,
    # the best smallest one (the determinants' area-weighted mean is 1 wherever the centre is).  The
    # bottom triangle's determinant is 2 y / 0.8, so it needs y >= MARGIN * 0.4 = 0.04: a move of
    # 0.05 up in the max-norm, with at most as much sideways.
    np.testing.assert_allclose(unfolded[0, 1], MARGIN * 0.4, atol=1e-9)
    assert abs(unfolded[0, 0] - 0.1) <= 0.05 + 1e-9
    assert 0.05 - 1e-9 <= moves[0] <= 0.05 * np.sqrt(2) + 1e-9


def test_random_tangles_of_a_smooth_map_are_undone_locally():
    rng = np.random.default_rng(5)
    vertices, triangles, free = grid_mesh()
    images = vertices + 0.05 * np.sin(3.0 * vertices[:, ::-1])
    kicked = rng.choice(np.flatnonzero(free), size=6, replace=False)
    images[kicked] += rng.normal(scale=0.12, size=(6, 2))
    images[kicked] = np.clip(images[kicked], 0.01, 0.99)
    assert np.any(doubled_areas(images, triangles) <= 0)
    unfolded, moves = unfold_triangles(vertices, images, triangles, free)
    assert np.all(doubled_areas(unfolded, triangles) > 1e-9 * doubled_areas(vertices, triangles))
    assert np.all(unit_square(unfolded[free]))
    assert np.all(moves[~free] == 0.0)
    # Only vertices of turned-over triangles and their neighbours move, and by less than a cell's width.
    turned = triangles[doubled_areas(images, triangles) <= 0]
    near = np.unique(triangles[np.isin(triangles, turned).any(axis=1)])
    assert set(np.flatnonzero(moves)) <= set(near)
    assert moves.max() < 1.0 / 8


def test_a_fold_that_no_free_vertex_can_undo_is_left_for_the_caller_to_see():
    vertices, triangles, free = grid_mesh(4)
    images = vertices.copy()
    images[[0, 1]] = images[[1, 0]]  # two fixed corner vertices swapped
    unfolded, moves = unfold_triangles(vertices, images, triangles, np.zeros_like(free))
    np.testing.assert_array_equal(unfolded, images)
    assert np.all(moves == 0.0) and np.any(doubled_areas(unfolded, triangles) <= 0)
