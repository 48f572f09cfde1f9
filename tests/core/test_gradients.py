"""core.basis_gradients, core.kernel_gradients: exact x-gradients of the kernels (core.gradients).

Identities first (sum_i grad G_i = 0, sum_i P_i grad G_i^T = I), on non-convex
domains, sharp corners and a clockwise cage far from the origin; then central
differences of `core.basis_functions`, the Poisson kernel on the exact disk, the
near-boundary rule, and the error messages.
"""

from __future__ import annotations

import re
import warnings

import numpy as np
import pytest
from support.shapes import circle, interior_points, inward_offsets

import core
from core.curves import examples
from core.curves.closest_point import distance_to_curve

NEWTON_KERNELS = tuple(
    name
    for name in core.KERNELS
    if name not in ("mean-value", "wachspress", "laplace", *core.BOUNDARY_INTEGRAL_KERNELS)
)
# Kernels with kernel values lambda(x, t) (`core.kernel`): all but the boundary-integral ones.
VALUE_KERNELS = tuple(name for name in core.KERNELS if name not in core.BOUNDARY_INTEGRAL_KERNELS)
CONVEX_ONLY = ("wachspress", "laplace")
L_SHAPE = np.array([[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2]], dtype=float)
SQUARE = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=float)


def domains(name: str) -> dict[str, core.ClosedBSpline]:
    """The test domains of a kernel: non-convex ones, or convex ones for the three-point family."""
    if name in CONVEX_ONLY:
        return {
            "ellipse": core.ClosedBSpline(examples.ellipse()),
            "square with corners": core.ClosedBSpline(np.repeat(SQUARE, 2, axis=0)),
        }
    return {
        "blob": core.ClosedBSpline(examples.blob()),
        "starfish with corners": core.ClosedBSpline(np.repeat(examples.starfish(), 2, axis=0)),
        "L with corners": core.ClosedBSpline(np.repeat(L_SHAPE, 2, axis=0)),
        "clockwise far away": core.ClosedBSpline(examples.blob()[::-1] * 3.0 + np.array([1e3, -2e3])),
    }


def central_differences(curve, x, name, step, samples_per_segment=100):
    """(G(x + step e_d) - G(x - step e_d)) / (2 step), shape (M, n, 2)."""
    result = np.zeros((x.shape[0], curve.n, 2))
    for d in range(2):
        offset = np.zeros(2)
        offset[d] = step
        high = core.basis_functions(curve, x + offset, name, samples_per_segment)
        low = core.basis_functions(curve, x - offset, name, samples_per_segment)
        result[:, :, d] = (high - low) / (2 * step)
    return result


def relative_error(approximation, exact):
    """Worst over points of max |approximation - exact| / max |exact| (per point)."""
    scale = np.abs(exact).max(axis=(1, 2))
    return float((np.abs(approximation - exact).max(axis=(1, 2)) / scale).max())


@pytest.mark.parametrize("name", core.KERNELS)
def test_gradients_sum_to_zero_and_differentiate_linear_precision(name):
    for label, curve in domains(name).items():
        x = interior_points(curve, 40, seed=21, margin=0.01)
        gradients, values, report = core.basis_gradients(
            curve, x, name, return_values=True, return_report=True
        )
        assert gradients.shape == (40, curve.n, 2), label
        scale = np.abs(gradients).max(axis=(1, 2))
        # Partition of unity: sum_i grad G_i = sum_j grad lambda_j = 0 up to rounding.
        assert (np.abs(gradients.sum(axis=1)).max(axis=1) <= 1e-12 * scale).all(), label
        # sum_i P_i (grad G_i)^T = I_2 holds for the Newton kernels up to the Newton residual
        # (1e-11 of the diameter) over the distance to the boundary (measured: at most 2.9 times
        # that); for the explicit kernels only to the quadrature error (measured <= 6e-4).
        identity = np.einsum("id,mie->mde", curve.control_points, gradients)
        error = np.abs(identity - np.eye(2)).max(axis=(1, 2))
        if name in NEWTON_KERNELS:
            distance = distance_to_curve(curve.piecewise_polynomial(), x)
            assert (error <= 5 * core.kernels.DEFAULT_TOLERANCE * curve.diameter / distance).all(), label
        else:
            assert error.max() <= 1e-3, label
        assert report.converged.all(), label
        # The values come from the same nodes as core.basis_functions; its Newton starts from a
        # coarse solve and this one from phi = 0, so they agree to the Newton tolerance (measured
        # <= 1e-12), not to rounding.
        np.testing.assert_allclose(values, core.basis_functions(curve, x, name), rtol=0, atol=1e-10)


