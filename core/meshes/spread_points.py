"""A well-spread subset of candidate points, compiled: `spread_points`, the circumcentres that one
round of `core.meshes.refinement` inserts (two close circumcentres of neighbouring bad triangles
would make a short edge).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from core.meshes.point_grid import grid_buckets, grid_layout


def spread_points(candidates: np.ndarray, radii: np.ndarray) -> np.ndarray:
    """The greedy subset of `candidates` (M, 2), taken in their order, each taken one blocking the
    later ones within half its radius (`radii`, (M,)) of it (on that circle too).

    Returns
    -------
    ndarray of shape (K, 2)
        The candidates taken, in their order.
    """
    if candidates.shape[0] == 0:
        return candidates
    candidates = np.ascontiguousarray(candidates, dtype=np.float64)
    reach = 0.5 * np.ascontiguousarray(radii, dtype=np.float64)
    low, cell, columns, rows = grid_layout(candidates, float(reach.max()))
    return candidates[_taken(candidates, reach, low, cell, columns, rows)]


@njit(cache=True)
def _taken(points, reach, low, cell, columns, rows):  # pragma: no cover - compiled
    """bool (M,): which points `spread_points` takes, with a grid of cells at least `reach` wide."""
    start, members = grid_buckets(points, low, cell, columns, rows)
    taken = np.zeros(points.shape[0], dtype=np.bool_)
    blocked = np.zeros(points.shape[0], dtype=np.bool_)
    for i in range(points.shape[0]):
        if blocked[i]:
            continue
        taken[i] = True
        x, y, squared = points[i, 0], points[i, 1], reach[i] * reach[i]
        column = min(int((x - low[0]) / cell), columns - 1)
        row = min(int((y - low[1]) / cell), rows - 1)
        for r in range(max(row - 1, 0), min(row + 2, rows)):
            for c in range(max(column - 1, 0), min(column + 2, columns)):
                for m in range(start[r * columns + c], start[r * columns + c + 1]):
                    j = members[m]
                    if (points[j, 0] - x) ** 2 + (points[j, 1] - y) ** 2 <= squared:
                        blocked[j] = True
    return taken
