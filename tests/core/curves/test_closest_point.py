"""Tests of core.curves.closest_point: its compiled loops see one type of points, read-only or not."""

import numpy as np

import core
from core.curves import closest_point


def test_read_only_points_get_the_distances_of_writeable_ones_without_another_compilation():
    curve = core.ClosedBSpline(np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 3.0], [0.0, 3.0]]))
    pieces = curve.piecewise_polynomial()
    points = np.array([[1.0, 1.0], [2.0, -1.0], [5.0, 2.0]])
    distances = closest_point.distance_to_curve(pieces, points)
    read_only = points.copy()
    read_only.setflags(write=False)
    np.testing.assert_array_equal(closest_point.distance_to_curve(pieces, read_only), distances)
    corners = curve.control_points  # read-only, as a curve keeps them
    expected = closest_point.distance_to_curve(pieces, corners.copy())
    np.testing.assert_array_equal(closest_point.distance_to_curve(pieces, corners), expected)
    assert len(closest_point._distances.signatures) == 1  # writeable C-contiguous float64 (M, 2)
