"""Fit a cage (closed uniform quadratic B-spline, Sec. 4.1) to an image's main silhouette.

The silhouette is the alpha channel when the image has a meaningful one, otherwise
the largest object against the background (Otsu threshold and morphology, with the
polarity in which the object does not touch the image border).  Its outer contour
is parameterised by arc length and the n control points solve the linear least
squares problem ``B(t) P = contour`` with the folded basis of `core.bspline`;
then a few rounds move every parameter to its foot point on the current curve and
minimise the distances to the tangent lines there, so the result fits the
distance to the curve, not to fixed parameters.

Coordinates are image pixels, x right, y down, origin at the image's top-left
corner; pixel (column i, row j) covers [i, i+1] x [j, j+1].
"""

from __future__ import annotations

import warnings

import cv2
import numpy as np
from scipy.ndimage import gaussian_filter1d

from core.bspline import ClosedBSpline, basis_weights
from core.validation import positive_int

#: Most rounds of the tangent-distance fit after the arc-length fit.
FIT_ROUNDS = 12
#: Newton steps of the foot-point parameters per round.
FOOT_POINT_STEPS = 3
#: Weight of the tangential distance relative to the normal one.
TANGENTIAL_WEIGHT = 1e-4
#: Neighbouring control points closer than this (pixels) become a sharp corner.
CORNER_SNAP = 1.0
#: Larger images are fitted on a copy of about this many pixels (2048 x 2048): the cost
#: grows with the outline's length, the cage's accuracy is a fraction of a span.
FIT_PIXELS = 1 << 22


class CageFitWarning(UserWarning):
    """The fit had to change the request (fewer points or smoothing) to stay simple."""


def fit_cage(image: np.ndarray, points: int = 16, max_pixels: int = FIT_PIXELS) -> np.ndarray:
    """Control points of a closed quadratic B-spline around the image's main silhouette.

    Parameters
    ----------
    image : ndarray of shape (H, W, 4) or (H, W, 3), uint8
        RGBA or RGB, row 0 at the top.
    points : int
        n >= 3, the number of control points.
    max_pixels : int
        An image of more pixels is fitted on a copy shrunk to about this many
        (`downscaled`), and the cage mapped back to the image's pixels.

    Returns
    -------
    ndarray of shape (m, 2), float64
        Control points in image pixels; m == points unless that curve crossed
        itself, in which case the contour is smoothed and then m is lowered until
        the curve is simple, with a `CageFitWarning` saying so.  Pairs closer
        than a pixel (of the fitted copy) are merged into sharp corners
        (`snap_corners`).

    Raises
    ------
    ValueError
        If the image holds no object or the object is too small for `points`.
    """
    points = positive_int(points, "points", minimum=3)
    image, scale = downscaled(image, positive_int(max_pixels, "max_pixels"))
    contour = silhouette_contour(image)
    if len(contour) < 3 * points:
        raise ValueError(
            f"the silhouette's outline has only {len(contour)} pixels, too few for {points} control "
            "points; use fewer points or a larger image"
        )
    length = _perimeter(contour)
    for count in range(points, 2, -1):
        for smoothing in (0.0, 0.25, 0.5, 1.0):
            # Smoothing over a fraction of one span irons out wiggles that make the
            # fit loop, without changing the shape at the scale of the spans.
            sigma = smoothing * len(contour) / count
            data = gaussian_filter1d(contour, sigma, axis=0, mode="wrap") if sigma else contour
            control_points = snap_corners(fit_closed_bspline(data, count))
            try:
                ClosedBSpline(control_points)
            except ValueError:
                continue
            if (count, smoothing) != (points, 0.0):
                remedy = [f"used {count} points"] if count != points else []
                if sigma:
                    pixels = sigma * length / len(contour) * float(np.sqrt(np.prod(scale)))
                    remedy.append(f"smoothed the outline over {pixels:.1f} px")
                warnings.warn(
                    f"the fitted curve with {points} control points crossed itself; {' and '.join(remedy)}",
                    CageFitWarning,
                    stacklevel=2,
                )
            return control_points * scale
    raise ValueError("could not fit a simple closed curve to the silhouette")


def downscaled(image: np.ndarray, max_pixels: int) -> tuple[np.ndarray, np.ndarray]:
    """`image` (H, W, C) shrunk by area averaging to at most `max_pixels` pixels.

    Returns the copy (h, w, C) (the image itself if small enough) and the scale
    (W / w, H / h), shape (2,), that maps its pixel coordinates (x right, y down,
    origin at the top-left corner) back to the image's.
    """
    height, width = image.shape[:2]
    if height * width <= max_pixels:
        return image, np.ones(2)
    factor = np.sqrt(max_pixels / (height * width))
    size = (max(1, int(width * factor)), max(1, int(height * factor)))
    small = cv2.resize(image, size, interpolation=cv2.INTER_AREA)
    return small, np.array([width / size[0], height / size[1]])


