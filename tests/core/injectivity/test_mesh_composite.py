"""core.injectivity.mesh_composite: discrete harmonic steps cut before a triangle turns over."""

from __future__ import annotations

import numpy as np

import core
from core.curves.examples import blob
from core.injectivity.mesh_composite import composite_on_mesh, harmonic_images


def test_an_affine_boundary_is_one_step_and_exact():
    """The cotangent weights reproduce linear maps: an affine move of the boundary moves the whole
    mesh by it, in one solve."""
    curve = core.ClosedBSpline(blob())
    mesh = core.triangulate(curve, max_edge=0.05)
    matrix, shift = np.array([[0.9, -0.3], [0.2, 1.1]]), np.array([0.4, -0.1])
    end = mesh.vertices[mesh.boundary] @ matrix.T + shift
    reached = composite_on_mesh(mesh.vertices, mesh.triangles, mesh.boundary, mesh.vertices, end)
    assert reached.reached == 1.0 and reached.solves == 1
    np.testing.assert_allclose(reached.images, mesh.vertices @ matrix.T + shift, atol=1e-12)


def test_every_step_keeps_every_triangle_and_the_end_is_on_the_boundary_values():
    """A drag whose one-step harmonic map folds: the composite ends on the boundary values with every
    triangle kept, the steps' progress rising to 1."""
    points = blob()
    curve = core.ClosedBSpline(points)
    mesh = core.triangulate(curve, max_edge=0.03)
    target = points.copy()
    target[5] = [0.25, 0.2]  # the middle of the right side pulled far into the left lobe
    end = core.ClosedBSpline(target)(mesh.boundary_parameters)
    one_step = harmonic_images(mesh.triangles, mesh.boundary, mesh.vertices, end)
    assert core.folded_triangles(mesh, one_step).any()
    shares = []
    reached = composite_on_mesh(
        mesh.vertices, mesh.triangles, mesh.boundary, mesh.vertices, end, progress=shares.append
    )
    assert reached.reached == 1.0 and reached.solves > 1
    assert shares == sorted(shares) and shares[-1] == 1.0
    assert not core.folded_triangles(mesh, reached.images).any()
    np.testing.assert_array_equal(reached.images[mesh.boundary], end)
