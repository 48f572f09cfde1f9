"""Fit a cage (closed uniform quadratic B-spline, Sec. 4.1) around the main subject of an image.

The subject is `app.subject.subject_mask`'s: an alpha channel, a silhouette on a plain
background, or the subject of a photograph found by GrabCut and refined.  The cage goes
`SUBJECT_MARGIN` outside a photograph's subject, because a segmentation is uncertain by a
few pixels and a cage that cuts into the subject tears it when deformed, while a thin band
of background inside the cage just moves along.

A photograph's subject is uncertain when it is tiny or when colour hardly tells it
from the background around it (`app.subject.colour_separation`): `fit_cage` then warns.
With a rectangle from the user there is always a cage, inside it: the rectangle itself
when nothing stands out there.

Alpha channels and plain silhouettes are exact to the pixel and get no margin.  The
outer contour of the subject is parameterised by arc length and the n control
points solve the linear least squares problem ``B(t) P = contour`` with the folded
basis of `core.bspline`; then a few rounds move every parameter to its foot point
on the current curve and minimise the distances to the tangent lines there, so
the result fits the distance to the curve, not to fixed parameters.

Coordinates are image pixels, x right, y down, origin at the image's top-left
corner; pixel (column i, row j) covers [i, i+1] x [j, j+1].  A rectangle is
(x, y, width, height) in the same pixels.
"""

from __future__ import annotations

import warnings

import cv2
import numpy as np
from scipy.ndimage import gaussian_filter1d

from app.subject import checked_image, checked_rect, colour_separation, downscaled, find_subject, grown
from core.bspline import ClosedBSpline, basis_weights
from core.mesh_basis import DEFAULT_SAMPLES_PER_SEGMENT
from core.validation import MAX_BOUNDARY_SAMPLES, positive_int

#: Most rounds of the tangent-distance fit after the arc-length fit.
FIT_ROUNDS = 12
#: Most control points of a fitted cage: what the kernels sample at their default density.
MAX_POINTS = MAX_BOUNDARY_SAMPLES // DEFAULT_SAMPLES_PER_SEGMENT
#: Newton steps of the foot-point parameters per round.
FOOT_POINT_STEPS = 3
#: Weight of the tangential distance relative to the normal one.
TANGENTIAL_WEIGHT = 1e-4
#: Neighbouring control points closer than this (pixels) become a sharp corner.
CORNER_SNAP = 1.0
#: Larger images are fitted on a copy of about this many pixels (2048 x 2048): the cost
#: grows with the outline's length, the cage's accuracy is a fraction of a span.
FIT_PIXELS = 1 << 22
#: A subject of less than `SMALL_SUBJECT` of the picture (or rectangle), or whose colours
#: and those of the background around it tell them apart for less than `SEPARATION` of
#: their pixels (`app.subject.colour_separation`), is uncertain: `fit_cage` warns
#: (`SubjectUncertainWarning`).  Measured on scikit-image's photographs: 0.82 to 0.99
#: where the cage holds the subject (chelsea 0.82, astronaut 0.88), 0.71 to 0.74 on the
#: cameraman, the motorcycle and the coins, whose cages miss much of them, 0.64 and 0.50
#: on the Hubble deep field and the moon, which have no single subject.
SMALL_SUBJECT = 0.01
SEPARATION = 0.78
#: The cage of a segmented subject goes around it grown by this fraction of the
#: diagonal of its bounding box.
SUBJECT_MARGIN = 0.015


class CageFitWarning(UserWarning):
    """The fit had to change the request (fewer points or smoothing) to stay simple."""


class SubjectUncertainWarning(UserWarning):
    """The subject of a photograph is uncertain: the cage may hold the wrong thing."""


