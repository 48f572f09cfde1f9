"""A closed uniform quadratic B-spline (Sec. 4.1) fitted to a closed outline, for `app.fit.subject`.

The n control points first solve the linear least squares problem ``B(t) P = contour``
for the outline's arc-length parameters t, with the folded basis of `core.curves.bspline`;
then a few rounds move every parameter to its foot point on the current curve and
minimise the distances to the tangent lines there, so the result fits the distance to
the curve, not to fixed parameters.  Control points closer than a pixel become sharp
corners (`snap_corners`).  Coordinates are image pixels, x right, y down.
"""

from __future__ import annotations

import numpy as np

from core import basis_weights

#: Most rounds of the tangent-distance fit after the arc-length fit.
FIT_ROUNDS = 12


#: Newton steps of the foot-point parameters per round.
FOOT_POINT_STEPS = 3


#: Weight of the tangential distance relative to the normal one.
TANGENTIAL_WEIGHT = 1e-4


#: Neighbouring control points closer than this (pixels) become a sharp corner.
CORNER_SNAP = 1.0


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


def fit_closed_bspline(
    data: np.ndarray, count: int, corners: tuple[int, ...] = (), parameters: np.ndarray | None = None
) -> np.ndarray:
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
    corners : tuple of int, optional
        Slots i whose control points are one doubled point, ``P_i = P_(i+1)``: a sharp
        corner of the curve at parameter i + 1 (`app.io.svg_cages` fits paths with corners).
    parameters : ndarray of shape (K,), optional
        The data's starting parameters in [0, n); by default their arc length, scaled to n.

    Returns
    -------
    ndarray of shape (n, 2)
        Control points; the curve may cross itself (callers check).
    """
    if parameters is None:
        steps = np.linalg.norm(np.diff(data, axis=0, append=data[:1]), axis=1)
        t = count * np.concatenate([[0.0], np.cumsum(steps)[:-1]]) / steps.sum()
    else:
        t = np.asarray(parameters, dtype=np.float64)
    # owner[slot]: the unknown point of each control point slot (a corner's two share one).
    slots = np.arange(count)
    slots[(np.asarray(corners, dtype=int) + 1) % count] = np.asarray(corners, dtype=int)
    _, owner = np.unique(slots, return_inverse=True)
    unknowns = int(owner.max()) + 1
    index, weights = basis_weights(t, count)
    control_points = _least_squares(owner[index], weights, data, unknowns)[owner]
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
        columns = np.tile(np.concatenate([owner[index], owner[index] + unknowns], axis=1), (2, 1))
        directions = np.concatenate([normal, tangential * tangent])
        both = np.tile(weights, (2, 1))
        coefficients = np.concatenate([directions[:, :1] * both, directions[:, 1:] * both], axis=1)
        right = np.sum(directions * np.concatenate([data, data]), axis=1)
        solution = _least_squares(columns, coefficients, right[:, None], 2 * unknowns)[:, 0]
        updated = np.stack([solution[:unknowns], solution[unknowns:]], axis=1)[owner]
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
