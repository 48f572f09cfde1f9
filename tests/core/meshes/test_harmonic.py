"""Tests of core.meshes.harmonic: the finite-element harmonic basis (Sec. 4.2)."""

import numpy as np
import pytest
from scipy.sparse import lil_matrix
from scipy.sparse.linalg import cg
from support.shapes import l_polygon as l_shape
from support.shapes import wavy_star as starfish

import core
from core.meshes.harmonic import harmonic_basis, stiffness_matrix
from core.meshes.mesh import Mesh
from core.meshes.triangulation import triangulate

CAGES = {
    "starfish": starfish(),
    "clockwise-starfish": starfish()[::-1].copy(),
    "l-shape": l_shape(),
    "hexagon-blob": np.array([[3.0, 0.2], [2.0, 2.5], [-1.0, 2.0], [-2.5, 0.0], [-1.0, -2.0], [2.0, -1.5]]),
}


@pytest.fixture(scope="module", params=list(CAGES))
def case(request):
    curve = core.ClosedBSpline(CAGES[request.param])
    mesh = triangulate(curve, max_edge=curve.diameter / 25)
    return curve, mesh, harmonic_basis(curve, mesh)


# ---------------------------------------------------------------- properties


def test_partition_of_unity(case):
    _, _, basis = case
    np.testing.assert_allclose(basis.sum(axis=1), 1.0, rtol=0, atol=1e-12)


def test_linear_precision(case):
    curve, mesh, basis = case
    # Linear FEM reproduces linear functions exactly; only rounding is left.
    tolerance = 1e-10 * curve.diameter
    np.testing.assert_allclose(basis @ curve.control_points, mesh.vertices, rtol=0, atol=tolerance)


def test_boundary_rows_are_exactly_the_b_spline_basis(case):
    curve, mesh, basis = case
    np.testing.assert_array_equal(basis[mesh.boundary], curve.basis_matrix(mesh.boundary_parameters))


def test_non_negative_on_a_delaunay_mesh(case):
    # Interior edges of a Delaunay mesh have non-negative cotangent weights, so the
    # discrete maximum principle holds.
    _, _, basis = case
    assert basis.min() >= -1e-14


def test_agrees_with_an_independent_element_by_element_solve(case):
    curve, mesh, basis = case
    count = mesh.vertices.shape[0]
    stiffness = lil_matrix((count, count))
    for triangle in mesh.triangles:
        corners = mesh.vertices[triangle]
        # Gradients of the three hat functions from the inverse of the affine map.
        jacobian = np.array([corners[1] - corners[0], corners[2] - corners[0]]).T
        area = 0.5 * abs(np.linalg.det(jacobian))
        reference = np.array([[-1.0, -1.0], [1.0, 0.0], [0.0, 1.0]])
        gradients = reference @ np.linalg.inv(jacobian)
        local = area * gradients @ gradients.T
        for a in range(3):
            for b in range(3):
                stiffness[triangle[a], triangle[b]] += local[a, b]
    stiffness = stiffness.tocsr()
    interior, boundary = mesh.interior, mesh.boundary
    boundary_values = curve.basis_matrix(mesh.boundary_parameters)
    system = stiffness[interior][:, interior]
    right = -(stiffness[interior][:, boundary] @ boundary_values)
    for i in range(curve.n):
        solution, info = cg(system, right[:, i], rtol=1e-14, atol=0.0, maxiter=10_000)
        assert info == 0
        np.testing.assert_allclose(basis[interior, i], solution, rtol=0, atol=1e-8)


def test_stiffness_matrix_is_symmetric_and_annihilates_linear_functions():
    curve = core.ClosedBSpline(starfish())
    mesh = triangulate(curve, max_edge=0.2)
    stiffness = stiffness_matrix(mesh.vertices, mesh.triangles)
    assert abs(stiffness - stiffness.T).max() <= 1e-14 * abs(stiffness).max()
    np.testing.assert_allclose(np.asarray(stiffness.sum(axis=1)).ravel(), 0.0, atol=1e-12)
    rng = np.random.default_rng(7)
    linear = mesh.vertices @ rng.normal(size=2) + rng.normal()
    residual = stiffness @ linear
    np.testing.assert_allclose(residual[mesh.interior], 0.0, atol=1e-12)
    # Orientation of the triangles does not matter.
    flipped = stiffness_matrix(mesh.vertices, mesh.triangles[:, ::-1])
    assert abs(flipped - stiffness).max() <= 1e-14 * abs(stiffness).max()


def interpolate(mesh, values, points):
    """Piecewise linear interpolation of vertex values (V, k) at points (Q, 2)."""
    corners = mesh.vertices[mesh.triangles]  # (T, 3, 2)
    e1 = corners[:, 1] - corners[:, 0]
    e2 = corners[:, 2] - corners[:, 0]
    determinant = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    offset = points[:, None, :] - corners[None, :, 0]
    b1 = (offset[..., 0] * e2[:, 1] - offset[..., 1] * e2[:, 0]) / determinant
    b2 = (e1[:, 0] * offset[..., 1] - e1[:, 1] * offset[..., 0]) / determinant
    b0 = 1 - b1 - b2
    inside = (b0 >= -1e-12) & (b1 >= -1e-12) & (b2 >= -1e-12)
    triangle = np.argmax(inside, axis=1)
    assert inside.any(axis=1).all()
    rows = np.arange(points.shape[0])
    weights = np.stack([b0[rows, triangle], b1[rows, triangle], b2[rows, triangle]], axis=1)
    return np.einsum("qk,qkn->qn", weights, values[mesh.triangles[triangle]])


def test_converges_under_mesh_refinement():
    curve = core.ClosedBSpline(starfish())
    rng = np.random.default_rng(3)
    data = rng.random(curve.n)
    probes = rng.uniform(-0.4, 0.4, size=(30, 2))
    values = []
    for max_edge in (0.1, 0.05, 0.025):
        mesh = triangulate(curve, max_edge=max_edge)
        values.append(interpolate(mesh, harmonic_basis(curve, mesh) @ data[:, None], probes)[:, 0])
    coarse, medium = np.abs(values[0] - values[2]).max(), np.abs(values[1] - values[2]).max()
    # Second order: halving the edge length divides the error by about 4.
    assert medium <= coarse / 2.5
    assert medium <= 1e-3


def test_mesh_without_interior_vertices():
    curve = core.ClosedBSpline(starfish())
    t = np.array([0.0, 5.0, 10.0])
    mesh = Mesh(curve(t), np.array([[0, 1, 2]]), np.arange(3), t)
    np.testing.assert_array_equal(harmonic_basis(curve, mesh), curve.basis_matrix(t))


# ---------------------------------------------------------------- errors


def test_rejects_a_mesh_of_another_curve():
    curve = core.ClosedBSpline(starfish())
    other = core.ClosedBSpline(starfish() * 1.01)
    with pytest.raises(ValueError, match="mesh was not made for this curve"):
        harmonic_basis(curve, triangulate(other, max_edge=0.3))


def test_rejects_wrong_types():
    curve = core.ClosedBSpline(starfish())
    mesh = triangulate(curve, max_edge=0.3)
    with pytest.raises(ValueError, match="curve must be a core.ClosedBSpline"):
        harmonic_basis(starfish(), mesh)
    with pytest.raises(ValueError, match="mesh must be a core.Mesh"):
        harmonic_basis(curve, mesh.vertices)