def fit_cage(
    image: np.ndarray,
    points: int = 16,
    rect=None,
    max_pixels: int = FIT_PIXELS,
) -> np.ndarray:
    """Control points of a closed quadratic B-spline around the image's main subject.

    Parameters
    ----------
    image : ndarray of shape (H, W, 4) or (H, W, 3), uint8
        RGBA or RGB, row 0 at the top.
    points : int
        n >= 3, the number of control points.
    rect : sequence of 4 numbers (x, y, width, height), optional
        Where the subject is, in image pixels; it must lie inside the image.  Only
        what is inside is considered.  Default: the whole image (for a photograph,
        all but a frame of `DEFAULT_INSET` of each side).
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
        (`snap_corners`).  The curve follows the outline of `subject_mask`, grown
        by `SUBJECT_MARGIN` when the subject was segmented from a photograph.
        With `rect` the curve always lies inside it: its control points are held
        there, and when nothing stands out in it (a texture), or what does has
        too short an outline, the cage is the rectangle (`rectangle_cage`).

    Warns
    -----
    SubjectUncertainWarning
        When the subject of a photograph is uncertain (`_warn_if_uncertain`), or
        the cage is the rectangle because nothing stood out in it.
    CageFitWarning
        When the request was changed to keep the curve simple.

    Raises
    ------
    ValueError
        If the image or the rectangle is invalid, or, without `rect`, the image
        holds no object or the object is too small for `points`.
    """
    points = positive_int(points, "points", minimum=3)
    if points > MAX_POINTS:
        raise ValueError(
            f"points={points:,} is more than the {MAX_POINTS:,} control points the kernels sample at "
            f"{DEFAULT_SAMPLES_PER_SEGMENT} per span; use 3 <= points <= {MAX_POINTS:,}"
        )
    image = checked_image(image)
    rect = checked_rect(rect, image.shape[1], image.shape[0])
    image, scale = downscaled(image, positive_int(max_pixels, "max_pixels"))
    region = None if rect is None else rect / np.tile(scale, 2)
    mask, exact = find_subject(image, region)
    if mask is None:
        warnings.warn(
            "the subject is uncertain: nothing stands out inside the rectangle, so the cage is the rectangle",
            SubjectUncertainWarning,
            stacklevel=2,
        )
        return rectangle_cage(rect, points)
    if not exact:
        _warn_if_uncertain(image, mask, region)
        mask = grown(mask, SUBJECT_MARGIN)
    contour = mask_outline(mask)
    if len(contour) < 3 * points:
        if region is not None:
            warnings.warn(
                f"the subject's outline in the rectangle has only {len(contour)} pixels, too few for "
                f"{points} control points: the cage is the rectangle",
                CageFitWarning,
                stacklevel=2,
            )
            return rectangle_cage(rect, points)
        raise ValueError(
            f"the subject's outline has only {len(contour)} pixels, too few for {points} control "
            "points; use fewer points or a larger image"
        )
    control_points = _simple_fit(contour, points, region, float(np.sqrt(np.prod(scale))))
    if control_points is not None:
        if rect is None:
            return control_points * scale
        return np.clip(control_points * scale, rect[:2], rect[:2] + rect[2:])
    if region is not None:
        warnings.warn(
            "no simple curve fits the subject: the cage is the rectangle", CageFitWarning, stacklevel=2
        )
        return rectangle_cage(rect, points)
    raise ValueError("could not fit a simple closed curve to the subject")


