"""core.meshes.band_regions: the band's triangles among those of its Delaunay triangulation."""

import numpy as np
import pytest

from core.meshes.band_regions import band_sides, band_triangles
from core.meshes.delaunay import delaunay
from core.meshes.mesh import triangle_signed_areas


def ring(count, radius):
    angles = 2.0 * np.pi * np.arange(count) / count
    return radius * np.stack([np.cos(angles), np.sin(angles)], axis=1)


def test_triangles_between_the_polygon_and_a_front_square_are_the_band():
    # A 24-gon (the boundary, counter-clockwise), a square core of two triangles (its border is
    # the front, the core on the left: counter-clockwise), points between, and a far ring.
    rng = np.random.default_rng(5)
    boundary = ring(24, 1.0)
    square = np.array([[-0.3, -0.3], [0.3, -0.3], [0.3, 0.3], [-0.3, 0.3]])
    angles, radii = rng.uniform(0, 2 * np.pi, 60), rng.uniform(0.55, 0.8, 60)
    between = np.stack([radii * np.cos(angles), radii * np.sin(angles)], axis=1)
    points = np.vstack([boundary, square, between, ring(8, 5.0)])
    tri = delaunay(points)
    front = 24 + np.array([[0, 1], [1, 2], [2, 3], [3, 0]])
    chord, front_side = band_sides(tri.simplices, 24, front)
    # Every chord and front edge is a side of two triangles (no point is near enough to break one).
    assert np.bincount(chord[chord >= 0]).tolist() == [2] * 24
    assert np.bincount(front_side[front_side >= 0]).tolist() == [2] * 4
    inside = band_triangles(tri.points, tri.simplices, tri.neighbors, chord, front, front_side, 1.0)
    centroids = points[tri.simplices].mean(axis=1)
    in_square = (np.abs(centroids) < 0.3).all(axis=1)
    in_polygon = np.linalg.norm(centroids, axis=1) < np.cos(np.pi / 24)
    assert inside.tolist() == np.flatnonzero(in_polygon & ~in_square).tolist()
    area = triangle_signed_areas(points, tri.simplices[inside]).sum()
    polygon_area = 0.5 * 24 * np.sin(2 * np.pi / 24)
    assert area == pytest.approx(polygon_area - 0.36, rel=1e-12)
    # The same boundary read clockwise: every region touches a chord from the wrong side.
    with pytest.raises(RuntimeError, match="not simple"):
        band_triangles(tri.points, tri.simplices, tri.neighbors, chord, front, front_side, -1.0)
