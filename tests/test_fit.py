"""Tests of app.fit on synthetic silhouettes with known outlines."""

import tracemalloc
import warnings

import cv2
import numpy as np
import pytest
from scipy.spatial import cKDTree

from app.fit import (
    FIT_PIXELS,
    CageFitWarning,
    downscaled,
    fit_cage,
    fit_closed_bspline,
    silhouette_mask,
    snap_corners,
)
from core import ClosedBSpline

HEIGHT, WIDTH = 300, 400
CENTRE, AXES = (210.3, 140.7), (120.0, 80.0)


def ellipse_coverage(supersampling=8):
    """Fraction of each pixel inside the ellipse, shape (H, W): an antialiased silhouette."""
    y, x = (np.mgrid[0 : HEIGHT * supersampling, 0 : WIDTH * supersampling] + 0.5) / supersampling
    inside = ((x - CENTRE[0]) / AXES[0]) ** 2 + ((y - CENTRE[1]) / AXES[1]) ** 2 <= 1
    return inside.reshape(HEIGHT, supersampling, WIDTH, supersampling).mean(axis=(1, 3))


def ellipse_points(count=20000):
    angle = np.linspace(0, 2 * np.pi, count, endpoint=False)
    return np.stack([CENTRE[0] + AXES[0] * np.cos(angle), CENTRE[1] + AXES[1] * np.sin(angle)], axis=1)


def curve_points(control_points, per_span=200):
    curve = ClosedBSpline(control_points)
    return curve(np.linspace(0, curve.n, per_span * curve.n, endpoint=False))


def star_polygon():
    angle = np.arange(10) * np.pi / 5 - np.pi / 2
    radius = np.where(np.arange(10) % 2 == 0, 130.0, 60.0)
    return np.stack([200 + radius * np.cos(angle), 150 + radius * np.sin(angle)], axis=1)


def star_image():
    """A red five-pointed star with antialiased edges on a transparent background, (H, W, 4) uint8."""
    image = np.zeros((HEIGHT, WIDTH, 4), dtype=np.uint8)
    polygon = np.round(star_polygon() * 16).astype(np.int32)
    cv2.fillPoly(image, [polygon], (255, 0, 0, 255), cv2.LINE_AA, shift=4)
    return image


def test_ellipse_on_plain_background_within_a_pixel():
    coverage = ellipse_coverage()
    grey = np.round(230 - 190 * coverage).astype(np.uint8)  # dark object on a light background
    image = np.repeat(grey[..., None], 3, axis=2)
    control_points = fit_cage(image, points=16)
    assert control_points.shape == (16, 2)
    distance, _ = cKDTree(ellipse_points()).query(curve_points(control_points))
    assert distance.max() < 1.0
    assert distance.mean() < 0.3


def test_ellipse_from_alpha_channel_ignores_colour():
    image = np.zeros((HEIGHT, WIDTH, 4), dtype=np.uint8)
    image[..., :3] = np.random.default_rng(0).integers(0, 256, (HEIGHT, WIDTH, 3))  # colour says nothing
    image[..., 3] = np.round(255 * ellipse_coverage()).astype(np.uint8)
    distance, _ = cKDTree(ellipse_points()).query(curve_points(fit_cage(image, points=12)))
    assert distance.max() < 1.0


def test_light_object_on_dark_background_and_border_touching_clutter():
    image = np.zeros((HEIGHT, WIDTH, 3), dtype=np.uint8)
    image[np.round(ellipse_coverage()) > 0] = 220
    image[:, :25] = 220  # a bright stripe along the border is not the object
    mask = silhouette_mask(image)
    assert not mask[:, :10].any()
    assert abs(int(mask.sum()) - np.pi * AXES[0] * AXES[1]) < 0.01 * np.pi * AXES[0] * AXES[1]


def test_star_is_simple_and_covers_the_silhouette():
    image = star_image()
    with warnings.catch_warnings():
        # Sharp tips pull pairs of control points together until they may loop;
        # the light smoothing that fixes that is reported, and fine here.
        warnings.simplefilter("ignore", CageFitWarning)
        control_points = fit_cage(image, points=24)
    assert control_points.shape == (24, 2)
    fitted = np.zeros((HEIGHT, WIDTH), dtype=np.uint8)
    cv2.fillPoly(fitted, [np.round(curve_points(control_points) * 16).astype(np.int32)], 1, shift=4)
    star = image[..., 3] >= 128
    overlap = (star & (fitted > 0)).sum() / (star | (fitted > 0)).sum()
    assert overlap > 0.95
    # The smooth curve cannot follow the sharp tips, but stays near every outline point.
    corners = star_polygon()
    outline = np.concatenate([np.linspace(corners[k - 1], corners[k], 50) for k in range(len(corners))])
    assert cKDTree(curve_points(control_points)).query(outline)[0].max() < 15


