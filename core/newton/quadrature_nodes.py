"""The quadrature nodes of one point (Sec. 4.1): directions to the uniform samples, the
boundary stretches closer than `NEAR_SPACINGS` sample spacings, and there a graded sinh rule
around the closest point of each stretch, with the curve's data at every node."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from core.curves.arc_length_compiled import evaluate_curve

# A point closer to the boundary than this many local sample spacings gets a refined rule.
NEAR_SPACINGS = 4.0


# Samples kept in the refined window beyond the near stretch, on each side.
WINDOW_MARGIN = 3


# Step of the graded rule in the sinh variable near the closest point (divided by the
# refinement factor when a point is solved again on a finer quadrature).
SINH_STEP = 0.15


MAX_WINDOWS = 8


MAX_WINDOW_NODES = 1024


@njit(cache=True, error_model="numpy")
def graded_side(edge, scale, step):
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

    Each side of `center` gets its own rule (`graded_side`) whose node spacing at
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
        left_intervals, left_scale, left_step = graded_side(left, scale, step)
    if right > 1e-9 * step:
        right_intervals, right_scale, right_step = graded_side(right, scale, step)
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
def directions(px, py, x, y, count, ux, uy, inv_r):
    """Unit directions u_j = (p_j - x) / r_j and 1 / r_j; returns min r_j.

    The minimum is taken in a second loop (`largest`) so that this one vectorises.
    """
    for j in range(count):
        dx = px[j] - x
        dy = py[j] - y
        inv = 1.0 / math.sqrt(dx * dx + dy * dy)
        ux[j] = dx * inv
        uy[j] = dy * inv
        inv_r[j] = inv
    return 1.0 / largest(inv_r, count)


@njit(cache=True, error_model="numpy", fastmath={"contract", "arcp", "reassoc", "nsz"})
def sample_directions(sample_x, sample_y, spacing, x, y, ux, uy, inv_r):
    """Unit directions u_k = (p_k - x) / r_k and 1 / r_k to the N samples, one vectorised pass.

    Returns the number of samples closer than NEAR_SPACINGS times their spacing
    (a point on a sample, r_k = 0, counts: it is on the boundary, and its
    directions are not used).  No min reduction here: it would stop the loop
    from vectorising (see `largest`).
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
def largest(values, count):
    """max_k values_k over the first `count` entries."""
    largest = values[0]
    for k in range(1, count):
        if values[k] > largest:
            largest = values[k]
    return largest


@njit(cache=True, error_model="numpy")
def node_geometry(t, node_arrays, nodes, runs, run_count, samples, geometry, corner_count):
    """p, p', p'' (px, py, tx, ty, sx, sy) at the `nodes` parameters t of a refined rule, then
    the `corner_count` corner point masses appended (their t and weight 1 in t, w).

    The `run_count` runs of uniform samples (`refined_nodes`) are copied from the
    stored samples in slices.  A graded node on a sample (step h, `count` of them)
    also takes the sample's stored values, so that the refined rule agrees with the
    plain one there; others are evaluated on the curve.
    """
    px, py, tx, ty, sx, sy, w = node_arrays  # `Nodes`, filled here
    rule = samples.rule
    sample_x, sample_y, tangent_x, tangent_y = rule.x, rule.y, rule.tangent_x, rule.tangent_y
    second_x, second_y, step, count = rule.second_x, rule.second_y, samples.step, rule.x.shape[0]
    coefficients, piece_length, corners = geometry
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
                px[node], py[node], tx[node], ty[node], sx[node], sy[node] = evaluate_curve(
                    coefficients, piece_length, t[node]
                )
        if r < run_count:
            first, sample, length = runs[r, 0], runs[r, 1] % count, runs[r, 2]
            while length > 0:  # at most twice: the run may wrap past sample N - 1
                piece = min(length, count - sample)
                # Views and an index from 0: no wrap-around check per element (`fold_onto_basis`);
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
        px[nodes + c], py[nodes + c], _, _, _, _ = evaluate_curve(coefficients, piece_length, corners[c, 0])
        t[nodes + c] = corners[c, 0]
        w[nodes + c] = 1.0


@njit(cache=True, error_model="numpy")
def wrap(t, period):
    return t - math.floor(t / period) * period


@njit(cache=True, error_model="numpy")
def near_stretches(sample_x, sample_y, spacing, x, y, near, nearest, windows):
    """The stretches of samples closer to (x, y) than NEAR_SPACINGS spacings, into `windows`.

    A sequential scan, run only when pass 1 (`sample_directions`) counted `near`
    > 0 such samples (`core.newton.gradient_solver` shares it).  Squared distances: no root
    or division.  Returns (the number of stretches, the nearest sample's index, its distance;
    `nearest` unchanged when near == 0).
    """
    window_start, window_stop = windows[0], windows[1]
    count = sample_x.shape[0]
    window_count = 0
    in_run = False
    nearest_index = np.int64(0)  # not a literal: one specialisation of merge_windows
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
def merge_windows(window_start, window_stop, window_count, count, nearest_index):
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
def refined_nodes(windows, window_count, samples, geometry, t, w):
    """Quadrature nodes (t) and weights (w) of a near point; returns their number.

    Uniform samples outside the windows, a graded sinh rule inside each window
    around its closest parameter (peak width from the local speed and curvature).
    Row i of `runs` (int, (MAX_WINDOWS + 1, 3)) is the run of uniform samples after
    window i: (its first node, its first sample index, not wrapped, its length).
    """
    window_start, window_stop, window_t, window_d, runs = windows
    count, step, sinh_step = samples.rule.x.shape[0], samples.step, samples.sinh_step
    coefficients, piece_length = geometry.coefficients, geometry.piece_length
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
        _, _, fx, fy, gx, gy = evaluate_curve(coefficients, piece_length, ti)
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
