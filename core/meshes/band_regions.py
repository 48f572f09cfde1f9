"""The band's triangles among those of its Delaunay triangulation, compiled: `band_sides` (which
triangle sides are boundary chords or front edges) and `band_triangles` (the triangles inside the
boundary polygon and outside the lattice core), for `core.meshes.refinement`.

The triangulation covers the convex hull of the boundary vertices, the band's lattice nodes, the
inserted points and a far ring around them.  Its triangles fall into connected regions that no
boundary chord and no front edge (a side of the core's border) separates; a region is inside when
it lies on the interior side of a chord or to the right of a front edge (the core is on the left),
outside when it lies on the other side of one or on the border of the triangulation.
"""

from __future__ import annotations

import numpy as np
from numba import njit


def band_sides(
    simplices: np.ndarray, boundary_count: int, front: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Which boundary chord and which front edge each triangle side is.

    Parameters
    ----------
    simplices : ndarray of shape (T, 3), int64
        Triangles; the first `boundary_count` points are the boundary vertices, in order around
        the curve: chord j joins vertices j and j + 1 (mod `boundary_count`).
    boundary_count : int
    front : ndarray of shape (F, 2), int64
        Front edges as pairs of point indices (either direction matches).

    Returns
    -------
    chord, front_side : ndarray of shape (T, 3), int64
        For side k of each triangle (opposite its corner k), the chord and the front edge it is,
        or -1.
    """
    return _sides(
        np.ascontiguousarray(simplices), boundary_count, np.ascontiguousarray(front, dtype=np.int64)
    )


def band_triangles(
    points: np.ndarray,
    simplices: np.ndarray,
    neighbors: np.ndarray,
    chord: np.ndarray,
    front: np.ndarray,
    front_side: np.ndarray,
    orientation: float,
) -> np.ndarray:
    """Indices of the triangles of the band (module doc), increasing.

    Parameters
    ----------
    points : ndarray of shape (N, 2)
    simplices, neighbors : ndarray of shape (T, 3), int64
        The triangulation (`core.meshes.delaunay.Triangulation`).
    chord, front_side : ndarray of shape (T, 3), int64
        `band_sides` of the triangles.
    front : ndarray of shape (F, 2), int64
        Front edges (tail, head), the core on their left.
    orientation : float
        1 if the boundary runs counter-clockwise, -1 if clockwise.

    Raises
    ------
    RuntimeError
        If a region is on both sides (the polygon is not simple: a refinement bug).
    """
    front = np.ascontiguousarray(front, dtype=np.int64)
    inside, simple = _inside(points, simplices, neighbors, chord, front, front_side, float(orientation))
    if not simple:
        raise RuntimeError("the boundary polygon is not simple; mesh refinement failed")
    return inside


@njit(cache=True)
def _sides(simplices, boundary_count, front):  # pragma: no cover - compiled
    """`band_sides`."""
    count = simplices.shape[0]
    chord = np.full((count, 3), -1, dtype=np.int64)
    front_side = np.full((count, 3), -1, dtype=np.int64)
    size = 0
    for t in range(count):
        for k in range(3):
            size = max(size, simplices[t, k] + 1)
    for e in range(front.shape[0]):
        size = max(size, front[e, 0] + 1, front[e, 1] + 1)
    # The front edges at each point, as compressed rows.
    start = np.zeros(size + 1, dtype=np.int64)
    for e in range(front.shape[0]):
        start[front[e, 0] + 1] += 1
        start[front[e, 1] + 1] += 1
    for v in range(size):
        start[v + 1] += start[v]
    filled = start[:-1].copy()
    edges_at = np.empty(2 * front.shape[0], dtype=np.int64)
    for e in range(front.shape[0]):
        for end in range(2):
            v = front[e, end]
            edges_at[filled[v]] = e
            filled[v] += 1
    for t in range(count):
        for k in range(3):
            u, v = simplices[t, (k + 1) % 3], simplices[t, (k + 2) % 3]
            if u < boundary_count and v < boundary_count:
                if (v - u) % boundary_count == 1:
                    chord[t, k] = u
                elif (u - v) % boundary_count == 1:
                    chord[t, k] = v
            for i in range(start[u], start[u + 1]):
                e = edges_at[i]
                if front[e, 0] + front[e, 1] - u == v:
                    front_side[t, k] = e
    return chord, front_side


@njit(cache=True)
def _inside(
    points, simplices, neighbors, chord, front, front_side, orientation
):  # pragma: no cover - compiled
    """`band_triangles`, and False where a region is on both sides."""
    count = simplices.shape[0]
    label = np.full(count, -1, dtype=np.int64)
    stack = np.empty(count, dtype=np.int64)
    regions = 0
    for seed in range(count):  # connected regions across sides that are neither chord nor front
        if label[seed] >= 0:
            continue
        label[seed] = regions
        stack[0] = seed
        size = 1
        while size:
            size -= 1
            t = stack[size]
            for k in range(3):
                u = neighbors[t, k]
                if u >= 0 and chord[t, k] < 0 and front_side[t, k] < 0 and label[u] < 0:
                    label[u] = regions
                    stack[size] = u
                    size += 1
        regions += 1
    inner = np.zeros(regions, dtype=np.bool_)
    outer = np.zeros(regions, dtype=np.bool_)
    for t in range(count):
        for k in range(3):
            opposite = simplices[t, k]
            px, py = points[opposite, 0], points[opposite, 1]
            if chord[t, k] >= 0:
                a = chord[t, k]
                b = simplices[t, (k + 1) % 3] + simplices[t, (k + 2) % 3] - a
                side = orientation * _cross(points[a, 0], points[a, 1], points[b, 0], points[b, 1], px, py)
                if side > 0:
                    inner[label[t]] = True
                elif side < 0:
                    outer[label[t]] = True
            elif front_side[t, k] >= 0:
                tail, head = front[front_side[t, k], 0], front[front_side[t, k], 1]
                core = _cross(points[tail, 0], points[tail, 1], points[head, 0], points[head, 1], px, py) > 0
                if core:
                    outer[label[t]] = True
                else:
                    inner[label[t]] = True
            elif neighbors[t, k] < 0:
                outer[label[t]] = True
    simple = True
    for r in range(regions):
        simple = simple and not (inner[r] and outer[r])
    total = 0
    for t in range(count):
        if inner[label[t]]:
            total += 1
    result = np.empty(total, dtype=np.int64)
    total = 0
    for t in range(count):
        if inner[label[t]]:
            result[total] = t
            total += 1
    return result, simple


@njit(cache=True)
def _cross(ax, ay, bx, by, px, py):  # pragma: no cover - compiled
    """cross(b - a, p - a): > 0 when p is to the left of a -> b."""
    return (bx - ax) * (py - ay) - (by - ay) * (px - ax)
