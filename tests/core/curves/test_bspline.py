"""core.ClosedBSpline: evaluation, folding, validation, inside test, subdivision."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest
from support.shapes import near_cusp

import core
from core.curves import bspline, examples
from core.curves.bspline import ClosedBSpline, knot_loops


def test_curve_is_the_folded_basis_times_the_control_points(blob):
    t = np.random.default_rng(0).uniform(0, blob.n, 500)
    np.testing.assert_allclose(blob.basis_matrix(t) @ blob.control_points, blob(t), atol=1e-15)
    np.testing.assert_allclose(blob.basis_matrix(t).sum(axis=1), 1.0, atol=1e-15)


def test_curve_is_periodic_and_c1(blob):
    t = np.arange(blob.n, dtype=float)  # the knots
    left, left_first, _ = blob.evaluate(t - 1e-9)
    right, right_first, _ = blob.evaluate(t + 1e-9)
    np.testing.assert_allclose(left, right, atol=1e-8)
    np.testing.assert_allclose(left_first, right_first, atol=1e-8)
    np.testing.assert_allclose(blob([0.0]), blob([float(blob.n)]), atol=1e-15)


def test_derivatives_match_finite_differences(starfish):
    t = np.random.default_rng(1).uniform(0, starfish.n, 50)
    t = t[np.abs(t - np.round(t)) > 1e-3]  # p'' jumps at the knots
    eps = 1e-6
    np.testing.assert_allclose(
        starfish.derivative(t), (starfish(t + eps) - starfish(t - eps)) / (2 * eps), atol=1e-8
    )
    np.testing.assert_allclose(
        starfish.derivative(t, 2),
        (starfish.derivative(t + eps) - starfish.derivative(t - eps)) / (2 * eps),
        atol=1e-6,
    )


def test_paper_convention_curve_starts_between_pn_and_p1():
    # Sec. 4.1: P_0 = P_n, knots (-2, ..., n + 2), so p(0) = (P_n + P_1) / 2.
    points = examples.ellipse(6)
    curve = core.ClosedBSpline(points)
    np.testing.assert_allclose(curve([0.0])[0], 0.5 * (points[-1] + points[0]), atol=1e-15)
    np.testing.assert_allclose(curve([1.0])[0], 0.5 * (points[0] + points[1]), atol=1e-15)


def test_area_is_exact_for_a_polygon():
    square = np.repeat(np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [0.0, 1.0]]), 2, axis=0)
    assert core.ClosedBSpline(square).area == pytest.approx(2.0, abs=1e-15)
    assert core.ClosedBSpline(square[::-1]).area == pytest.approx(-2.0, abs=1e-15)


def test_subdivision_leaves_the_curve_unchanged(starfish):
    finer = starfish.subdivide()
    assert finer.n == 2 * starfish.n
    t = np.linspace(0, starfish.n, 301)
    np.testing.assert_allclose(finer(2 * t), starfish(t), atol=1e-14)


def test_subdivision_keeps_sharp_corners():
    polygon = core.ClosedBSpline(np.repeat(examples.ellipse(5), 2, axis=0))
    finer = polygon.subdivide()
    assert len(finer.corners()) == len(polygon.corners()) == 5
    t = np.linspace(0, polygon.n, 401)
    np.testing.assert_allclose(finer(2 * t), polygon(t), atol=1e-14)


def test_corners_of_doubled_points():
    points = np.array([[0.0, 0.0], [0.0, 0.0], [2.0, 0.0], [1.0, 2.0]])
    curve = core.ClosedBSpline(points)
    corners = curve.corners()
    assert corners.shape == (1, 5)
    np.testing.assert_allclose(curve(corners[:, 0]), [[0.0, 0.0]], atol=1e-15)
    np.testing.assert_allclose(curve.derivative(corners[:, 0]), [[0.0, 0.0]], atol=1e-15)


def test_contains_uses_the_true_curve(blob):
    rng = np.random.default_rng(2)
    s = rng.uniform(0, blob.n, 200)
    points, tangents, _ = blob.evaluate(s)
    normal = np.stack([-tangents[:, 1], tangents[:, 0]], axis=1)
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    inward = normal if blob.is_counterclockwise else -normal
    offset = 1e-5 * blob.diameter
    assert blob.contains(points + offset * inward).all()
    assert not blob.contains(points - offset * inward).any()
    assert blob.contains(points).all()  # the closed domain includes its boundary


def test_contains_at_reflex_and_convex_corners():
    # An L shape as a polygon: the reflex corner at (1, 1).
    corners = np.array([[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2]], dtype=float)
    curve = core.ClosedBSpline(np.repeat(corners, 2, axis=0))
    inside = np.array([[0.99, 0.99], [1.0 - 1e-7, 1.5], [0.5, 0.5], [1.5, 1.0 - 1e-7]])
    outside = np.array([[1.01, 1.01], [1.0 + 1e-7, 1.5], [2.0 + 1e-7, 0.5], [-1e-9, 1.0]])
    assert curve.contains(inside).all()
    assert not curve.contains(outside).any()


@pytest.mark.parametrize(
    ("points", "message"),
    [
        ([[0, 0], [1, 0]], "at least 3"),
        ([[0, 0], [1, 0], [np.nan, 1]], "NaN or infinite"),
        ([[0, 0], [1, 0], [1, 1, 2]], "control_points must"),
        ([[0, 0], [1, 0], [2, 0], [3, 0]], "no area"),
        ([[1, 1], [1, 1], [1, 1], [1, 1]], "same point"),
        ([[0, 0], [6, 0], [6, 1], [0, 5], [0, 6], [6, 6]], "crosses or touches itself"),
        ([[0, 0], [0, 0], [0, 0], [1, 0], [0, 1]], "repeat a point at most twice"),
        ("abc", "control_points must"),
        (
            [[0, 0], [1e308, 0], [0, 1]],
            r"control_points\[1\] = \[1e\+308, 0.0\] is out of range: .* within \+-1e\+150",
        ),
        (
            [[0, 0], [10**400, 0], [0, 1]],
            r"control_points must be a list of \(x, y\) number pairs \(int too large",
        ),
    ],
)
def test_invalid_control_points_are_rejected_with_a_clear_message(points, message):
    with pytest.raises(ValueError, match=message):
        core.ClosedBSpline(points)


def test_a_figure_eight_is_reported_as_self_intersecting_not_as_zero_area():
    with pytest.raises(ValueError, match="crosses or touches itself"):
        core.ClosedBSpline([[0, 0], [2, 0], [0, 2], [2, 2]])


def test_derivative_order_is_checked(blob):
    with pytest.raises(ValueError, match="order must be 1 or 2"):
        blob.derivative([0.5], order=3)


def test_sample_checks_samples_per_segment(blob):
    with pytest.raises(ValueError, match="samples_per_segment must be at least 2"):
        blob.sample(1)
    most = (1 << 20) // blob.n
    assert blob.sample(most).count == most * blob.n
    with pytest.raises(
        ValueError, match=rf"more than the 1,048,576 allowed; use 2 <= samples_per_segment <= {most}"
    ):
        blob.sample(most + 1)
    with pytest.raises(ValueError, match="samples_per_segment must be an integer"):
        blob.sample(2.5)


@pytest.mark.parametrize("gap", [1e-4, 1e-2, 0.9, 2.0])
def test_tiny_loops_at_a_knot_are_found_exactly_and_rejected(gap):
    # Almost equal neighbours with the cage turning back over them: the two spans at
    # their knot cross again, in a loop far smaller than any polyline chord.
    points = near_cusp(gap, 150)
    ((i, s, v),) = knot_loops(points)
    knot = (int(i) + 1) % len(points)
    spline = core.ClosedBSpline.__new__(core.ClosedBSpline)  # evaluate without validation
    spline._points = points
    crossing = spline.evaluate(np.array([knot - s, knot + v]))[0]
    np.testing.assert_allclose(crossing[0], crossing[1], rtol=0, atol=1e-9)
    loop = spline(np.linspace(knot - s, knot + v, 1001))
    assert 0 < np.linalg.norm(loop - loop[0], axis=1).max() < gap
    with pytest.raises(ValueError, match=f"tiny loop between control points {int(i)} and {int(i) + 1}"):
        core.ClosedBSpline(points)


@pytest.mark.parametrize("turn_degrees", [60, 120, 135])
def test_near_cusps_without_a_loop_are_valid(turn_degrees):
    assert knot_loops(near_cusp(0.01, turn_degrees)).shape == (0, 3)
    core.ClosedBSpline(near_cusp(0.01, turn_degrees))


def ellipse_cage(count):
    angles = np.linspace(0.0, 2 * np.pi, count, endpoint=False)
    return np.c_[600 + 500 * np.cos(angles), 500 + 300 * np.sin(angles)]


def test_a_convex_cage_of_10000_points_validates_in_linear_memory():
    # Every dense sample is on the hull: the pairwise diameter needed 32n x 32n x 2 floats
    # (1.5 TiB here); the span pairs tested for crossings were an n x n matrix.
    points = ellipse_cage(10_000)
    tracemalloc.start()
    try:
        curve = core.ClosedBSpline(points)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 512 * 2**20  # measured: 120 MiB
    assert abs(curve.diameter - 1000.0) <= 1e-4 * 1000.0


def test_the_span_sweep_finds_the_same_first_crossing_as_all_pairs():
    rng = np.random.default_rng(11)
    crossing = 0
    for trial in range(300):
        count = int(rng.integers(3, 30))
        angles = np.sort(rng.uniform(0.0, 2 * np.pi, count))
        radii = rng.uniform(0.2, 1.0, count) if trial % 2 else 1 + 0.05 * rng.normal(size=count)
        points = (
            rng.normal(size=(count, 2))
            if trial % 5 == 0
            else np.c_[radii * np.cos(angles), radii * np.sin(angles)]
        )
        expected = all_pairs_first_crossing(points)
        assert bspline._first_self_intersection(points) == expected
        crossing += expected is not None
    assert 30 < crossing < 270  # both outcomes are exercised


def all_pairs_first_crossing(points):
    """The oracle: every pair of spans, no pruning, the lexicographically first hit (the pairs of
    span 0 first, then those of span 1, ...: the first span with a hit ends the search)."""
    n = len(points)
    u = np.linspace(0.0, 1.0, bspline._CHORDS + 1)
    b0 = 0.5 * (np.roll(points, 1, axis=0) + points)
    b2 = 0.5 * (points + np.roll(points, -1, axis=0))
    pad = 1e-9 * float(np.ptp(points, axis=0).max())
    for i in range(n - 1):
        j = np.arange(i + 1, n)
        valid = np.ones((len(j), bspline._CHORDS, bspline._CHORDS), dtype=bool)
        follows = j == i + 1
        wraps = ~follows & (i == 0) & (j == n - 1)
        valid[follows, -1, :] = valid[follows, :, 0] = False
        valid[wraps, 0, :] = valid[wraps, :, -1] = False
        rows = np.full(len(j), i)
        a = bspline._polyline(b0[rows], points[rows], b2[rows], u)
        b = bspline._polyline(b0[j], points[j], b2[j], u)
        hits = np.flatnonzero(bspline._chords_meet(a, b, valid, pad))
        if hits.size:
            return i, int(j[hits[0]])
    return None


def test_a_translated_curve_is_the_curve_of_the_moved_points(starfish):
    offset = np.array([-3.25, 7.5])
    moved = starfish.translated(offset)
    built = ClosedBSpline(starfish.control_points + offset)
    np.testing.assert_array_equal(moved.control_points, built.control_points)
    assert moved.area == pytest.approx(built.area, rel=1e-12)
    assert moved.diameter == pytest.approx(built.diameter, rel=1e-12)
    t = np.linspace(0.0, starfish.n, 50)
    np.testing.assert_allclose(moved(t), starfish(t) + offset, rtol=0, atol=1e-12)
    assert not moved.control_points.flags.writeable


def test_a_translation_that_makes_points_coincide_is_checked_again():
    # 1e-17 apart at the origin, equal once moved by 1: a sharp corner appears, and with a third
    # equal point the constructor's one-line error.
    points = np.array([[0.0, 0.0], [1e-17, 0.0], [2e-17, 0.0], [1.0, 1.0], [0.0, 1.0]])
    with pytest.raises(ValueError, match="coincide"):
        ClosedBSpline(points).translated([1.0, 0.0])


def test_a_translation_is_checked_like_the_constructor_where_it_may_change_the_curve(starfish):
    with pytest.raises(ValueError, match="offset must be 2 numbers"):
        starfish.translated(np.zeros((starfish.n, 2)))
    with pytest.raises(ValueError, match="out of range"):
        starfish.translated([2e150, 0.0])
    # A square moved 1e20 times its size away: the points round to a segment, which the
    # constructor refuses.
    with pytest.raises(ValueError):
        ClosedBSpline([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]).translated([1e20, 1e20])


def test_corner_angles_are_the_domain_s_angles_in_either_orientation():
    # A square with its corners doubled: four right angles; an arrow's tip (a spike) is below π,
    # its notch (pointing into the domain) above, and reversing the curve keeps them.
    square = ClosedBSpline(np.repeat([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]], 2, axis=0))
    np.testing.assert_allclose(square.corner_angles(), np.full(4, np.pi / 2), rtol=1e-14)
    arrow = np.repeat([[0.0, 0.0], [4.0, 1.0], [0.0, 2.0], [1.0, 1.0]], 2, axis=0)
    for points in (arrow, arrow[::-1]):
        curve = ClosedBSpline(points)
        angles = dict(zip(curve.corners()[:, 0].tolist(), curve.corner_angles().tolist(), strict=True))
        tip = [a for t, a in angles.items() if np.allclose(curve(np.array([t]))[0], [4.0, 1.0])]
        notch = [a for t, a in angles.items() if np.allclose(curve(np.array([t]))[0], [1.0, 1.0])]
        np.testing.assert_allclose(tip, [2.0 * np.arctan(0.25)], rtol=1e-12)
        np.testing.assert_allclose(notch, [2.0 * np.pi - 2.0 * np.arctan(1.0)], rtol=1e-12)
