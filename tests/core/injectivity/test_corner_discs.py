"""Corner discs (core.injectivity.corner_discs) and the cornered drags where libigl fails."""

from __future__ import annotations

import numpy as np
from support.fold_free_checks import unfolded

import core
from app.studies.quality_suite import polygon
from core.injectivity.corner_discs import disc_images, radial_discs

SQUARE = polygon([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
#: A random strong drag of the square (two corners moved) on which libigl's
#: bijective_composite_harmonic_mapping raised "failed" on the 1.5k-vertex mesh that
#: core.triangulate made before it opened corner ears: the corner at (0, 0) opens from 90 degrees
#: to more than 180.
DRAG = polygon([[0.0, 0.0], [-0.0206, -0.3927], [0.6213, 0.6636], [0.0, 1.0]])


def test_a_step_across_a_straight_angle_is_radial_in_its_corner_disc_and_continuous():
    """A step of the drag's path where the corner at (0, 0) turns past 180 degrees: its disc is
    unproven by the certificate; mapped radially, it meets the harmonic map on the arc and turns
    no triangle of a fine polar grid over."""
    s = 0.975
    current, following = ((1 - t) * SQUARE + t * DRAG for t in (s, s + 1 / 64))
    curve = core.ClosedBSpline(current)
    certificate = core.certify_injective(curve, following)
    assert certificate.away_from_corners and not certificate.injective
    discs = radial_discs(curve, following, certificate)
    assert discs is not None and len(discs) == 4  # every sharp corner's disc is radial
    disc = next(disc for disc in discs if np.array_equal(disc.point, [0.0, 0.0]))
    assert disc.turn == 1.0  # the square runs counter-clockwise
    # On the arc (just inside it, and just outside) the radial map meets the harmonic map.
    angles = np.linspace(0.01, disc.angle - 0.01, 50)
    directions = rotated(disc.leave, angles)
    inner = disc_images(curve, following, (disc.radius * (1 - 1e-9)) * directions, discs)
    harmonic = core.basis_functions(curve, disc.radius * directions, "poisson") @ following
    np.testing.assert_allclose(inner, harmonic, atol=1e-7)
    # A polar grid of the sector: every triangle keeps its orientation.
    radii, angles = np.meshgrid(np.linspace(0, 0.999, 40)[1:] * disc.radius, np.linspace(0, disc.angle, 60))
    grid = radii[..., None] * rotated(disc.leave, angles)
    images = disc_images(curve, following, grid.reshape(-1, 2), discs).reshape(grid.shape)
    for points in (grid, images):
        a, b, c = points[:-1, :-1], points[:-1, 1:], points[1:, :-1]
        areas = (b[..., 0] - a[..., 0]) * (c[..., 1] - a[..., 1]) - (b[..., 1] - a[..., 1]) * (
            c[..., 0] - a[..., 0]
        )
        assert (areas > 0).all()  # along a row the radius grows, down a column the angle: counter-clockwise


def rotated(direction: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """The unit vector `direction` (2,) turned counter-clockwise by `angles` (...): shape (..., 2)."""
    cosines, sines = np.cos(angles)[..., None], np.sin(angles)[..., None]
    return cosines * direction + sines * np.array([-direction[1], direction[0]])


def test_triangulate_leaves_no_ear_at_a_sharp_corner():
    mesh = core.triangulate(core.ClosedBSpline(SQUARE), max_edge=0.08)
    on_boundary = np.isin(mesh.triangles, mesh.boundary)
    assert not on_boundary.all(axis=1).any()


def test_a_cornered_drag_where_libigl_fails_is_unfolded():
    """The corner opening past a straight angle folds the harmonic map in a tiny disc.  On the mesh's
    own composite no triangle turns over and the map is proven a bijection on the mesh; without the
    mesh's boundary, the continuous composite maps each corner's disc radially and is proven
    outside the discs."""
    curve = core.ClosedBSpline(SQUARE)
    mesh = core.triangulate(curve, max_edge=0.08)
    _, certificate = unfolded(curve, DRAG, mesh)
    assert certificate.injective and certificate.on_mesh and certificate.sigma2_min > 0
    _, continuous = core.fold_free_deform(curve, DRAG, mesh.vertices)
    assert continuous.away_from_corners and not continuous.injective and continuous.sigma2_min > 0
    assert 0 < continuous.corner_radius < 0.1
    assert "proven outside a radius of" in str(continuous)
