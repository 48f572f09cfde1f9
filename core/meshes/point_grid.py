"""Points sorted into a grid of square cells, compiled (`grid_layout`, `grid_buckets`): the
neighbour searches of `core.meshes.encroachment`, `core.meshes.empty_disks`,
`core.meshes.spread_points`, `nearest_distances`, `within_reach` and `nearest_neighbours` look
only at the cells near a query.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

#: At most about this many cells per point (cells are widened where more would be needed).
CELLS_PER_POINT = 4

#: `within_reach`'s cells are this many times narrower than its reach (fewer points looked at).
WITHIN_CELLS = 4.0


def grid_layout(points: np.ndarray, least_cell: float) -> tuple[np.ndarray, float, int, int]:
    """The grid of `points` (M, 2), M >= 1, with cells at least `least_cell` wide; RuntimeError
    if a point is not finite.

    Returns
    -------
    low : ndarray of shape (2,)
        The grid's corner (the points' lowest x and y).
    cell : float
        The cells' side: `least_cell`, or wider where that would give more than
        `CELLS_PER_POINT` cells per point.
    columns, rows : int
    """
    low_x, low_y, high_x, high_y = _bounds(points)
    width, height = high_x - low_x, high_y - low_y
    if not (math.isfinite(width) and math.isfinite(height)):  # the compiled searches index by them
        raise RuntimeError("a point of the refinement is not finite (a flat triangle)")
    cell = max(least_cell, math.sqrt(width * height / (CELLS_PER_POINT * points.shape[0])))
    cell = max(cell, max(width, height) / (1 << 16), 1e-300)
    return np.array([low_x, low_y]), cell, int(width // cell) + 1, int(height // cell) + 1


@njit(cache=True)
def _bounds(points):  # pragma: no cover - compiled
    """Lowest x and y, highest x and y of the points (M, 2), NaN if one is not finite (a loop:
    numpy's reductions along the short axis cost more than the grid searches)."""
    low_x, low_y, high_x, high_y = np.inf, np.inf, -np.inf, -np.inf
    for i in range(points.shape[0]):
        x, y = points[i, 0], points[i, 1]
        if not (np.isfinite(x) and np.isfinite(y)):
            return np.nan, np.nan, np.nan, np.nan
        low_x, high_x = min(low_x, x), max(high_x, x)
        low_y, high_y = min(low_y, y), max(high_y, y)
    return low_x, low_y, high_x, high_y


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
    filled = np.empty(rows * columns, dtype=np.int64)
    for c in range(rows * columns):
        filled[c] = start[c]
    members = np.empty(count, dtype=np.int64)
    for i in range(count):
        members[filled[cell_of[i]]] = i
        filled[cell_of[i]] += 1
    return start, members


def nearest_distances(points: np.ndarray, x: np.ndarray, reach: float) -> np.ndarray:
    """Distance from each of x (M, 2) to the nearest of `points` (N, 2), N >= 1, or inf where none
    is within `reach` (on it counts) or x is not finite: ndarray of shape (M,)."""
    points = np.ascontiguousarray(points, dtype=np.float64)
    low, cell, columns, rows = grid_layout(points, reach)
    x = np.ascontiguousarray(x, dtype=np.float64).reshape(-1, 2)
    return _nearest(points, x, reach, low, cell, columns, rows)


@njit(cache=True)
def _nearest(points, x, reach, low, cell, columns, rows):  # pragma: no cover - compiled
    """`nearest_distances`, with a grid of cells at least `reach` wide."""
    start, members = grid_buckets(points, low, cell, columns, rows)
    result = np.full(x.shape[0], np.inf)
    for i in range(x.shape[0]):
        if not (np.isfinite(x[i, 0]) and np.isfinite(x[i, 1])):
            continue
        column = int(np.floor((x[i, 0] - low[0]) / cell))
        row = int(np.floor((x[i, 1] - low[1]) / cell))
        best = reach * reach
        found = False
        for r in range(max(row - 1, 0), min(row + 2, rows)):
            for c in range(max(column - 1, 0), min(column + 2, columns)):
                for m in range(start[r * columns + c], start[r * columns + c + 1]):
                    j = members[m]
                    squared = (points[j, 0] - x[i, 0]) ** 2 + (points[j, 1] - x[i, 1]) ** 2
                    if squared <= best:
                        best, found = squared, True
        if found:
            result[i] = np.sqrt(best)
    return result


def within_reach(points: np.ndarray, x: np.ndarray, reach: float) -> np.ndarray:
    """Whether one of `points` (N, 2), N >= 1, is within `reach` of each of x (M, 2) (on it counts;
    False where x is not finite): bool ndarray of shape (M,), ``nearest_distances(...) <= reach``
    but a query stops at the first point found (the sizing's grading asks it of every curve
    sample, with cells as wide as the grading's reach: a nearest search there visits many)."""
    points = np.ascontiguousarray(points, dtype=np.float64)
    low, cell, columns, rows = grid_layout(points, reach / WITHIN_CELLS)
    x = np.ascontiguousarray(x, dtype=np.float64).reshape(-1, 2)
    return _within(points, x, reach, low, cell, columns, rows)


@njit(cache=True)
def _within(points, x, reach, low, cell, columns, rows):  # pragma: no cover - compiled
    """`within_reach`, with a grid of square cells of side `cell`: the cells within `reach` of a
    query's cell are searched."""
    start, members = grid_buckets(points, low, cell, columns, rows)
    result = np.zeros(x.shape[0], dtype=np.bool_)
    bound = reach * reach
    span = int(np.ceil(reach / cell))
    for i in range(x.shape[0]):
        if not (np.isfinite(x[i, 0]) and np.isfinite(x[i, 1])):
            continue
        column = int(np.floor((x[i, 0] - low[0]) / cell))
        row = int(np.floor((x[i, 1] - low[1]) / cell))
        for r in range(max(row - span, 0), min(row + span + 1, rows)):
            for c in range(max(column - span, 0), min(column + span + 1, columns)):
                for m in range(start[r * columns + c], start[r * columns + c + 1]):
                    j = members[m]
                    if (points[j, 0] - x[i, 0]) ** 2 + (points[j, 1] - x[i, 1]) ** 2 <= bound:
                        result[i] = True
                        break
                if result[i]:
                    break
            if result[i]:
                break
    return result


def nearest_neighbours(
    points: np.ndarray, x: np.ndarray, k: int, bound: float = np.inf
) -> tuple[np.ndarray, np.ndarray]:
    """The `k` nearest of `points` (N, 2), N >= 1, within `bound` of each of x (M, 2), nearest
    first, in the layout of ``scipy.spatial.cKDTree(points).query(x, k, distance_upper_bound=bound)``.

    Returns
    -------
    distance : ndarray of shape (M, k)
        Distances, inf where fewer than k points are within `bound`.
    index : ndarray of shape (M, k), int64
        Indices into `points`, N where the distance is inf.
    """
    points = np.ascontiguousarray(points, dtype=np.float64)
    low, cell, columns, rows = grid_layout(points, 0.0)
    x = np.ascontiguousarray(x, dtype=np.float64).reshape(-1, 2)
    return _neighbours(points, x, k, float(bound), low, cell, columns, rows)


@njit(cache=True)
def _neighbours(points, x, k, bound, low, cell, columns, rows):  # pragma: no cover - compiled
    """`nearest_neighbours`: rings of cells around each query's cell, until no nearer point can
    be in the next ring (whose points are at least (ring - 1) cells away)."""
    start, members = grid_buckets(points, low, cell, columns, rows)
    distance = np.full((x.shape[0], k), np.inf)
    index = np.full((x.shape[0], k), points.shape[0], dtype=np.int64)
    for i in range(x.shape[0]):
        if not (np.isfinite(x[i, 0]) and np.isfinite(x[i, 1])):
            continue
        row0 = int(np.floor((x[i, 1] - low[1]) / cell))
        column0 = int(np.floor((x[i, 0] - low[0]) / cell))
        # The rings that can hold points: from the query's cell to the grid's far side.
        last = max(abs(row0), abs(row0 - rows + 1), abs(column0), abs(column0 - columns + 1))
        for ring in range(last + 1):
            gap = (ring - 1) * cell
            if gap > bound or gap >= distance[i, k - 1]:
                break
            for r in range(max(row0 - ring, 0), min(row0 + ring + 1, rows)):
                step = 1 if abs(r - row0) == ring else 2 * ring  # inner rows: the two ends only
                for c in range(column0 - ring, column0 + ring + 1, max(step, 1)):
                    if c < 0 or c >= columns:
                        continue
                    for m in range(start[r * columns + c], start[r * columns + c + 1]):
                        j = members[m]
                        d = np.sqrt((points[j, 0] - x[i, 0]) ** 2 + (points[j, 1] - x[i, 1]) ** 2)
                        if d > bound or d >= distance[i, k - 1]:
                            continue
                        slot = k - 1
                        while slot > 0 and distance[i, slot - 1] > d:
                            distance[i, slot] = distance[i, slot - 1]
                            index[i, slot] = index[i, slot - 1]
                            slot -= 1
                        distance[i, slot] = d
                        index[i, slot] = j
    return distance, index
