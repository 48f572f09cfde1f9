"""core.meshes.distortion: singular values, conformal distortion and folded area on maps with known
answers."""

from __future__ import annotations

import numpy as np
import pytest

import core
from core.curves import examples
from core.meshes import distortion


def grid(columns: int = 6, rows: int = 4) -> tuple[np.ndarray, np.ndarray]:
    """A regular triangulation of [-1, 1] x [0, 1], vertices (V, 2) and triangles (T, 3),
    counter-clockwise, with a column of vertices on x = 0 (columns even)."""
    x, y = np.meshgrid(np.linspace(-1.0, 1.0, columns + 1), np.linspace(0.0, 1.0, rows + 1))
    vertices = np.stack([x.ravel(), y.ravel()], axis=1)
    triangles = []
    for j in range(rows):
        for i in range(columns):
            a = j * (columns + 1) + i
            b, c, d = a + 1, a + columns + 1, a + columns + 2
            triangles += [[a, b, d], [a, d, c]]
    return vertices, np.array(triangles)


@pytest.fixture(scope="module")
def mesh():
    return core.triangulate(core.ClosedBSpline(examples.blob()))


def test_identity_has_no_folds_and_no_distortion(mesh):
    sigma = distortion.signed_singular_values(
        distortion.triangle_jacobians(mesh.vertices, mesh.vertices, mesh.triangles)
    )
    np.testing.assert_allclose(sigma, 1.0, rtol=0, atol=1e-12)
    np.testing.assert_allclose(distortion.conformal_distortion(sigma), 1.0, rtol=0, atol=1e-12)
    assert distortion.folded_area_fraction(np.abs(mesh.signed_areas()), sigma) == 0.0


def test_an_affine_map_has_its_singular_values_everywhere(mesh):
    matrix = np.array([[1.7, 0.6], [-0.3, 0.9]])
    deformed = mesh.vertices @ matrix.T + [4.0, -2.0]
    sigma = distortion.signed_singular_values(
        distortion.triangle_jacobians(mesh.vertices, deformed, mesh.triangles)
    )
    expected = np.linalg.svd(matrix, compute_uv=False)
    np.testing.assert_allclose(sigma, np.broadcast_to(expected, sigma.shape), rtol=1e-12)
    ratio = distortion.conformal_distortion(sigma)
    np.testing.assert_allclose(ratio, expected[0] / expected[1], rtol=1e-12)


def test_a_similarity_is_conformal(mesh):
    turn = 0.7
    matrix = 2.5 * np.array([[np.cos(turn), -np.sin(turn)], [np.sin(turn), np.cos(turn)]])
    sigma = distortion.signed_singular_values(
        distortion.triangle_jacobians(mesh.vertices, mesh.vertices @ matrix.T, mesh.triangles)
    )
    np.testing.assert_allclose(sigma, 2.5, rtol=1e-12)


def test_a_reflection_has_a_negative_second_singular_value():
    sigma = distortion.signed_singular_values(np.array([[[1.0, 0.0], [0.0, -3.0]], [[0.0, 2.0], [1.0, 0.0]]]))
    np.testing.assert_allclose(sigma, [[3.0, -1.0], [2.0, -1.0]], rtol=1e-15)


def test_a_map_folding_the_left_half_over_the_right_counts_that_half():
    vertices, triangles = grid()
    # x' = |x|: the left half is mirrored onto the right one, each of its triangles folded.
    deformed = np.abs(vertices)
    areas = np.full(len(triangles), 1.0 / len(triangles))  # a regular grid
    sigma = distortion.signed_singular_values(distortion.triangle_jacobians(vertices, deformed, triangles))
    left = vertices[triangles].mean(axis=1)[:, 0] < 0
    np.testing.assert_allclose(sigma[left], [[1.0, -1.0]] * int(left.sum()), rtol=1e-12)
    np.testing.assert_allclose(sigma[~left], 1.0, rtol=1e-12)
    assert distortion.folded_area_fraction(areas, sigma) == pytest.approx(0.5, rel=1e-12)
    ratio = distortion.conformal_distortion(sigma, cap=7.0)
    np.testing.assert_array_equal(ratio[left], 7.0)
    np.testing.assert_allclose(ratio[~left], 1.0, rtol=1e-12)


def test_a_collapsed_map_counts_as_folded_and_is_capped():
    vertices, triangles = grid(2, 1)
    flattened = vertices * [1.0, 0.0]
    sigma = distortion.signed_singular_values(distortion.triangle_jacobians(vertices, flattened, triangles))
    np.testing.assert_allclose(sigma[:, 1], 0.0, rtol=0, atol=1e-15)
    assert distortion.folded_area_fraction(np.full(len(triangles), 0.25), sigma) == 1.0
    assert (distortion.conformal_distortion(sigma) == distortion.DISTORTION_CAP).all()


def test_stretch_beyond_the_cap_is_capped():
    sigma = distortion.signed_singular_values(np.array([[[50.0, 0.0], [0.0, 1.0]], [[3.0, 0.0], [0.0, 1.0]]]))
    np.testing.assert_allclose(distortion.conformal_distortion(sigma, cap=10.0), [10.0, 3.0], rtol=1e-15)


def test_weighted_quantile():
    values = np.array([5.0, 1.0, 3.0, 2.0])
    assert distortion.weighted_quantile(values, np.ones(4), 0.5) == 2.0
    assert distortion.weighted_quantile(values, np.ones(4), 0.99) == 5.0
    assert distortion.weighted_quantile(values, [0.0, 0.0, 0.0, 1.0], 0.99) == 2.0
    assert distortion.weighted_quantile(values, [1.0, 97.0, 1.0, 1.0], 0.97) == 1.0
    with pytest.raises(ValueError, match=r"quantile must be in \[0, 1\]"):
        distortion.weighted_quantile(values, np.ones(4), 1.5)


def test_bad_input_is_named():
    vertices, triangles = grid(2, 1)
    with pytest.raises(ValueError, match="deformed must have shape"):
        distortion.triangle_jacobians(vertices, vertices[:-1], triangles)
    with pytest.raises(ValueError, match=r"triangles must have shape \(T, 3\)"):
        distortion.triangle_jacobians(vertices, vertices, triangles[:, :2])
    flat = vertices * [1.0, 0.0]
    with pytest.raises(ValueError, match="degenerate"):
        distortion.triangle_jacobians(flat, vertices, triangles)
