"""core.meshes.mesh_transfer: the P1 interpolant of one mesh at other points, and G moved to a coarser mesh.

By properties: barycentric rows sum to 1 and reproduce linear functions to round-off,
points are found inside their triangle (the nearest-centroid candidates grow until
they are), a mesh's own vertices get identity rows, and a transferred G keeps the
partition of unity and linear precision of the G it came from, with the exact
B-spline basis on the boundary.
"""

import numpy as np
import pytest

import core
from core.curves import examples
from core.meshes.mesh_transfer import interpolation_matrix, transfer_basis


@pytest.fixture(scope="module")
def blob():
    curve = core.ClosedBSpline(examples.blob() * 100.0)
    fine = core.triangulate(curve, max_edge=1.5)
    return curve, fine, core.harmonic_basis(curve, fine)


def inside_points(curve, count, seed):
    rng = np.random.default_rng(seed)
    low, high = curve.control_points.min(axis=0), curve.control_points.max(axis=0)
    points = rng.uniform(low, high, (4 * count, 2))
    return points[curve.contains(points)][:count]


def test_rows_sum_to_one_and_reproduce_linear_functions(blob):
    curve, fine, _ = blob
    points = inside_points(curve, 5000, seed=3)
    matrix = interpolation_matrix(fine, points)
    assert matrix.shape == (len(points), len(fine.vertices))
    np.testing.assert_allclose(matrix.sum(axis=1).A1, 1.0, atol=1e-13)
    np.testing.assert_allclose(matrix @ fine.vertices, points, atol=1e-11)
    linear = fine.vertices @ [0.3, -1.7] + 5.0
    np.testing.assert_allclose(matrix @ linear, points @ [0.3, -1.7] + 5.0, atol=1e-10)


def test_points_deep_inside_are_inside_their_triangle(blob):
    curve, fine, _ = blob
    # Points on the mesh's own edges and deep inside a graded (band-refined) mesh.
    interior = np.setdiff1d(np.arange(len(fine.vertices)), fine.boundary)
    rng = np.random.default_rng(5)
    triangles = fine.vertices[fine.triangles[rng.choice(len(fine.triangles), 3000, replace=False)]]
    weights = rng.dirichlet(np.ones(3), size=len(triangles))
    points = np.einsum("tk,tkd->td", weights, triangles)
    matrix = interpolation_matrix(fine, points).tocoo()
    assert matrix.data.min() >= -1e-12  # found a containing triangle for every point
    # A vertex of the mesh gets its own value.
    vertex_rows = interpolation_matrix(fine, fine.vertices[interior[:500]])
    np.testing.assert_allclose(vertex_rows @ fine.vertices, fine.vertices[interior[:500]], atol=1e-11)
    values = rng.random(len(fine.vertices))
    np.testing.assert_allclose(vertex_rows @ values, values[interior[:500]], atol=1e-12)


def test_points_between_a_chord_and_the_curve_extrapolate_linearly(blob):
    curve, fine, _ = blob
    # Curve points halfway between two boundary vertices: outside the mesh's polygon where
    # the curve is convex, so no triangle contains them.
    middle = 0.5 * (fine.boundary_parameters + np.roll(fine.boundary_parameters, -1))
    middle[-1] = 0.5 * (fine.boundary_parameters[-1] + fine.boundary_parameters[0] + curve.n)
    points = curve(np.mod(middle, curve.n))
    matrix = interpolation_matrix(fine, points)
    assert matrix.tocoo().data.min() < -1e-9  # some really are outside
    np.testing.assert_allclose(matrix.sum(axis=1).A1, 1.0, atol=1e-13)
    np.testing.assert_allclose(matrix @ fine.vertices, points, atol=1e-10)


def test_transferred_basis_keeps_the_invariants(blob):
    curve, fine, basis = blob
    coarse = core.triangulate(curve, max_edge=6.0)
    moved = transfer_basis(curve, fine, basis, coarse)
    assert moved.shape == (len(coarse.vertices), curve.n)
    assert np.array_equal(moved[coarse.boundary], curve.basis_matrix(coarse.boundary_parameters))
    np.testing.assert_allclose(moved.sum(axis=1), 1.0, atol=1e-12)
    fine_error = np.abs(basis @ curve.control_points - fine.vertices).max()
    coarse_error = np.abs(moved @ curve.control_points - coarse.vertices).max()
    assert coarse_error <= fine_error + 1e-9 * curve.diameter
    # The FEM harmonic basis is non-negative at the vertices; its P1 interpolant is too.
    assert moved.min() >= basis.min() - 1e-12
    # The same mesh gets its own G back.
    np.testing.assert_allclose(transfer_basis(curve, fine, basis, fine), basis, atol=1e-12)


def test_transfer_refuses_a_basis_of_another_shape_or_a_mesh_of_another_curve(blob):
    curve, fine, basis = blob
    coarse = core.triangulate(curve, max_edge=6.0)
    with pytest.raises(ValueError, match="basis must have shape"):
        transfer_basis(curve, fine, basis[:, :-1], coarse)
    other = core.ClosedBSpline(examples.blob() * 90.0)
    with pytest.raises(ValueError, match="not made for this curve"):
        transfer_basis(curve, fine, basis, core.triangulate(other, max_edge=6.0))
