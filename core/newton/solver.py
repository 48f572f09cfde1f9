"""Per-point evaluation of the barycentric kernels, compiled with numba.

For one point x this module
1. builds the quadrature: the periodic trapezoid rule on the N uniform samples
   (Sec. 4.1), refined near the boundary (a graded sinh rule around the closest
   point of every boundary stretch closer than `NEAR_SPACINGS` sample spacings),
2. evaluates the weight function omega_x (Eq. 18-20, 23 and Sec. 3.1, 3.4) or the
   explicit kernels (Eq. 5 and the three-point family of Sec. 1.1),
3. for the weighted maximum-likelihood kernels minimises the convex F(phi) of
   Eq. 16 by Newton's method with Armijo backtracking from phi = 0, every trial
   kept strictly inside the feasible set, and forms lambda by Eq. 14 and 17,
4. accumulates w_j lambda(x, t_j) into an output row: either lumped onto the N
   samples (the kernel values, `core.kernel`) or multiplied by the folded
   B-spline basis (the basis functions G, Sec. 4.3).

With phi_0 normalised to 1 the feasible set is {phi : 1 + phi . u_j > 0 for all
nodes}, which contains the unit disk.  The linear-precision residual
|sum_j c_j (p_j - x)| / sum_j c_j of the discrete kernel is exactly |grad F| / D
(D = sum a_j / (r_j s_j)), which is what the Newton loop drives below tolerance.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from core.curves.crossing_slabs import inside_polygon

# Kernel identifiers shared with core.kernels.
MAXIMUM_LIKELIHOOD = 0
PSEUDO_HARMONIC = 1
POWER = 2
HARMONIC_LIKE = 3
MODIFIED_MEAN_VALUE = 4
MODIFIED_MEAN_VALUE_SQUARED = 5
MEAN_VALUE = 6
WACHSPRESS = 7
LAPLACE = 8

SHIFT_NONE = 0
SHIFT_INTEGRAL = 1
SHIFT_MEAN = 2

OUTPUT_SAMPLES = 0  # lambda lumped onto the N samples, row sums to 1 / h
OUTPUT_BASIS = 1  # G_i = sum_j w_j lambda_j N_i(t_j), row sums to 1

STATUS_CONVERGED = 0
STATUS_NOT_CONVERGED = 1
STATUS_OUTSIDE = 2
STATUS_AT_FEASIBLE_EDGE = 3

# A point closer to the boundary than this many local sample spacings gets a refined rule.
NEAR_SPACINGS = 4.0
# Samples kept in the refined window beyond the near stretch, on each side.
WINDOW_MARGIN = 3
# Step of the graded rule in the sinh variable near the closest point (divided by the
# refinement factor when a point is solved again on a finer quadrature).
SINH_STEP = 0.15
# Points closer than this (relative to the diameter) are on the boundary: Lagrange limit.
ON_BOUNDARY = 1e-12
# Kernel share above which an unresolved peak of lambda-hat is reported: about the
# trapezoid rule's own error at N = 100 n, so a report means a real loss of accuracy.
PEAK_MASS = 1e-4
MAX_WINDOWS = 8
MAX_WINDOW_NODES = 1024
MAX_NEWTON = 100
# Blending factors of the path-following fallback (see _continuation), ending at 0.
CONTINUATION = (0.5, 0.1, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 0.0)
MAX_BACKTRACKS = 60
# Warm start of far points (_coarse_start): the coarse rule's spacing is at most the point's
# distance over this many, and it keeps at least this many nodes.
COARSE_SPACINGS = 3.0
MIN_COARSE_NODES = 96
# The coarse minimiser is a start only, off the full one by the subset's quadrature error
# anyway: its Newton stops at this many times the tolerance (one step fewer, as many on all N).
COARSE_LOOSER = 1e3
# A far point's Newton starts from the last minimisers of its block of BLOCK points (see
# solve_points and _predicted_start) when they are closer than WARM_REACH times its distance to
# the boundary (phi varies on that scale); otherwise from a coarse solve.
WARM_REACH = 1.0
BLOCK = 64
# Near points start from every fourth node of their refined rule (the separation that gives it).
NEAR_START_SEPARATION = 4.0 * COARSE_SPACINGS
# Far points start from every other sample at least: nearer than 2 COARSE_SPACINGS spacings
# that subset is a cruder rule, but Newton from its minimiser still takes about 1 step
# on all N, against 4 to 6 from phi = 0.
FAR_START_SEPARATION = 2.0 * COARSE_SPACINGS
ARMIJO = 1e-4
# Newton steps with |delta| <= FULL_STEP (1 - |phi|) are accepted without a trial (see _newton):
# feasible, and Armijo holds for any FULL_STEP < 1/2 (0.45: the bound is 0.09 slope <= ARMIJO slope).
FULL_STEP = 0.45
# Slack for rounding (in u_j and s_j, ~1e-16) in the bound that skips the peak scan
# (`_maximum_likelihood`).
ROUNDING_SLACK = 1e-12


@njit(cache=True, error_model="numpy")
def _evaluate_curve(coefficients, piece_length, t):
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


@njit(cache=True, error_model="numpy")
def _output_parameter(coefficients, mode, t):
    """The parameter at which a quadrature node enters the output row: the quadrature's
    own, except that the B-spline basis (OUTPUT_BASIS) of an arc-length curve is
    evaluated at the natural parameter t(s)."""
    if mode == OUTPUT_BASIS and coefficients.shape[2] == 3:
        span, u = natural_parameter(coefficients, t)
        return span + u
    return t


@njit(cache=True, error_model="numpy")
def _closest_parameter(coefficients, piece_length, x, y, lo, hi):
    """Parameter in [lo, hi] closest to (x, y): coarse scan, then safeguarded Newton."""
    scan = 24
    best_t = lo
    best_d = 1e300
    for i in range(scan + 1):
        t = lo + (hi - lo) * i / scan
        px, py, _, _, _, _ = _evaluate_curve(coefficients, piece_length, t)
        d = (px - x) ** 2 + (py - y) ** 2
        if d < best_d:
            best_d = d
            best_t = t
    width = (hi - lo) / scan
    a = max(lo, best_t - width)
    b = min(hi, best_t + width)
    t = best_t
    for _ in range(80):
        px, py, fx, fy, sx, sy = _evaluate_curve(coefficients, piece_length, t)
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
    px, py, _, _, _, _ = _evaluate_curve(coefficients, piece_length, t)
    d = (px - x) ** 2 + (py - y) ** 2
    if d > best_d:  # Newton wandered to a worse stationary point (a corner): keep the scan
        return best_t, math.sqrt(best_d)
    return t, math.sqrt(d)


@njit(cache=True, error_model="numpy")
def _accumulate(row, mode, value, t, step, count, control_count):
    """Add value * (lumping or basis weights at t) into the output row."""
    if mode == OUTPUT_SAMPLES:
        scaled = t / step
        k = int(math.floor(scaled))
        theta = scaled - k
        k = k % count
        row[k] += value * (1.0 - theta) / step
        if theta > 0.0:
            row[(k + 1) % count] += value * theta / step
    else:
        period = float(control_count)
        t = t - math.floor(t / period) * period
        segment = min(int(t), control_count - 1)  # t >= 0 here
        u = t - segment
        # The neighbouring spans, cyclically, without integer modulo (this runs per node).
        before = segment - 1 if segment > 0 else control_count - 1
        after = segment + 1 if segment + 1 < control_count else 0
        row[before] += value * 0.5 * (1.0 - u) * (1.0 - u)
        row[segment] += value * 0.5 * (-2.0 * u * u + 2.0 * u + 1.0)
        row[after] += value * 0.5 * u * u


@njit(cache=True, error_model="numpy")
def _side_of_curve(coefficients, piece_length, t, x, y, orientation):
    """+1 if (x, y) is on the inner side of the curve at its closest parameter t, else -1.

    The one-sided chords at t decide, which also covers sharp corners (zero
    tangent): the point is inside a convex turn if it is left of both, of a reflex
    turn if left of either (counter-clockwise curve; orientation -1 mirrors this).
    """
    px, py, _, _, _, _ = _evaluate_curve(coefficients, piece_length, t)
    dx = x - px
    dy = y - py
    eps = 1e-6 * piece_length
    ax0, ay0, _, _, _, _ = _evaluate_curve(coefficients, piece_length, t - eps)
    bx0, by0, _, _, _, _ = _evaluate_curve(coefficients, piece_length, t + eps)
    ax = px - ax0
    ay = py - ay0
    bx = bx0 - px
    by = by0 - py
    left_a = orientation * (ax * dy - ay * dx) > 0.0
    left_b = orientation * (bx * dy - by * dx) > 0.0
    if orientation * (ax * by - ay * bx) >= 0.0:
        return 1 if (left_a and left_b) else -1
    return 1 if (left_a or left_b) else -1


@njit(cache=True, error_model="numpy")
def _graded_side(edge, scale, step):
    """Sinh rule on one side of the centre: (intervals m, sinh scale s', sigma step).

    The rule is t = centre +- s' sinh(sigma), sigma in [0, sigma_e], m uniform
    steps.  m is chosen so that s' <= scale (the peak is resolved), then s' is
    solved so that the node spacing at the window end is exactly the sample step:
    sqrt(s'^2 + edge^2) asinh(edge / s') = m h (the left side decreases in s').
    That makes the h^2 f' / 12 end terms of Euler-Maclaurin cancel against the
    uniform rule outside (see _graded_nodes).
    """
    needed = math.sqrt(scale * scale + edge * edge) * math.asinh(edge / scale) / step
    intervals = max(2, int(math.ceil(max(needed, edge / step + 1.0))))
    cap = MAX_WINDOW_NODES // 2 - 1
    if intervals > cap:
        # A window longer than the node budget: no exact end spacing, graded all the same.
        return cap, scale, math.asinh(edge / scale) / cap
    target = intervals * step
    low = scale
    while math.sqrt(low * low + edge * edge) * math.asinh(edge / low) <= target and low > 1e-300:
        low *= 0.5
    high = scale
    # Safeguarded Newton in s' on g(s') = sqrt(s'^2 + edge^2) asinh(edge / s') - target,
    # g' = s' asinh(edge / s') / sqrt(s'^2 + edge^2) - edge / s' < 0, inside the bracket
    # g(low) > 0 >= g(high); a geometric bisection step wherever Newton leaves it.
    # Bisection alone took 64 steps of a square root and an asinh each.
    current = high
    for _ in range(64):
        root = math.sqrt(current * current + edge * edge)
        spread = math.asinh(edge / current)
        excess = root * spread - target
        if excess > 0.0:
            low = current
        else:
            high = current
        if excess == 0.0:
            break
        slope = current * spread / root - edge / current
        candidate = current - excess / slope if slope < 0.0 else -1.0
        if not (low < candidate < high):
            candidate = math.sqrt(low * high)
        if abs(candidate - current) <= 4e-16 * current:
            current = candidate
            break
        if high - low <= 4e-16 * high:
            current = high
            break
        current = candidate
    return intervals, current, math.asinh(edge / current) / intervals


@njit(cache=True, error_model="numpy")
def _end_correction(dsigma):
    """Euler-Maclaurin end terms of the sinh rule per unit edge (t'' = t'''' = edge at the end)."""
    return dsigma**2 / 12.0 - dsigma**4 / 720.0


@njit(cache=True, error_model="numpy")
def _graded_nodes(center, scale, start, stop, step, times, weights, offset):
    """Trapezoid rule in sigma for t = center +- scale' sinh(sigma) on [start, stop].

    Each side of `center` gets its own rule (`_graded_side`) whose node spacing at
    the window end is exactly the sample step h.  By Euler-Maclaurin the trapezoid
    error of the window is then (h^2 / 12) f'(t_end), cancelling the uniform rule
    outside, plus (dsigma^2 / 12) f(t_end) t''(sigma_end) with t'' = |t_end -
    center| (and its dsigma^4 companion), which is removed from the end weights.
    The junctions then cost O(h^2 dsigma^2) instead of O(h dsigma).  Nodes are
    written in increasing t from `offset`; the end nodes carry only the inner half
    weight.  Returns the new offset.
    """
    count = offset
    left = center - start
    right = stop - center
    left_intervals, left_scale, left_step = 0, scale, 0.0
    right_intervals, right_scale, right_step = 0, scale, 0.0
    # A side shorter than rounding of the window's ends is none: a closest point found at
    # a window's end (the centre of a square, one window round the whole curve) left 2e-15
    # there, whose graded rule divided by zero and wrote NaN times.
    if left > 1e-9 * step:
        left_intervals, left_scale, left_step = _graded_side(left, scale, step)
    if right > 1e-9 * step:
        right_intervals, right_scale, right_step = _graded_side(right, scale, step)
    for i in range(left_intervals, 0, -1):
        sigma = i * left_step
        times[count] = center - left_scale * math.sinh(sigma)
        weight = left_scale * math.cosh(sigma) * left_step
        if i == left_intervals:
            weight = 0.5 * weight - left * _end_correction(left_step)
        weights[count] = weight
        count += 1
    times[count] = center
    weights[count] = 0.5 * (left_scale * left_step + right_scale * right_step)
    count += 1
    for i in range(1, right_intervals + 1):
        sigma = i * right_step
        times[count] = center + right_scale * math.sinh(sigma)
        weight = right_scale * math.cosh(sigma) * right_step
        if i == right_intervals:
            weight = 0.5 * weight - right * _end_correction(right_step)
        weights[count] = weight
        count += 1
    return count


@njit(cache=True, error_model="numpy", fastmath={"contract", "arcp", "reassoc", "nsz"})
def _directions(px, py, x, y, count, ux, uy, inv_r):
    """Unit directions u_j = (p_j - x) / r_j and 1 / r_j; returns min r_j.

    The minimum is taken in a second loop (`_largest`) so that this one vectorises.
    """
    for j in range(count):
        dx = px[j] - x
        dy = py[j] - y
        inv = 1.0 / math.sqrt(dx * dx + dy * dy)
        ux[j] = dx * inv
        uy[j] = dy * inv
        inv_r[j] = inv
    return 1.0 / _largest(inv_r, count)


@njit(cache=True, error_model="numpy", fastmath={"contract", "arcp", "reassoc", "nsz"})
def _sample_directions(sample_x, sample_y, spacing, x, y, ux, uy, inv_r):
    """Unit directions u_k = (p_k - x) / r_k and 1 / r_k to the N samples, one vectorised pass.

    Returns the number of samples closer than NEAR_SPACINGS times their spacing
    (a point on a sample, r_k = 0, counts: it is on the boundary, and its
    directions are not used).  No min reduction here: it would stop the loop
    from vectorising (see `_largest`).
    """
    near = 0
    for k in range(sample_x.shape[0]):
        dx = sample_x[k] - x
        dy = sample_y[k] - y
        r2 = dx * dx + dy * dy
        inv = 1.0 / math.sqrt(r2)
        ux[k] = dx * inv
        uy[k] = dy * inv
        inv_r[k] = inv
        limit = NEAR_SPACINGS * spacing[k]
        near += r2 < limit * limit
    return near


@njit(cache=True, error_model="numpy")
def _largest(values, count):
    """max_k values_k over the first `count` entries."""
    largest = values[0]
    for k in range(1, count):
        if values[k] > largest:
            largest = values[k]
    return largest


@njit(cache=True, error_model="numpy", fastmath={"contract", "arcp", "reassoc", "nsz"})
def _weights(kernel, power, shift, px, py, tx, ty, sx, sy, w, x, y, count, corners, ux, uy, inv_r, r_min, a):
    """Normalised weights a_j = w_j omega_j / sum (maximum-likelihood family), or
    normalised w_j mu_j for the explicit kernels (Eq. 5 and Sec. 1.1).

    Every omega and mu is scaled by a power of r_min, which cancels in the
    normalisation and keeps 1 / r^k far from overflow.  For the three-point family
    the point masses of sharp corners follow the `count` nodes (their px, py must be
    filled in); returns the total node count.
    """
    if kernel == MAXIMUM_LIKELIHOOD:
        for j in range(count):
            a[j] = w[j]
    elif kernel == PSEUDO_HARMONIC:
        for j in range(count):
            a[j] = w[j] * (r_min * inv_r[j])
    elif kernel == POWER or kernel == HARMONIC_LIKE:
        k = 4.0 if kernel == HARMONIC_LIKE else power
        integral = 0.0
        length = 0.0
        if k == 4.0:
            for j in range(count):
                q = r_min * inv_r[j]
                q2 = q * q
                a[j] = q2 * q2
                integral += w[j] * a[j]
                length += w[j]
        elif k == 3.0:  # inverse-cube-mean: a libm pow per node cost more than the whole Newton solve
            for j in range(count):
                q = r_min * inv_r[j]
                a[j] = q * q * q
                integral += w[j] * a[j]
                length += w[j]
        else:
            for j in range(count):
                a[j] = (r_min * inv_r[j]) ** k
                integral += w[j] * a[j]
                length += w[j]
        mode = SHIFT_INTEGRAL if kernel == HARMONIC_LIKE else shift
        # Eq. 19-20: omega + int omega over the whole parameter interval (or its mean).
        constant = 0.0
        if mode == SHIFT_INTEGRAL:
            constant = integral
        elif mode == SHIFT_MEAN:
            constant = integral / length
        # The sum of w (omega + constant) is known: normalise in the same pass.
        inverse = 1.0 / (integral + constant * length)
        for j in range(count):
            a[j] = w[j] * (a[j] + constant) * inverse
        return count
    elif kernel == MODIFIED_MEAN_VALUE or kernel == MODIFIED_MEAN_VALUE_SQUARED:
        for j in range(count):
            # |d theta / dt| = |(p - x) x p'| / r^2 (Eq. 23).
            turn = abs(ux[j] * ty[j] - uy[j] * tx[j]) * inv_r[j] * r_min
            a[j] = w[j] * (turn * turn if kernel == MODIFIED_MEAN_VALUE_SQUARED else turn)
    elif kernel == MEAN_VALUE:
        for j in range(count):
            # mu = (p - x) x p' / r^3 (Eq. 5).
            q = r_min * inv_r[j]
            a[j] = w[j] * (ux[j] * ty[j] - uy[j] * tx[j]) * q * q
    else:  # WACHSPRESS or LAPLACE (Sec. 1.1)
        for j in range(count):
            speed2 = tx[j] * tx[j] + ty[j] * ty[j]
            cross = (px[j] - x) * ty[j] - (py[j] - y) * tx[j]
            curvature = tx[j] * sy[j] - ty[j] * sx[j]
            if speed2 == 0.0 or cross == 0.0:
                a[j] = 0.0  # a corner sample: its mass is the corner term below
                continue
            if kernel == WACHSPRESS:
                mu = curvature / (cross * cross) * r_min * r_min
            else:
                r2 = 1.0 / (inv_r[j] * inv_r[j])
                mu = (2.0 * speed2 * cross - r2 * curvature) / (cross * cross)
            a[j] = w[j] * mu
        for c in range(corners.shape[0]):
            # The tangent turns at a sharp corner B while p stays put: a point mass
            # int d alpha / ((B - x) x T(alpha))^2 = [cot(alpha - beta)] / |B - x|^2.
            j = count + c
            qx = px[j] - x
            qy = py[j] - y
            q2 = qx * qx + qy * qy
            ax = corners[c, 1]
            ay = corners[c, 2]
            bx = corners[c, 3]
            by = corners[c, 4]
            cross_a = qx * ay - qy * ax
            cross_b = qx * by - qy * bx
            mass = 0.0
            if cross_a != 0.0 and cross_b != 0.0:
                mass = (qx * ax + qy * ay) / cross_a - (qx * bx + qy * by) / cross_b
            r = math.sqrt(q2)
            ux[j] = qx / r
            uy[j] = qy / r
            inv_r[j] = 1.0 / r
            a[j] = mass / q2 * r_min * r_min if kernel == WACHSPRESS else -mass
        count += corners.shape[0]
    total = 0.0
    for j in range(count):
        total += a[j]
    inverse = 1.0 / total
    for j in range(count):
        a[j] *= inverse
    return count


@njit(cache=True, error_model="numpy", fastmath={"contract", "arcp", "reassoc", "nsz"})
def _newton(ux, uy, inv_r, a, s, inv_s, trial, trial_inv, count, tolerance, phix, phiy):
    """Minimise F(phi) = -sum a_j log(1 + phi . u_j) (Eq. 16 with phi_0 = 1).

    Newton's method with Armijo backtracking from (phix, phiy): phi = 0 in the
    paper (Sec. 4.1), or a warm start (`_coarse_start`); a start outside the
    feasible set is replaced by phi = 0.  A trial with
    any 1 + phi . u_j <= 0 is rejected like an Armijo failure.  One fused pass per
    trial gives the gradient, Hessian and D at the trial point and, with
    z_j = s_j(trial) / s_j - 1, the log-free bound

        F(trial) - F(phi) = -sum a_j log(1 + z_j) <= -sum a_j z_j + sum a_j z_j^2 / (2 m_j),

    m_j = min(1, 1 + z_j), from log(1 + z) >= z - z^2 / (2 min(1, 1 + z)) for z > -1;
    1 / m_j = max(1, s_j / s_j(trial)) needs no division of its own.  If the bound
    meets the Armijo condition the step is accepted; only otherwise is a tighter
    bound computed (`_change_bound`, log1p only where z_j < -1/2).  A step short
    enough that it is feasible and meets the bound for sure (|delta| <= FULL_STEP
    (1 - |phi|): every late step, from phi = 0 or a warm start) needs no trial: one
    `_newton_terms` pass at the new phi, without the bound's sums.  The loops carry no
    min/max reduction (feasibility is a count), so that they vectorise.

    On return `s` and `inv_s` hold 1 + phi . u_j and its inverse.  Returns
    (iterations, status, residual, phix, phiy, D), residual = |grad F| / D in length
    units: the linear-precision error of the discrete kernel; D = sum a_j / (r_j s_j)
    at the returned phi is the normaliser of Eq. 17.
    """
    gx, gy, hxx, hxy, hyy, d, infeasible = _newton_terms(ux, uy, inv_r, a, s, inv_s, count, phix, phiy)
    if infeasible > 0:
        # A warm start outside the feasible set: start from phi = 0 (always feasible).
        phix = 0.0
        phiy = 0.0
        gx, gy, hxx, hxy, hyy, d, infeasible = _newton_terms(ux, uy, inv_r, a, s, inv_s, count, phix, phiy)
    residual = math.sqrt(gx * gx + gy * gy) / d
    status = STATUS_NOT_CONVERGED
    iterations = 0
    swapped = False
    while True:
        if residual <= tolerance:
            status = STATUS_CONVERGED
            break
        if iterations == MAX_NEWTON:
            break
        determinant = hxx * hyy - hxy * hxy
        if not determinant > 0.0:
            break
        deltax = -(hyy * gx - hxy * gy) / determinant
        deltay = -(-hxy * gx + hxx * gy) / determinant
        slope = gx * deltax + gy * deltay
        if not slope < 0.0:
            break
        # |z_j| <= |delta| / min s_j <= |delta| / (1 - |phi|) (|u_j| = 1).  Below FULL_STEP the
        # full step is feasible and the bound below meets the Armijo condition for sure:
        # -sum a z = slope, sum a z^2 / m <= -slope / (1 - zeta), so the bound is at most
        # slope (1 - 1 / (2 (1 - zeta))) <= ARMIJO slope.  It is taken without the trial
        # pass, and one `_newton_terms` pass at the new phi gives the next step's terms.
        reach = 1.0 - math.sqrt(phix * phix + phiy * phiy)
        if reach > 0.0 and math.sqrt(deltax * deltax + deltay * deltay) <= FULL_STEP * reach:
            iterations += 1
            phix += deltax
            phiy += deltay
            gx, gy, hxx, hxy, hyy, d, _ = _newton_terms(ux, uy, inv_r, a, s, inv_s, count, phix, phiy)
            residual = math.sqrt(gx * gx + gy * gy) / d
            continue
        alpha = 1.0
        accepted = False
        for _ in range(MAX_BACKTRACKS):
            infeasible = 0
            linear = 0.0
            quadratic = 0.0
            ngx = 0.0
            ngy = 0.0
            nxx = 0.0
            nxy = 0.0
            nyy = 0.0
            nd = 0.0
            for j in range(count):
                step_dot = alpha * (deltax * ux[j] + deltay * uy[j])
                z = step_dot * inv_s[j]
                sj = s[j] + step_dot
                inv = 1.0 / sj
                trial[j] = sj
                trial_inv[j] = inv
                infeasible += sj <= 0.0
                aj = a[j]
                linear += aj * z
                ratio = s[j] * inv
                quadratic += aj * z * z * (ratio if ratio > 1.0 else 1.0)
                ia = aj * inv
                ngx -= ia * ux[j]
                ngy -= ia * uy[j]
                ib = ia * inv
                nxx += ib * ux[j] * ux[j]
                nxy += ib * ux[j] * uy[j]
                nyy += ib * uy[j] * uy[j]
                nd += ia * inv_r[j]
            if infeasible == 0:
                bound = -linear + 0.5 * quadratic
                if (
                    bound <= ARMIJO * alpha * slope
                    or _change_bound(a, ux, uy, inv_s, deltax, deltay, alpha, count) <= ARMIJO * alpha * slope
                ):
                    accepted = True
                    break
            alpha *= 0.5
        if not accepted:
            break
        iterations += 1
        phix += alpha * deltax
        phiy += alpha * deltay
        s, trial = trial, s
        inv_s, trial_inv = trial_inv, inv_s
        swapped = not swapped
        gx, gy, hxx, hxy, hyy, d = ngx, ngy, nxx, nxy, nyy, nd
        residual = math.sqrt(gx * gx + gy * gy) / d
    if swapped:
        # The caller's s / inv_s are the local trial arrays now: copy the result back.
        for j in range(count):
            trial[j] = s[j]
            trial_inv[j] = inv_s[j]
    return iterations, status, residual, phix, phiy, d


@njit(cache=True, error_model="numpy", fastmath={"contract", "arcp", "reassoc", "nsz"})
def _newton_terms(ux, uy, inv_r, a, s, inv_s, count, phix, phiy):
    """Gradient, Hessian and D of F (Eq. 16) at phi; fills s_j = 1 + phi . u_j and 1 / s_j.

    Returns (gx, gy, hxx, hxy, hyy, D, the number of s_j <= 0); the terms are
    meaningful only if that number is 0 (phi feasible).
    """
    gx = 0.0
    gy = 0.0
    hxx = 0.0
    hxy = 0.0
    hyy = 0.0
    d = 0.0
    infeasible = 0
    for j in range(count):
        sj = 1.0 + phix * ux[j] + phiy * uy[j]
        infeasible += sj <= 0.0
        inv = 1.0 / sj
        s[j] = sj
        inv_s[j] = inv
        ia = a[j] * inv
        gx -= ia * ux[j]
        gy -= ia * uy[j]
        ib = ia * inv
        hxx += ib * ux[j] * ux[j]
        hxy += ib * ux[j] * uy[j]
        hyy += ib * uy[j] * uy[j]
        d += ia * inv_r[j]
    return gx, gy, hxx, hxy, hyy, d, infeasible


@njit(cache=True, error_model="numpy")
def _continuation(ux, uy, inv_r, a, w, blend, s, inv_s, trial, trial_inv, count, tolerance, iterations):
    """Path-following for the points Newton from phi = 0 does not bring home.

    When omega spans many orders of magnitude (the unshifted powers of Sec. 3.3)
    the minimiser hugs the edge of the feasible set and damped Newton steps from
    phi = 0 crawl.  The weights (1 - mu) a + mu w / sum(w) blend the kernel with the
    unweighted one (omega = 1, well conditioned); mu falls to 0 and each stage starts
    from the previous minimiser.  The last stage is exactly the problem of Eq. 16,
    so the result is the same minimiser, only reached.  Returns (iterations,
    status, residual) of the whole path and D (see `_newton`) at its end.
    """
    length = 0.0
    for j in range(count):
        length += w[j]
    phix = 0.0
    phiy = 0.0
    status = STATUS_NOT_CONVERGED
    residual = math.inf
    d = 1.0
    for mu in CONTINUATION:
        for j in range(count):
            blend[j] = (1.0 - mu) * a[j] + mu * w[j] / length
        stage_tolerance = tolerance if mu == 0.0 else 1e4 * tolerance
        taken, status, residual, phix, phiy, d = _newton(
            ux, uy, inv_r, blend, s, inv_s, trial, trial_inv, count, stage_tolerance, phix, phiy
        )
        iterations += taken
        if status != STATUS_CONVERGED:
            break
    return iterations, status, residual, d


@njit(cache=True, error_model="numpy")
def _coarse_start(ux, uy, inv_r, a, count, separation, coarse, tolerance, phix, phiy):
    """Warm start of Newton for a far point: the minimiser of Eq. 16 on every stride-th node.

    The trapezoid rule on a subset of the uniform samples converges geometrically
    in the point's distance over the subset's spacing, so at a point `separation`
    sample spacings from the boundary the coarse minimiser, on
    stride <= separation / COARSE_SPACINGS times fewer nodes, is within a few
    Newton steps' contraction of the full one; Newton on all nodes
    (`_newton`) then polishes it, usually in one step, to the same tolerance.  The
    answer stays the minimiser of the full rule; only the starting point changes.
    `coarse` holds four scratch arrays for the subset (u_x, u_y, 1 / r, a) and
    four for Newton, which starts from (phix, phiy) (a neighbour's minimiser, or 0)
    and stops at COARSE_LOOSER times `tolerance`.  Returns the coarse minimiser;
    (phix, phiy) where no subset applies, (0, 0) if the coarse Newton did not converge.
    """
    stride = 1
    while 2 * stride * COARSE_SPACINGS <= separation and count // (2 * stride) >= MIN_COARSE_NODES:
        stride *= 2
    if stride == 1:
        return phix, phiy
    coarse_ux, coarse_uy, coarse_inv_r, coarse_a, s, inv_s, trial, trial_inv = coarse
    nodes = count // stride
    for j in range(nodes):
        k = j * stride
        coarse_ux[j] = ux[k]
        coarse_uy[j] = uy[k]
        coarse_inv_r[j] = inv_r[k]
        coarse_a[j] = a[k]
    _, status, _, phix, phiy, _ = _newton(
        coarse_ux,
        coarse_uy,
        coarse_inv_r,
        coarse_a,
        s,
        inv_s,
        trial,
        trial_inv,
        nodes,
        COARSE_LOOSER * tolerance,
        phix,
        phiy,
    )
    if status != STATUS_CONVERGED:
        return 0.0, 0.0
    return phix, phiy


@njit(cache=True, error_model="numpy")
def _predicted_start(x, y, history, reach):
    """A start for Newton at (x, y) from the last two minimisers of its block.

    history = (x1, y1, phix1, phiy1, x2, y2, phix2, phiy2), the last point first
    (NaN where missing).  If both lie within `reach` of each other and of (x, y)
    (mesh neighbours along a row), phi is extrapolated linearly along x2 -> x1,
    which is within ~1e-3 of the minimiser and needs no coarse solve (returns
    (phix, phiy, True)); if only the last is that close, its phi is the coarse
    solve's start; else phi = 0.  Any start gives the same minimiser (`_newton`).
    """
    x1, y1, phix1, phiy1, x2, y2, phix2, phiy2 = history
    if not math.hypot(x - x1, y - y1) <= reach:  # also NaN
        return 0.0, 0.0, False
    dx = x1 - x2
    dy = y1 - y2
    length2 = dx * dx + dy * dy
    if not (0.0 < length2 <= reach * reach):
        return phix1, phiy1, False
    along = min(max(((x - x1) * dx + (y - y1) * dy) / length2, 0.0), 1.0)
    return phix1 + along * (phix1 - phix2), phiy1 + along * (phiy1 - phiy2), True


@njit(cache=True, error_model="numpy")
def _change_bound(a, ux, uy, inv_s, deltax, deltay, alpha, count):
    """An upper bound on F(phi + alpha delta) - F(phi) = -sum a_j log1p(z_j), all z_j > -1 (Eq. 16).

    Exact (log1p) for the few nodes with z_j < -1/2, where a polynomial bound is
    loose; elsewhere -log(1 + z) <= -z + z^2 / 2 (z >= 0) and, from the series
    sum_k |z|^k / k, -log(1 + z) <= -z + z^2 / 2 + |z|^3 / (3 (1 + z)) (z < 0),
    within 3 % of the log at z = -1/2 and far closer at the usual small z.
    """
    change = 0.0
    for j in range(count):
        z = alpha * (deltax * ux[j] + deltay * uy[j]) * inv_s[j]
        if z < -0.5:
            change -= a[j] * math.log1p(z)
        elif z < 0.0:
            change += a[j] * (-z + 0.5 * z * z - z * z * z / (3.0 * (1.0 + z)))
        else:
            change += a[j] * (-z + 0.5 * z * z)
    return change


# Inlined into solve_points by numba: otherwise LLVM optimises and compiles the whole solver
# twice (once as this function, once linked into solve_points), and every point's call
# copies the scratch and curve tuples (tens of arrays, reference counts included).
@njit(cache=True, error_model="numpy", inline="always")
def _solve_point(x, y, settings, curve, geometry, largest_spacing, row, scratch, windows, start):
    """Evaluate one point; writes its output row and returns (iterations, status, residual, phix, phiy).

    `settings`, `curve` and `geometry` are the shared tuples of `solve_points`,
    `largest_spacing` the largest of the sample spacings, `scratch` and `windows`
    per-thread work arrays.  `start` holds the last two points of the block and their
    minimisers, from which a far point's Newton starts (`_predicted_start`).
    phix, phiy is this point's minimiser of Eq. 16 on the plain rule, NaN where
    there is none to pass on (explicit kernels, near points).
    """
    kernel, power, shift, mode, orientation, diameter, control_count, tolerance = settings
    coefficients, piece_length, corners = geometry
    window_start, window_stop, window_t, window_d, runs = windows
    (
        sample_x,
        sample_y,
        tangent_x,
        tangent_y,
        second_x,
        second_y,
        spacing,
        uniform,
        sample_t,
        basis0,
        basis1,
        basis2,
        step,
        sinh_step,
        out_step,
        slabs,
    ) = curve
    (px, py, tx, ty, sx, sy, w, t, ux, uy, inv_r, a, s, inv_s, trial, trial_inv, blend, ones) = scratch[:18]
    coarse = scratch[18:]
    count = sample_x.shape[0]
    out_count = int(round(count * step / out_step))
    # Pass 1: directions to the samples and, for a point near the boundary, the
    # stretches closer than NEAR_SPACINGS (found in a second, sequential scan).
    near = _sample_directions(sample_x, sample_y, spacing, x, y, ux, uy, inv_r)
    nearest = 1.0 / _largest(inv_r, count) if near == 0 else 1e300
    window_count, nearest_index, nearest = _near_stretches(
        sample_x, sample_y, spacing, x, y, near, nearest, windows
    )
    window_count = _merge_windows(
        window_start, window_stop, min(window_count, MAX_WINDOWS), count, nearest_index
    )

    three_point = kernel == WACHSPRESS or kernel == LAPLACE
    corner_count = corners.shape[0] if three_point else 0
    if window_count == 0:
        if not inside_polygon(sample_x, sample_y, slabs, x, y):
            return 0, STATUS_OUTSIDE, nearest, math.nan, math.nan
        if corner_count == 0:
            # The common case: the plain trapezoid rule on the shared samples.
            total = _weights(
                kernel,
                power,
                shift,
                sample_x,
                sample_y,
                tangent_x,
                tangent_y,
                second_x,
                second_y,
                uniform,
                x,
                y,
                count,
                corners,
                ux,
                uy,
                inv_r,
                nearest,
                a,
            )
            likelihood = kernel <= MODIFIED_MEAN_VALUE_SQUARED
            if likelihood:
                phix, phiy, predicted = _predicted_start(x, y, start, WARM_REACH * nearest)
                if not predicted:
                    phix, phiy = _coarse_start(
                        ux,
                        uy,
                        inv_r,
                        a,
                        count,
                        max(nearest / largest_spacing, FAR_START_SEPARATION),
                        coarse,
                        tolerance * diameter,
                        phix,
                        phiy,
                    )
                # No sample is within NEAR_SPACINGS spacings: |u_(k+1) - u_k| <= chord / nearest
                # (2 |p - q| / (|p| + |q|) bounds |p / |p| - q / |q||), so the peak scan is skipped.
                iterations, status, residual, d, phix, phiy = _maximum_likelihood(
                    ux, uy, inv_r, a, s, inv_s, trial, trial_inv, blend, uniform, step, count,
                    tolerance * diameter, phix, phiy, largest_spacing / nearest,
                )  # fmt: skip
                if mode == OUTPUT_BASIS:
                    # Eq. 17's normalisation folded into the basis sums: no pass of its own.
                    _fold_onto_basis(
                        row, a, inv_r, inv_s, 1.0 / d, basis0, basis1, basis2, control_count,
                        coefficients, step,
                    )  # fmt: skip
                    return iterations, status, residual, phix, phiy
                inverse = 1.0 / d
                for k in range(count):
                    a[k] = a[k] * inv_r[k] * inv_s[k] * inverse
            else:
                iterations, status, residual = _finish(
                    kernel, ux, uy, inv_r, a, s, inv_s, trial, trial_inv, blend, total, sample_x, sample_y,
                    uniform, step, x, y, tolerance * diameter, 0.0, 0.0, math.inf,
                )  # fmt: skip
            if mode == OUTPUT_BASIS:
                _fold_onto_basis(
                    row, a, ones, ones, 1.0, basis0, basis1, basis2, control_count,
                    coefficients, step,
                )  # fmt: skip
            elif out_count == count:
                for k in range(count):
                    row[k] += a[k] / step
            else:
                for k in range(count):
                    _accumulate(row, mode, a[k], sample_t[k], out_step, out_count, control_count)
            if likelihood:
                return iterations, status, residual, phix, phiy
            return iterations, status, residual, math.nan, math.nan
        nodes = 0
        for k in range(count):
            t[nodes] = sample_t[k]
            w[nodes] = step
            nodes += 1
        runs[0, 0] = 0  # every sample, one run
        runs[0, 1] = 0
        runs[0, 2] = count
        run_count = 1
    else:
        closest_t = nearest_index * step
        closest_d = nearest
        for i in range(window_count):
            ti, di = _closest_parameter(
                coefficients, piece_length, x, y, window_start[i] * step, window_stop[i] * step
            )
            window_t[i] = ti
            window_d[i] = di
            if di < closest_d:
                closest_d = di
                closest_t = ti
        if closest_d <= ON_BOUNDARY * diameter:
            closest_t = _output_parameter(coefficients, mode, _wrap(closest_t, count * step))
            _accumulate(row, mode, 1.0, closest_t, out_step, out_count, control_count)
            return 0, STATUS_CONVERGED, 0.0, math.nan, math.nan
        if _side_of_curve(coefficients, piece_length, closest_t, x, y, orientation) < 0:
            return 0, STATUS_OUTSIDE, closest_d, math.nan, math.nan
        nodes = _refined_nodes(
            window_start,
            window_stop,
            window_t,
            window_d,
            window_count,
            count,
            step,
            sinh_step,
            coefficients,
            piece_length,
            t,
            w,
            runs,
        )
        run_count = window_count
    # Pass 2 (near points, corners): the nodes' curve data and directions.
    _node_geometry(
        t, w, nodes, runs, run_count, step, count, sample_x, sample_y, tangent_x, tangent_y, second_x,
        second_y, coefficients, piece_length, corners, corner_count, px, py, tx, ty, sx, sy,
    )  # fmt: skip
    r_min = _directions(px, py, x, y, nodes, ux, uy, inv_r)
    total = _weights(
        kernel, power, shift, px, py, tx, ty, sx, sy, w, x, y, nodes, corners, ux, uy, inv_r, r_min, a
    )
    phix, phiy = 0.0, 0.0
    if kernel <= MODIFIED_MEAN_VALUE_SQUARED:
        phix, phiy = _coarse_start(
            ux, uy, inv_r, a, total, NEAR_START_SEPARATION, coarse, tolerance * diameter, 0.0, 0.0
        )
    iterations, status, residual = _finish(
        kernel,
        ux,
        uy,
        inv_r,
        a,
        s,
        inv_s,
        trial,
        trial_inv,
        blend,
        total,
        px,
        py,
        w,
        step,
        x,
        y,
        tolerance * diameter,
        phix,
        phiy,
        math.inf,
    )
    _accumulate_nodes(
        row, mode, a, t, total, count * step, out_step, out_count, control_count, coefficients, runs,
        run_count, curve,
    )  # fmt: skip
    return iterations, status, residual, math.nan, math.nan


@njit(cache=True, error_model="numpy")
def _accumulate_nodes(
    row, mode, a, t, total, period, out_step, out_count, control_count, coefficients, runs, run_count, curve
):  # fmt: skip
    """`_accumulate` of a_j at the output parameter of every node t_j, j < total (each (total,)).

    For the B-spline basis (OUTPUT_BASIS) the `run_count` runs of uniform samples
    (`_refined_nodes`) are folded with the samples' stored basis values
    (`_fold_run`); for the other nodes the three weights of a run of nodes on one
    span are summed in registers and added to the row when the span changes: the
    nodes come in increasing t but for the wrap and the appended corners, so this is
    a few additions per span instead of three read-modify-writes of the row per node.
    `curve` is the tuple of `solve_points`.
    """
    if mode != OUTPUT_BASIS:
        for j in range(total):
            _accumulate(row, mode, a[j], _wrap(t[j], period), out_step, out_count, control_count)
        return
    current = np.int64(-1)  # not a literal: one specialisation of _add_span
    s0 = 0.0
    s1 = 0.0
    s2 = 0.0
    spans = float(control_count)
    arc_length = coefficients.shape[2] == 3  # a call per node costs more than the rest
    j = 0
    for r in range(run_count + 1):
        stop = runs[r, 0] if r < run_count else total
        for node in range(j, stop):
            # Most nodes are in range already: math.floor costs a library call, skip it.
            tj = t[node]
            if not 0.0 <= tj < period:
                tj = _wrap(tj, period)
            if arc_length:
                tj = _output_parameter(coefficients, mode, tj)
            if not 0.0 <= tj < spans:
                tj = _wrap(tj, spans)
            segment = min(int(tj), control_count - 1)  # tj >= 0 here
            if segment != current:
                if current >= 0:
                    _add_span(row, current, control_count, s0, s1, s2)
                current = segment
                s0 = 0.0
                s1 = 0.0
                s2 = 0.0
            u = tj - segment
            value = 0.5 * a[node]
            s0 += value * (1.0 - u) * (1.0 - u)
            s1 += value * (-2.0 * u * u + 2.0 * u + 1.0)
            s2 += value * u * u
        if r < run_count:
            if current >= 0:
                _add_span(row, current, control_count, s0, s1, s2)
            current = -1
            _fold_run(row, a, runs[r, 0], runs[r, 1], runs[r, 2], control_count, coefficients, curve)
            j = runs[r, 0] + runs[r, 2]
    if current >= 0:
        _add_span(row, current, control_count, s0, s1, s2)


@njit(cache=True, error_model="numpy", fastmath={"contract", "arcp", "reassoc", "nsz"})
def _fold_run(row, a, first, sample, length, control_count, coefficients, curve):
    """row_i += sum a_node N_i(t_k) over a run of uniform samples k = sample, sample + 1, ...
    (mod N) at nodes first, first + 1, ... (`length` of them), with the samples'
    stored basis values (basis0..2 of `curve`, see `_fold_onto_basis`).
    """
    count = curve[0].shape[0]
    basis0, basis1, basis2, step = curve[9], curve[10], curve[11], curve[12]
    sample = sample % count
    while length > 0:  # at most twice: the run may wrap past sample N - 1
        end = min(count, sample + length)
        span = _span_of_sample(coefficients, count, control_count, step, sample)
        k = sample
        while k < end:
            stop = min(end, span_first_sample(coefficients, count, control_count, step, span + 1))
            offset = first - sample
            span_a = a[k + offset : stop + offset]
            span0 = basis0[k:stop]
            span1 = basis1[k:stop]
            span2 = basis2[k:stop]
            s0 = 0.0
            s1 = 0.0
            s2 = 0.0
            for i in range(span_a.shape[0]):
                s0 += span_a[i] * span0[i]
                s1 += span_a[i] * span1[i]
                s2 += span_a[i] * span2[i]
            _add_span(row, span, control_count, s0, s1, s2)
            k = stop
            span += 1
        first += end - sample
        length -= end - sample
        sample = 0


@njit(cache=True, error_model="numpy")
def _span_of_sample(coefficients, count, control_count, step, k):
    """The span whose samples (`span_first_sample`) include sample k, 0 <= k < count."""
    span = min(k * control_count // count, control_count - 1)
    while span > 0 and span_first_sample(coefficients, count, control_count, step, span) > k:
        span -= 1
    while span_first_sample(coefficients, count, control_count, step, span + 1) <= k:
        span += 1
    return span


@njit(cache=True, error_model="numpy")
def _add_span(row, segment, control_count, s0, s1, s2):
    """Add the sums s0, s1, s2 of a span's nodes to N_(segment-1), N_segment, N_(segment+1) (cyclic)."""
    before = segment - 1 if segment > 0 else control_count - 1
    after = segment + 1 if segment + 1 < control_count else 0
    row[before] += s0
    row[segment] += s1
    row[after] += s2


@njit(cache=True, error_model="numpy", fastmath={"contract", "arcp", "reassoc", "nsz"})
def _fold_onto_basis(row, a, inv_r, inv_s, factor, basis0, basis1, basis2, control_count, coefficients, step):
    """row_i += sum_k c_k N_i(t_k) over the N uniform samples (Sec. 4.3), shape (n,).

    c_k = factor a_k inv_r_k inv_s_k: for the maximum-likelihood kernels 1 / r_k,
    1 / s_k and factor = 1 / D (Eq. 14 and 17), so that the kernel needs no pass of
    its own; for the explicit kernels, whose `a` is the kernel, arrays of ones (a
    flag choosing the product would stop the loop vectorising).  The samples of
    span j (`span_first_sample`: N / n of them in the natural parameter, as many as
    its share of the length in arc length) touch only N_(j-1), N_j and N_(j+1),
    whose values at the samples are basis0, basis1 and basis2, each (N,).
    """
    count = basis0.shape[0]
    first = 0  # span 0 starts at sample 0 in either parameter
    for j in range(control_count):
        last = span_first_sample(coefficients, count, control_count, step, j + 1)
        s0 = 0.0
        s1 = 0.0
        s2 = 0.0
        # Views and an index from 0: a computed index first + i might be negative for all
        # numba knows, and the wrap-around check per element stops the loop vectorising.
        span_a = a[first:last]
        span_r = inv_r[first:last]
        span_s = inv_s[first:last]
        span0 = basis0[first:last]
        span1 = basis1[first:last]
        span2 = basis2[first:last]
        for i in range(span_a.shape[0]):
            c = span_a[i] * span_r[i] * span_s[i]
            s0 += c * span0[i]
            s1 += c * span1[i]
            s2 += c * span2[i]
        first = last
        row[(j - 1) % control_count] += factor * s0
        row[j] += factor * s1
        row[(j + 1) % control_count] += factor * s2


@njit(cache=True, error_model="numpy")
def _node_geometry(
    t, w, nodes, runs, run_count, step, count, sample_x, sample_y, tangent_x, tangent_y, second_x,
    second_y, coefficients, piece_length, corners, corner_count, px, py, tx, ty, sx, sy,
):  # fmt: skip
    """p, p', p'' (px, py, tx, ty, sx, sy) at the `nodes` parameters t of a refined rule, then
    the `corner_count` corner point masses appended (their t and weight 1 in t, w).

    The `run_count` runs of uniform samples (`_refined_nodes`) are copied from the
    stored samples in slices.  A graded node on a sample (step h, `count` of them)
    also takes the sample's stored values, so that the refined rule agrees with the
    plain one there; others are evaluated on the curve.
    """
    inverse = 1.0 / step
    j = 0
    for r in range(run_count + 1):
        stop = runs[r, 0] if r < run_count else nodes
        for node in range(j, stop):
            # The nearest sample index, round(t / step), without a division or a library call.
            q = t[node] * inverse
            k = int(q + 0.5) if q >= 0.0 else -int(0.5 - q)
            if abs(t[node] - k * step) <= 1e-12 * step:
                # k % count without an integer division (k is at most a period out of range).
                while k < 0:
                    k += count
                while k >= count:
                    k -= count
                px[node] = sample_x[k]
                py[node] = sample_y[k]
                tx[node] = tangent_x[k]
                ty[node] = tangent_y[k]
                sx[node] = second_x[k]
                sy[node] = second_y[k]
            else:
                px[node], py[node], tx[node], ty[node], sx[node], sy[node] = _evaluate_curve(
                    coefficients, piece_length, t[node]
                )
        if r < run_count:
            first, sample, length = runs[r, 0], runs[r, 1] % count, runs[r, 2]
            while length > 0:  # at most twice: the run may wrap past sample N - 1
                piece = min(length, count - sample)
                # Views and an index from 0: no wrap-around check per element (`_fold_onto_basis`);
                # one loop, not slice assignments, which took seconds more to compile.
                target = (px[first:], py[first:], tx[first:], ty[first:], sx[first:], sy[first:])
                source = (
                    sample_x[sample:], sample_y[sample:], tangent_x[sample:], tangent_y[sample:],
                    second_x[sample:], second_y[sample:],
                )  # fmt: skip
                for i in range(piece):
                    target[0][i] = source[0][i]
                    target[1][i] = source[1][i]
                    target[2][i] = source[2][i]
                    target[3][i] = source[3][i]
                    target[4][i] = source[4][i]
                    target[5][i] = source[5][i]
                first += piece
                length -= piece
                sample = 0
            j = runs[r, 0] + runs[r, 2]
    for c in range(corner_count):
        px[nodes + c], py[nodes + c], _, _, _, _ = _evaluate_curve(coefficients, piece_length, corners[c, 0])
        t[nodes + c] = corners[c, 0]
        w[nodes + c] = 1.0


@njit(cache=True, error_model="numpy")
def _wrap(t, period):
    return t - math.floor(t / period) * period


@njit(cache=True, error_model="numpy", fastmath={"contract", "arcp", "reassoc", "nsz"})
def _finish(
    kernel,
    ux,
    uy,
    inv_r,
    a,
    s,
    inv_s,
    trial,
    trial_inv,
    blend,
    total,
    px,
    py,
    w,
    step,
    x,
    y,
    tolerance,
    phix,
    phiy,
    spread,
):
    """Turn normalised weights `a` into the quadrature-weighted kernel w_j lambda_j (in `a`).

    Maximum-likelihood family: `_maximum_likelihood` from (phix, phiy), with `spread`
    its bound on |u_(j+1) - u_j| (math.inf if unknown), then Eq. 14 and 17,
    c_j = a_j / (r_j s_j) normalised.  Explicit kernels: `a` already is it.
    Returns (iterations, status, residual).
    """
    if kernel <= MODIFIED_MEAN_VALUE_SQUARED:
        iterations, status, residual, d, _, _ = _maximum_likelihood(
            ux,
            uy,
            inv_r,
            a,
            s,
            inv_s,
            trial,
            trial_inv,
            blend,
            w,
            step,
            total,
            tolerance,
            phix,
            phiy,
            spread,
        )
        inverse = 1.0 / d
        for j in range(total):
            a[j] = a[j] * inv_r[j] * inv_s[j] * inverse
        return iterations, status, residual
    # Explicit kernels: the linear-precision residual is the quadrature's own.
    ex = 0.0
    ey = 0.0
    for j in range(total):
        ex += a[j] * (px[j] - x)
        ey += a[j] * (py[j] - y)
    return 0, STATUS_CONVERGED, math.sqrt(ex * ex + ey * ey)


@njit(cache=True, error_model="numpy")
def _maximum_likelihood(
    ux, uy, inv_r, a, s, inv_s, trial, trial_inv, blend, w, step, total, tolerance, phix, phiy, spread
):
    """Minimise Eq. 16 for the normalised weights `a` and check that lambda-hat is resolved.

    Newton (`_newton`) from (phix, phiy), the path-following fallback
    (`_continuation`) if it fails, then `_peak_unresolved` at the peak of 1 / s_j.
    `spread` bounds |u_(j+1) - u_j| over all neighbouring nodes (math.inf if
    unknown).  Every s_j >= 1 - |phi| (|u_j| = 1), so when spread^2 < 2 (1 - |phi|)
    the peak passes `_peak_unresolved` for sure, and the scan for it is skipped.

    On return `s`, `inv_s` hold 1 + phi . u_j and its inverse at the minimiser.
    Returns (iterations, status, residual, D, phix, phiy), D = sum a_j / (r_j s_j), so
    that lambda_j w_j = a_j / (r_j s_j D) (Eq. 14 and 17); phi is NaN after the
    path-following fallback.
    """
    iterations, status, residual, phix, phiy, d = _newton(
        ux, uy, inv_r, a, s, inv_s, trial, trial_inv, total, tolerance, phix, phiy
    )
    reach = 1.0 - math.sqrt(phix * phix + phiy * phiy)
    if status != STATUS_CONVERGED:
        iterations, status, residual, d = _continuation(
            ux, uy, inv_r, a, w, blend, s, inv_s, trial, trial_inv, total, tolerance, iterations
        )
        phix, phiy = math.nan, math.nan  # the path's phi is not returned
        reach = 0.0  # so scan
    resolved = (spread + ROUNDING_SLACK) ** 2 < 2.0 * (reach - ROUNDING_SLACK)
    if status == STATUS_CONVERGED and not resolved:
        smallest = 1.0
        peak = np.int64(0)  # not a literal: one specialisation of _peak_unresolved
        for j in range(total):
            if s[j] < smallest:
                smallest = s[j]
                peak = j
        # The peak's share of the constraint sum_j a_j / s_j = 1 (Eq. 12 with phi_0 = 1).
        share = a[peak] * inv_s[peak]
        if _peak_unresolved(ux, uy, share, w, step, total, peak, smallest):
            status = STATUS_AT_FEASIBLE_EDGE
    return iterations, status, residual, d, phix, phiy


@njit(cache=True, error_model="numpy")
def _peak_unresolved(ux, uy, share, w, step, count, peak, smallest):
    """Whether lambda-hat = 1 / s (Eq. 14) peaks more sharply than the nodes resolve.

    Near its minimum s_min, 1 / (1 + phi . u) has an angular half-width of about
    sqrt(2 s_min).  If the neighbouring nodes are farther apart in direction, the
    node's share of the constraint mass sum_j a_j / s_j = 1 (Eq. 12), which is what
    pins phi, may belong anywhere within its cell w; the error that can cause is
    about share * w / h.  Reported when above PEAK_MASS (e.g. the unshifted high
    powers of Sec. 3.3, or omega^2 weights near the boundary); a sharp peak inside
    the finely graded window of a near point is harmless and is not.
    """
    if share * w[peak] <= PEAK_MASS * step:
        return False
    before = (peak - 1) % count
    after = (peak + 1) % count
    spread = max(
        math.sqrt((ux[peak] - ux[before]) ** 2 + (uy[peak] - uy[before]) ** 2),
        math.sqrt((ux[after] - ux[peak]) ** 2 + (uy[after] - uy[peak]) ** 2),
    )
    return spread > math.sqrt(2.0 * max(smallest, 0.0))


@njit(cache=True, error_model="numpy")
def _near_stretches(sample_x, sample_y, spacing, x, y, near, nearest, windows):
    """The stretches of samples closer to (x, y) than NEAR_SPACINGS spacings, into `windows`.

    A sequential scan, run only when pass 1 (`_sample_directions`) counted `near`
    > 0 such samples (`core.newton.gradient_solver` shares it).  Squared distances: no root
    or division.  Returns (the number of stretches, the nearest sample's index, its distance;
    `nearest` unchanged when near == 0).
    """
    window_start, window_stop = windows[0], windows[1]
    count = sample_x.shape[0]
    window_count = 0
    in_run = False
    nearest_index = np.int64(0)  # not a literal: one specialisation of _merge_windows
    nearest_squared = math.inf
    for k in range(count if near > 0 else 0):
        dx = sample_x[k] - x
        dy = sample_y[k] - y
        r2 = dx * dx + dy * dy
        if r2 < nearest_squared:
            nearest_squared = r2
            nearest_index = k
        limit = NEAR_SPACINGS * spacing[k]
        if r2 < limit * limit:
            if not in_run:
                if window_count < MAX_WINDOWS:
                    window_start[window_count] = k
                window_count += 1
                in_run = True
            if window_count <= MAX_WINDOWS:
                window_stop[window_count - 1] = k
        else:
            in_run = False
    if near > 0:
        nearest = math.sqrt(nearest_squared)
    return window_count, nearest_index, nearest


@njit(cache=True, error_model="numpy")
def _merge_windows(window_start, window_stop, window_count, count, nearest_index):
    """Join stretches that wrap over index 0, widen by WINDOW_MARGIN, merge overlaps.

    Indices may leave [0, count) (they are taken modulo count later).  Returns the
    number of windows.
    """
    if window_count >= 2 and window_start[0] == 0 and window_stop[window_count - 1] == count - 1:
        window_start[0] = window_start[window_count - 1] - count
        window_count -= 1
    for i in range(window_count):
        window_start[i] -= WINDOW_MARGIN
        window_stop[i] += WINDOW_MARGIN
    merged = 0
    for i in range(window_count):
        if merged > 0 and window_start[i] <= window_stop[merged - 1]:
            window_stop[merged - 1] = max(window_stop[merged - 1], window_stop[i])
        else:
            window_start[merged] = window_start[i]
            window_stop[merged] = window_stop[i]
            merged += 1
    window_count = merged
    if window_count >= 2 and window_stop[window_count - 1] - count >= window_start[0]:
        window_start[0] = window_start[window_count - 1] - count
        window_count -= 1
    if window_count == 1 and window_stop[0] - window_start[0] >= count - 1:
        window_start[0] = nearest_index - count // 2  # the whole curve is near: one window
        window_stop[0] = window_start[0] + count
    return window_count


@njit(cache=True, error_model="numpy")
def _refined_nodes(
    window_start,
    window_stop,
    window_t,
    window_d,
    window_count,
    count,
    step,
    sinh_step,
    coefficients,
    piece_length,
    t,
    w,
    runs,
):
    """Quadrature nodes (t) and weights (w) of a near point; returns their number.

    Uniform samples outside the windows, a graded sinh rule inside each window
    around its closest parameter (peak width from the local speed and curvature).
    Row i of `runs` (int, (MAX_WINDOWS + 1, 3)) is the run of uniform samples after
    window i: (its first node, its first sample index, not wrapped, its length).
    """
    # Reach at least step / sinh_step on both sides of the closest point, so that the
    # sigma step of the graded rule (about h / reach) is at most sinh_step; never
    # into the neighbouring window.
    reach = int(math.ceil(1.0 / sinh_step))
    if not (window_count == 1 and window_stop[0] - window_start[0] >= count):
        for i in range(window_count):
            previous_stop = window_stop[window_count - 1] - count if i == 0 else window_stop[i - 1]
            next_start = window_start[i + 1] if i + 1 < window_count else window_start[0] + count
            centre = int(math.floor(window_t[i] / step))
            window_start[i] = max(previous_stop + 1, min(window_start[i], centre - reach))
            window_stop[i] = min(next_start - 1, max(window_stop[i], centre + 1 + reach))
    nodes = np.int64(0)  # not a literal: one specialisation of _graded_nodes
    for i in range(window_count):
        lo = window_start[i] * step
        hi = window_stop[i] * step
        ti = window_t[i]
        _, _, fx, fy, gx, gy = _evaluate_curve(coefficients, piece_length, ti)
        speed = math.sqrt(fx * fx + fy * fy)
        bend = math.sqrt(gx * gx + gy * gy)
        # Parameter width of the peak: solve speed tau + bend tau^2 / 2 = distance.
        di = window_d[i]
        scale = 2.0 * di / (speed + math.sqrt(speed * speed + 2.0 * bend * di) + 1e-300)
        scale = min(scale, hi - lo)
        first = nodes
        nodes = _graded_nodes(ti, scale, lo, hi, step, t, w, nodes)
        # The window's end nodes are samples: they also get the outer half step.
        w[first] += 0.5 * step
        w[nodes - 1] += 0.5 * step
        next_start = window_start[i + 1] if i + 1 < window_count else window_start[0] + count
        runs[i, 0] = nodes
        runs[i, 1] = window_stop[i] + 1
        runs[i, 2] = max(next_start - window_stop[i] - 1, 0)
        for k in range(window_stop[i] + 1, next_start):
            t[nodes] = k * step
            w[nodes] = step
            nodes += 1
    return nodes


@njit(cache=True, nogil=True, error_model="numpy")
def solve_points(points, settings, curve, geometry, out, iterations, status, residual, first, stride):
    """Evaluate the points first, first + stride, ... of (M, 2) into out (M, columns).

    Per-point diagnostics go to iterations, status and residual, each (M,).
    The GIL is released, so that `core.kernels` runs one call per thread with
    `stride` threads: cheaper to compile than numba's parallel loops, and as fast.
    Points are dealt out round-robin in blocks of BLOCK, so that the costlier
    near-boundary points spread evenly.  Within a block a far point's Newton starts
    from the last minimiser (`_solve_point`): neighbours in a mesh's vertex order,
    their minimisers are close.  A block is solved in order by one thread, so the
    result depends on the points' order, never on the number of threads.

    settings = (kernel, power, shift, output mode, orientation (+1 counter-clockwise),
    diameter, n control points, Newton tolerance relative to the diameter).
    curve = (sample_x, sample_y, tangent_x, tangent_y, second_x, second_y,
    spacing, uniform weights, t_k, basis0, basis1, basis2, h, sinh_step, out_step, slabs):
    twelve contiguous float64 arrays of shape (N,) (basis* are the three non-zero
    B-spline basis values at t_k, used in OUTPUT_BASIS mode), the sample step, the
    sinh step of the near-boundary rule, the step of the output samples
    (OUTPUT_SAMPLES lumps onto that grid, which may be coarser than the samples), and
    `core.curves.crossing_slabs.crossing_slabs(sample_y)` for the inside test of far points.
    geometry = (piecewise-polynomial coefficients (P, D + 1, 2), piece length,
    corners (C, 5)): the exact curve between samples.
    """
    count = curve[0].shape[0]
    capacity = count + MAX_WINDOWS * MAX_WINDOW_NODES + geometry[2].shape[0] + 8
    # Scratch arrays allocated once per call: fresh allocations per point fault in
    # new pages and serialise the threads.
    scratch = (
        np.empty(capacity),
        np.empty(capacity),
        np.empty(capacity),
        np.empty(capacity),
        np.empty(capacity),
        np.empty(capacity),
        np.empty(capacity),
        np.empty(capacity),
        np.empty(capacity),
        np.empty(capacity),
        np.empty(capacity),
        np.empty(capacity),
        np.empty(capacity),
        np.empty(capacity),
        np.empty(capacity),
        np.empty(capacity),
        np.empty(capacity),
        np.ones(capacity),  # c_k = a_k in `_fold_onto_basis` for the explicit kernels
        np.empty(capacity),
        np.empty(capacity),
        np.empty(capacity),
        np.empty(capacity),
        np.empty(capacity),
        np.empty(capacity),
        np.empty(capacity),
        np.empty(capacity),
    )
    window_start = np.empty(MAX_WINDOWS + 1, dtype=np.int64)
    window_stop = np.empty(MAX_WINDOWS + 1, dtype=np.int64)
    window_t = np.empty(MAX_WINDOWS + 1)
    window_d = np.empty(MAX_WINDOWS + 1)
    runs = np.empty((MAX_WINDOWS + 1, 3), dtype=np.int64)
    windows = (window_start, window_stop, window_t, window_d, runs)
    largest_spacing = _largest(curve[6], count)  # not .max(): numpy's compiles three more functions
    count = points.shape[0]
    for block in range(first, (count + BLOCK - 1) // BLOCK, stride):
        nan = math.nan
        history = (nan, nan, nan, nan, nan, nan, nan, nan)
        for m in range(block * BLOCK, min(count, (block + 1) * BLOCK)):
            x = points[m, 0]
            y = points[m, 1]
            iterations[m], status[m], residual[m], phix, phiy = _solve_point(
                x, y, settings, curve, geometry, largest_spacing, out[m], scratch, windows, history
            )
            if not math.isnan(phix):
                history = (x, y, phix, phiy, history[0], history[1], history[2], history[3])
