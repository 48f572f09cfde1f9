"""core.meshes.smoothing: Laplacian smoothing passes that keep every triangle valid."""

import numpy as np

from core.meshes.delaunay import delaunay
from core.meshes.mesh import triangle_signed_areas
from core.meshes.smoothing import KEPT_AREA, smoothing_pass


def test_a_point_in_a_hexagon_moves_to_its_centre():
    angles = np.pi / 3 * np.arange(6)
    points = np.vstack([[[0.3, -0.2]], np.stack([np.cos(angles), np.sin(angles)], axis=1)])
    simplices = np.array([[0, 1 + k, 1 + (k + 1) % 6] for k in range(6)])
    movable = np.array([True] + [False] * 6)
    moved = smoothing_pass(points, simplices, movable)
    np.testing.assert_allclose(moved[0], [0.0, 0.0], atol=1e-15)
    np.testing.assert_array_equal(moved[1:], points[1:])


def test_passes_keep_every_triangle_a_share_of_its_area():
    rng = np.random.default_rng(9)
    inner = rng.uniform(-0.9, 0.9, (300, 2))
    angles = 2 * np.pi * np.arange(40) / 40
    points = np.vstack([np.stack([np.cos(angles), np.sin(angles)], axis=1) * 1.3, inner])
    tri = delaunay(points)
    movable = np.arange(points.shape[0]) >= 40
    for _ in range(3):
        before = triangle_signed_areas(points, tri.simplices)
        moved = smoothing_pass(points, tri.simplices, movable)
        assert (triangle_signed_areas(moved, tri.simplices) >= KEPT_AREA * before).all()
        np.testing.assert_array_equal(moved[:40], points[:40])
        assert np.abs(moved[40:] - points[40:]).max() > 1e-3  # the points did move
        points = moved
