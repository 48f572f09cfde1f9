"""Exact point-in-curve and distance queries for closed piecewise-polynomial curves.

`winding_numbers` counts signed crossings of a horizontal ray with the exact
quadratic spans of a `ClosedBSpline` (roots of a quadratic per span), so points
within any distance of the curve are classified by the true curve, not a polygon.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from core.curves.boundary import PiecewisePolynomial
from core.curves.closest_parameter import closest_parameter
from core.library_threads import in_shares

# Direction (radians) of the rays of the crossing test, deliberately not a round angle.
RAY_ANGLE = 0.6180339887498949


@njit(cache=True, nogil=True, error_model="numpy")
def _winding(coefficients, points, out, first, shares):
    """The winding numbers of `winding_numbers` into out (M,), for the points first, first + shares,
    ... (`core.library_threads.in_shares`)."""
    pieces = coefficients.shape[0]
    for m in range(first, points.shape[0], shares):
        x = points[m, 0]
        y = points[m, 1]
        winding = 0
        for k in range(pieces):
            c0x = coefficients[k, 0, 0]
            c1x = coefficients[k, 1, 0]
            c2x = coefficients[k, 2, 0]
            c0y = coefficients[k, 0, 1] - y
            c1y = coefficients[k, 1, 1]
            c2y = coefficients[k, 2, 1]
            # Bounding box of the span (its Bezier hull) for a quick rejection.
            y0 = c0y
            y1 = c0y + 0.5 * c1y
            y2 = c0y + c1y + c2y
            if (y0 > 0 and y1 > 0 and y2 > 0) or (y0 < 0 and y1 < 0 and y2 < 0):
                continue
            roots = np.empty(2)
            count = 0
            if c2y == 0.0:
                if c1y != 0.0:
                    roots[0] = -c0y / c1y
                    count = 1
            else:
                discriminant = c1y * c1y - 4.0 * c2y * c0y
                if discriminant > 0.0:
                    sq = math.sqrt(discriminant)
                    # Numerically stable pair of roots.
                    q = -0.5 * (c1y + (sq if c1y >= 0 else -sq))
                    roots[0] = q / c2y
                    roots[1] = c0y / q if q != 0.0 else roots[0]
                    count = 2
            for i in range(count):
                u = roots[i]
                if u < 0.0 or u >= 1.0:
                    continue
                px = c0x + u * (c1x + u * c2x)
                if px <= x:
                    continue
                slope = c1y + 2.0 * c2y * u
                if slope > 0:
                    winding += 1
                elif slope < 0:
                    winding -= 1
        out[m] = winding


def winding_numbers(curve: PiecewisePolynomial, points: np.ndarray) -> np.ndarray:
    """Winding number of the quadratic curve around each point, int ndarray of shape (M,)."""
    if curve.coefficients.shape[1] != 3:
        raise ValueError("winding_numbers needs a quadratic piecewise polynomial")
    # Cast the ray in a direction no cage is likely to align with (horizontal edges
    # and zero-speed corners are common in hand-made cages): rotate the frame.
    rotation = np.array([[np.cos(RAY_ANGLE), np.sin(RAY_ANGLE)], [-np.sin(RAY_ANGLE), np.cos(RAY_ANGLE)]])
    coefficients = np.ascontiguousarray(curve.coefficients @ rotation.T)
    rotated = np.ascontiguousarray(np.asarray(points, dtype=np.float64) @ rotation.T)
    out = np.zeros(points.shape[0], dtype=np.int64)
    in_shares(_winding, rotated.shape[0], coefficients, rotated, out)
    return out


@njit(cache=True, nogil=True, error_model="numpy")
def _distances(coefficients, piece_length, points, out_t, out_d, first, shares):
    """The closest parameters and distances of `closest_parameters` into out_t and out_d (M,), for
    the points first, first + shares, ... (`core.library_threads.in_shares`)."""
    pieces = coefficients.shape[0]
    for m in range(first, points.shape[0], shares):
        best = 1e300
        best_t = 0.0
        for k in range(pieces):
            t, d = closest_parameter(
                coefficients,
                piece_length,
                points[m, 0],
                points[m, 1],
                k * piece_length,
                (k + 1) * piece_length,
            )
            if d < best:
                best = d
                best_t = t
        out_t[m] = best_t
        out_d[m] = best


def closest_parameters(curve: PiecewisePolynomial, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Closest curve parameter and distance for each point, two ndarrays of shape (M,)."""
    # Writeable, as numba compiled it: a read-only array (a curve's own points are) is another type,
    # and would be compiled again at its first use, outside the installed cache.
    points = np.require(np.asarray(points, dtype=np.float64).reshape(-1, 2), requirements="CW")
    out_t = np.zeros(points.shape[0])
    out_d = np.zeros(points.shape[0])
    in_shares(_distances, points.shape[0], curve.coefficients, curve.piece_length, points, out_t, out_d)
    return np.mod(out_t, curve.period), out_d


def distance_to_curve(curve: PiecewisePolynomial, points: np.ndarray) -> np.ndarray:
    """Distance from each point (M, 2) to the curve, ndarray of shape (M,)."""
    return closest_parameters(curve, points)[1]
