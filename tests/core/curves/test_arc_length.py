"""core.curves.arc_length: the boundary in its (normalised) arc length, and the kernels in it (Fig. 12)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad
from support.shapes import interior_points, l_polygon, pixel_blob

import core
from core.curves import examples
from core.curves.arc_length import ArcLengthCurve

# Weighted maximum-likelihood kernels: linear precision to the Newton tolerance, positive.
POSITIVE = (
    "harmonic-like",
    "inverse-cube-mean",
    "pseudo-harmonic",
    "maximum-likelihood",
    "modified-mean-value",
)


def cages() -> dict[str, np.ndarray]:
    """Control points of curves with very different spans (ids for parametrize)."""
    rotation = np.array([[0.6, -0.8], [0.8, 0.6]])
    return {
        "crowded": examples.crowded(),
        "blob": examples.blob(),
        "corners": l_polygon(),
        # clockwise in a y-up frame, far from the origin, in pixels
        "clockwise-far": pixel_blob() @ rotation.T + np.array([4.0e4, -2.5e4]),
        # nearly uniform speed on the long straight sides (the Gauss-Legendre branch)
        "straight-sides": np.array(
            [[0, 0], [1, 0], [2, 0], [3, 0.02], [4, 0], [4, 1], [3, 1.01], [2, 1], [1, 1], [0, 1]], float
        ),
    }


CAGES = cages()


def reference_arc_lengths(curve: core.ClosedBSpline, ts) -> list[float]:
    """int_0^t |p'| for each t of ts, by adaptive quadrature span by span (independent of
    core.curves.arc_length); each whole span is integrated once for all of them."""
    speed = lambda v: float(np.linalg.norm(curve.derivative([v])[0]))  # noqa: E731
    spans = [quad(speed, j, j + 1, epsabs=0, epsrel=2e-14, limit=200)[0] for j in range(curve.n)]
    lengths = []
    for t in ts:
        whole = int(np.floor(t))
        lengths.append(sum(spans[:whole]) + quad(speed, whole, t, epsabs=0, epsrel=2e-14, limit=200)[0])
    return lengths


@pytest.mark.parametrize("name", CAGES)
def test_the_map_is_accurate_and_monotone(name):
    curve = core.ClosedBSpline(CAGES[name])
    arc = ArcLengthCurve(curve.piecewise_polynomial())
    to_length = arc.length / curve.n  # s is the arc length scaled to the period n
    s = np.sort(np.random.default_rng(21).uniform(0, curve.n, 60))
    t = arc.natural(s)
    whole, *lengths = reference_arc_lengths(curve, [curve.n, *t])
    assert arc.length == pytest.approx(whole, rel=1e-13)
    # |s(t(s)) - s| in length units, against an independent quadrature of |p'|.
    errors = [abs(length - si * to_length) for length, si in zip(lengths, s, strict=True)]
    assert max(errors) <= 1e-12 * curve.diameter
    # q(s) is the curve at t(s); the numba evaluation agrees with the numpy one.
    q, dq, ddq = arc.evaluate(s)
    p, dp, _ = curve.evaluate(t)
    assert np.abs(q - p).max() <= 1e-12 * curve.diameter
    # Unit speed (times L / n); the second derivative is the curvature normal.
    moving = np.linalg.norm(dp, axis=1) > 0
    np.testing.assert_allclose(np.linalg.norm(dq[moving], axis=1), to_length, rtol=1e-14)
    assert np.abs(np.sum(dq * ddq, axis=1)).max() <= 1e-12 * to_length * np.abs(ddq).max()
    # Monotone, and inverse to s(t), on a dense grid (also across knots and corners).
    dense = np.linspace(0, curve.n, 20001)[:-1]
    assert np.all(np.diff(arc.natural(dense)) > 0)
    grid = np.linspace(0, curve.n, 2001)[:-1]
    np.testing.assert_allclose(arc.arc_length(arc.natural(grid)), grid, atol=1e-13 * curve.n)
    np.testing.assert_allclose(arc.natural(arc.arc_length(grid)), grid, atol=1e-7)


def test_the_derivatives_are_those_of_q():
    curve = core.ClosedBSpline(CAGES["crowded"])
    arc = ArcLengthCurve(curve.piecewise_polynomial())
    knots = arc.knots
    s = np.random.default_rng(22).uniform(0, curve.n, 40)
    s = s[np.min(np.abs(s[:, None] - knots[None, :]), axis=1) > 1e-3]  # p'' jumps at the knots
    step = 1e-5
    q, dq, ddq = arc.evaluate(s)
    after, before = arc.evaluate(s + step)[0], arc.evaluate(s - step)[0]
    np.testing.assert_allclose((after - before) / (2 * step), dq, atol=1e-9)
    np.testing.assert_allclose((after - 2 * q + before) / step**2, ddq, atol=2e-4)


@pytest.mark.parametrize("name", ["crowded", "blob", "corners", "clockwise-far"])
@pytest.mark.parametrize("kernel", ["harmonic-like", "inverse-cube-mean", "pseudo-harmonic"])
def test_partition_of_unity_linear_precision_and_positivity(name, kernel):
    curve = core.ClosedBSpline(CAGES[name])
    x = interior_points(curve, 300, seed=23)
    G, report = core.basis_functions(curve, x, kernel, parameterization="arc-length", return_report=True)
    np.testing.assert_allclose(G.sum(axis=1), 1.0, atol=1e-13)
    assert np.abs(G @ curve.control_points - x).max() <= 1e-10 * curve.diameter
    assert report.residual.max() <= 1e-11 * curve.diameter
    assert G.min() >= 0


@pytest.mark.parametrize("kernel", POSITIVE)
def test_positive_kernels_stay_positive_on_the_starfish(kernel, starfish):
    x = interior_points(starfish, 300, seed=24)
    assert core.basis_functions(starfish, x, kernel, parameterization="arc-length").min() >= 0


@pytest.mark.parametrize("name", ["crowded", "blob", "corners", "clockwise-far"])
def test_boundary_points_get_the_lagrange_limit(name):
    curve = core.ClosedBSpline(CAGES[name])
    t = np.random.default_rng(25).uniform(0, curve.n, 50)
    G = core.basis_functions(curve, curve(t), parameterization="arc-length")
    np.testing.assert_allclose(G, curve.basis_matrix(t), atol=1e-12)


def test_interpolation_near_the_boundary():
    # g(x) -> f(p(t)) as x -> p(t), through the refined rule in s (Fig. 3 as in test_basis).
    curve = core.ClosedBSpline(CAGES["crowded"])
    t = np.random.default_rng(26).uniform(0, curve.n, 40)
    data = 0.5 + 0.5 * np.sin(2 * np.pi * np.arange(curve.n) / curve.n)
    points, tangents, _ = curve.evaluate(t)
    inward = np.stack([-tangents[:, 1], tangents[:, 0]], axis=1)
    inward /= np.linalg.norm(inward, axis=1, keepdims=True)
    expected = curve.basis_matrix(t) @ data
    errors = {}
    for distance in (1e-4, 1e-6, 1e-9):
        x = points + distance * curve.diameter * inward
        G = core.basis_functions(curve, x, "harmonic-like", parameterization="arc-length")
        errors[distance] = np.abs(G @ data - expected)
    slope = errors[1e-4] / 1e-4
    for distance in (1e-6, 1e-9):
        np.testing.assert_array_less(errors[distance], 1.1 * slope * distance + 1e-11)


def test_on_a_near_uniform_speed_circle_both_agree():
    # A regular m-gon's B-spline has speed between cos(pi / m) and 1 of its maximum: the
    # arc length differs from the natural parameter by O(1 - cos(pi / m)) and so do the
    # basis functions, which agree in the limit.
    differences, deviations = [], []
    for m in (16, 32, 64):
        angles = 2 * np.pi * np.arange(m) / m
        circle = core.ClosedBSpline(np.stack([np.cos(angles), np.sin(angles)], axis=1))
        x = interior_points(circle, 150, seed=27)
        natural = core.basis_functions(circle, x, "harmonic-like")
        arc = core.basis_functions(circle, x, "harmonic-like", parameterization="arc-length")
        differences.append(np.abs(natural - arc).max())
        deviations.append(1 - np.cos(np.pi / m))
    assert all(d <= 0.02 * e for d, e in zip(differences, deviations, strict=True))
    assert differences[0] > 3.5 * differences[1] > 3.5**2 * differences[2]


def test_modified_mean_value_does_not_depend_on_the_parameterization():
    # Sec. 5: omega_x dt = |d theta| (Eq. 23) for every parameterisation, so the two differ
    # by their quadrature errors only, O(h^2): they agree as the samples grow denser.
    curve = core.ClosedBSpline(CAGES["crowded"])
    x = interior_points(curve, 200, seed=28, margin=0.05)
    differences = []
    for per in (50, 100, 200):
        natural = core.basis_functions(curve, x, "modified-mean-value", per)
        arc = core.basis_functions(curve, x, "modified-mean-value", per, parameterization="arc-length")
        differences.append(np.abs(natural - arc).max())
    assert differences[0] > 3.5 * differences[1] > 3.5**2 * differences[2]
    assert differences[2] <= 5e-6


@pytest.mark.parametrize("kernel", ["maximum-likelihood", "harmonic-like", "inverse-cube-mean"])
def test_fig_12_the_mass_follows_the_parameter_or_the_length(kernel):
    # Six of twelve control points crowd into 8 % of the circle (examples.crowded).  In the
    # natural parameter their five spans are 5/12 of the parameter and the kernel's mass
    # follows: they take far more of the interpolant than the length they hold.  In arc
    # length the mass follows the length, like that of the parameter-free modified mean
    # value kernel (Sec. 5), which measures the boundary by the angle it subtends.
    curve = core.ClosedBSpline(examples.crowded())
    dense = slice(0, 6)
    x = np.array([[0.0, 0.0], [-0.5, 0.0], [0.0, 0.5], [0.3, -0.3]])
    natural = core.basis_functions(curve, x, kernel)[:, dense].sum(axis=1)
    arc = core.basis_functions(curve, x, kernel, parameterization="arc-length")[:, dense].sum(axis=1)
    angle = core.basis_functions(curve, x, "modified-mean-value")[:, dense].sum(axis=1)
    assert np.all(np.abs(arc - angle) <= 0.2 * (natural - angle))
    assert np.all(natural - arc >= 0.04)
    # Squeezed: in arc length a crowded point's basis function is concentrated next to its
    # short stretch of boundary; in the natural parameter it reaches far into the domain.
    depth = np.array([[0.95, 0.0], [0.5, 0.0], [0.0, 0.0], [-0.5, 0.0]])
    middle = 3
    g_natural = core.basis_functions(curve, depth, kernel)[:, middle]
    g_arc = core.basis_functions(curve, depth, kernel, parameterization="arc-length")[:, middle]
    assert g_arc[0] > g_natural[0]
    assert np.all(g_natural[1:] > 1.8 * g_arc[1:])


def test_kernel_values_in_arc_length(blob):
    boundary = blob.sample(40)
    x = interior_points(blob, 50, seed=29, margin=0.1)  # the trapezoid rule, not lumped
    values = core.kernel(boundary, x, "harmonic-like", parameterization="arc-length")
    arc = blob.sample(40, parameterization="arc-length")
    np.testing.assert_allclose(values.sum(axis=1) * arc.step, 1.0, atol=1e-13)
    assert np.abs(values * arc.step @ arc.points - x).max() <= 1e-10 * blob.diameter
    np.testing.assert_array_equal(values, core.kernel(arc, x, "harmonic-like"))


def test_mesh_basis_functions_in_arc_length(blob, tmp_path, monkeypatch):
    monkeypatch.setenv("TRANSFINITE_CACHE_DIR", str(tmp_path))
    mesh = core.triangulate(blob, max_edge=blob.diameter / 12)
    natural = core.mesh_basis_functions(blob, mesh, "harmonic-like")
    arc = core.mesh_basis_functions(blob, mesh, "harmonic-like", parameterization="arc-length")
    np.testing.assert_array_equal(arc[mesh.boundary], blob.basis_matrix(mesh.boundary_parameters))
    interior = mesh.interior
    np.testing.assert_array_equal(
        arc[interior],
        core.basis_functions(blob, mesh.vertices[interior], "harmonic-like", parameterization="arc-length"),
    )
    assert np.abs(arc - natural).max() > 1e-3  # a separate cache entry, not the natural one
    cached = core.mesh_basis_functions(blob, mesh, "harmonic-like", parameterization="arc-length")
    np.testing.assert_array_equal(cached, arc)
    assert len(list(tmp_path.glob("*.npz"))) == 2


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (
            lambda c, m: core.basis_functions(c, [[0.5, 0.5]], parameterization="length"),
            "unknown parameterization",
        ),
        (lambda c, m: c.sample(10, parameterization=None), "unknown parameterization"),
        (
            lambda c, m: core.mesh_basis_functions(c, m, "harmonic", parameterization="arc-length"),
            "does not depend",
        ),
        (
            lambda c, m: core.kernel(
                core.Boundary(*c.evaluate(np.arange(40) / 4.0), 0.25),
                [[0.5, 0.5]],
                parameterization="arc-length",
            ),
            "needs the quadratic B-spline pieces",
        ),
    ],
)
def test_invalid_parameterizations(call, message, blob):
    mesh = core.triangulate(blob, max_edge=blob.diameter / 6)
    with pytest.raises(ValueError, match=message):
        call(blob, mesh)