@pytest.mark.parametrize("name", core.KERNELS)
def test_gradients_match_central_differences_away_from_the_boundary(name):
    for label, curve in domains(name).items():
        # Farther than NEAR_SPACINGS sample spacings: the nodes are the fixed samples, and the
        # gradient is the exact derivative of the discrete basis_functions.
        x = interior_points(curve, 12, seed=22, margin=0.05)
        gradients = core.basis_gradients(curve, x, name)
        differences = central_differences(curve, x, name, 1e-5 * curve.diameter)
        # Central differences err by O(step^2) (about 1e-9 here) plus rounding / step.
        assert relative_error(differences, gradients) <= 1e-6, label


def test_pseudo_harmonic_gradient_is_the_poisson_kernel_gradient_on_a_disk():
    boundary = circle(400)
    rng = np.random.default_rng(23)
    radius = 0.8 * np.sqrt(rng.uniform(size=100))
    angle = rng.uniform(0, 2 * np.pi, 100)
    x = np.stack([radius * np.cos(angle), radius * np.sin(angle)], axis=1)
    gradients = core.kernel_gradients(boundary, x, "pseudo-harmonic")
    # lambda = (1 - |x|^2) / (2 pi |p - x|^2) (Eq. 7), so
    # grad lambda = -2 x / (2 pi r^2) + (1 - |x|^2) 2 (p - x) / (2 pi r^4).
    offset = boundary.points[None, :, :] - x[:, None, :]
    r2 = (offset**2).sum(-1)[..., None]
    inside = (1 - (x**2).sum(1))[:, None, None]
    exact = -2 * x[:, None, :] / (2 * np.pi * r2) + inside * 2 * offset / (2 * np.pi * r2**2)
    assert np.abs(gradients - exact).max() <= 1e-12 * np.abs(exact).max()


@pytest.mark.parametrize(
    "name", ["inverse-cube-mean", "harmonic-like", "pseudo-harmonic", "modified-mean-value", "mean-value"]
)
def test_near_the_boundary_the_gradient_is_the_quadrature_of_the_exact_gradient(name, blob):
    # Nearer than NEAR_SPACINGS spacings the graded nodes follow x; the gradient holds them
    # fixed (core.gradients).  It converges to the gradient of a quadrature 16 times finer,
    # on which these points are far and which is exact there (previous test), to about the
    # O(h^2) error of the values (measured: at most 1.4e-3, modified mean value at 1e-2), ...
    s = np.linspace(0, blob.n, 7, endpoint=False) + 0.37
    for distance in (1e-2, 1e-3):
        x = inward_offsets(blob, s, distance * blob.diameter)
        gradients = core.basis_gradients(blob, x, name)
        fine = core.basis_gradients(blob, x, name, samples_per_segment=1600)
        assert relative_error(gradients, fine) <= 2e-3, distance
    # ... and at 1 % of the diameter it is within 0.5 % of the central differences of the
    # discrete values, whose moving nodes add the x-derivative of the quadrature error
    # (measured: at most 2.1e-3, mean value; nearer, up to 0.27 at 1e-3 of the diameter).
    x = inward_offsets(blob, s, 1e-2 * blob.diameter)
    gradients = core.basis_gradients(blob, x, name)
    differences = central_differences(blob, x, name, 1e-5 * blob.diameter)
    assert relative_error(differences, gradients) <= 5e-3


