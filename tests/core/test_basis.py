"""core.basis_functions: the folded basis G (Sec. 4.3) and its properties on B-spline domains."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from support.shapes import (
    interior_points,
    inward_offsets,  # noqa: F401
)

import core
from core.curves import examples
from core.curves.closest_point import distance_to_curve

POINT_KERNELS = tuple(name for name in core.KERNELS if name not in ("wachspress", "laplace"))
# Every weighted maximum-likelihood kernel but omega = 1, whose interpolation is very slow (Sec. 3.1).
INTERPOLATING = tuple(name for name in POINT_KERNELS if name not in ("mean-value", "maximum-likelihood"))
# With omega^2 the lambda-hat of points very near the boundary peaks more sharply than
# the far boundary's samples resolve; the solver reports those points.
RESOLVED_NEAR_BOUNDARY = ("harmonic-like", "inverse-cube-mean", "pseudo-harmonic", "modified-mean-value")


def smooth_data(n: int) -> np.ndarray:
    """B-spline boundary data F_i in [0, 1], smooth along the curve."""
    return 0.5 + 0.5 * np.sin(2 * np.pi * np.arange(n) / n)


@pytest.mark.parametrize("name", core.KERNELS)
def test_partition_of_unity_and_linear_precision(name, ellipse, blob):
    curve = ellipse if name in ("wachspress", "laplace") else blob
    x = interior_points(curve, 400, seed=11)
    G, report = core.basis_functions(curve, x, name, return_report=True)
    assert G.shape == (400, curve.n)
    np.testing.assert_allclose(G.sum(axis=1), 1.0, atol=1e-13)
    error = np.abs(G @ curve.control_points - x).max()
    if name == "poisson":
        # The boundary integral's discretisation error (poisson: ~1e-10 of the diameter).
        assert error <= 1e-9 * curve.diameter
        np.testing.assert_allclose(report.residual, np.linalg.norm(G @ curve.control_points - x, axis=1))
    elif name in POINT_KERNELS and name != "mean-value":
        # Exact for any quadrature: the residual of Newton's method, nothing else.
        assert error <= 1e-10 * curve.diameter
        assert report.residual.max() <= 1e-11 * curve.diameter
    else:
        # Explicit kernels: linear precision holds to the O(h^2) quadrature error.
        assert error <= 1e-4 * curve.diameter


@pytest.mark.parametrize("name", POINT_KERNELS)
def test_non_negative_except_mean_value(name, starfish):
    x = interior_points(starfish, 400, seed=12)
    G = core.basis_functions(starfish, x, name)
    if name == "mean-value":
        assert G.min() < 0  # the transfinite mean value kernel is not positive (Sec. 1.1)
    else:
        assert G.min() >= 0


@pytest.mark.parametrize("name", INTERPOLATING)
def test_interpolation_near_the_boundary_also_between_samples(name, blob):
    # The paper's Fig. 3: g(x) -> f(p(s)) as x -> p(s).  s is random, so mostly
    # between the samples t_k.  A plain trapezoid rule stalls (error ~4e-3 at both
    # 1e-4 and 1e-5); here the error must fall linearly with the distance d, i.e. be
    # the interpolant's own slope times d (up to its curvature, a few per cent at
    # d = 1e-4), all the way down to the Lagrange limit.
    s = np.random.default_rng(13).uniform(0, blob.n, 60)
    data = smooth_data(blob.n)  # in [0, 1]
    expected = blob.basis_matrix(s) @ data
    errors, flagged = {}, np.zeros(s.size, dtype=bool)
    for distance in (1e-4, 1e-5, 1e-8, 1e-11):
        x = inward_offsets(blob, s, distance * blob.diameter)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", core.ConvergenceWarning)
            G, report = core.basis_functions(blob, x, name, return_report=True)
        errors[distance] = np.abs(G @ data - expected)
        flagged |= report.failed
    if name in RESOLVED_NEAR_BOUNDARY:
        assert not flagged.any()
    # Points the solver does not flag obey the law; the others were reported, never silent.
    slope = errors[1e-4][~flagged] / 1e-4  # per point: |dg/dn| in units of the diameter
    assert slope.max(initial=0.0) < 12.0
    for distance in (1e-5, 1e-8, 1e-11):
        # plus the Newton tolerance (1e-11 of the diameter) as the floor
        np.testing.assert_array_less(errors[distance][~flagged], 1.1 * slope * distance + 1e-11)
    # The bounds, for data whose interpolant is not steeper than 10 per diameter.
    gentle = 0.5 + 0.4 * (data - 0.5)
    for distance, bound in ((1e-4, 1e-3), (1e-5, 2e-4)):
        x = inward_offsets(blob, s, distance * blob.diameter)
        error = np.abs(core.basis_functions(blob, x, name) @ gentle - blob.basis_matrix(s) @ gentle).max()
        assert error <= bound, (distance, error)


def test_boundary_points_get_the_lagrange_limit(starfish):
    s = np.random.default_rng(14).uniform(0, starfish.n, 50)
    G = core.basis_functions(starfish, starfish(s))
    np.testing.assert_allclose(G, starfish.basis_matrix(s), atol=1e-12)


def test_interpolant_is_continuous_across_the_near_boundary_switch(blob):
    # Farther than a few sample spacings the plain trapezoid rule is used, nearer a
    # refined rule: the values must agree where one takes over from the other.
    s = np.full(400, 2.37)
    spacing = np.linalg.norm(blob.derivative([2.37])[0]) / 100
    distances = np.linspace(2.0, 6.0, 400) * spacing
    points, tangents, _ = blob.evaluate(s)
    normal = np.stack([-tangents[:, 1], tangents[:, 0]], axis=1)
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    x = points + distances[:, None] * (normal if blob.is_counterclockwise else -normal)
    g = core.basis_functions(blob, x) @ smooth_data(blob.n)
    jumps = np.abs(np.diff(g, 2))  # second differences: a jump shows as an outlier
    assert jumps.max() < 1e-6


@pytest.mark.parametrize("name", ["harmonic-like", "modified-mean-value", "mean-value"])
def test_orientation_does_not_matter(name, starfish):
    x = interior_points(starfish, 100, seed=15)
    forward = core.basis_functions(starfish, x, name)
    reversed_curve = core.ClosedBSpline(starfish.control_points[::-1])
    backward = core.basis_functions(reversed_curve, x, name)
    np.testing.assert_allclose(backward[:, ::-1], forward, atol=1e-11)


@pytest.mark.parametrize("name", ["harmonic-like", "pseudo-harmonic", "mean-value"])
def test_similarity_invariance(name, blob):
    x = interior_points(blob, 100, seed=16)
    G = core.basis_functions(blob, x, name)
    angle = 0.7
    rotation = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    scale, shift = 250.0, np.array([310.0, -42.0])
    moved = core.ClosedBSpline(scale * blob.control_points @ rotation.T + shift)
    np.testing.assert_allclose(
        core.basis_functions(moved, scale * x @ rotation.T + shift, name), G, atol=1e-10
    )


@pytest.mark.parametrize("name", POINT_KERNELS)
def test_polygons_with_doubled_control_points(name):
    # The paper's Fig. 10: a non-convex polygon, every control point doubled.
    corners = np.array([[0, 0], [4, 0], [4, 3], [2, 1.5], [0, 3]], dtype=float)
    polygon = core.ClosedBSpline(np.repeat(corners, 2, axis=0))
    x = interior_points(polygon, 200, seed=17)
    G = core.basis_functions(polygon, x, name)
    np.testing.assert_allclose(G.sum(axis=1), 1.0, atol=1e-13)
    tolerance = {"mean-value": 1e-4, "poisson": 1e-9}.get(name, 1e-10)  # quadrature; boundary integral
    assert np.abs(G @ polygon.control_points - x).max() <= tolerance * polygon.diameter
    # On the edges the basis is the piecewise linear hat of the polygon's vertices.
    edge_point = np.array([[2.0, 0.0]])
    vertex_weights = core.basis_functions(polygon, edge_point, name).reshape(-1, 2).sum(axis=1)
    np.testing.assert_allclose(vertex_weights, [0.5, 0.5, 0, 0, 0], atol=1e-12)


def test_wachspress_and_laplace_on_a_polygon_are_the_discrete_coordinates():
    vertices = np.array([[0, 0], [2, 0], [3, 1.5], [1.5, 3], [-0.5, 1.5]], dtype=float)
    polygon = core.ClosedBSpline(np.repeat(vertices, 2, axis=0))
    # Farther than a few sample spacings the rule is the plain trapezoid rule, exact for
    # the polygon's piecewise linear integrands; nearer, the graded rule's nodes miss the
    # corner knots and the agreement is that of the quadrature.
    x = interior_points(polygon, 50, seed=18)
    far = distance_to_curve(polygon.piecewise_polynomial(), x) > 0.05 * polygon.diameter

    def area(a, b, c):
        return 0.5 * (
            (b[..., 0] - a[..., 0]) * (c[..., 1] - a[..., 1])
            - (b[..., 1] - a[..., 1]) * (c[..., 0] - a[..., 0])
        )

    previous, following = np.roll(vertices, 1, axis=0), np.roll(vertices, -1, axis=0)
    before = area(x[:, None], previous[None], vertices[None])
    after = area(x[:, None], vertices[None], following[None])
    wachspress = area(previous, vertices, following)[None] / (before * after)
    r2 = lambda v: ((v[None] - x[:, None]) ** 2).sum(-1)  # noqa: E731
    across = area(x[:, None], previous[None], following[None])
    harmonic = (r2(following) * before - r2(vertices) * across + r2(previous) * after) / (before * after)
    for name, weights in (("wachspress", wachspress), ("laplace", harmonic)):
        G = core.basis_functions(polygon, x, name)
        expected = weights / weights.sum(1, keepdims=True)
        np.testing.assert_allclose((G[:, 0::2] + G[:, 1::2])[far], expected[far], atol=1e-13)
        np.testing.assert_allclose(G[:, 0::2] + G[:, 1::2], expected, atol=5e-6)  # measured 1.7e-6


def test_memory_is_bounded_by_the_chunk(blob, monkeypatch):
    # Points are solved in chunks of core.kernels.CHUNK: the work arrays never grow with M.
    from core import kernels

    calls, solved = [], []
    original = kernels.solver.solve_points

    def counting(*arguments):
        points, first, stride = arguments[0], arguments[-2], arguments[-1]
        calls.append(points.shape[0])
        solved.append(len(range(first, points.shape[0], stride)))  # each thread's share
        return original(*arguments)

    monkeypatch.setattr(kernels.solver, "solve_points", counting)
    x = interior_points(blob, 3 * kernels.CHUNK + 5, seed=19)
    core.basis_functions(blob, x, "mean-value")
    assert max(calls) == kernels.CHUNK and sum(solved) == x.shape[0]


@pytest.mark.parametrize(
    ("arguments", "message"),
    [
        ({"curve": "not a curve"}, "curve must be a core.ClosedBSpline"),
        ({"samples_per_segment": 0}, "samples_per_segment must be at least 2"),
        ({"kernel": "wachspress"}, "convex domains only"),
        ({"x": [[10.0, 10.0]]}, "1 of 1 points of x are outside the domain"),
    ],
)
def test_invalid_arguments(arguments, message, starfish):
    call = {"curve": starfish, "x": [[0.0, 0.0]]} | arguments
    with pytest.raises(ValueError, match=message):
        core.basis_functions(call.pop("curve"), call.pop("x"), **call)


def test_starfish_example_is_non_convex_with_limbs():
    curve = core.ClosedBSpline(examples.starfish())
    with pytest.raises(ValueError, match="convex domains only"):
        core.basis_functions(curve, [[0.0, 0.0]], "laplace")
