"""Delaunay triangulation of a planar point set, compiled: `delaunay` (the band's triangulation in
`core.meshes.refinement`).

Bowyer-Watson insertion: the points, in the order of a Hilbert curve through them (each point
lands near the one before, so the walk that finds its triangle is short), are inserted one by
one into a triangulation that starts as one large triangle around them; the triangles whose
open circumdisk holds the new point (the cavity, grown from the triangle that holds it across
neighbours) are replaced by a fan of triangles from the point to the cavity's border.  The
cavity is kept star-shaped from the point even where rounding errors in the in-circle test
would make it not so (a triangle whose border edge the point does not see strictly is left
out), so every triangle stays counter-clockwise.  The triangles with a corner of the
initial triangle are dropped at the end.

The predicates are in floating point, not exact: on cocircular points either diagonal may come
out, which is still a Delaunay triangulation.  Coordinates are (x, y), counter-clockwise in a
y-up frame.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

#: Side of the Hilbert grid that orders the insertions (cells per side: 2 ** HILBERT_ORDER).
HILBERT_ORDER = 10
#: The initial triangle's corners lie this many times the points' extent from their centre.
ENCLOSING_SCALE = 64.0


class Triangulation(NamedTuple):
    """A Delaunay triangulation (`delaunay`).

    Attributes
    ----------
    points : ndarray of shape (N, 2), float64
        The points triangulated.
    simplices : ndarray of shape (T, 3), int64
        Indices into `points`, each triangle counter-clockwise (y up).
    neighbors : ndarray of shape (T, 3), int64
        ``neighbors[t, k]`` is the triangle across the side opposite corner k of triangle t, or
        -1 on the border: the convex hull, but for thin slivers along it that the initial
        triangle, far but not infinitely so, may leave out.
    duplicates : ndarray of shape (D,), int64
        Indices of the points left out, each equal to a point of the triangulation.
    """

    points: np.ndarray
    simplices: np.ndarray
    neighbors: np.ndarray
    duplicates: np.ndarray


def delaunay(points: np.ndarray) -> Triangulation:
    """Delaunay triangulation of `points` (N, 2), at least one; points equal to an earlier one
    are left out (listed in its `duplicates`).  The refinement puts a ring of far points around
    the domain, so the hull's slivers never concern it."""
    points = np.ascontiguousarray(points, dtype=np.float64)
    return Triangulation(points, *_triangulate(points, _hilbert_order(points)))


def _hilbert_order(points: np.ndarray) -> np.ndarray:
    """Permutation (N,) of the points along a Hilbert curve over their bounding box."""
    return np.argsort(_hilbert_keys(points, HILBERT_ORDER), kind="stable")


@njit(cache=True)
def _hilbert_keys(points, order):  # pragma: no cover - compiled
    """Distance along the Hilbert curve of a 2 ** order grid over the points' (N, 2) bounding box
    of the cell of each point."""
    low_x, low_y, high_x, high_y = np.inf, np.inf, -np.inf, -np.inf
    for i in range(points.shape[0]):
        low_x, high_x = min(low_x, points[i, 0]), max(high_x, points[i, 0])
        low_y, high_y = min(low_y, points[i, 1]), max(high_y, points[i, 1])
    side = (1 << order) - 1
    scale = side / max(high_x - low_x, high_y - low_y, 1e-300)
    keys = np.empty(points.shape[0], dtype=np.int64)
    n = 1 << order
    for i in range(points.shape[0]):
        cx = min(int((points[i, 0] - low_x) * scale), side)
        cy = min(int((points[i, 1] - low_y) * scale), side)
        key = 0
        s = n >> 1
        while s > 0:
            rx = 1 if (cx & s) > 0 else 0
            ry = 1 if (cy & s) > 0 else 0
            key += s * s * ((3 * rx) ^ ry)
            if ry == 0:  # rotate the quadrant
                if rx == 1:
                    cx = s - 1 - cx
                    cy = s - 1 - cy
                cx, cy = cy, cx
            s >>= 1
        keys[i] = key
    return keys


@njit(cache=True)
def _orientation(px, py, ax, ay, bx, by):  # pragma: no cover - compiled
    """Twice the signed area of (p, a, b): > 0 when counter-clockwise."""
    return (ax - px) * (by - py) - (ay - py) * (bx - px)


