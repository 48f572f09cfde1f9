"""core.kernel: the properties of the paper's kernels on sampled boundaries.

Property tests first: partition of unity, linear precision, non-negativity, the
Poisson kernel on a disk, mean value = modified mean value inside ker(Omega),
convergence of the trapezoid rule; then the error messages.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from support.shapes import circle, interior_points

import core
from core.curves import examples

# The weighted maximum-likelihood family (Eq. 14-17): every kernel but the explicit ones, so
# that any kernel added to core.KERNELS is covered by the property tests below.
NEWTON_KERNELS = tuple(
    name
    for name in core.KERNELS
    if name not in ("mean-value", "wachspress", "laplace", *core.BOUNDARY_INTEGRAL_KERNELS)
)
# Kernels with kernel values lambda(x, t) (`core.kernel`): all but the boundary-integral ones.
VALUE_KERNELS = tuple(name for name in core.KERNELS if name not in core.BOUNDARY_INTEGRAL_KERNELS)
# The Newton tolerance is 1e-11 of the diameter; every kernel of this family must meet it.
LINEAR_PRECISION = 1e-10


@pytest.mark.parametrize("name", VALUE_KERNELS)
def test_partition_of_unity(name, ellipse):
    boundary = ellipse.sample(50)
    x = interior_points(ellipse, 300, seed=1)
    values = core.kernel(boundary, x, name)
    assert values.shape == (300, boundary.count)
    np.testing.assert_allclose(boundary.step * values.sum(axis=1), 1.0, atol=1e-13)


@pytest.mark.parametrize("name", NEWTON_KERNELS)
def test_linear_precision_to_the_newton_tolerance(name, blob):
    boundary = blob.sample(50)
    # Farther than a few sample spacings the kernel is exactly the trapezoid rule on the samples.
    x = interior_points(blob, 300, seed=2, margin=0.05)
    values, report = core.kernel(boundary, x, name, return_report=True)
    reproduced = boundary.step * values @ boundary.points
    assert np.abs(reproduced - x).max() <= LINEAR_PRECISION * blob.diameter
    assert report.converged.all()
    assert report.residual.max() <= 1e-11 * blob.diameter


@pytest.mark.parametrize("name", NEWTON_KERNELS)
def test_maximum_likelihood_family_is_non_negative_on_a_non_convex_domain(name, starfish):
    boundary = starfish.sample(40)
    x = interior_points(starfish, 400, seed=3)
    values = core.kernel(boundary, x, name)
    assert values.min() >= 0.0


def test_mean_value_kernel_is_negative_somewhere_on_a_non_convex_domain(starfish):
    boundary = starfish.sample(40)
    x = interior_points(starfish, 400, seed=3)
    assert core.kernel(boundary, x, "mean-value").min() < -1e-3


def test_pseudo_harmonic_kernel_is_the_poisson_kernel_on_a_disk():
    boundary = circle(400)
    rng = np.random.default_rng(4)
    radius = 0.8 * np.sqrt(rng.uniform(size=200))
    angle = rng.uniform(0, 2 * np.pi, 200)
    x = np.stack([radius * np.cos(angle), radius * np.sin(angle)], axis=1)
    values = core.kernel(boundary, x, "pseudo-harmonic")
    distance2 = ((boundary.points[None, :, :] - x[:, None, :]) ** 2).sum(-1)
    poisson = (1 - (x**2).sum(1))[:, None] / (2 * np.pi * distance2)  # Eq. 7, normalised
    np.testing.assert_allclose(values, poisson, rtol=1e-11, atol=0)


def test_mean_value_equals_modified_mean_value_on_a_disk():
    # A disk is its own kernel, and there the trapezoid rule is spectrally accurate:
    # Eq. 22-23 hold to rounding.
    boundary = circle(400)
    x = np.array([[0.1, 0.2], [-0.5, 0.3], [0.6, -0.6]])
    mean_value = core.kernel(boundary, x, "mean-value")
    modified = core.kernel(boundary, x, "modified-mean-value")
    np.testing.assert_allclose(modified, mean_value, rtol=1e-11, atol=0)


def test_modified_mean_value_equals_mean_value_inside_the_kernel_of_the_domain(starfish):
    # Points near the centre of the star are in ker(Omega); the two kernels agree up
    # to the quadrature error, which falls as O(h^2) (Sec. 3.4).
    rng = np.random.default_rng(5)
    x = rng.uniform(-0.1, 0.1, size=(50, 2))
    differences = []
    for per in (50, 100, 200):
        boundary = starfish.sample(per)
        mean_value = core.kernel(boundary, x, "mean-value")
        modified = core.kernel(boundary, x, "modified-mean-value")
        differences.append(np.abs(mean_value - modified).max() / mean_value.max())
    assert differences[-1] < 1e-4
    assert differences[0] / differences[1] > 3.5 and differences[1] / differences[2] > 3.5


def test_modified_mean_value_differs_from_mean_value_outside_the_kernel(starfish):
    boundary = starfish.sample(100)
    x = np.array([[0.0, 0.8]])  # inside the top arm, not in ker(Omega)
    mean_value = core.kernel(boundary, x, "mean-value")
    modified = core.kernel(boundary, x, "modified-mean-value")
    assert mean_value.min() < 0 <= modified.min()


@pytest.mark.parametrize("name", ["harmonic-like", "pseudo-harmonic", "mean-value"])
def test_trapezoid_rule_converges_as_the_samples_grow(name, blob):
    x = interior_points(blob, 50, seed=6, margin=0.05)
    data = np.sin(2 * np.pi * np.arange(blob.n) / blob.n)
    reference = core.basis_functions(blob, x, name, samples_per_segment=1600) @ data
    errors = [
        np.abs(core.basis_functions(blob, x, name, samples_per_segment=per) @ data - reference).max()
        for per in (25, 50, 100)
    ]
    # Second order (the B-spline boundary is C^1 with p'' jumping at the knots).
    assert errors[0] / errors[1] > 3.0 and errors[1] / errors[2] > 3.0
    assert errors[2] < 1e-4


def test_shift_of_eq_19_pulls_the_kernel_towards_omega_one(blob):
    boundary = blob.sample(50)
    x = interior_points(blob, 100, seed=7, margin=0.05)
    plain = core.kernel(boundary, x, "power", power=4, shift="none")
    mean = core.kernel(boundary, x, "power", power=4, shift="mean")
    integral = core.kernel(boundary, x, "power", power=4, shift="integral")
    harmonic_like = core.kernel(boundary, x, "harmonic-like")
    unweighted = core.kernel(boundary, x, "maximum-likelihood")
    np.testing.assert_allclose(integral, harmonic_like, rtol=1e-9, atol=1e-12)
    # The integral shift (Eq. 19 as written) moves the kernel farther from 1/r^4 than the mean shift.
    assert np.abs(integral - plain).max() > np.abs(mean - plain).max()
    assert np.abs(integral - unweighted).max() < np.abs(plain - unweighted).max()


def test_kernel_on_the_boundary_is_a_discrete_delta(blob):
    boundary = blob.sample(20)
    s = np.array([3.0, 3.0 + 0.25 * boundary.step])  # on a sample and between samples
    values = core.kernel(boundary, blob(s), "harmonic-like")
    k = int(round(3.0 / boundary.step))
    expected = np.zeros_like(values)
    expected[0, k] = 1 / boundary.step
    expected[1, k] = 0.75 / boundary.step
    expected[1, k + 1] = 0.25 / boundary.step
    np.testing.assert_allclose(values, expected, atol=1e-9 / boundary.step)


def test_unshifted_high_power_near_the_boundary_is_reported_not_hidden(blob):
    s = np.linspace(0.3, blob.n - 0.3, 20)
    points, tangents, _ = blob.evaluate(s)
    inward = np.stack([-tangents[:, 1], tangents[:, 0]], axis=1)
    inward /= np.linalg.norm(inward, axis=1, keepdims=True)
    if not blob.is_counterclockwise:
        inward = -inward
    x = points + 1e-3 * blob.diameter * inward
    with pytest.warns(core.ConvergenceWarning, match="did not converge cleanly"):
        _, report = core.kernel(blob.sample(20), x, "power", power=8, return_report=True)
    assert report.failed.any()
    # The shift of Eq. 19 is the cure the paper proposes.
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        _, report = core.kernel(blob.sample(20), x, "power", power=8, shift="integral", return_report=True)
    assert report.converged.all()


def test_progress_is_reported_up_to_one(blob):
    fractions = []
    x = interior_points(blob, 9000, seed=8)
    core.kernel(blob.sample(5), x, "mean-value", progress=fractions.append)
    assert fractions == sorted(fractions) and fractions[-1] == 1.0 and len(fractions) >= 3


def test_three_point_kernels_need_a_convex_domain(starfish, ellipse):
    for name in ("wachspress", "laplace"):
        with pytest.raises(ValueError, match="convex domains only"):
            core.kernel(starfish.sample(10), [[0.0, 0.0]], name)
        values = core.kernel(ellipse.sample(100), [[0.1, 0.1]], name)
        assert np.isfinite(values).all()


def test_wachspress_is_non_negative_and_laplace_can_be_negative():
    polygon = core.ClosedBSpline(np.repeat(np.array([[0, 0], [2, 0], [3, 1.5], [1.5, 3], [-0.5, 1.5]]), 2, 0))
    x = interior_points(polygon, 200, seed=9)
    assert core.basis_functions(polygon, x, "wachspress").min() >= 0
    assert core.basis_functions(polygon, x, "laplace").min() < 0


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"kernel": "harmonic"}, "unknown kernel 'harmonic'; choose one of"),
        ({"kernel": "power", "power": -1}, "power must be a finite number > 0"),
        ({"kernel": "power", "shift": "half"}, "shift must be one of"),
        ({"kernel": "harmonic-like", "power": 2}, "does not take parameter"),
        ({"tolerance": 0}, "tolerance must be a finite number > 0"),
    ],
)
def test_invalid_kernel_arguments(kwargs, message, blob):
    with pytest.raises(ValueError, match=message):
        core.kernel(blob.sample(5), [[0.5, 0.5]], **kwargs)


def test_points_outside_the_domain_are_counted(blob):
    x = np.array([[0.5, 0.5], [5.0, 5.0], [-1.0, 0.2]])
    with pytest.raises(ValueError, match="2 of 3 points of x are outside the domain"):
        core.kernel(blob.sample(5), x)


@pytest.mark.parametrize(("x", "message"), [([[0.5, np.nan]], "NaN"), ([[1, 2, 3]], r"shape \(M, 2\)")])
def test_invalid_points(x, message, blob):
    with pytest.raises(ValueError, match=message):
        core.kernel(blob.sample(5), x)


def test_boundary_argument_is_checked(blob):
    with pytest.raises(ValueError, match="boundary must be a core.Boundary"):
        core.kernel(blob, [[0.5, 0.5]])


def test_example_cages_are_valid():
    for points in (examples.blob(), examples.starfish(), examples.ellipse(), examples.dumbbell()):
        assert core.ClosedBSpline(points).area != 0


def test_compiled_solver_matches_the_plain_numpy_reference(blob):
    from core.newton.reference import reference_kernel

    boundary = blob.sample(30)
    x = interior_points(blob, 100, seed=10, margin=0.05)
    expected = reference_kernel(boundary, x)  # Eq. 20
    np.testing.assert_allclose(
        core.kernel(boundary, x, "harmonic-like"), expected, rtol=1e-9, atol=1e-12 * expected.max()
    )
    unshifted = reference_kernel(boundary, x, power=2.0, shift=False)
    np.testing.assert_allclose(
        core.kernel(boundary, x, "power", power=2.0), unshifted, rtol=1e-9, atol=1e-12 * unshifted.max()
    )


def test_path_following_brings_unshifted_powers_home(blob):
    # Newton from phi = 0 crawls when omega = 1 / r^k spans many orders of magnitude;
    # the continuation of core.newton.solver reaches the same minimiser (Eq. 16 is convex).
    x = interior_points(blob, 3000, seed=21)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", core.ConvergenceWarning)
        _, report = core.basis_functions(blob, x, "power", power=3, return_report=True)
    assert (report.status != 1).all()  # 1: not converged
    assert report.iterations.max() > 100  # some points did need the path
    converged = report.converged
    assert report.residual[converged].max() <= 1e-11 * blob.diameter


def test_inverse_cube_mean_is_eq_19_with_the_third_power_and_the_mean_shift(blob):
    boundary = blob.sample(50)
    x = interior_points(blob, 200, seed=15)
    named = core.kernel(boundary, x, "inverse-cube-mean")
    np.testing.assert_array_equal(named, core.kernel(boundary, x, "power", power=3.0, shift="mean"))
    with pytest.raises(ValueError, match="'inverse-cube-mean' does not take parameter"):
        core.kernel(boundary, x, "inverse-cube-mean", power=2.0)
