"""Laplacian smoothing that keeps triangles valid, compiled: `smoothing_pass`, a step of
`core.triangulate` (`core.meshes.refinement.Refinement.smooth`).

Each movable point moves to the mean of its neighbours; moves that would leave a triangle with
less than `KEPT_AREA` of its area before the pass are undone (every corner of such a triangle goes
back), repeatedly, so every triangle stays counter-clockwise.
"""

from __future__ import annotations

import numpy as np
from numba import njit

#: Share of its area before a pass that every triangle keeps.
KEPT_AREA = 0.1
#: Rounds of undoing moves per pass.
UNDO_ROUNDS = 20


def smoothing_pass(points: np.ndarray, simplices: np.ndarray, movable: np.ndarray) -> np.ndarray:
    """One smoothing pass (module doc).

    Parameters
    ----------
    points : ndarray of shape (P, 2)
    simplices : ndarray of shape (T, 3), int64
        Counter-clockwise triangles.
    movable : ndarray of shape (P,), bool
        Points free to move; each must be an interior vertex of the triangles (every edge at it
        is a side of two triangles), so the mean over its triangles' other corners is the mean
        of its neighbours.

    Returns
    -------
    ndarray of shape (P, 2)
        The points after the pass.
    """
    return _smoothing_pass(
        np.ascontiguousarray(points, dtype=np.float64),
        np.ascontiguousarray(simplices, dtype=np.int64),
        np.ascontiguousarray(movable, dtype=np.bool_),
    )


@njit(cache=True)
def _doubled_area(points, simplices, t):  # pragma: no cover - compiled
    a, b, c = simplices[t, 0], simplices[t, 1], simplices[t, 2]
    return (points[b, 0] - points[a, 0]) * (points[c, 1] - points[a, 1]) - (points[b, 1] - points[a, 1]) * (
        points[c, 0] - points[a, 0]
    )


@njit(cache=True)
def _smoothing_pass(points, simplices, movable):  # pragma: no cover - compiled
    """`smoothing_pass`."""
    count = points.shape[0]
    total = np.zeros((count, 2))
    incidences = np.zeros(count, dtype=np.int64)
    for t in range(simplices.shape[0]):
        for k in range(3):
            v = simplices[t, k]
            for j in range(1, 3):
                u = simplices[t, (k + j) % 3]
                total[v, 0] += points[u, 0]
                total[v, 1] += points[u, 1]
            incidences[v] += 2
    moved = points.copy()
    for v in range(count):
        if movable[v] and incidences[v] > 0:
            moved[v, 0] = total[v, 0] / incidences[v]
            moved[v, 1] = total[v, 1] / incidences[v]
    for _ in range(UNDO_ROUNDS):
        undone = False
        for t in range(simplices.shape[0]):
            if _doubled_area(moved, simplices, t) < KEPT_AREA * _doubled_area(points, simplices, t):
                undone = True
                for k in range(3):
                    v = simplices[t, k]
                    moved[v, 0], moved[v, 1] = points[v, 0], points[v, 1]
        if not undone:
            break
    return moved