@njit(cache=True)
def _in_circumdisk(xy, corners, qx, qy):  # pragma: no cover - compiled
    """> 0 when (qx, qy) is inside the circumdisk of the counter-clockwise triangle `corners`."""
    ax, ay = xy[corners[0], 0] - qx, xy[corners[0], 1] - qy
    bx, by = xy[corners[1], 0] - qx, xy[corners[1], 1] - qy
    cx, cy = xy[corners[2], 0] - qx, xy[corners[2], 1] - qy
    return (
        (ax * ax + ay * ay) * (bx * cy - by * cx)
        - (bx * bx + by * by) * (ax * cy - ay * cx)
        + (cx * cx + cy * cy) * (ax * by - ay * bx)
    )


@njit(cache=True)
def _locate(xy, corners, neighbors, triangles, start, qx, qy):  # pragma: no cover - compiled
    """One of the first `triangles` triangles that holds (qx, qy) (on its sides counts), by a
    visibility walk from `start`; -1 if the walk (rounding errors) has not ended after as many
    steps as triangles."""
    t = start
    for step in range(triangles + 16):
        moved = False
        for shift in range(3):
            k = (step + shift) % 3  # a rotating first side keeps the walk from cycling
            a, b = corners[t, (k + 1) % 3], corners[t, (k + 2) % 3]
            if _orientation(qx, qy, xy[a, 0], xy[a, 1], xy[b, 0], xy[b, 1]) < 0.0 and neighbors[t, k] >= 0:
                t = neighbors[t, k]
                moved = True
                break
        if not moved:
            return t
    return -1


@njit(cache=True)
def _cavity(xy, corners, neighbors, seed, q, mark, stamp, cavity):  # pragma: no cover - compiled
    """Fill `cavity` with the triangles to replace by the fan from point q; returns their count.

    Grown from `seed` across sides into triangles whose circumdisk holds q and whose far side q
    sees strictly (`mark[t] == stamp` for those taken).
    """
    qx, qy = xy[q, 0], xy[q, 1]
    mark[seed] = stamp
    cavity[0] = seed
    size, head = 1, 0
    while head < size:
        t = cavity[head]
        head += 1
        for k in range(3):
            u = neighbors[t, k]
            if u < 0 or mark[u] == stamp or _in_circumdisk(xy, corners[u], qx, qy) <= 0.0:
                continue
            visible = True
            for j in range(3):  # u's sides other than the one it shares with t
                if neighbors[u, j] == t:
                    continue
                a, b = corners[u, (j + 1) % 3], corners[u, (j + 2) % 3]
                if _orientation(qx, qy, xy[a, 0], xy[a, 1], xy[b, 0], xy[b, 1]) <= 0.0:
                    visible = False
            if visible:
                mark[u] = stamp
                cavity[size] = u
                size += 1
    return size


