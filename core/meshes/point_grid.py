"""Points sorted into a grid of square cells, compiled (`grid_layout`, `grid_buckets`): the
neighbour searches of `core.meshes.encroachment`, `core.meshes.empty_disks` and
`core.meshes.spread_points` look only at the cells near a query.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

#: At most about this many cells per point (cells are widened where more would be needed).
CELLS_PER_POINT = 4


def grid_layout(points: np.ndarray, least_cell: float) -> tuple[np.ndarray, float, int, int]:
    """The grid of `points` (M, 2), M >= 1, with cells at least `least_cell` wide.

    Returns
    -------
    low : ndarray of shape (2,)
        The grid's corner (the points' lowest x and y).
    cell : float
        The cells' side: `least_cell`, or wider where that would give more than
        `CELLS_PER_POINT` cells per point.
    columns, rows : int
    """
    low = points.min(axis=0)
    extent = points.max(axis=0) - low
    cell = max(least_cell, math.sqrt(extent[0] * extent[1] / (CELLS_PER_POINT * points.shape[0])))
    cell = max(cell, float(extent.max()) / (1 << 16), 1e-300)
    columns, rows = (np.floor(extent / cell).astype(np.int64) + 1).tolist()
    return low, cell, columns, rows


@njit(cache=True)
def grid_buckets(points, low, cell, columns, rows):  # pragma: no cover - compiled
    """The points (M, 2) of each cell of the grid (`grid_layout`), as compressed rows.

    Returns
    -------
    start : ndarray of shape (rows * columns + 1,), int64
        The points of cell ``row * columns + column`` are ``members[start[c]:start[c + 1]]``.
    members : ndarray of shape (M,), int64
    """
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
    return start, members
