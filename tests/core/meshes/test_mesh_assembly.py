"""core.meshes.mesh_assembly: the final mesh on the vertices that its triangles use."""

import numpy as np

from core.meshes.mesh_assembly import assembled_triangles


def test_unused_points_are_left_out_and_triangles_renumbered():
    points = np.arange(16.0).reshape(8, 2)
    core = np.array([[0, 2, 3]])
    band_index = np.array([5, 2, 7, 0])  # band point i is points[band_index[i]]
    band = np.array([[0, 1, 3], [2, 0, 3]])
    vertices, triangles, used = assembled_triangles(points, core, band_index, band)
    assert used.tolist() == [True, False, True, True, False, True, False, True]
    np.testing.assert_array_equal(vertices, points[used])
    expected = np.vstack([core, band_index[band]])  # the same triangles, as points
    np.testing.assert_array_equal(vertices[triangles], points[expected])