def test_points_on_the_boundary_get_nan_gradients_and_their_lagrange_values(blob):
    t = np.array([0.25, 3.5, 7.75])
    on_curve = blob.evaluate(t)[0]
    inside = interior_points(blob, 2, seed=24, margin=0.05)
    gradients, values = core.basis_gradients(blob, np.vstack([on_curve, inside]), return_values=True)
    assert np.isnan(gradients[:3]).all()
    assert np.isfinite(gradients[3:]).all()
    np.testing.assert_allclose(values[:3], blob.basis_matrix(t), atol=1e-12)


def test_refined_points_get_gradients_from_the_refined_quadrature(blob, monkeypatch):
    # With omega^2 these two points at 1e-5 of the diameter are at the feasible edge on the
    # samples (status 3) and are solved again on a 4 or 16 times finer quadrature: values
    # and gradients alike.
    name = "modified-mean-value-squared"
    x = inward_offsets(blob, np.array([6.4, 8.4]), 1e-5 * blob.diameter)
    gradients, values, report = core.basis_gradients(blob, x, name, return_values=True, return_report=True)
    assert report.converged.all()
    # Two Newton runs (basis_functions starts from a coarse solve) agree to the Newton
    # tolerance over the distance, 1e-5 of the diameter here (measured 3e-10).
    bound = core.kernels.DEFAULT_TOLERANCE / 1e-5
    np.testing.assert_allclose(values, core.basis_functions(blob, x, name), rtol=0, atol=bound)
    identity = np.einsum("id,mie->mde", blob.control_points, gradients)
    assert np.abs(identity - np.eye(2)).max() <= 5 * core.kernels.DEFAULT_TOLERANCE / 1e-5
    monkeypatch.setattr(core.kernels, "REFINEMENTS", ())
    with pytest.warns(core.ConvergenceWarning):
        _, unrefined = core.basis_functions(blob, x, name, return_report=True)
    assert (unrefined.status == 3).all()


def test_bad_input_is_refused_with_one_clear_message(blob, ellipse):
    with pytest.raises(ValueError, match="outside the domain"):
        core.basis_gradients(blob, [[5.0, 5.0]])
    with pytest.raises(ValueError, match="unknown kernel 'gauss-seidel'"):
        core.basis_gradients(blob, [[0.0, 0.0]], kernel="gauss-seidel")
    with pytest.raises(ValueError, match="curve must be a core.ClosedBSpline"):
        core.basis_gradients(blob.sample(10), [[0.0, 0.0]])
    with pytest.raises(ValueError, match="boundary must be a core.Boundary"):
        core.kernel_gradients(blob, [[0.0, 0.0]])
    with pytest.raises(ValueError, match="convex domains only"):
        core.basis_gradients(blob, [[0.0, 0.0]], kernel="wachspress")
    with pytest.raises(ValueError, match="x has 1 point"):
        core.basis_gradients(ellipse, [[np.nan, 0.0]])


# ---------------------------------------------------------------- at mesh vertices, cached


@pytest.fixture
def cache_directory(tmp_path, monkeypatch):
    directory = tmp_path / "cache"
    monkeypatch.setenv("TRANSFINITE_CACHE_DIR", str(directory))
    return directory


@pytest.fixture(scope="module")
def mesh_setup():
    curve = core.ClosedBSpline(np.repeat(examples.starfish(), 2, axis=0))
    return curve, core.triangulate(curve, max_edge=0.3)


def gradient_entry(cache_directory):
    """The path of the gradient entry (the one whose array has a trailing axis of 2)."""
    (path,) = [path for path in cache_directory.glob("*.npz") if np.load(path)["basis"].ndim == 3]
    return path