def _simple_fit(
    contour: np.ndarray, points: int, region: np.ndarray | None, pixel: float
) -> np.ndarray | None:
    """Control points (m, 2) of a simple closed curve fitted to `contour` (K, 2), or None.

    The first of `points`, `points` - 1, ... 3 control points and of growing smoothings of the
    contour whose curve does not cross itself, held inside `region` (x, y, width, height) if
    given; a `CageFitWarning` says what was given up.  `pixel` is the side of one pixel of the
    contour's copy in image pixels (to report the smoothing in them).
    """
    length = _perimeter(contour)
    for count in range(points, 2, -1):
        for smoothing in (0.0, 0.25, 0.5, 1.0):
            # Smoothing over a fraction of one span irons out wiggles that make the
            # fit loop, without changing the shape at the scale of the spans.
            sigma = smoothing * len(contour) / count
            data = gaussian_filter1d(contour, sigma, axis=0, mode="wrap") if sigma else contour
            control_points = snap_corners(fit_closed_bspline(data, count))
            if region is not None:
                # Each span lies in the convex hull of its three control points: with them
                # in the rectangle, so is the whole curve.
                control_points = np.clip(control_points, region[:2], region[:2] + region[2:])
            try:
                ClosedBSpline(control_points)
            except ValueError:
                continue
            if (count, smoothing) != (points, 0.0):
                remedy = [f"used {count} points"] if count != points else []
                if sigma:
                    remedy.append(f"smoothed the outline over {sigma * length / len(contour) * pixel:.1f} px")
                warnings.warn(
                    f"the fitted curve with {points} control points crossed itself; {' and '.join(remedy)}",
                    CageFitWarning,
                    stacklevel=3,
                )
            return control_points
    return None


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


def _warn_if_uncertain(image: np.ndarray, subject: np.ndarray, rect: np.ndarray | None) -> None:
    """`SubjectUncertainWarning` when the photograph's `subject` (H, W) bool is small (`SMALL_SUBJECT`)
    or hardly told apart from the background by colour (`SEPARATION`)."""
    height, width = image.shape[:2]
    where = "the picture" if rect is None else "the rectangle"
    share = subject.sum() / (height * width if rect is None else rect[2] * rect[3])
    reasons = []
    if share < SMALL_SUBJECT:
        reasons.append(f"what was found covers only {100 * share:.1f} % of {where}")
    separation = colour_separation(image, subject)
    if separation < SEPARATION:
        reasons.append(
            f"colour tells it from the background around it for only {100 * separation:.0f} % of pixels"
        )
    if reasons:
        advice = "a tighter rectangle" if rect is not None else "a rectangle around the subject (fit --rect)"
        warnings.warn(
            f"the subject is uncertain: {' and '.join(reasons)}; check the cage, or give {advice}",
            SubjectUncertainWarning,
            stacklevel=3,
        )


def rectangle_cage(rect, points: int = 16) -> np.ndarray:
    """The rectangle (x, y, width, height), image pixels, as a cage of `points` control points.

    With `points` >= 8 the curve is the rectangle itself: its corners doubled (sharp)
    and the other points on its sides, spread in proportion to their lengths.  With
    fewer, the four corners once each: a rounded rectangle inside it, through the
    sides' midpoints.

    Returns
    -------
    ndarray of shape (max(points, 8), 2) or (4, 2), float64
    """
    x, y, width, height = (float(v) for v in rect)
    corners = np.array([[x, y], [x + width, y], [x + width, y + height], [x, y + height]])
    if points < 8:
        return corners
    lengths = np.array([width, height, width, height])
    extra = points - 8
    shares = extra * lengths / lengths.sum()
    counts = np.floor(shares).astype(int)
    counts[np.argsort(counts - shares)[: extra - counts.sum()]] += 1  # largest remainders
    result = []
    for corner, following, count in zip(corners, np.roll(corners, -1, axis=0), counts, strict=True):
        result += [corner, corner]
        result += [corner + (following - corner) * k / (count + 1) for k in range(1, count + 1)]
    return np.array(result)


def mask_outline(mask: np.ndarray) -> np.ndarray:
    """Outer outline of the largest region of `mask` (H, W), ndarray of shape (K, 2), image pixels.

    The points are the centres of the boundary pixels moved half a pixel outwards,
    which puts them on the edge between object and background.
    """
    contours, _ = cv2.findContours(mask.astype(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
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


def _perimeter(contour: np.ndarray) -> float:
    return float(np.linalg.norm(np.diff(contour, axis=0, append=contour[:1]), axis=1).sum())
