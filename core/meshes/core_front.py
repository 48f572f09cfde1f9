"""The border of the lattice core, compiled: `core_front`, for `core.meshes.refinement` (the band
is triangulated up to this front, whose edges must be Delaunay edges of the band's points).
"""

from __future__ import annotations

import numpy as np
from numba import njit

#: A lattice node inside the core has this many core triangles around it.
FULL_DEGREE = 6


def core_front(corners: np.ndarray, node_count: int) -> tuple[np.ndarray, np.ndarray]:
    """Core triangles per node and the front of the core.

    Parameters
    ----------
    corners : ndarray of shape (C, 3), int64
        The core triangles' nodes, counter-clockwise.
    node_count : int

    Returns
    -------
    count : ndarray of shape (node_count,), int64
        How many core triangles each node is a corner of (`FULL_DEGREE`: inside the core).
    front : ndarray of shape (F, 2), int64
        The directed edges of core triangles that no other core triangle shares, with the core on
        their left, in the order of the triangles and their sides.
    """
    return _front(np.ascontiguousarray(corners, dtype=np.int64), node_count)


@njit(cache=True)
def _front(corners, node_count):  # pragma: no cover - compiled
    """`core_front`: only the triangles with a corner of fewer than six core triangles can have a
    front edge, and both triangles of any edge with such an end are among them."""
    count = np.zeros(node_count, dtype=np.int64)
    for t in range(corners.shape[0]):
        for k in range(3):
            count[corners[t, k]] += 1
    edges = np.empty((3 * corners.shape[0], 2), dtype=np.int64)
    size = 0
    for t in range(corners.shape[0]):
        if (
            count[corners[t, 0]] < FULL_DEGREE
            or count[corners[t, 1]] < FULL_DEGREE
            or count[corners[t, 2]] < FULL_DEGREE
        ):
            for k in range(3):
                edges[size, 0], edges[size, 1] = corners[t, k], corners[t, (k + 1) % 3]
                size += 1
    # Each edge appears once or twice; group the edges by their lower end to find the twins.
    start = np.zeros(node_count + 1, dtype=np.int64)
    for e in range(size):
        start[min(edges[e, 0], edges[e, 1]) + 1] += 1
    for v in range(node_count):
        start[v + 1] += start[v]
    filled = np.zeros(node_count, dtype=np.int64)
    grouped = np.empty(size, dtype=np.int64)
    for e in range(size):
        low = min(edges[e, 0], edges[e, 1])
        grouped[start[low] + filled[low]] = e
        filled[low] += 1
    single = np.ones(size, dtype=np.bool_)
    for v in range(node_count):
        for i in range(start[v], start[v + 1]):
            for j in range(i + 1, start[v + 1]):
                e, f = grouped[i], grouped[j]
                if max(edges[e, 0], edges[e, 1]) == max(edges[f, 0], edges[f, 1]):
                    single[e] = False
                    single[f] = False
    total = 0
    for e in range(size):
        single[e] = single[e] and (count[edges[e, 0]] < FULL_DEGREE or count[edges[e, 1]] < FULL_DEGREE)
        total += single[e]
    front = np.empty((total, 2), dtype=np.int64)
    total = 0
    for e in range(size):
        if single[e]:
            front[total, 0], front[total, 1] = edges[e, 0], edges[e, 1]
            total += 1
    return count, front
