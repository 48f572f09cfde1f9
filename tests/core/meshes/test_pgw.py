"""Tests of core.meshes.pgw: transfinite positive Gordon-Wixom basis functions (Sec. 1.1)."""

import numpy as np
import pytest
from scipy.optimize import brentq
from support.shapes import l_polygon as l_shape
from support.shapes import wavy_star as starfish

import core
from core.meshes.pgw import pgw_basis

CONVEX = np.array([[2.0, 0.0], [1.0, 1.5], [-1.0, 1.2], [-1.5, -0.5], [0.5, -1.5]])
CAGES = {
    "convex": CONVEX,
    "starfish": starfish(),
    "clockwise-starfish": starfish()[::-1].copy(),
    "l-shape": l_shape(),
}


def interior_points(curve, count, seed):
    """Random points inside the curve, from a fixed seed."""
    rng = np.random.default_rng(seed)
    low, high = curve.control_points.min(axis=0), curve.control_points.max(axis=0)
    candidates = rng.uniform(low, high, size=(20 * count, 2))
    return candidates[curve.contains(candidates)][:count]


@pytest.fixture(scope="module", params=list(CAGES))
def case(request):
    curve = core.ClosedBSpline(CAGES[request.param])
    x = interior_points(curve, 300, seed=1)
    return curve, x, pgw_basis(curve, x, angles=256)


# ---------------------------------------------------------------- properties


def test_partition_of_unity(case):
    _, _, basis = case
    np.testing.assert_allclose(basis.sum(axis=1), 1.0, rtol=0, atol=1e-12)


def test_non_negative(case):
    _, _, basis = case
    assert basis.min() >= 0.0


def test_linear_precision_is_exact_for_any_number_of_directions(case):
    # Each pair term g_ij interpolates linearly along its line through x, so
    # G @ P == x holds term by term: the angular quadrature does not limit it, only
    # rounding does (measured below 2e-15 of the diameter).
    curve, x, basis = case
    np.testing.assert_allclose(basis @ curve.control_points, x, rtol=0, atol=1e-13 * curve.diameter)
    few = pgw_basis(curve, x[:20], angles=3)
    np.testing.assert_allclose(few @ curve.control_points, x[:20], rtol=0, atol=1e-13 * curve.diameter)


def test_lagrange_property_on_the_curve(case):
    curve, _, _ = case
    t = np.linspace(0, curve.n, 37, endpoint=False) + 0.013
    np.testing.assert_allclose(pgw_basis(curve, curve(t), angles=64), curve.basis_matrix(t), atol=1e-12)


def test_interpolates_near_the_curve():
    curve = core.ClosedBSpline(starfish())
    t = np.linspace(0, curve.n, 23, endpoint=False) + 0.31
    points, tangents, _ = curve.evaluate(t)
    inward = np.stack([-tangents[:, 1], tangents[:, 0]], axis=1) / np.linalg.norm(tangents, axis=1)[:, None]
    # The error is linear in the distance (measured 2.55 times it), for any angles.
    for distance in (1e-4, 1e-7, 1e-10):
        basis = pgw_basis(curve, points + distance * inward, angles=128)
        assert np.abs(basis - curve.basis_matrix(t)).max() <= 4 * distance


def test_angular_quadrature_converges():
    curve = core.ClosedBSpline(starfish())
    x = interior_points(curve, 50, seed=2)
    reference = pgw_basis(curve, x, angles=8192)
    errors = [np.abs(pgw_basis(curve, x, angles=k) - reference).max() for k in (128, 512, 2048)]
    assert errors[0] > errors[1] > errors[2]
    assert errors[2] <= 1e-4