def snap_corners(control_points: np.ndarray, tolerance: float = CORNER_SNAP) -> np.ndarray:
    """Make neighbouring control points closer than `tolerance` an exact double.

    Least squares pulls two control points together at a sharp corner of the
    outline.  Less than a pixel apart they are a corner to the eye, but a curvature
    spike to the numerics; doubled exactly they are the sharp corner that
    `core.ClosedBSpline` models (Fig. 10 of the paper).  Pairs do not chain, so
    no point is repeated three times.

    Parameters
    ----------
    control_points : ndarray of shape (n, 2)
    tolerance : float
        Distance in pixels.

    Returns
    -------
    ndarray of shape (n, 2)
    """
    points = np.array(control_points, dtype=np.float64)
    count = len(points)
    taken = np.zeros(count, dtype=bool)
    for i in range(count):
        j = (i + 1) % count
        if not (taken[i] or taken[j]) and np.linalg.norm(points[i] - points[j]) < tolerance:
            points[i] = points[j] = 0.5 * (points[i] + points[j])
            taken[i] = taken[j] = True
    return points


def silhouette_mask(image: np.ndarray) -> np.ndarray:
    """The main object of the image, bool ndarray of shape (H, W).

    The alpha channel decides when it is present and not all opaque; otherwise
    the object is the largest component of an Otsu threshold, taking the polarity
    (dark or light object) whose largest component does not touch the border.
    """
    image = np.asarray(image)
    if image.dtype != np.uint8 or image.ndim != 3 or image.shape[2] not in (3, 4):
        raise ValueError(
            f"image must be an (H, W, 3) or (H, W, 4) uint8 array, got {image.dtype} {image.shape}"
        )
    if image.shape[2] == 4 and image[..., 3].min() < 255:
        candidates = [_largest_component(image[..., 3] >= 128)]
    else:
        grey = cv2.GaussianBlur(cv2.cvtColor(image[..., :3], cv2.COLOR_RGB2GRAY), (5, 5), 0)
        _, light = cv2.threshold(grey, 0, 1, cv2.THRESH_BINARY + cv2.THRESH_OTSU)
        size = max(3, (min(image.shape[:2]) // 200) | 1)
        kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (size, size))
        candidates = []
        for mask in (light, 1 - light):
            mask = cv2.morphologyEx(mask.astype(np.uint8), cv2.MORPH_OPEN, kernel)
            mask = cv2.morphologyEx(mask, cv2.MORPH_CLOSE, kernel)
            candidates.append(_largest_component(mask > 0, avoid_border=True))
    touches, area, mask = max(candidates, key=lambda c: (not c[0], c[1]))
    if area < 16:
        raise ValueError("found no object in the image (the silhouette is empty or tiny)")
    return mask


def silhouette_contour(image: np.ndarray) -> np.ndarray:
    """Outer outline of `silhouette_mask`, ndarray of shape (K, 2), image pixels.

    The points are the centres of the boundary pixels moved half a pixel outwards,
    which puts them on the edge between object and background.
    """
    mask = silhouette_mask(image).astype(np.uint8)
    contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    contour = max(contours, key=cv2.contourArea).reshape(-1, 2).astype(np.float64) + 0.5
    tangent = np.roll(contour, -2, axis=0) - np.roll(contour, 2, axis=0)
    tangent /= np.maximum(np.linalg.norm(tangent, axis=1, keepdims=True), 1e-12)
    area = 0.5 * np.sum(
        contour[:, 0] * np.roll(contour[:, 1], -1) - np.roll(contour[:, 0], -1) * contour[:, 1]
    )
    outward = np.sign(area) * np.stack([tangent[:, 1], -tangent[:, 0]], axis=1)
    return contour + 0.5 * outward


def fit_closed_bspline(data: np.ndarray, count: int) -> np.ndarray:
    """Least-squares closed uniform quadratic B-spline through a closed point sequence.

    Starts from the linear fit at arc-length parameters, then minimises the
    distance to the tangent lines at the foot points (TDM, Wang, Pottmann and Liu
    2006): plain parameter correction only creeps along the curve, this converges
    quadratically (a sampled spline is recovered to rounding in a few rounds).

    Parameters
    ----------
    data : ndarray of shape (K, 2)
        Points along a closed curve, in order, the last one followed by the first.
    count : int
        n, the number of control points.

    Returns
    -------
    ndarray of shape (n, 2)
        Control points; the curve may cross itself (callers check).
    """
    steps = np.linalg.norm(np.diff(data, axis=0, append=data[:1]), axis=1)
    t = count * np.concatenate([[0.0], np.cumsum(steps)[:-1]]) / steps.sum()
    index, weights = basis_weights(t, count)
    control_points = _least_squares(index, weights, data, count)
    extent = float(np.ptp(data, axis=0).max())
    # A small tangential term keeps the system regular where the data are noisy
    # (pixel staircases) without holding the parameters back.
    tangential = np.sqrt(TANGENTIAL_WEIGHT)
    best, best_error = control_points, np.inf
    for _ in range(FIT_ROUNDS):
        for _ in range(FOOT_POINT_STEPS):
            t = _foot_point_parameters(control_points, data, t)
        index, weights = basis_weights(t, count)
        point, first, _ = _derivatives(control_points, t)
        # On a wiggly outline (a segmented photograph) the rounds can diverge: keep the
        # control points of the smallest distance to the data, and stop once it grows.
        error = float(np.mean(np.sum((point - data) ** 2, axis=1)))
        if error > best_error:
            break
        best, best_error = control_points, error
        tangent = first / np.maximum(np.linalg.norm(first, axis=1, keepdims=True), 1e-300)
        normal = np.stack([tangent[:, 1], -tangent[:, 0]], axis=1)
        # Unknowns (x_1..x_n, y_1..y_n); a row's coefficients are direction x basis weights.
        columns = np.tile(np.concatenate([index, index + count], axis=1), (2, 1))
        directions = np.concatenate([normal, tangential * tangent])
        both = np.tile(weights, (2, 1))
        coefficients = np.concatenate([directions[:, :1] * both, directions[:, 1:] * both], axis=1)
        right = np.sum(directions * np.concatenate([data, data]), axis=1)
        solution = _least_squares(columns, coefficients, right[:, None], 2 * count)[:, 0]
        updated = np.stack([solution[:count], solution[count:]], axis=1)
        change = np.abs(updated - control_points).max()
        control_points = updated
        if change <= 1e-12 * extent:
            return control_points
    return best


def _least_squares(columns: np.ndarray, coefficients: np.ndarray, right: np.ndarray, size: int) -> np.ndarray:
    """Least-squares solution (size, d) of a sparse system through its normal equations.

    Row k of the system has the values ``coefficients[k]`` (R, m) in the columns
    ``columns[k]`` (R, m) of `size` unknowns, and right-hand sides ``right[k]``
    (R, d).  The normal equations are assembled from the m nonzeros per row in
    O(R m^2): a dense least-squares solve of the (R, size) system costs more, and
    the threads of a parallel BLAS make it slower still on a busy machine.
    """
    pairs = (columns[:, :, None] * size + columns[:, None, :]).ravel()
    products = (coefficients[:, :, None] * coefficients[:, None, :]).ravel()
    matrix = np.bincount(pairs, products, minlength=size * size).reshape(size, size)
    moments = np.stack(
        [np.bincount(columns.ravel(), (coefficients * r[:, None]).ravel(), minlength=size) for r in right.T],
        axis=1,
    )
    return np.linalg.lstsq(matrix, moments, rcond=None)[0]


def _derivatives(control_points: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """p(t), p'(t), p''(t) of the closed B-spline, each of shape (K, 2)."""
    index, weights = basis_weights(t, control_points.shape[0])
    u = (t - np.floor(t))[:, None]
    corners = control_points[index]  # (K, 3, 2)
    point = np.einsum("kj,kjd->kd", weights, corners)
    first = (u - 1) * corners[:, 0] + (1 - 2 * u) * corners[:, 1] + u * corners[:, 2]
    second = corners[:, 0] - 2 * corners[:, 1] + corners[:, 2]
    return point, first, second


def _foot_point_parameters(control_points: np.ndarray, data: np.ndarray, t: np.ndarray) -> np.ndarray:
    """One Newton step per point towards the parameter of its closest curve point."""
    point, first, second = _derivatives(control_points, t)
    difference = point - data
    gradient = np.sum(difference * first, axis=1)
    speed = np.sum(first * first, axis=1)
    curvature = speed + np.sum(difference * second, axis=1)
    # Far from a minimum the Hessian can be small or negative: fall back to the
    # Gauss-Newton term, and never move by more than half a span.
    curvature = np.where(curvature > 0.1 * speed, curvature, speed)
    step = np.clip(gradient / np.maximum(curvature, 1e-300), -0.5, 0.5)
    return np.mod(t - step, control_points.shape[0])


def _largest_component(mask: np.ndarray, *, avoid_border: bool = False) -> tuple[bool, int, np.ndarray]:
    """(touches the border, area, mask) of the largest 8-connected component.

    With `avoid_border`, components touching the border count only if no other exists.
    """
    count, labels, stats, _ = cv2.connectedComponentsWithStats(mask.astype(np.uint8), connectivity=8)
    if count <= 1:
        return True, 0, np.zeros(mask.shape, dtype=bool)
    height, width = mask.shape
    left, top = stats[1:, cv2.CC_STAT_LEFT], stats[1:, cv2.CC_STAT_TOP]
    right, bottom = left + stats[1:, cv2.CC_STAT_WIDTH], top + stats[1:, cv2.CC_STAT_HEIGHT]
    touches = (left == 0) | (top == 0) | (right == width) | (bottom == height)
    area = stats[1:, cv2.CC_STAT_AREA]
    order = np.lexsort((-area, touches)) if avoid_border else np.argsort(-area)
    best = int(order[0])
    return bool(touches[best]), int(area[best]), labels == best + 1


def _perimeter(contour: np.ndarray) -> float:
    return float(np.linalg.norm(np.diff(contour, axis=0, append=contour[:1]), axis=1).sum())
