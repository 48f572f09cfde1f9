"""core.meshes.triangle_shapes: circumradii, shortest edges, centroids and circumcentres."""

import numpy as np

from core.meshes.triangle_shapes import circumcentres, triangle_shapes


def test_shapes_of_random_triangles_agree_with_their_circumcircles():
    rng = np.random.default_rng(6)
    points = rng.uniform(-1.0, 1.0, (300, 2))
    simplices = rng.choice(300, (200, 3), replace=True)
    simplices = simplices[(simplices[:, 0] != simplices[:, 1]) & (simplices[:, 1] != simplices[:, 2])]
    simplices = simplices[simplices[:, 0] != simplices[:, 2]]
    radius, shortest, centroids = triangle_shapes(points, simplices)
    centres = circumcentres(points, simplices)
    corners = points[simplices]
    distance = np.linalg.norm(corners - centres[:, None, :], axis=2)  # every corner on the circle
    np.testing.assert_allclose(distance, np.repeat(radius[:, None], 3, axis=1), rtol=1e-7)
    edges = np.linalg.norm(corners - np.roll(corners, 1, axis=1), axis=2)
    np.testing.assert_allclose(shortest, edges.min(axis=1), rtol=1e-15)
    np.testing.assert_allclose(centroids, corners.mean(axis=1), rtol=1e-14, atol=1e-15)


def test_an_equilateral_triangle():
    points = np.array([[0.0, 0.0], [2.0, 0.0], [1.0, np.sqrt(3.0)]])
    radius, shortest, _ = triangle_shapes(points, np.array([[0, 1, 2]]))
    np.testing.assert_allclose(radius, 2.0 / np.sqrt(3.0), rtol=1e-15)
    np.testing.assert_allclose(shortest, 2.0, rtol=1e-15)
    np.testing.assert_allclose(
        circumcentres(points, np.array([[0, 2, 1]])), [[1.0, 1.0 / np.sqrt(3.0)]], rtol=1e-15
    )
