"""A proof that a closed quadratic B-spline is a simple curve, by Bézier subdivision.

`core.ClosedBSpline` rejects curves whose polylines cross (24 chords a span), which finds
crossings but proves nothing.  A bijection onto the inside of a target curve needs the
target proven simple (`core.injectivity.certificate`), so this module proves it:

- each span j is the quadratic Bézier arc (b0, b1, b2) of `core.ClosedBSpline` (Sec. 4.1),
  which lies in the convex hull of its three points (and so in their bounding box);
- two spans that share no end point are disjoint when their boxes are, else both are halved
  (de Casteljau) and the four pairs of halves tested again, down to `MAX_DEPTH` halvings;
- two spans that meet at a knot K (the end of one, the start of the other) meet nowhere
  else when a direction w separates them: w . (b - K) < 0 for every Bézier point b of the
  first except K, > 0 for the second (their hulls then lie in opposite closed half-planes
  that share only the line through K, where each hull holds only K).  w runs from the
  first arc's far end towards the second's, seen from K; at a smooth knot it is the
  tangent, at a sharp corner (a doubled control point) it separates the two straight
  sides unless they point the same way (a cusp, which is not simple).  Where w fails, the
  halves away from K are tested as disjoint pairs and the two halves at K again.

A pair still undecided after `MAX_DEPTH` halvings (arcs closer than ~2^-MAX_DEPTH of their
size, or touching) is reported as a possible crossing: the answer "simple" is a proof,
"not proven" may be a curve that only comes very close to itself.
"""

from __future__ import annotations

import numpy as np

#: Halvings of a pair of arcs before it counts as a possible crossing.
MAX_DEPTH = 40


def bezier_spans(control_points: np.ndarray) -> np.ndarray:
    """The spans of the closed quadratic B-spline of control points (n, 2) as Bézier arcs,
    ndarray of shape (n, 3, 2): span j (t in [j, j + 1]) has b0 = (P_j + P_{j+1}) / 2,
    b1 = P_{j+1}, b2 = (P_{j+1} + P_{j+2}) / 2 in the paper's numbering (array rows j - 1,
    j, j + 1)."""
    points = np.asarray(control_points, dtype=np.float64)
    previous = np.roll(points, 1, axis=0)
    following = np.roll(points, -1, axis=0)
    return np.stack([0.5 * (previous + points), points, 0.5 * (points + following)], axis=1)


def first_crossing(control_points: np.ndarray) -> tuple[int, int] | None:
    """None if the closed quadratic B-spline of control points (n, 2) is proven simple, else
    the spans (j, k) of a pair not proven apart (a crossing, a touch or a near touch)."""
    spans = bezier_spans(control_points)
    n = spans.shape[0]
    retraced = np.flatnonzero(np.all(spans[:, 0] == spans[:, 2], axis=1))
    if retraced.size:  # a span that ends where it starts runs out and back
        j = int(retraced[0])
        return j, j
    low, high = spans.min(axis=1), spans.max(axis=1)
    overlap = np.all((low[:, None] <= high[None]) & (low[None] <= high[:, None]), axis=2)
    for j, k in zip(*np.nonzero(np.triu(overlap, 1)), strict=True):
        if k == j + 1:
            apart = _adjacent_apart(spans[j], spans[k], MAX_DEPTH)
        elif j == 0 and k == n - 1:
            apart = _adjacent_apart(spans[k], spans[j], MAX_DEPTH)
        else:
            apart = _disjoint(_flat(spans[j]), _flat(spans[k]), MAX_DEPTH)
        if not apart:
            return int(j), int(k)
    return None


def _halves(arc: tuple) -> tuple[tuple, tuple]:
    """de Casteljau at u = 1/2: the two halves of a quadratic Bézier arc, each arc as the six
    numbers (x0, y0, x1, y1, x2, y2) (Python floats: the subdivision makes thousands of tiny
    arcs, for which numpy's per-call cost was 20 times the arithmetic)."""
    x0, y0, x1, y1, x2, y2 = arc
    left_x, left_y = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
    right_x, right_y = 0.5 * (x1 + x2), 0.5 * (y1 + y2)
    centre_x, centre_y = 0.5 * (left_x + right_x), 0.5 * (left_y + right_y)
    return (x0, y0, left_x, left_y, centre_x, centre_y), (centre_x, centre_y, right_x, right_y, x2, y2)


def _boxes_apart(a: tuple, b: tuple) -> bool:
    """Whether the bounding boxes of arcs a and b (six numbers each, `_halves`) are apart."""
    return (
        max(a[0], a[2], a[4]) < min(b[0], b[2], b[4])
        or max(b[0], b[2], b[4]) < min(a[0], a[2], a[4])
        or max(a[1], a[3], a[5]) < min(b[1], b[3], b[5])
        or max(b[1], b[3], b[5]) < min(a[1], a[3], a[5])
    )


def _flat(arc: np.ndarray) -> tuple:
    """Arc (3, 2) as the six numbers of `_halves`."""
    return tuple(arc.ravel().tolist())


def _disjoint(a: tuple, b: tuple, depth: int) -> bool:
    """Whether arcs a and b (six numbers each, `_halves`) are proven disjoint within `depth`
    halvings."""
    pending = [(a, b, depth)]
    while pending:
        a, b, left = pending.pop()
        if _boxes_apart(a, b):
            continue
        if left == 0:
            return False
        for part_a in _halves(a):
            for part_b in _halves(b):
                pending.append((part_a, part_b, left - 1))
    return True


def _adjacent_apart(a: np.ndarray, b: np.ndarray, depth: int) -> bool:
    """Whether arc a (3, 2), ending at the knot K = a[2] = b[0], and arc b (3, 2) meet only at K."""
    knot = a[2]
    if not np.array_equal(knot, b[0]):
        return _disjoint(_flat(a), _flat(b), depth)
    back, ahead = a[:2] - knot, b[1:] - knot
    far_back, far_ahead = back[np.any(back != 0, axis=1)], ahead[np.any(ahead != 0, axis=1)]
    direction = far_ahead[-1] / np.linalg.norm(far_ahead[-1]) - far_back[0] / np.linalg.norm(far_back[0])
    if np.any(direction != 0) and np.all(far_back @ direction < 0) and np.all(far_ahead @ direction > 0):
        return True
    if depth == 0:
        return False
    flat_b = _flat(b)
    a_far, a_near = _halves(_flat(a))
    b_near, b_far = _halves(flat_b)
    return (
        _disjoint(a_far, flat_b, depth - 1)
        and _disjoint(a_near, b_far, depth - 1)
        and _adjacent_apart(np.reshape(a_near, (3, 2)), np.reshape(b_near, (3, 2)), depth - 1)
    )


__all__ = ["bezier_spans", "first_crossing"]
