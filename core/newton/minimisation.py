"""The minimisation of Eq. 16: Newton's method with Armijo backtracking from a warm or coarse
start, every trial strictly inside the feasible set {phi : 1 + phi . u_j > 0}, a path-following
fallback, and the normalisation of Eq. 14 and 17 (`finish`)."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from core.newton.codes import (
    MODIFIED_MEAN_VALUE_SQUARED,
    STATUS_AT_FEASIBLE_EDGE,
    STATUS_CONVERGED,
    STATUS_NOT_CONVERGED,
)

# Kernel share above which an unresolved peak of lambda-hat is reported: about the
# trapezoid rule's own error at N = 100 n, so a report means a real loss of accuracy.
PEAK_MASS = 1e-4


MAX_NEWTON = 100


# Blending factors of the path-following fallback (see _continuation), ending at 0.
CONTINUATION = (0.5, 0.1, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 0.0)


MAX_BACKTRACKS = 60


# Warm start of far points (coarse_start): the coarse rule's spacing is at most the point's
# distance over this many, and it keeps at least this many nodes.
COARSE_SPACINGS = 3.0


MIN_COARSE_NODES = 96


# The coarse minimiser is a start only, off the full one by the subset's quadrature error
# anyway: its Newton stops at this many times the tolerance (one step fewer, as many on all N).
COARSE_LOOSER = 1e3


ARMIJO = 1e-4


# Newton steps with |delta| <= FULL_STEP (1 - |phi|) are accepted without a trial (see newton_steps):
# feasible, and Armijo holds for any FULL_STEP < 1/2 (0.45: the bound is 0.09 slope <= ARMIJO slope).
FULL_STEP = 0.45


# Slack for rounding (in u_j and s_j, ~1e-16) in the bound that skips the peak scan
# (`maximum_likelihood`).
ROUNDING_SLACK = 1e-12


@njit(cache=True, error_model="numpy", fastmath={"contract", "arcp", "reassoc", "nsz"})
def newton_steps(directions, a, buffers, count, tolerance, start):
    """Minimise F(phi) = -sum a_j log(1 + phi . u_j) (Eq. 16 with phi_0 = 1).

    `directions` = (u_x, u_y, 1 / r) and `a` of the `count` nodes; `buffers` = (s, 1 / s, and
    both at a trial) receive s_j = 1 + phi . u_j; `start` = (phix, phiy).

    Newton's method with Armijo backtracking from (phix, phiy): phi = 0 in the
    paper (Sec. 4.1), or a warm start (`coarse_start`); a start outside the
    feasible set is replaced by phi = 0.  A trial with
    any 1 + phi . u_j <= 0 is rejected like an Armijo failure.  One fused pass per
    trial gives the gradient, Hessian and D at the trial point and, with
    z_j = s_j(trial) / s_j - 1, the log-free bound

        F(trial) - F(phi) = -sum a_j log(1 + z_j) <= -sum a_j z_j + sum a_j z_j^2 / (2 m_j),

    m_j = min(1, 1 + z_j), from log(1 + z) >= z - z^2 / (2 min(1, 1 + z)) for z > -1;
    1 / m_j = max(1, s_j / s_j(trial)) needs no division of its own.  If the bound
    meets the Armijo condition the step is accepted; only otherwise is a tighter
    bound computed (`change_bound`, log1p only where z_j < -1/2).  A step short
    enough that it is feasible and meets the bound for sure (|delta| <= FULL_STEP
    (1 - |phi|): every late step, from phi = 0 or a warm start) needs no trial: one
    `_newton_terms` pass at the new phi, without the bound's sums.  The loops carry no
    min/max reduction (feasibility is a count), so that they vectorise.

    On return `s` and `inv_s` hold 1 + phi . u_j and its inverse.  Returns
    (iterations, status, residual, phix, phiy, D), residual = |grad F| / D in length
    units: the linear-precision error of the discrete kernel; D = sum a_j / (r_j s_j)
    at the returned phi is the normaliser of Eq. 17.
    """
    ux, uy, inv_r = directions
    s, inv_s, trial, trial_inv = buffers
    phix, phiy = start
    gx, gy, hxx, hxy, hyy, d, infeasible = _newton_terms(directions, a, s, inv_s, count, (phix, phiy))
    if infeasible > 0:
        # A warm start outside the feasible set: start from phi = 0 (always feasible).
        phix = 0.0
        phiy = 0.0
        gx, gy, hxx, hxy, hyy, d, infeasible = _newton_terms(directions, a, s, inv_s, count, (phix, phiy))
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
            gx, gy, hxx, hxy, hyy, d, _ = _newton_terms(directions, a, s, inv_s, count, (phix, phiy))
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
                    or change_bound(a, ux, uy, inv_s, deltax, deltay, alpha, count) <= ARMIJO * alpha * slope
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
def _newton_terms(directions, a, s, inv_s, count, phi):
    """Gradient, Hessian and D of F (Eq. 16) at phi; fills s_j = 1 + phi . u_j and 1 / s_j.

    Returns (gx, gy, hxx, hxy, hyy, D, the number of s_j <= 0); the terms are
    meaningful only if that number is 0 (phi feasible).
    """
    ux, uy, inv_r = directions
    phix, phiy = phi
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
def _continuation(work, w, count, tolerance, iterations):
    """Path-following for the points Newton from phi = 0 does not bring home.

    When omega spans many orders of magnitude (the unshifted powers of Sec. 3.3)
    the minimiser hugs the edge of the feasible set and damped Newton steps from
    phi = 0 crawl.  The weights (1 - mu) a + mu w / sum(w) blend the kernel with the
    unweighted one (omega = 1, well conditioned); mu falls to 0 and each stage starts
    from the previous minimiser.  The last stage is exactly the problem of Eq. 16,
    so the result is the same minimiser, only reached.  Returns (iterations,
    status, residual) of the whole path and D (see `newton_steps`) at its end.
    """
    a, blend = work.a, work.blend
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
        taken, status, residual, phix, phiy, d = newton_steps(
            (work.ux, work.uy, work.inv_r), blend, (work.s, work.inv_s, work.trial, work.trial_inv),
            count, stage_tolerance, (phix, phiy),
        )  # fmt: skip
        iterations += taken
        if status != STATUS_CONVERGED:
            break
    return iterations, status, residual, d


@njit(cache=True, error_model="numpy")
def coarse_start(directions, a, count, separation, coarse, tolerance, start):
    """Warm start of Newton for a far point: the minimiser of Eq. 16 on every stride-th node.

    The trapezoid rule on a subset of the uniform samples converges geometrically
    in the point's distance over the subset's spacing, so at a point `separation`
    sample spacings from the boundary the coarse minimiser, on
    stride <= separation / COARSE_SPACINGS times fewer nodes, is within a few
    Newton steps' contraction of the full one; Newton on all nodes
    (`newton_steps`) then polishes it, usually in one step, to the same tolerance.  The
    answer stays the minimiser of the full rule; only the starting point changes.
    `coarse` holds four scratch arrays for the subset (u_x, u_y, 1 / r, a) and
    four for Newton, which starts from (phix, phiy) (a neighbour's minimiser, or 0)
    and stops at COARSE_LOOSER times `tolerance`.  Returns the coarse minimiser;
    (phix, phiy) where no subset applies, (0, 0) if the coarse Newton did not converge.
    `directions` = (u_x, u_y, 1 / r) of the `count` nodes, `start` = (phix, phiy).
    """
    ux, uy, inv_r = directions
    phix, phiy = start
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
    _, status, _, phix, phiy, _ = newton_steps(
        (coarse_ux, coarse_uy, coarse_inv_r), coarse_a, (s, inv_s, trial, trial_inv), nodes,
        COARSE_LOOSER * tolerance, (phix, phiy),
    )  # fmt: skip
    if status != STATUS_CONVERGED:
        return 0.0, 0.0
    return phix, phiy


@njit(cache=True, error_model="numpy")
def predicted_start(x, y, history, reach):
    """A start for Newton at (x, y) from the last two minimisers of its block.

    history = (x1, y1, phix1, phiy1, x2, y2, phix2, phiy2), the last point first
    (NaN where missing).  If both lie within `reach` of each other and of (x, y)
    (mesh neighbours along a row), phi is extrapolated linearly along x2 -> x1,
    which is within ~1e-3 of the minimiser and needs no coarse solve (returns
    (phix, phiy, True)); if only the last is that close, its phi is the coarse
    solve's start; else phi = 0.  Any start gives the same minimiser (`newton_steps`).
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
def change_bound(a, ux, uy, inv_s, deltax, deltay, alpha, count):
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


@njit(cache=True, error_model="numpy", fastmath={"contract", "arcp", "reassoc", "nsz"})
def finish(kernel, work, total, nodes, step, point, limits, start):
    """Turn normalised weights `a` into the quadrature-weighted kernel w_j lambda_j (in `a`).

    Maximum-likelihood family: `maximum_likelihood` from (phix, phiy), with `spread`
    its bound on |u_(j+1) - u_j| (math.inf if unknown), then Eq. 14 and 17,
    c_j = a_j / (r_j s_j) normalised.  Explicit kernels: `a` already is it.
    `work` holds the arrays (`Work`), `nodes` the rule (`Nodes`: p and the weights, h apart
    on the samples), `point` = (x, y), `limits` = (Newton's tolerance, `spread`), `start` =
    (phix, phiy).  Returns (iterations, status, residual).
    """
    a, inv_r, inv_s = work.a, work.inv_r, work.inv_s
    px, py, w = nodes.x, nodes.y, nodes.weight
    x, y = point
    if kernel <= MODIFIED_MEAN_VALUE_SQUARED:
        iterations, status, residual, d, _, _ = maximum_likelihood(work, w, step, total, limits, start)
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
def maximum_likelihood(work, w, step, total, limits, start):
    """Minimise Eq. 16 for the normalised weights `a` and check that lambda-hat is resolved.

    Newton (`newton_steps`) from (phix, phiy), the path-following fallback
    (`_continuation`) if it fails, then `_peak_unresolved` at the peak of 1 / s_j.
    `spread` bounds |u_(j+1) - u_j| over all neighbouring nodes (math.inf if
    unknown).  Every s_j >= 1 - |phi| (|u_j| = 1), so when spread^2 < 2 (1 - |phi|)
    the peak passes `_peak_unresolved` for sure, and the scan for it is skipped.

    On return `s`, `inv_s` hold 1 + phi . u_j and its inverse at the minimiser.
    Returns (iterations, status, residual, D, phix, phiy), D = sum a_j / (r_j s_j), so
    that lambda_j w_j = a_j / (r_j s_j D) (Eq. 14 and 17); phi is NaN after the
    path-following fallback.  `work` holds the arrays (`Work`), `w` the nodes' weights (step h
    apart on the samples), `limits` = (Newton's tolerance, `spread`), `start` = (phix, phiy).
    """
    ux, uy, inv_r, a, s, inv_s, trial, trial_inv, blend = work
    tolerance, spread = limits
    phix, phiy = start
    iterations, status, residual, phix, phiy, d = newton_steps(
        (ux, uy, inv_r), a, (s, inv_s, trial, trial_inv), total, tolerance, (phix, phiy)
    )
    reach = 1.0 - math.sqrt(phix * phix + phiy * phiy)
    if status != STATUS_CONVERGED:
        iterations, status, residual, d = _continuation(work, w, total, tolerance, iterations)
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
