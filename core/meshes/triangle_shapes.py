"""Sizes and shapes of triangles, compiled: `triangle_shapes` and `circumcentres`, what the
refinement of `core.meshes.refinement` measures in every round.
"""

from __future__ import annotations

import numpy as np
from numba import njit


def triangle_shapes(points: np.ndarray, simplices: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Circumradius, shortest edge and centroid of each triangle.

    Parameters
    ----------
    points : ndarray of shape (P, 2)
    simplices : ndarray of shape (T, 3), int64
        Triangles of positive area.

    Returns
    -------
    radius, shortest : ndarray of shape (T,)
    centroids : ndarray of shape (T, 2)
    """
    return _shapes(
        np.ascontiguousarray(points, dtype=np.float64), np.ascontiguousarray(simplices, dtype=np.int64)
    )


def circumcentres(points: np.ndarray, simplices: np.ndarray) -> np.ndarray:
    """Circumcentres (T, 2) of the triangles `simplices` (T, 3) of `points` (P, 2)."""
    return _centres(
        np.ascontiguousarray(points, dtype=np.float64), np.ascontiguousarray(simplices, dtype=np.int64)
    )


@njit(cache=True, error_model="numpy")  # a flat triangle: an infinite radius, not an exception
def _shapes(points, simplices):  # pragma: no cover - compiled
    """`triangle_shapes`."""
    count = simplices.shape[0]
    radius = np.empty(count)
    shortest = np.empty(count)
    centroids = np.empty((count, 2))
    for t in range(count):
        p, q, r = simplices[t, 0], simplices[t, 1], simplices[t, 2]
        a = np.sqrt((points[q, 0] - points[r, 0]) ** 2 + (points[q, 1] - points[r, 1]) ** 2)
        b = np.sqrt((points[r, 0] - points[p, 0]) ** 2 + (points[r, 1] - points[p, 1]) ** 2)
        c = np.sqrt((points[p, 0] - points[q, 0]) ** 2 + (points[p, 1] - points[q, 1]) ** 2)
        doubled = (points[q, 0] - points[p, 0]) * (points[r, 1] - points[p, 1]) - (
            points[q, 1] - points[p, 1]
        ) * (points[r, 0] - points[p, 0])
        radius[t] = a * b * c / (2.0 * abs(doubled))
        shortest[t] = min(a, b, c)
        centroids[t, 0] = (points[p, 0] + points[q, 0] + points[r, 0]) / 3.0
        centroids[t, 1] = (points[p, 1] + points[q, 1] + points[r, 1]) / 3.0
    return radius, shortest, centroids


@njit(cache=True, error_model="numpy")
def _centres(points, simplices):  # pragma: no cover - compiled
    """`circumcentres`."""
    result = np.empty((simplices.shape[0], 2))
    for t in range(simplices.shape[0]):
        ax, ay = points[simplices[t, 0], 0], points[simplices[t, 0], 1]
        bx, by = points[simplices[t, 1], 0] - ax, points[simplices[t, 1], 1] - ay
        cx, cy = points[simplices[t, 2], 0] - ax, points[simplices[t, 2], 1] - ay
        d = 2.0 * (bx * cy - by * cx)
        bb, cc = bx * bx + by * by, cx * cx + cy * cy
        result[t, 0] = ax + (cy * bb - by * cc) / d
        result[t, 1] = ay + (bx * cc - cx * bb) / d
    return result
