"""The closed quadratic B-spline through given points: its control points by a cyclic linear system.

A user who draws an outline clicks points *on* it.  The curve of Sec. 4.1 (closed,
uniform, quadratic) passes through none of its control points P_1..P_n; on the span
t in [j, j+1), u = t - j, it is

    p(t) = (1 - u)^2 / 2 P_j + (-2u^2 + 2u + 1) / 2 P_{j+1} + u^2 / 2 P_{j+2}

(indices cyclic, array row j holding P_{j+1} as in `core.curves.bspline`).  Its point nearest
to the control point of array row k is the middle of the span it dominates,
t = k + 1/2 (u = 1/2):

    p(k + 1/2) = (P_{k-1} + 6 P_k + P_{k+1}) / 8,                             (1)

with array rows k - 1, k, k + 1 taken mod n.  For clicked points Q_1..Q_m, one control
point per click and (1) set equal to each click gives the cyclic tridiagonal system

    P_{k-1} + 6 P_k + P_{k+1} = 8 Q_k,    k = 0..m-1 (mod m),                  (2)

strictly diagonally dominant (6 > 1 + 1), so it has one solution for every m >= 1 and
its condition number is at most (6 + 2) / (6 - 2) = 2: the control points are the
clicks' to rounding, and the curve passes through every click to rounding.

A sharp corner at a click C is the drawing's doubled control point P_k = P_{k+1} = C:
the curve passes through C at the knot t = k + 1 between them
(p(k + 1) = (P_k + P_{k+1}) / 2 = C) and turns there.  The doubled points are known,
so (2) keeps one equation and one unknown for each smooth click, with the corners'
control points moved to its right-hand side; between two corners the system is a
plain (non-cyclic) tridiagonal one, still diagonally dominant.

Coordinates are (x, y) in any frame (image pixels in the viewer).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse
import scipy.sparse.linalg

from core.validation import as_points


def interpolating_control_points(points, corners=None) -> np.ndarray:
    """Control points of the closed quadratic B-spline through `points`, in order.

    Parameters
    ----------
    points : array_like of shape (m, 2)
        The points the curve passes through, in the order it visits them, m >= 1.
    corners : array_like of bool, shape (m,), optional
        Which points are sharp corners (none by default).  A corner becomes a doubled
        control point equal to it; every other point Q_k gets one control point P_k
        solving Eq. (2) of the module docstring.

    Returns
    -------
    ndarray of shape (m + number of corners, 2)
        The control points: point k's one control point, or its two equal ones for a
        corner, in the order of `points`.  ``ClosedBSpline(result)(interpolation_parameters(corners))``
        is `points` to rounding (~1e-15 of their extent).

    Raises
    ------
    ValueError
        `points` is not a non-empty finite (m, 2) array, or `corners` does not hold one
        boolean per point.
    """
    points = as_points(points, "points", min_count=1)
    corner = _checked_corners(corners, len(points))
    # Centred on the bounding box: the solve then works on differences of positions only.
    centre = 0.5 * (points.min(axis=0) + points.max(axis=0))
    centred = points - centre
    first_row = _first_rows(corner)
    count = len(points) + int(corner.sum())
    control = np.empty((count, 2))
    control[first_row[corner]] = centred[corner]
    control[first_row[corner] + 1] = centred[corner]
    rows = first_row[~corner]
    if rows.size:
        unknown = np.full(count, -1)
        unknown[rows] = np.arange(rows.size)
        right_side = 8.0 * centred[~corner]
        equations, columns, values = [np.arange(rows.size)], [np.arange(rows.size)], [np.full(rows.size, 6.0)]
        for neighbour in ((rows - 1) % count, (rows + 1) % count):
            known = unknown[neighbour] < 0
            right_side[known] -= control[neighbour[known]]
            equations.append(np.flatnonzero(~known))
            columns.append(unknown[neighbour[~known]])
            values.append(np.ones(int((~known).sum())))
        # COO sums repeated entries: with one or two unknowns a neighbour is met twice (m = 2) or is
        # the point itself (m = 1), which is what the cyclic system (2) says.
        matrix = scipy.sparse.coo_matrix(
            (np.concatenate(values), (np.concatenate(equations), np.concatenate(columns))),
            shape=(rows.size, rows.size),
        ).tocsc()
        control[rows] = scipy.sparse.linalg.splu(matrix).solve(right_side)
    return control + centre


def interpolation_parameters(corners) -> np.ndarray:
    """Parameters t, ndarray of shape (m,), where the curve of `interpolating_control_points` passes
    through each point: k + 1/2 for a smooth point whose control point is array row k, and k + 1 for a
    corner whose doubled control points are rows k and k + 1.

    Parameters
    ----------
    corners : array_like of bool, shape (m,)
    """
    corner = _checked_corners(corners, None)
    return _first_rows(corner) + np.where(corner, 1.0, 0.5)


def _first_rows(corner: np.ndarray) -> np.ndarray:
    """The first control point's array row of each point (corners take two rows)."""
    sizes = 1 + corner.astype(np.int64)
    return np.cumsum(sizes) - sizes


def _checked_corners(corners, count: int | None) -> np.ndarray:
    if corners is None:
        return np.zeros(count, dtype=bool)
    array = np.asarray(corners)
    if array.ndim != 1 or (count is not None and array.shape[0] != count):
        expected = "one per point" if count is None else f"{count}, one per point"
        raise ValueError(f"corners must be a 1-D array of booleans ({expected}), got shape {array.shape}")
    if array.dtype != bool and not (np.issubdtype(array.dtype, np.integer) and np.isin(array, (0, 1)).all()):
        raise ValueError(f"corners must be booleans, got {array.dtype} values")
    return array.astype(bool)
