"""Which points encroach on a boundary chord (lie inside its diametral circle), compiled:
`encroached_chords`, for Ruppert's rule in `core.meshes.refinement`.

The points are sorted into a grid of square cells at least as wide as the largest circle
(`core.meshes.point_grid`), so each circle is checked against the points of the 3 x 3 cells around
its centre only.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from core.meshes.point_grid import grid_buckets, grid_layout

#: A point on a circle (to rounding) does not encroach: radii are shrunk by this share.
ON_CIRCLE = 1e-12


def encroached_chords(points: np.ndarray, centres: np.ndarray, radii: np.ndarray) -> np.ndarray:
    """For each point, a circle that holds it strictly inside, or -1.

    Parameters
    ----------
    points : ndarray of shape (M, 2)
    centres : ndarray of shape (B, 2)
        Centres of the diametral circles of the chords.
    radii : ndarray of shape (B,)

    Returns
    -------
    ndarray of shape (M,), int64
        The index of one such circle (the last), or -1.
    """
    result = np.full(points.shape[0], -1, dtype=np.int64)
    if points.shape[0] == 0 or centres.shape[0] == 0:
        return result
    points = np.ascontiguousarray(points, dtype=np.float64)
    low, cell, columns, rows = grid_layout(points, 2.0 * float(radii.max()))  # cells a circle wide
    centres = np.ascontiguousarray(centres, dtype=np.float64)
    _encroached(points, centres, radii * (1.0 - ON_CIRCLE), low, cell, columns, rows, result)
    return result


@njit(cache=True)
def _encroached(points, centres, radii, low, cell, columns, rows, result):  # pragma: no cover - compiled
    """`encroached_chords` into `result` (M,), with the points in a grid of `rows` x `columns` cells
    of side `cell` from `low`."""
    start, members = grid_buckets(points, low, cell, columns, rows)
    for j in range(centres.shape[0]):
        x, y, squared = centres[j, 0], centres[j, 1], radii[j] * radii[j]
        column = int(np.floor((x - low[0]) / cell))
        row = int(np.floor((y - low[1]) / cell))
        for r in range(max(row - 1, 0), min(row + 2, rows)):
            for c in range(max(column - 1, 0), min(column + 2, columns)):
                for m in range(start[r * columns + c], start[r * columns + c + 1]):
                    i = members[m]
                    dx, dy = points[i, 0] - x, points[i, 1] - y
                    if dx * dx + dy * dy < squared:
                        result[i] = j
