"""Diameter of a planar point set in O(N log N) time and O(N) memory.

The diameter (largest distance between two points) is attained by a pair of
antipodal vertices of the convex hull.  Rotating calipers visit every antipodal
pair: for hull edge k, the vertex farthest from its supporting line is the vertex
whose normal cone holds the edge's inward normal, found for all edges at once by
a binary search over the (monotone) outward normal angles.  Pairwise distances of
all points, which the domain checks once used, need N^2 memory: gigabytes for a
few hundred control points.
"""

from __future__ import annotations

import numpy as np

#: Largest point set whose hull is found in plain Python (`_hull`); larger ones by Qhull.
PLAIN_HULL_POINTS = 20_000
# Antipodal vertices searched on either side of the one the angles give: guards the
# search against rounding in arctan2 where consecutive hull edges are almost parallel.
_NEIGHBOURS = 2


def point_set_diameter(points: np.ndarray) -> float:
    """Largest Euclidean distance between two of `points`.

    Parameters
    ----------
    points : ndarray of shape (N, 2), float64, finite

    Returns
    -------
    float
        Exactly ``max_ij |points[i] - points[j]|`` as pairwise differences would
        compute it (the same pair, the same arithmetic), in O(N log N) time.
    """
    points = np.asarray(points, dtype=np.float64)
    if points.shape[0] < 2:
        return 0.0
    hull = _hull(points)
    if hull.shape[0] <= 3:
        return _pairwise_maximum(hull, hull)
    edges = np.roll(hull, -1, axis=0) - hull
    # Outward normal angle of each edge (hull counter-clockwise): the direction of the edge
    # turned clockwise.  Unwrapped, the angles increase by the exterior angles, 2 pi in all.
    normal = np.unwrap(np.arctan2(-edges[:, 0], edges[:, 1]))
    count = hull.shape[0]
    # Vertex k + 1 is extreme for directions between the normals of edges k and k + 1, so the
    # vertex farthest from edge k is the one whose cone holds the opposite direction.
    opposite = normal + np.pi
    cones = np.concatenate([normal, normal + 2 * np.pi])
    extreme = np.searchsorted(cones, opposite) % count
    offsets = np.arange(-_NEIGHBOURS, _NEIGHBOURS + 1)
    partners = (extreme[:, None] + offsets[None, :]) % count  # (h, 2 NEIGHBOURS + 1)
    best = 0.0
    for corner in (np.arange(count), (np.arange(count) + 1) % count):
        difference = hull[corner][:, None, :] - hull[partners]
        best = max(best, float(np.sqrt((difference**2).sum(-1).max())))
    return best


def _hull(points: np.ndarray) -> np.ndarray:
    """Convex hull vertices (h, 2), counter-clockwise; the two extreme points if degenerate.

    Up to `PLAIN_HULL_POINTS` points, Andrew's monotone chain over them sorted by (x, y), in plain
    floats: no scipy.spatial to import (a quarter of a second of a warp's start, for the cage's
    dense samples); past it, Qhull.
    """
    if len(points) > PLAIN_HULL_POINTS:
        from scipy.spatial import ConvexHull, QhullError

        try:
            return points[ConvexHull(points).vertices]
        except (QhullError, ValueError):
            hull = []
    else:
        hull = _chain(points[np.lexsort((points[:, 1], points[:, 0]))].tolist())
    if len(hull) >= 3:
        return np.asarray(hull)
    # Collinear (or coincident) points: the diameter joins the lexicographic extremes.
    order = np.lexsort((points[:, 1], points[:, 0]))
    return points[[order[0], order[-1]]]


def _chain(ranked: list) -> list:
    """The convex hull's vertices, counter-clockwise, of points [x, y] sorted by (x, y): lower then
    upper chain, collinear points left out."""

    def chain(sequence):
        kept: list = []
        for x, y in sequence:
            while len(kept) >= 2:
                (ax, ay), (bx, by) = kept[-2], kept[-1]
                if (bx - ax) * (y - ay) - (by - ay) * (x - ax) > 0:
                    break
                kept.pop()
            kept.append((x, y))
        return kept

    lower, upper = chain(ranked), chain(reversed(ranked))
    return lower[:-1] + upper[:-1]


def _pairwise_maximum(a: np.ndarray, b: np.ndarray) -> float:
    difference = a[:, None, :] - b[None, :, :]
    return float(np.sqrt((difference**2).sum(-1).max()))
