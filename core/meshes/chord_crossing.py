"""The boundary chord that hides a point from a triangle, compiled: `first_chords_crossed`, for
the circumcentre insertions of `core.meshes.refinement`.

Ruppert's rule: a bad triangle's circumcentre is inserted only if no boundary chord separates it
from the triangle; otherwise the chord that does is split.  The straight walk from the triangle's
centroid toward the circumcentre, across the sides of the band's triangulation, finds the first
chord crossed, or the triangle that holds the circumcentre.
"""

from __future__ import annotations

import numpy as np
from numba import njit


def first_chords_crossed(
    points: np.ndarray, simplices: np.ndarray, neighbors: np.ndarray, chord: np.ndarray, starts: np.ndarray,
    targets: np.ndarray,
) -> np.ndarray:  # fmt: skip
    """For each triangle of `starts`, the first boundary chord that the segment from its centroid
    to its target crosses, or -1 if none does.

    Parameters
    ----------
    points : ndarray of shape (N, 2)
    simplices, neighbors : ndarray of shape (T, 3), int64
        A triangulation with counter-clockwise triangles (`core.meshes.delaunay.Triangulation`;
        the triangles that the walks cross must be counter-clockwise).
    chord : ndarray of shape (T, 3), int64
        The boundary chord that each side is, or -1 (`core.meshes.band_regions.band_sides`).
    starts : ndarray of shape (M,), int64
        Triangles to walk from.
    targets : ndarray of shape (M, 2)
        Points to walk to.

    Returns
    -------
    ndarray of shape (M,), int64
        A chord that the walk met first (a side of the triangulation crossed), or -1 where the walk
        reached its target's triangle, or ran off the triangulation (only possible outside every
        chord, which is crossed first).
    """
    return _walks(
        np.ascontiguousarray(points, dtype=np.float64), simplices, neighbors, chord,
        np.ascontiguousarray(starts, dtype=np.int64), np.ascontiguousarray(targets, dtype=np.float64),
    )  # fmt: skip


@njit(cache=True)
def _walks(points, simplices, neighbors, chord, starts, targets):  # pragma: no cover - compiled
    """`first_chords_crossed`."""
    result = np.full(starts.size, -1, dtype=np.int64)
    for i in range(starts.size):
        t = starts[i]
        ox = (points[simplices[t, 0], 0] + points[simplices[t, 1], 0] + points[simplices[t, 2], 0]) / 3.0
        oy = (points[simplices[t, 0], 1] + points[simplices[t, 1], 1] + points[simplices[t, 2], 1]) / 3.0
        qx, qy = targets[i, 0], targets[i, 1]
        dx, dy = qx - ox, qy - oy
        for _ in range(simplices.shape[0]):
            side = -1
            for k in range(3):
                a, b = simplices[t, (k + 1) % 3], simplices[t, (k + 2) % 3]
                ax, ay, bx, by = points[a, 0], points[a, 1], points[b, 0], points[b, 1]
                beyond = (bx - ax) * (qy - ay) - (by - ay) * (qx - ax) < 0.0  # q right of a -> b
                a_right = dx * (ay - oy) - dy * (ax - ox) <= 0.0
                b_left = dx * (by - oy) - dy * (bx - ox) >= 0.0
                if beyond and a_right and b_left:
                    side = k
                    break
            if side < 0:  # the target is in t
                break
            if chord[t, side] >= 0:
                result[i] = chord[t, side]
                break
            t = neighbors[t, side]
            if t < 0:
                break
    return result
