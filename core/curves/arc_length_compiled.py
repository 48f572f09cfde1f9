"""The boundary in compiled code: a closed piecewise polynomial, or its arc-length
reparameterisation (Fig. 12c), evaluated at a parameter; arc length <-> curve parameter.

`evaluate_curve` is what every compiled kernel calls for p(t), p'(t), p''(t): a coefficient
array with a third channel makes its argument the normalised arc length s
(`core.curves.arc_length` builds it), so that the solver, the closest-point search and the
output rows run unchanged in either parameterisation.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True, error_model="numpy")
def evaluate_curve(coefficients, piece_length, t):
    """p(t), p'(t), p''(t) of a closed piecewise polynomial (see core.curves.boundary).

    A third channel makes the argument the normalised arc length s (`core.curves.arc_length`).
    """
    if coefficients.shape[2] == 3:
        return arc_length_curve(coefficients, t)
    pieces = coefficients.shape[0]
    period = pieces * piece_length
    t = t - math.floor(t / period) * period
    scaled = t / piece_length
    piece = int(math.floor(scaled))
    if piece >= pieces:
        piece = pieces - 1
    if piece < 0:
        piece = 0
    u = scaled - piece
    degree = coefficients.shape[1] - 1
    vx = coefficients[piece, degree, 0]
    vy = coefficients[piece, degree, 1]
    fx = 0.0
    fy = 0.0
    sx = 0.0
    sy = 0.0
    for d in range(degree - 1, -1, -1):
        sx = sx * u + 2.0 * fx
        sy = sy * u + 2.0 * fy
        fx = fx * u + vx
        fy = fy * u + vy
        vx = vx * u + coefficients[piece, d, 0]
        vy = vy * u + coefficients[piece, d, 1]
    inverse = 1.0 / piece_length
    return vx, vy, fx * inverse, fy * inverse, sx * inverse * inverse, sy * inverse * inverse


# Gauss-Legendre rule on [-1, 1] for the arc length of nearly uniform-speed spans.
_LEGENDRE_NODES, _LEGENDRE_WEIGHTS = np.polynomial.legendre.leggauss(16)


@njit(cache=True, error_model="numpy")
def span_arc_length(coefficients, span, u):
    """Arc length of span `span` of a quadratic curve from its start to local u in [0, 1].

    p'(v) = a + v c with a = coefficients[span, 1], c = 2 coefficients[span, 2].  In
    closed form with tau = p' . c / |c| and h = |a x c| / |c| (the distance of the
    line p'(v) from the origin), int sqrt(tau^2 + h^2) d tau / |c|; when |c| is small
    next to |p'| (the zeros of |p'|^2 are then farther than 9 span lengths away) the
    closed form cancels and a 16-point Gauss-Legendre rule is exact to rounding instead.
    """
    ax = coefficients[span, 1, 0]
    ay = coefficients[span, 1, 1]
    cx = 2.0 * coefficients[span, 2, 0]
    cy = 2.0 * coefficients[span, 2, 1]
    c = math.sqrt(cx * cx + cy * cy)
    if c <= 0.05 * (math.sqrt(ax * ax + ay * ay) + math.sqrt((ax + cx) ** 2 + (ay + cy) ** 2)):
        total = 0.0
        for i in range(_LEGENDRE_NODES.shape[0]):
            v = 0.5 * u * (_LEGENDRE_NODES[i] + 1.0)
            total += _LEGENDRE_WEIGHTS[i] * math.sqrt((ax + v * cx) ** 2 + (ay + v * cy) ** 2)
        return 0.5 * u * total
    h = abs(ax * cy - ay * cx) / c
    return _speed_primitive(ax + u * cx, ay + u * cy, cx, cy, c, h) - _speed_primitive(ax, ay, cx, cy, c, h)


@njit(cache=True, error_model="numpy")
def _speed_primitive(wx, wy, cx, cy, c, h):
    """(tau |w| + h^2 asinh(tau / h)) / (2 |c|), tau = w . c / |c|: d/dv of it is |w(v)|."""
    tau = (wx * cx + wy * cy) / c
    value = tau * math.sqrt(wx * wx + wy * wy)
    if h > 1e-150 * c:
        value += h * h * math.asinh(tau / h)
    return value / (2.0 * c)


@njit(cache=True, error_model="numpy")
def natural_parameter(coefficients, s):
    """(span, u): the natural parameter t = span + u of normalised arc length s (periodic),
    by safeguarded Newton on `span_arc_length` (|p'| is its derivative).

    coefficients (n, 3, 3): the natural quadratic pieces (channels 0, 1) and, in
    channel 2, each span's start S_j and length l_j in the normalised arc length
    (period n) and the scale L / n of the lengths (`core.curves.arc_length`).
    """
    spans = coefficients.shape[0]
    s = s - math.floor(s / spans) * spans
    lo_span = 0
    hi_span = spans - 1
    while lo_span < hi_span:  # the last span starting at or before s
        middle = (lo_span + hi_span + 1) // 2
        if coefficients[middle, 0, 2] <= s:
            lo_span = middle
        else:
            hi_span = middle - 1
    span = lo_span
    scale = coefficients[span, 2, 2]
    length = coefficients[span, 1, 2] * scale
    target = (s - coefficients[span, 0, 2]) * scale
    if target >= length:
        return span, 1.0
    if target <= 0.0:
        return span, 0.0
    lo = 0.0
    hi = 1.0
    ax = coefficients[span, 1, 0]
    ay = coefficients[span, 1, 1]
    cx = 2.0 * coefficients[span, 2, 0]
    cy = 2.0 * coefficients[span, 2, 1]
    bend = math.sqrt(cx * cx + cy * cy)  # |p''|, bounds how far Newton's step is off
    u = target / length
    for _ in range(100):
        f = span_arc_length(coefficients, span, u) - target
        if f == 0.0:
            break
        if f > 0.0:
            hi = u
        else:
            lo = u
        speed = math.sqrt((ax + u * cx) ** 2 + (ay + u * cy) ** 2)
        candidate = u - f / speed if speed > 0.0 else -1.0
        if not (lo < candidate < hi):
            candidate = 0.5 * (lo + hi)
        elif (candidate - u) ** 2 * bend <= 1e-16 * speed:
            u = candidate  # the Newton step's own error, (step^2 / 2) |p''| / |p'|, is below 1e-16
            break
        if abs(candidate - u) <= 4e-16 or hi - lo <= 4e-16:
            u = candidate
            break
        u = candidate
    return span, u


@njit(cache=True, error_model="numpy")
def arc_length_curve(coefficients, s):
    """q(s) = p(t(s)), q'(s) and q''(s) of the curve in its normalised arc length s.

    With c = L / n the speed, q' = c T and q'' = c^2 (p'' - (p'' . T) T) / |p'|^2 at
    t(s), T = p' / |p'|.  Where p' = 0 (a sharp corner's knot, between two straight
    spans) T jumps: q' is c times the mean of its one-sided limits (what the trapezoid
    rule wants there, and no false stationary point for the closest-point search) and
    q'' = 0.
    """
    span, u = natural_parameter(coefficients, s)
    spans = coefficients.shape[0]
    px = coefficients[span, 0, 0] + u * (coefficients[span, 1, 0] + u * coefficients[span, 2, 0])
    py = coefficients[span, 0, 1] + u * (coefficients[span, 1, 1] + u * coefficients[span, 2, 1])
    fx = coefficients[span, 1, 0] + 2.0 * u * coefficients[span, 2, 0]
    fy = coefficients[span, 1, 1] + 2.0 * u * coefficients[span, 2, 1]
    gx = 2.0 * coefficients[span, 2, 0]
    gy = 2.0 * coefficients[span, 2, 1]
    speed = math.sqrt(fx * fx + fy * fy)
    scale = coefficients[span, 2, 2]
    if speed == 0.0:  # a corner: p' = -(1 - u) c before it, u c after it
        before = (span - 1) % spans if u < 0.5 else span
        after = span if u < 0.5 else (span + 1) % spans
        bx = coefficients[before, 2, 0]
        by = coefficients[before, 2, 1]
        ax = coefficients[after, 2, 0]
        ay = coefficients[after, 2, 1]
        nb = math.sqrt(bx * bx + by * by)
        na = math.sqrt(ax * ax + ay * ay)
        return px, py, 0.5 * scale * (ax / na - bx / nb), 0.5 * scale * (ay / na - by / nb), 0.0, 0.0
    tx = fx / speed
    ty = fy / speed
    along = gx * tx + gy * ty
    bend = scale * scale / (speed * speed)
    return px, py, scale * tx, scale * ty, (gx - along * tx) * bend, (gy - along * ty) * bend


@njit(cache=True, error_model="numpy")
def span_first_sample(coefficients, count, control_count, step, span):
    """Index of the first of the `count` samples (step h) on span `span` (0..n; n gives count).

    Natural parameter: span * count / n.  Normalised arc length (three channels):
    the first k with k h >= S_span, i.e. ceil(S_span / h).
    """
    if span >= control_count:
        return count
    if coefficients.shape[2] == 3:
        return min(count, int(math.ceil(coefficients[span, 0, 2] / step)))
    return span * (count // control_count)


@njit(cache=True, error_model="numpy")
def arc_length_samples(coefficients, s):
    """`arc_length_curve` at every s of shape (m,): ndarray (m, 6) of q, q', q'' (x, y each)."""
    out = np.empty((s.shape[0], 6))
    for m in range(s.shape[0]):
        out[m, 0], out[m, 1], out[m, 2], out[m, 3], out[m, 4], out[m, 5] = arc_length_curve(
            coefficients, s[m]
        )
    return out


@njit(cache=True, error_model="numpy")
def natural_parameters(coefficients, s):
    """(span, u) of `natural_parameter` at every s of shape (m,): two ndarrays of shape (m,)."""
    spans = np.empty(s.shape[0], dtype=np.int64)
    local = np.empty(s.shape[0])
    for m in range(s.shape[0]):
        spans[m], local[m] = natural_parameter(coefficients, s[m])
    return spans, local