def test_self_intersecting_fit_is_retried_and_reported():
    image = star_image()
    # Ten points for ten corners: the plain least-squares curve loops at the tips.
    assert _crosses_itself(fit_closed_bspline(_outline(image), 10))
    with pytest.warns(CageFitWarning, match=r"with 10 control points crossed itself; (used|smoothed)"):
        control_points = fit_cage(image, points=10)
    ClosedBSpline(control_points)  # simple


def test_snap_corners_doubles_close_pairs_without_chaining():
    points = np.array([[0, 0], [0.3, 0], [0.6, 0.1], [50, 0], [50, 40], [49.5, 40.2], [0, 40]], dtype=float)
    snapped = snap_corners(points)
    assert np.array_equal(snapped[0], snapped[1]) and np.allclose(snapped[0], [0.15, 0])
    assert np.array_equal(snapped[2], points[2]), "a third point must not join the pair"
    assert np.array_equal(snapped[4], snapped[5])
    assert np.array_equal(snapped[[3, 6]], points[[3, 6]])
    ClosedBSpline(snapped)


def test_fit_closed_bspline_reproduces_a_spline():
    reference = np.array([[0, 0], [60, -10], [120, 20], [110, 90], [40, 100], [-10, 50]], dtype=float)
    samples = curve_points(reference, per_span=40)
    # Start the data mid-span: the fit must also find the parameter shift.
    fitted = fit_closed_bspline(np.roll(samples, 17, axis=0), 6)
    assert np.abs(fitted - reference).max() < 1e-3


def test_errors():
    with pytest.raises(ValueError, match="found no object"):
        fit_cage(np.zeros((50, 50, 4), dtype=np.uint8))
    with pytest.raises(ValueError, match="points must be at least 3"):
        fit_cage(np.zeros((50, 50, 3), dtype=np.uint8), points=2)
    tiny = np.zeros((50, 50, 4), dtype=np.uint8)
    tiny[20:26, 20:26, 3] = 255
    with pytest.raises(ValueError, match="too few for 16 control points"):
        fit_cage(tiny)
    with pytest.raises(ValueError, match=r"\(H, W, 3\) or \(H, W, 4\) uint8"):
        fit_cage(np.zeros((50, 50), dtype=np.uint8))


def _outline(image):
    from app.fit import silhouette_contour

    return silhouette_contour(image)


def _crosses_itself(control_points):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            ClosedBSpline(control_points)
        except ValueError:
            return True
    return False


def test_a_large_image_is_fitted_on_a_small_copy_and_the_cage_mapped_back():
    # 16x the default test picture in each direction (31 megapixels, 8x FIT_PIXELS): the same
    # ellipse scaled, fitted within a pixel of the copy, while the work stays that of the copy.
    scale = 16
    coverage = cv2.resize(ellipse_coverage(), (WIDTH * scale, HEIGHT * scale), interpolation=cv2.INTER_LINEAR)
    image = np.repeat(np.round(230 - 190 * coverage).astype(np.uint8)[..., None], 3, axis=2)
    tracemalloc.start()
    try:
        control_points = fit_cage(image, points=16)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    # Measured: 56 MiB, against 322 MiB when the full image is fitted (FIT_PIXELS = 4 Mpx).
    assert peak < 24 * FIT_PIXELS
    copy_pixel = np.sqrt(image.shape[0] * image.shape[1] / FIT_PIXELS)
    distance, _ = cKDTree(ellipse_points() * scale).query(curve_points(control_points))
    assert distance.max() < 1.5 * copy_pixel
    assert distance.mean() < 0.5 * copy_pixel


def test_downscaled_maps_pixel_edges_back_exactly():
    image = np.zeros((1000, 3001, 3), dtype=np.uint8)
    small, scale = downscaled(image, 100_000)
    assert small.shape[0] * small.shape[1] <= 100_000
    np.testing.assert_array_equal(np.array(small.shape[1::-1]) * scale, [3001, 1000])
    same, one = downscaled(image, image.shape[0] * image.shape[1])
    assert same is image and one.tolist() == [1.0, 1.0]
