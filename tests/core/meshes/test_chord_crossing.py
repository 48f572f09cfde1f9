"""core.meshes.chord_crossing: the first boundary chord between a triangle and a point."""

import numpy as np

from core.meshes.band_regions import band_sides, band_triangles
from core.meshes.chord_crossing import first_chords_crossed
from core.meshes.delaunay import delaunay


def test_walks_stop_at_the_first_chord_a_segment_crosses():
    # A star polygon (concave stretches: segments may leave and enter again) with points inside
    # and a far ring, triangulated; walks from inside triangles to random targets.
    rng = np.random.default_rng(2)
    angles = 2.0 * np.pi * np.arange(60) / 60
    radius = 1.0 + 0.3 * np.cos(5 * angles)
    boundary = np.stack([radius * np.cos(angles), radius * np.sin(angles)], axis=1)
    inner = rng.uniform(0.0, 2 * np.pi, 200)
    depth = rng.uniform(0.0, 0.6, 200) * (1.0 + 0.3 * np.cos(5 * inner))
    far = 6.0 * np.stack([np.cos(angles[::6]), np.sin(angles[::6])], axis=1)
    points = np.vstack([boundary, np.stack([depth * np.cos(inner), depth * np.sin(inner)], axis=1), far])
    tri = delaunay(points)
    chord, front_side = band_sides(tri.simplices, 60, np.zeros((0, 2), dtype=np.int64))
    assert np.bincount(chord[chord >= 0]).tolist() == [2] * 60  # the polygon is in the triangulation
    inside = band_triangles(
        tri.points, tri.simplices, tri.neighbors, chord, np.zeros((0, 2)), front_side, 1.0
    )
    starts = rng.choice(inside, 500)
    targets = rng.uniform(-1.5, 1.5, (500, 2))
    crossed = first_chords_crossed(points, tri.simplices, tri.neighbors, chord, starts, targets)
    # Brute force: the polygon edge that the segment centroid -> target crosses nearest its start.
    origin = points[tri.simplices[starts]].mean(axis=1)
    a, b = boundary, np.roll(boundary, -1, axis=0)
    direction, edge = targets - origin, b - a
    offset = a[None] - origin[:, None]
    denominator = direction[:, None, 0] * edge[None, :, 1] - direction[:, None, 1] * edge[None, :, 0]
    along = (offset[..., 0] * edge[None, :, 1] - offset[..., 1] * edge[None, :, 0]) / denominator
    across = (offset[..., 0] * direction[:, None, 1] - offset[..., 1] * direction[:, None, 0]) / denominator
    along = np.where((along >= 0) & (along <= 1) & (across >= 0) & (across <= 1), along, np.inf)
    expected = np.where(np.isfinite(along.min(axis=1)), along.argmin(axis=1), -1)
    assert 100 < (expected >= 0).sum() < 400
    np.testing.assert_array_equal(crossed, expected)
