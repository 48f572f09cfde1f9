"""The closest point of the curve to x within an interval of parameters, and the side of the
curve x lies on there, in compiled code: what the solver asks of the exact curve near a point
(`core.newton.solver`) and what `core.curves.closest_point` asks for many points."""

from __future__ import annotations

import math

from numba import njit

from core.curves.arc_length_compiled import evaluate_curve


@njit(cache=True, error_model="numpy")
def closest_parameter(coefficients, piece_length, x, y, lo, hi):
    """Parameter in [lo, hi] closest to (x, y): coarse scan, then safeguarded Newton."""
    scan = 24
    best_t = lo
    best_d = 1e300
    for i in range(scan + 1):
        t = lo + (hi - lo) * i / scan
        px, py, _, _, _, _ = evaluate_curve(coefficients, piece_length, t)
        d = (px - x) ** 2 + (py - y) ** 2
        if d < best_d:
            best_d = d
            best_t = t
    width = (hi - lo) / scan
    a = max(lo, best_t - width)
    b = min(hi, best_t + width)
    t = best_t
    for _ in range(80):
        px, py, fx, fy, sx, sy = evaluate_curve(coefficients, piece_length, t)
        dx = px - x
        dy = py - y
        f = dx * fx + dy * fy
        fprime = fx * fx + fy * fy + dx * sx + dy * sy
        if f > 0.0:
            b = t
        else:
            a = t
        if fprime > 0.0:
            candidate = t - f / fprime
        else:
            candidate = -1.0
        if not (a < candidate < b):
            candidate = 0.5 * (a + b)
        if abs(candidate - t) <= 1e-15 * (1.0 + abs(t)) or b - a <= 1e-15 * (1.0 + abs(t)):
            t = candidate
            break
        t = candidate
    px, py, _, _, _, _ = evaluate_curve(coefficients, piece_length, t)
    d = (px - x) ** 2 + (py - y) ** 2
    if d > best_d:  # Newton wandered to a worse stationary point (a corner): keep the scan
        return best_t, math.sqrt(best_d)
    return t, math.sqrt(d)


@njit(cache=True, error_model="numpy")
def side_of_curve(coefficients, piece_length, t, x, y, orientation):
    """+1 if (x, y) is on the inner side of the curve at its closest parameter t, else -1.

    The one-sided chords at t decide, which also covers sharp corners (zero
    tangent): the point is inside a convex turn if it is left of both, of a reflex
    turn if left of either (counter-clockwise curve; orientation -1 mirrors this).
    """
    px, py, _, _, _, _ = evaluate_curve(coefficients, piece_length, t)
    dx = x - px
    dy = y - py
    eps = 1e-6 * piece_length
    ax0, ay0, _, _, _, _ = evaluate_curve(coefficients, piece_length, t - eps)
    bx0, by0, _, _, _, _ = evaluate_curve(coefficients, piece_length, t + eps)
    ax = px - ax0
    ay = py - ay0
    bx = bx0 - px
    by = by0 - py
    left_a = orientation * (ax * dy - ay * dx) > 0.0
    left_b = orientation * (bx * dy - by * dx) > 0.0
    if orientation * (ax * by - ay * bx) >= 0.0:
        return 1 if (left_a and left_b) else -1
    return 1 if (left_a or left_b) else -1
