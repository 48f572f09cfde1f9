"""core.curves.interpolating_spline: the closed quadratic B-spline through given points, with corners."""

from __future__ import annotations

import numpy as np
import pytest

from core.curves.bspline import ClosedBSpline, basis_weights
from core.curves.interpolating_spline import interpolating_control_points, interpolation_parameters


def curve(control: np.ndarray, t: np.ndarray) -> np.ndarray:
    """p(t), (m, 2), of the closed uniform quadratic B-spline (any n >= 1, self-crossing or not)."""
    index, weights = basis_weights(np.mod(t, len(control)), len(control))
    return np.einsum("mk,mkd->md", weights, control[index])


def extent(points: np.ndarray) -> float:
    return float(np.ptp(points, axis=0).max())


@pytest.mark.parametrize("count", [1, 2, 3, 4, 5, 8, 33, 500])
def test_the_curve_passes_through_every_point(count):
    rng = np.random.default_rng(count)
    points = rng.uniform([100.0, 50.0], [900.0, 700.0], (count, 2))
    control = interpolating_control_points(points)
    assert control.shape == (count, 2)
    passed = curve(control, interpolation_parameters(np.zeros(count, bool)))
    np.testing.assert_allclose(passed, points, rtol=0, atol=1e-12 * max(extent(points), 1.0))


@pytest.mark.parametrize("seed", range(5))
def test_points_on_the_curve_at_the_span_middles_give_back_its_control_points(seed):
    rng = np.random.default_rng(seed)
    control = rng.uniform(-300.0, 300.0, (int(rng.integers(3, 40)), 2))
    middles = curve(control, np.arange(len(control)) + 0.5)
    np.testing.assert_allclose(
        interpolating_control_points(middles), control, rtol=0, atol=1e-12 * extent(control)
    )


@pytest.mark.parametrize("seed", range(5))
def test_corners_are_doubled_control_points_and_the_rest_is_the_curves_own(seed):
    rng = np.random.default_rng(10 + seed)
    clicks = rng.uniform(0.0, 1000.0, (12, 2))
    corner = rng.random(12) < 0.4
    corner[seed % 12] = True
    corner[(seed + 1) % 12] = True  # two corners in a row: a straight segment between them
    control = np.repeat(clicks, np.where(corner, 2, 1), axis=0)
    # The points a curve with these control points passes through: each corner, and the middle
    # of the span of each single control point.
    t = interpolation_parameters(corner)
    points = curve(control, t)
    np.testing.assert_array_equal(points[corner], clicks[corner])  # (C + C) / 2 is exact
    found = interpolating_control_points(points, corner)
    np.testing.assert_allclose(found, control, rtol=0, atol=1e-12 * extent(clicks))
    rows = np.cumsum(np.where(corner, 2, 1)) - np.where(corner, 2, 1)
    np.testing.assert_array_equal(found[rows[corner]], found[rows[corner] + 1])


def test_a_corner_is_sharp_and_exact_and_the_smooth_points_are_passed():
    square = np.array([[0.0, 0.0], [400.0, 0.0], [400.0, 300.0], [0.0, 300.0]])
    # A bulge through (200, 380) on the side y = 300.
    points = np.vstack([square[:3], [[200.0, 380.0]], square[3:]])
    corner = np.array([True, True, True, False, True])
    control = interpolating_control_points(points, corner)
    spline = ClosedBSpline(control)  # a valid cage
    t = interpolation_parameters(corner)
    np.testing.assert_array_equal(spline(t[corner]), points[corner])
    np.testing.assert_allclose(spline(t[3:4]), points[3:4], rtol=0, atol=1e-12 * 400)
    # A corner: the curve stops there (p' = 0) and leaves in another direction.
    np.testing.assert_allclose(spline.derivative(t[1:2]), 0.0, atol=1e-12)
    before = spline.derivative(t[1:2] - 1e-6)[0]
    after = spline.derivative(t[1:2] + 1e-6)[0]
    cosine = before @ after / np.linalg.norm(before) / np.linalg.norm(after)
    assert cosine < 0.5


def test_smooth_points_give_a_smooth_curve_through_them():
    angle = np.linspace(0, 2 * np.pi, 9)[:-1]
    points = 200.0 * np.column_stack([np.cos(angle), np.sin(angle)]) + 300.0
    spline = ClosedBSpline(interpolating_control_points(points))
    t = np.arange(8.0)  # the knots, where p'' jumps: the tangent is continuous there
    left, right = spline.derivative(t - 1e-9), spline.derivative(t + 1e-9)
    np.testing.assert_allclose(left, right, atol=1e-6)
    # The interpolating curve of a circle's points stays close to the circle (the control points
    # lie outside it), unlike the curve with those points as control points, which cuts inside.
    radius = np.linalg.norm(spline(np.linspace(0, 8, 400, endpoint=False)) - 300.0, axis=1)
    assert np.all(np.abs(radius - 200.0) < 0.02 * 200.0)
    inside = np.linalg.norm(ClosedBSpline(points)(np.arange(8.0)) - 300.0, axis=1)
    assert np.all(inside < 0.93 * 200.0)


@pytest.mark.parametrize(
    ("points", "corners", "message"),
    [
        (np.zeros((0, 2)), None, "at least 1"),
        ([[0.0, 0.0], [1.0, np.nan]], None, "NaN or infinite"),
        (np.zeros((3, 3)), None, r"shape \(M, 2\)"),
        (np.zeros((3, 2)), [True, False], "one per point"),
        (np.zeros((3, 2)), [0.5, 1, 0], "booleans"),
    ],
)
def test_bad_input_is_one_clear_error(points, corners, message):
    with pytest.raises(ValueError, match=message):
        interpolating_control_points(points, corners)