def test_mesh_gradients_are_the_basis_gradients_at_the_interior_vertices(
    mesh_setup, cache_directory, monkeypatch
):
    curve, mesh = mesh_setup
    values, gradients = core.mesh_basis_functions(curve, mesh, kernel="inverse-cube-mean", gradients=True)
    assert gradients.shape == (mesh.vertices.shape[0], curve.n, 2)
    np.testing.assert_array_equal(values, core.mesh_basis_functions(curve, mesh, kernel="inverse-cube-mean"))
    interior = mesh.interior
    np.testing.assert_array_equal(
        gradients[interior], core.basis_gradients(curve, mesh.vertices[interior], "inverse-cube-mean")
    )
    assert np.isnan(gradients[mesh.boundary]).all()
    assert len(list(cache_directory.glob("*.npz"))) == 2  # the values' entry and the gradients'

    compute = core.gradients.basis_gradients

    def spot_checks_only(curve, points, *args, **kwargs):
        # A read computes a few rows again (core.mesh_basis.recomputed_rows_problem), not all.
        if len(points) > core.mesh_basis.SPOT_CHECKS:
            raise AssertionError("recomputed instead of reading the cache")
        return compute(curve, points, *args, **kwargs)

    monkeypatch.setattr(core.gradients, "basis_gradients", spot_checks_only)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        _, again = core.mesh_basis_functions(curve, mesh, kernel="inverse-cube-mean", gradients=True)
    np.testing.assert_array_equal(again, gradients)


@pytest.mark.parametrize(
    ("damage", "problem"),
    [
        ("one bit flipped", "checksum mismatch"),
        ("rescaled, checksummed", "misses the identity"),
        ("a column added, checksummed", "sum to 0 only within"),
    ],
)
def test_a_damaged_gradient_entry_is_recomputed_and_reported(mesh_setup, cache_directory, damage, problem):
    curve, mesh = mesh_setup
    _, expected = core.mesh_basis_functions(curve, mesh, kernel="pseudo-harmonic", gradients=True)
    path = gradient_entry(cache_directory)
    with np.load(path) as file:
        stored, errors, checksum = file["basis"], file["errors"], str(file["checksum"])
    wrong = stored.copy()
    if damage == "one bit flipped":
        wrong.reshape(-1).view(np.uint64)[7] ^= np.uint64(1) << np.uint64(30)
    elif damage == "rescaled, checksummed":
        wrong *= 1.0 + 1e-6
        checksum = core.storage.cache._checksum(path.stem, wrong, errors)
    else:
        wrong[:, 0] += 1e-6 * np.abs(stored).max()
        checksum = core.storage.cache._checksum(path.stem, wrong, errors)
    with open(path, "wb") as stream:
        np.savez(stream, basis=wrong, errors=errors, checksum=np.array(checksum))
    with pytest.warns(core.CacheWarning, match=re.escape(problem)):
        _, gradients = core.mesh_basis_functions(curve, mesh, kernel="pseudo-harmonic", gradients=True)
    np.testing.assert_array_equal(gradients, expected)


@pytest.mark.parametrize("kernel", ["harmonic", "pgw"])
def test_mesh_only_kernels_have_no_pointwise_gradients(mesh_setup, kernel):
    curve, mesh = mesh_setup
    with pytest.raises(
        ValueError, match=f"kernel '{kernel}' has no pointwise gradients; use the per-triangle"
    ):
        core.mesh_basis_functions(curve, mesh, kernel=kernel, gradients=True, cache=False)


@pytest.mark.parametrize("samples_per_segment", [2, 4])
def test_the_centre_of_a_coarsely_sampled_square(samples_per_segment):
    # One near window round the whole curve whose closest point is its end: the graded rule had a
    # side 2e-15 long and wrote NaN nodes (out-of-bounds writes in the compiled solver).
    square = core.ClosedBSpline(np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]))
    gradients, G = core.basis_gradients(
        square, [[0.5, 0.5]], "maximum-likelihood", samples_per_segment, return_values=True
    )
    assert np.isfinite(G).all() and np.isfinite(gradients).all()
    np.testing.assert_allclose(G @ square.control_points, [[0.5, 0.5]], atol=1e-12)
    np.testing.assert_allclose(gradients.sum(axis=1), 0.0, atol=1e-10)
    values = core.basis_functions(square, [[0.5, 0.5]], "maximum-likelihood", samples_per_segment)
    np.testing.assert_allclose(G, values, atol=1e-12)