def test_default_directions_follow_samples_per_segment():
    curve = core.ClosedBSpline(starfish())
    x = interior_points(curve, 10, seed=3)
    np.testing.assert_array_equal(pgw_basis(curve, x), pgw_basis(curve, x, angles=100 * curve.n // 2))
    np.testing.assert_array_equal(
        pgw_basis(curve, x, samples_per_segment=20), pgw_basis(curve, x, angles=20 * curve.n // 2)
    )


def test_translation_invariance():
    curve = core.ClosedBSpline(starfish())
    x = interior_points(curve, 40, seed=4)
    shift = np.array([123.0, -45.0])
    moved = core.ClosedBSpline(starfish() + shift)
    np.testing.assert_allclose(
        pgw_basis(moved, x + shift, angles=128), pgw_basis(curve, x, angles=128), rtol=0, atol=1e-10
    )


# ---------------------------------------------------------------- brute force


def brute_force_pgw(curve, x, angles, per_span=400):
    """PGW by the paper's double sum, with intersections found by bracketing and brentq."""
    t = np.linspace(0, curve.n, per_span * curve.n + 1)
    samples = curve(t)
    rows = []
    for point in x:
        numerator = np.zeros(curve.n)
        denominator = 0.0
        for theta in (np.arange(angles) + 0.5) * np.pi / angles:
            e = np.array([np.cos(theta), np.sin(theta)])

            def side(s, e=e, point=point):
                q = curve(np.array([s % curve.n]))[0] - point
                return q[0] * e[1] - q[1] * e[0]

            offset = samples - point
            values = offset[:, 0] * e[1] - offset[:, 1] * e[0]
            roots = [
                brentq(side, t[k], t[k + 1], xtol=1e-15, rtol=1e-15)
                for k in np.flatnonzero(np.sign(values[:-1]) != np.sign(values[1:]))
            ]
            ahead, behind = [], []
            for root in roots:
                y, tangent, _ = (array[0] for array in curve.evaluate(np.array([root % curve.n])))
                d = float((y - point) @ e)
                h = abs((y - point)[0] * tangent[1] - (y - point)[1] * tangent[0]) / np.linalg.norm(tangent)
                row = curve.basis_matrix(np.array([root % curve.n]))[0]
                (ahead if d > 0 else behind).append((abs(d), h, row))
            for d_i, h_i, f_i in ahead:
                for d_j, h_j, f_j in behind:
                    weight = (d_i + d_j) / (d_i**2 * d_j**2) * h_i * h_j
                    pair = (f_i / d_i + f_j / d_j) / (1 / d_i + 1 / d_j)
                    numerator += weight * pair
                    denominator += weight
        rows.append(numerator / denominator)
    return np.array(rows)


@pytest.mark.parametrize("name", ["convex", "starfish", "l-shape"])
def test_agrees_with_a_brute_force_evaluation(name):
    # Same directions, independent intersections and the unfactorised double sum:
    # measured agreement 2e-16.
    curve = core.ClosedBSpline(CAGES[name])
    x = interior_points(curve, 4, seed=5)
    expected = brute_force_pgw(curve, x, angles=24)
    np.testing.assert_allclose(pgw_basis(curve, x, angles=24), expected, rtol=0, atol=1e-13)


# ---------------------------------------------------------------- interface and errors


def test_progress_is_reported():
    curve = core.ClosedBSpline(starfish())
    x = np.tile(interior_points(curve, 10, seed=6), (500, 1))  # more than one chunk
    seen = []
    pgw_basis(curve, x, angles=16, progress=seen.append)
    assert seen == sorted(seen) and seen[-1] == 1.0 and len(seen) >= 2


def test_rejects_points_outside():
    curve = core.ClosedBSpline(starfish())
    x = np.vstack([interior_points(curve, 3, seed=7), [[5.0, 5.0], [0.0, 1.45]]])
    with pytest.raises(ValueError, match=r"2 of 5 points of x are outside the domain \(first: index 3"):
        pgw_basis(curve, x, angles=32)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"angles": 0}, "angles must be at least 1"),
        ({"angles": 2.5}, "angles must be an integer"),
        ({"samples_per_segment": 1}, "samples_per_segment must be at least 2"),
        ({"x": np.zeros((3, 3))}, r"x must have shape \(M, 2\)"),
        ({"x": [[0.0, np.nan]]}, "x has 1 point"),
        ({"curve": CONVEX}, "curve must be a core.ClosedBSpline"),
        ({"progress": "yes"}, "progress must be a callable"),
    ],
)
def test_rejects_bad_arguments(kwargs, message):
    arguments = {"curve": core.ClosedBSpline(CONVEX), "x": [[0.0, 0.0]]} | kwargs
    with pytest.raises(ValueError, match=message):
        pgw_basis(**arguments)