@njit(cache=True)
def _triangulate(points, order):  # pragma: no cover - compiled
    """`delaunay` of `points` (N, 2) inserted in `order` (N,)."""
    count = points.shape[0]
    xy = np.empty((count + 3, 2))
    low_x, low_y, high_x, high_y = np.inf, np.inf, -np.inf, -np.inf
    for i in range(count):  # loops, not slices and reductions: those cost seconds of compilation
        xy[i, 0], xy[i, 1] = points[i, 0], points[i, 1]
        low_x, high_x = min(low_x, points[i, 0]), max(high_x, points[i, 0])
        low_y, high_y = min(low_y, points[i, 1]), max(high_y, points[i, 1])
    centre_x, centre_y = 0.5 * (low_x + high_x), 0.5 * (low_y + high_y)
    reach = ENCLOSING_SCALE * max(high_x - low_x, high_y - low_y, 1e-300)
    for k in range(3):
        angle = 2.0 * np.pi * k / 3.0 + 0.5 * np.pi
        xy[count + k, 0] = centre_x + reach * np.cos(angle)
        xy[count + k, 1] = centre_y + reach * np.sin(angle)
    capacity = 2 * count + 8  # a triangulation of count + 3 points, 3 on its hull, has 2 count + 1
    corners = np.empty((capacity, 3), dtype=np.int64)
    neighbors = np.full((capacity, 3), -1, dtype=np.int64)
    corners[0, 0], corners[0, 1], corners[0, 2] = count, count + 1, count + 2
    # np.int64, not 1 and 0: numba would compile _locate and _without_enclosing for the constants
    # first and for int64 again once the loop changes them (~0.8 CPU-s of the mesher's compile).
    triangles = np.int64(1)
    mark = np.zeros(capacity, dtype=np.int64)
    cavity = np.empty(capacity, dtype=np.int64)
    fan_of = np.full(count + 3, -1, dtype=np.int64)  # the new triangle (q, v, .) of a border vertex v
    border = np.empty((capacity, 3), dtype=np.int64)  # (a, b, triangle outside) of the cavity
    duplicates = np.empty(count, dtype=np.int64)
    duplicate_count = 0
    last = np.int64(0)
    for stamp in range(1, count + 1):
        q = order[stamp - 1]
        qx, qy = xy[q, 0], xy[q, 1]
        seed = _locate(xy, corners, neighbors, triangles, last, qx, qy)
        if seed < 0:  # the walk cycled (rounding): look at every triangle
            for t in range(triangles):
                if _holds(xy, corners[t], qx, qy):
                    seed = t
                    break
        equal = False
        for k in range(3):
            v = corners[seed, k]
            equal = equal or (xy[v, 0] == qx and xy[v, 1] == qy)
        if equal:
            duplicates[duplicate_count] = q
            duplicate_count += 1
            continue
        size = _cavity(xy, corners, neighbors, seed, q, mark, stamp, cavity)
        edges = 0
        for i in range(size):
            t = cavity[i]
            for k in range(3):
                u = neighbors[t, k]
                if u < 0 or mark[u] != stamp:
                    border[edges, 0] = corners[t, (k + 1) % 3]
                    border[edges, 1] = corners[t, (k + 2) % 3]
                    border[edges, 2] = u
                    edges += 1
        for e in range(edges):  # the fan reuses the cavity's slots first
            t = cavity[e] if e < size else triangles + e - size
            a, b, outside = border[e, 0], border[e, 1], border[e, 2]
            corners[t, 0], corners[t, 1], corners[t, 2] = q, a, b
            neighbors[t, 0] = outside
            if outside >= 0:
                for j in range(3):
                    if corners[outside, (j + 1) % 3] == b and corners[outside, (j + 2) % 3] == a:
                        neighbors[outside, j] = t
            mark[t] = 0
            fan_of[a] = t
        for e in range(edges):
            t = cavity[e] if e < size else triangles + e - size
            following = fan_of[corners[t, 2]]
            neighbors[t, 1] = following
            neighbors[following, 2] = t
        triangles += max(edges - size, 0)
        last = cavity[0]
    simplices, adjacent = _without_enclosing(corners, neighbors, triangles, count)
    return simplices, adjacent, duplicates[:duplicate_count]


@njit(cache=True)
def _without_enclosing(corners, neighbors, triangles, count):  # pragma: no cover - compiled
    """The first `triangles` triangles (T, 3) and their neighbours (T, 3) without those with a
    corner >= count (the initial triangle's), renumbered; sides they shared become hull sides (-1)."""
    index = np.full(triangles, -1, dtype=np.int64)
    kept = 0
    for t in range(triangles):
        if corners[t, 0] < count and corners[t, 1] < count and corners[t, 2] < count:
            index[t] = kept
            kept += 1
    simplices = np.empty((kept, 3), dtype=np.int64)
    adjacent = np.empty((kept, 3), dtype=np.int64)
    for t in range(triangles):
        if index[t] >= 0:
            for k in range(3):
                simplices[index[t], k] = corners[t, k]
                u = neighbors[t, k]
                adjacent[index[t], k] = index[u] if u >= 0 else -1
    return simplices, adjacent


@njit(cache=True)
def _holds(xy, corners, qx, qy):  # pragma: no cover - compiled
    """Whether the counter-clockwise triangle `corners` holds (qx, qy), its sides included."""
    for k in range(3):
        a, b = corners[(k + 1) % 3], corners[(k + 2) % 3]
        if _orientation(qx, qy, xy[a, 0], xy[a, 1], xy[b, 0], xy[b, 1]) < 0.0:
            return False
    return True
