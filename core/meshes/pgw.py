"""Transfinite positive Gordon-Wixom (PGW) basis functions (Manson et al.; the paper's Sec. 1.1).

For a point x and a line L through x in direction theta, let y_i = x + d_i e
(d_i > 0, "ahead") and y_-j = x - d_-j e ("behind") be all the intersections of
L with the curve, and h_k the distance from x to the tangent line at y_k.  PGW
interpolates f linearly between every pair (ahead, behind),

    g_ij = (f(y_i) / d_i + f(y_-j) / d_-j) / (1 / d_i + 1 / d_-j),

and averages with weights w_ij = (d_i + d_-j) / (d_i^2 d_-j^2) h_i h_-j over all
pairs and all directions (Sec. 1.1):

    g(x) = int sum_ij g_ij w_ij dtheta / int sum_ij w_ij dtheta.

Since g_ij w_ij = h_i h_-j (f(y_i) d_-j + f(y_-j) d_i) / (d_i^2 d_-j^2), the double
sum factorises per line into sums over the intersections:

    sum_ij g_ij w_ij = S1_- sum_i f(y_i) h_i / d_i^2 + S1_+ sum_j f(y_-j) h_-j / d_-j^2,
    sum_ij w_ij      = S2_+ S1_- + S2_- S1_+,

with S1_+- = sum h / d and S2_+- = sum h / d^2 over the intersections ahead
(behind).  The line at theta + pi is the same line, so theta runs over [0, pi)
(midpoint rule).  Replacing f(y) by the folded B-spline basis row N(t) at the
parameter t of y gives the basis functions G(x) (Sec. 4.3).

Each pair term g_ij reproduces linear f exactly, whatever its weight, so rows sum
to 1 and G @ P = x up to rounding for every number of directions: the angular
quadrature affects only how close G is to the exact PGW integral.

The intersections are exact: each span of the quadratic B-spline is a parabola
arc whose Bezier points are knot midpoints and control points, and the signed
distance of the arc to L is a quadratic in Bernstein form; the knot values are
shared by neighbouring spans, so every crossing is counted exactly once.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from numba import njit

from core.curves.bspline import ClosedBSpline
from core.library_threads import in_shares
from core.validation import as_points, positive_int

# Points per compiled call: paces the progress callback.
CHUNK = 2048
# A point within this fraction of the diameter of the curve is on it (Lagrange row).
ON_CURVE = 1e-12


def pgw_basis(
    curve: ClosedBSpline,
    x,
    samples_per_segment: int = 100,
    angles: int | None = None,
    progress: Callable[[float], None] | None = None,
) -> np.ndarray:
    """Positive Gordon-Wixom basis functions G_i(x_m) of the n control points.

    Parameters
    ----------
    curve : ClosedBSpline
        The source cage, n control points.
    x : array_like of shape (M, 2)
        Points in the closed domain (on the curve, within 1e-12 of the diameter:
        the B-spline basis at that parameter, the Lagrange limit).
    samples_per_segment : int
        Sets the default number of directions, ``samples_per_segment * n / 2``
        lines over [0, pi), i.e. ``samples_per_segment * n`` directions around x,
        as many as the N boundary samples of the point kernels.
    angles : int, optional
        Number of lines through each point (midpoint rule in theta over [0, pi)).
    progress : callable, optional
        Called with the fraction done in [0, 1].

    Returns
    -------
    ndarray of shape (M, n)
        Non-negative, rows sum to 1 and ``G @ curve.control_points == x`` up to
        rounding.

    Raises
    ------
    ValueError
        If an argument is invalid or some points are outside the curve.
    """
    if not isinstance(curve, ClosedBSpline):
        raise ValueError(f"curve must be a core.ClosedBSpline, got {type(curve).__name__}")
    per = positive_int(samples_per_segment, "samples_per_segment", minimum=2)
    if angles is None:
        angles = max(1, per * curve.n // 2)
    angles = positive_int(angles, "angles")
    if progress is not None and not callable(progress):
        raise ValueError(f"progress must be a callable taking a fraction, got {progress!r}")
    points = as_points(x, "x")
    count = points.shape[0]
    theta = (np.arange(angles) + 0.5) * (np.pi / angles)
    directions = np.ascontiguousarray(np.stack([np.cos(theta), np.sin(theta)], axis=1))
    control = np.ascontiguousarray(curve.control_points)
    values = np.zeros((count, curve.n))
    outside = np.zeros(count, dtype=np.bool_)
    snap = ON_CURVE * curve.diameter
    for start in range(0, count, CHUNK):
        stop = min(start + CHUNK, count)
        rows = (control, points[start:stop], directions, snap, values[start:stop], outside[start:stop])
        in_shares(_pgw_rows, stop - start, *rows)
        if progress is not None:
            progress(stop / count)
    if outside.any():
        first = int(np.flatnonzero(outside)[0])
        raise ValueError(
            f"{int(outside.sum())} of {count} points of x are outside the domain "
            f"(first: index {first}, {points[first].tolist()})"
        )
    return values


@njit(cache=True)
def _span_roots(s0, s1, s2, roots):
    """Parameters u of the zeros of a quadratic in Bernstein form on one span.

    s(u) = s0 (1-u)^2 + 2 s1 u (1-u) + s2 u^2.  A zero at u = 0 belongs to this
    span and one at u = 1 to the next, so with knot values shared between spans
    each crossing is found once; roots pushed out of [0, 1] by rounding are
    clamped back.  Returns the count (0, 1 or 2) written to `roots`.
    """
    a = s0 - 2.0 * s1 + s2
    b = 2.0 * (s1 - s0)
    c = s0
    if s0 == 0.0:
        roots[0] = 0.0
        if a != 0.0:
            other = -b / a
            if 0.0 < other < 1.0:
                roots[1] = other
                return 2
        return 1
    if s2 == 0.0:
        if a != 0.0:
            other = c / a  # the roots are 1 and c / a
            if 0.0 < other < 1.0:
                roots[0] = other
                return 1
        return 0
    if (s0 > 0.0) != (s2 > 0.0):
        # One sign change: exactly one zero in (0, 1).
        if a == 0.0:
            u = -c / b
        else:
            discriminant = max(b * b - 4.0 * a * c, 0.0)
            q = -0.5 * (b + math.copysign(math.sqrt(discriminant), b))
            first = q / a
            second = c / q if q != 0.0 else first
            # Pick the root nearer to [0, 1].
            gap_first = max(-first, first - 1.0, 0.0)
            gap_second = max(-second, second - 1.0, 0.0)
            u = first if gap_first <= gap_second else second
        roots[0] = min(max(u, 0.0), 1.0)
        return 1
    # Same sign at both ends: two zeros in (0, 1) or none.  The Bezier ordinate s1
    # must have the other sign and the vertex of the parabola must dip through 0.
    if (s1 > 0.0) == (s0 > 0.0) or a == 0.0:
        return 0
    vertex = -b / (2.0 * a)
    if not 0.0 < vertex < 1.0:
        return 0
    discriminant = b * b - 4.0 * a * c
    if discriminant <= 0.0:
        return 0
    q = -0.5 * (b + math.copysign(math.sqrt(discriminant), b))
    roots[0] = min(max(q / a, 0.0), 1.0)
    roots[1] = min(max(c / q, 0.0), 1.0)
    return 2


@njit(cache=True, nogil=True)
def _pgw_rows(control, points, directions, snap, out, outside, first, shares):
    """Fill out (M, n) with PGW basis rows and flag the points outside the curve in outside (M,),
    for the points first, first + shares, ... (`core.library_threads.in_shares`)."""
    n = control.shape[0]
    for m in range(first, points.shape[0], shares):
        x = points[m, 0]
        y = points[m, 1]
        # Bezier points relative to x: knot midpoints K_j = (P_{j-1} + P_j) / 2, controls P_j.
        knot = np.empty((n + 1, 2))
        for j in range(n):
            previous = control[(j - 1) % n]
            knot[j, 0] = 0.5 * (previous[0] + control[j, 0]) - x
            knot[j, 1] = 0.5 * (previous[1] + control[j, 1]) - y
        knot[n, 0] = knot[0, 0]
        knot[n, 1] = knot[0, 1]
        middle = np.empty((n, 2))
        for j in range(n):
            middle[j, 0] = control[j, 0] - x
            middle[j, 1] = control[j, 1] - y
        side_knot = np.empty(n + 1)
        side_middle = np.empty(n)
        found_t = np.empty(2 * n)
        found_d = np.empty(2 * n)
        found_h = np.empty(2 * n)
        roots = np.empty(2)
        row = np.zeros(n)
        total = 0.0
        odd_lines = 0
        on_curve = -1.0
        for a in range(directions.shape[0]):
            ex = directions[a, 0]
            ey = directions[a, 1]
            for j in range(n + 1):
                side_knot[j] = knot[j, 0] * ey - knot[j, 1] * ex
            for j in range(n):
                side_middle[j] = middle[j, 0] * ey - middle[j, 1] * ex
            found = 0
            ahead = 0
            for j in range(n):
                s0 = side_knot[j]
                s1 = side_middle[j]
                s2 = side_knot[j + 1]
                # Convex hull of the Bezier points on one side of the line: no crossing.
                if (s0 > 0.0 and s1 > 0.0 and s2 > 0.0) or (s0 < 0.0 and s1 < 0.0 and s2 < 0.0):
                    continue
                if s0 == 0.0 and s1 == 0.0 and s2 == 0.0:
                    continue  # a straight span along the line: tangent, zero weight
                for r in range(_span_roots(s0, s1, s2, roots)):
                    u = roots[r]
                    w0 = (1.0 - u) * (1.0 - u)
                    w1 = 2.0 * u * (1.0 - u)
                    w2 = u * u
                    px = w0 * knot[j, 0] + w1 * middle[j, 0] + w2 * knot[j + 1, 0]
                    py = w0 * knot[j, 1] + w1 * middle[j, 1] + w2 * knot[j + 1, 1]
                    tx = 2.0 * ((1.0 - u) * (middle[j, 0] - knot[j, 0]) + u * (knot[j + 1, 0] - middle[j, 0]))
                    ty = 2.0 * ((1.0 - u) * (middle[j, 1] - knot[j, 1]) + u * (knot[j + 1, 1] - middle[j, 1]))
                    d = px * ex + py * ey
                    speed = math.sqrt(tx * tx + ty * ty)
                    # Distance from x (the origin here) to the tangent line at y; 0 at a
                    # corner's knot, where the tangent is undefined (a single direction).
                    h = abs(px * ty - py * tx) / speed if speed > 0.0 else 0.0
                    found_t[found] = j + u
                    found_d[found] = d
                    found_h[found] = h
                    found += 1
                    if d > 0.0:
                        ahead += 1
                    if abs(d) <= snap:
                        on_curve = j + u
            if on_curve >= 0.0:
                break
            if ahead % 2 == 1:
                odd_lines += 1
            first_ahead = 0.0
            second_ahead = 0.0
            first_behind = 0.0
            second_behind = 0.0
            for k in range(found):
                d = abs(found_d[k])
                if found_d[k] > 0.0:
                    first_ahead += found_h[k] / d
                    second_ahead += found_h[k] / (d * d)
                else:
                    first_behind += found_h[k] / d
                    second_behind += found_h[k] / (d * d)
            total += second_ahead * first_behind + second_behind * first_ahead
            for k in range(found):
                d = abs(found_d[k])
                weight = found_h[k] / (d * d) * (first_behind if found_d[k] > 0.0 else first_ahead)
                if weight != 0.0:
                    _add_basis(row, found_t[k], weight, n)
        if on_curve >= 0.0:
            row[:] = 0.0
            _add_basis(row, on_curve, 1.0, n)
            total = 1.0
        elif 2 * odd_lines <= directions.shape[0] or total <= 0.0:
            outside[m] = True
            total = 1.0
        for i in range(n):
            out[m, i] = row[i] / total


@njit(cache=True)
def _add_basis(row, t, weight, n):
    """row += weight * folded B-spline basis at t (Sec. 4.3)."""
    span = int(math.floor(t))
    u = t - span
    if span >= n:
        span -= n
        u = t - n - span
    row[(span - 1) % n] += weight * 0.5 * (1.0 - u) * (1.0 - u)
    row[span % n] += weight * 0.5 * (-2.0 * u * u + 2.0 * u + 1.0)
    row[(span + 1) % n] += weight * 0.5 * u * u
