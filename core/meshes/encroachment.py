"""Which points encroach on a boundary chord (lie inside its diametral circle), compiled:
`encroached_chords`, for Ruppert's rule in `core.meshes.refinement`.

The points are sorted into a grid of square cells at least as wide as the largest circle, so each
circle is checked against the points of the 3 x 3 cells around its centre only.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

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
    low = points.min(axis=0)
    extent = np.ptp(points, axis=0)
    # Cells at least a circle wide; wider where that would make more cells than 4 per point.
    cell = max(2.0 * float(radii.max()), math.sqrt(extent[0] * extent[1] / (4 * points.shape[0])))
    cell = max(cell, float(extent.max()) / (1 << 16), 1e-300)
    shape = np.floor(extent / cell).astype(np.int64) + 1
    _encroached(
        points,
        np.ascontiguousarray(centres, dtype=np.float64),
        radii * (1.0 - ON_CIRCLE),
        low,
        cell,
        shape[0],
        shape[1],
        result,
    )
    return result


@njit(cache=True)
def _encroached(points, centres, radii, low, cell, columns, rows, result):  # pragma: no cover - compiled
    """`encroached_chords` into `result` (M,), with the points in a grid of `rows` x `columns` cells
    of side `cell` from `low`."""
    count = points.shape[0]
    cell_of = np.empty(count, dtype=np.int64)
    start = np.zeros(rows * columns + 1, dtype=np.int64)
    for i in range(count):
        column = min(int((points[i, 0] - low[0]) / cell), columns - 1)
        row = min(int((points[i, 1] - low[1]) / cell), rows - 1)
        cell_of[i] = row * columns + column
        start[cell_of[i] + 1] += 1
    for c in range(rows * columns):
        start[c + 1] += start[c]
    filled = start[:-1].copy()
    members = np.empty(count, dtype=np.int64)
    for i in range(count):
        members[filled[cell_of[i]]] = i
        filled[cell_of[i]] += 1
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
