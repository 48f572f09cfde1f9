"""Point-in-polygon tests against the closed sample polygon, with a slab index of its edges.

The crossing-number test (a horizontal ray from the point, counting the edges it
crosses) only ever counts edges whose y-range contains the point's y.  The plane
is cut into horizontal slabs; each slab lists the edges whose y-range meets it, so
a test reads the few edges of one slab instead of all N.  The answer is exactly
that of the test over every edge: an edge that can cross is always listed, and
each listed edge is tested with the same formula.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

#: Samples per slab: about two edges of a smooth curve cross each slab where it crosses it.
SAMPLES_PER_SLAB = 4


@njit(cache=True, error_model="numpy")
def _slab(y, low, inverse_height, slabs):
    """The slab index of height y, clamped to [0, slabs - 1]: non-decreasing in y."""
    scaled = (y - low) * inverse_height
    if not scaled >= 0.0:  # below the polygon (or NaN)
        return 0
    return min(int(math.floor(scaled)), slabs - 1)


@njit(cache=True, error_model="numpy")
def _edge_slabs(sample_y, low, inverse_height, slabs, first, last):
    """The first and last slab that edge i's y-range meets, into first and last, each (N,)."""
    count = sample_y.shape[0]
    for i in range(count):
        j = i - 1 if i > 0 else count - 1
        first[i] = _slab(min(sample_y[i], sample_y[j]), low, inverse_height, slabs)
        last[i] = _slab(max(sample_y[i], sample_y[j]), low, inverse_height, slabs)


def crossing_slabs(sample_y: np.ndarray) -> tuple[np.ndarray, np.ndarray, float, float]:
    """The slab index of the closed polygon with vertex heights `sample_y`, shape (N,).

    Edge i joins vertex i - 1 (N - 1 for i = 0) to vertex i.  Slab indices come
    from the one function the test uses (`_slab`, non-decreasing in y), so an edge
    whose y-range holds a point's y is always listed in that point's slab.

    Returns
    -------
    offsets : ndarray of int64, shape (K + 1,)
        Slab k lists ``edges[offsets[k]:offsets[k + 1]]``.
    edges : ndarray of int64, shape (E,)
        Edge indices, every edge in each slab its y-range meets.
    low, inverse_height : float
        Slab k covers heights [low + k / inverse_height, low + (k + 1) / inverse_height).
    """
    sample_y = np.ascontiguousarray(sample_y, dtype=np.float64)
    count = sample_y.shape[0]
    slabs = max(1, count // SAMPLES_PER_SLAB)
    low, high = float(sample_y.min()), float(sample_y.max())
    inverse_height = slabs / (high - low) if high > low else 0.0
    first = np.empty(count, dtype=np.int64)
    last = np.empty(count, dtype=np.int64)
    _edge_slabs(sample_y, low, inverse_height, slabs, first, last)
    lengths = last - first + 1
    edge = np.repeat(np.arange(count), lengths)
    starts = np.cumsum(lengths) - lengths
    slab = np.repeat(first, lengths) + np.arange(edge.size) - np.repeat(starts, lengths)
    order = np.argsort(slab, kind="stable")
    offsets = np.zeros(slabs + 1, dtype=np.int64)
    offsets[1:] = np.cumsum(np.bincount(slab, minlength=slabs))
    return offsets, edge[order], low, inverse_height


@njit(cache=True, error_model="numpy")
def inside_polygon(sample_x, sample_y, slabs, x, y):
    """Crossing-number test of (x, y) against the closed sample polygon (each (N,)).

    `slabs` is `crossing_slabs(sample_y)`; only the edges of the point's slab are
    tested, with the formula of the full test.
    """
    offsets, edges, low, inverse_height = slabs
    count = sample_x.shape[0]
    k = _slab(y, low, inverse_height, offsets.shape[0] - 1)
    inside = False
    for e in range(offsets[k], offsets[k + 1]):
        i = edges[e]
        j = i - 1 if i > 0 else count - 1
        yi = sample_y[i]
        yj = sample_y[j]
        if (yi > y) != (yj > y):
            xcross = sample_x[i] + (y - yi) / (yj - yi) * (sample_x[j] - sample_x[i])
            if x < xcross:
                inside = not inside
    return inside
