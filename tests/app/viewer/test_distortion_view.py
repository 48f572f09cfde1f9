"""The viewer's distortion view (app.viewer.distortion_view): exact vertex Jacobians and folds."""

import numpy as np
import pytest

import core
from app.viewer.distortion_view import FOLDED, vertex_distortion
from core.curves import examples


@pytest.fixture(scope="module")
def blob():
    """A non-convex cage in pixels, its mesh, G and grad G of a point kernel."""
    curve = core.ClosedBSpline(examples.blob() * 200.0 + [50.0, 80.0])
    mesh = core.triangulate(curve, max_edge=14.0)
    basis, gradients = core.mesh_basis_functions(
        curve, mesh, "inverse-cube-mean", cache=False, gradients=True
    )
    return curve, mesh, basis, gradients


@pytest.mark.parametrize("exact", [True, False])
def test_an_affine_target_gives_its_matrix_everywhere(blob, exact):
    curve, mesh, basis, gradients = blob
    matrix = np.array([[1.3, 0.4], [-0.2, 0.9]])
    target = curve.control_points @ matrix.T + [7.0, -3.0]
    shown = gradients if exact else None
    area, summary = vertex_distortion(mesh.vertices, mesh.triangles, basis, shown, target, "area")
    # Linear precision: G @ P' is the affine map, so every Jacobian is the matrix (exact
    # ones to the solver's tolerance, triangle means to rounding).
    np.testing.assert_allclose(area, np.log2(np.linalg.det(matrix)), atol=1e-6)
    assert summary.folded == 0 and summary.vertices == len(mesh.vertices)
    assert summary.exact == (int(np.isfinite(gradients).all(axis=(1, 2)).sum()) if exact else 0)
    singular = np.linalg.svd(matrix, compute_uv=False)
    conformal, _ = vertex_distortion(mesh.vertices, mesh.triangles, basis, shown, target, "conformal")
    np.testing.assert_allclose(conformal, np.log2(singular[0] / singular[1]), atol=1e-6)
    assert summary.min_det == pytest.approx(np.linalg.det(matrix), abs=1e-7)


def test_vertex_jacobians_are_the_derivative_of_the_deformation(blob):
    curve, mesh, basis, gradients = blob
    rng = np.random.default_rng(12)
    target = curve.control_points + rng.normal(scale=12.0, size=curve.control_points.shape)
    values, _ = vertex_distortion(mesh.vertices, mesh.triangles, basis, gradients, target, "area")
    from core.curves.closest_point import distance_to_curve

    # Away from the boundary, where the gradients are the derivative of the discrete values.
    distance = distance_to_curve(curve.piecewise_polynomial(), mesh.vertices)
    far = np.flatnonzero(distance > 0.05 * curve.diameter)
    picked = rng.choice(far, 12, replace=False)
    step = 1e-4 * curve.diameter
    for v in picked:
        x = mesh.vertices[v]
        columns = []
        for e in range(2):
            offset = np.zeros(2)
            offset[e] = step
            ahead, behind = core.basis_functions(curve, [x + offset, x - offset], "inverse-cube-mean")
            columns.append((ahead - behind) @ target / (2 * step))
        determinant = np.linalg.det(np.column_stack(columns))
        assert values[v] == pytest.approx(np.log2(determinant), abs=1e-6)


def test_a_fold_is_found_at_the_vertices_where_det_j_changes_sign(blob):
    curve, mesh, basis, gradients = blob
    target = curve.control_points.copy()
    centre = curve.control_points.mean(axis=0)
    target[3] = centre + 1.6 * (centre - target[3])  # pulled right through the domain
    values, summary = vertex_distortion(mesh.vertices, mesh.triangles, basis, gradients, target, "area")
    exact = np.isfinite(gradients).all(axis=(1, 2))
    jacobians = core.meshes.distortion.vertex_jacobians(gradients[exact], target)
    folded_exact = np.linalg.det(jacobians) <= 0
    assert folded_exact.any() and (~folded_exact).any()
    np.testing.assert_array_equal(values[exact] == FOLDED, folded_exact)
    assert summary.folded >= folded_exact.sum() and summary.min_det < 0
    assert summary.min_det <= np.linalg.det(jacobians).min()  # boundary vertices count too
    # Without gradients (FEM harmonic, or not computed yet) folds come from the triangles.
    coarse, estimate = vertex_distortion(mesh.vertices, mesh.triangles, basis, None, target, "area")
    folded_triangles = core.folded_triangles(mesh, basis @ target)
    expected = np.zeros(len(mesh.vertices), bool)
    expected[mesh.triangles[folded_triangles].ravel()] = True
    np.testing.assert_array_equal(coarse == FOLDED, expected)
    assert estimate.exact == 0


def test_an_unknown_measure_is_refused(blob):
    curve, mesh, basis, gradients = blob
    with pytest.raises(ValueError, match="measure"):
        vertex_distortion(mesh.vertices, mesh.triangles, basis, None, curve.control_points, "volume")
