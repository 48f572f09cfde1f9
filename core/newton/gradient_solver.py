"""Per-point gradients of the barycentric kernels, compiled with numba next to `core.newton.solver`.

One point x is evaluated exactly as `core.newton.solver` evaluates it (the same nodes
t_j and weights w_j: the trapezoid rule far from the boundary, the graded sinh
rule near it, both built by `core.newton.point_rule`; the same weights, Newton solve
and normalisation, by the same functions), and then the x-derivative of every quadrature-weighted
kernel value lambda_j = w_j lambda(x, t_j) is formed in closed form.  The
derivation is in `core.gradients`; the notation here follows it:

    a~_j      the unnormalised weight w_j omega_x(t_j) (Eq. 18-20, 23) or the
              explicit kernel w_j mu(x, t_j) (Eq. 5, Sec. 1.1), and grad a~_j,
    b_j       = lambda_j r_j s_j, proportional to a~_j (Eq. 14 and 17),
    H         = sum_j b_j u_j u_j^T / s_j^2, the Hessian of F (Eq. 16),
    Phi       = d phi / d x = H^-1 (D - I + K + v phi^T)   (implicit function theorem),
    dc_j      = grad b_j / (r_j s_j) + lambda_j (u_j / r_j - grad s_j / s_j),
    grad lambda_j = dc_j - lambda_j sum_k dc_k.

Rows of gradients are accumulated like the values (lumped onto samples or
folded onto the B-spline basis, `output_rows.accumulate`).
"""

from __future__ import annotations

import math

from numba import njit

from core.newton import codes, kernel_weights, minimisation, output_rows, point_rule, quadrature_nodes, solver
from core.newton.solver_state import Directions, thread_arrays


@njit(cache=True, error_model="numpy", inline="always")
def _weight_derivative(kernel, power, node, point, ray, r_min, omega, constant):
    """a~_j and grad a~_j of one node (a~ as in `kernel_weights`, up to one factor common to all j).

    Scalars only (no array arguments: a call per node must not touch reference
    counts): `node` = (p, p', p'' and the weight w), `point` = (x, y), `ray` = (u, 1 / r).
    `omega` is q^k, q = r_min / r, for the power kernels, and `constant`
    the shift of Eq. 19-20 in the same units (its gradient is added by the caller).
    Returns (a~, da~/dx, da~/dy).
    """
    px, py, tx, ty, sx, sy, w = node
    x, y = point
    ux, uy, r_inv = ray
    if kernel == codes.MAXIMUM_LIKELIHOOD:
        return w, 0.0, 0.0
    if kernel == codes.PSEUDO_HARMONIC:
        value = w * r_min * r_inv
        return value, value * ux * r_inv, value * uy * r_inv
    if kernel == codes.POWER or kernel == codes.HARMONIC_LIKE:
        k = 4.0 if kernel == codes.HARMONIC_LIKE else power
        slope = w * k * omega * r_inv  # |grad q^k| w: grad r = -u
        return w * (omega + constant), slope * ux, slope * uy
    if kernel == codes.MODIFIED_MEAN_VALUE or kernel == codes.MODIFIED_MEAN_VALUE_SQUARED:
        # omega = |(p - x) x p'| / r^2 (Eq. 23): grad (p - x) x p' = (-p'_y, p'_x), grad r = -u.
        turn = (ux * ty - uy * tx) * r_inv * r_min  # signed (u x p') / r
        sign = 1.0 if turn >= 0.0 else -1.0
        gx = sign * (-ty) * r_inv * r_inv * r_min + 2.0 * abs(turn) * ux * r_inv
        gy = sign * tx * r_inv * r_inv * r_min + 2.0 * abs(turn) * uy * r_inv
        if kernel == codes.MODIFIED_MEAN_VALUE:
            return w * abs(turn), w * gx, w * gy
        return w * turn * turn, 2.0 * w * abs(turn) * gx, 2.0 * w * abs(turn) * gy
    if kernel == codes.MEAN_VALUE:
        # mu = (p - x) x p' / r^3 (Eq. 5).
        q = r_min * r_inv
        cross = (ux * ty - uy * tx) * q * q
        gx = -ty * r_inv * q * q + 3.0 * cross * ux * r_inv
        gy = tx * r_inv * q * q + 3.0 * cross * uy * r_inv
        return w * cross, w * gx, w * gy
    # WACHSPRESS or LAPLACE (Sec. 1.1), a curve node.
    speed2 = tx * tx + ty * ty
    dx = px - x
    dy = py - y
    cross = dx * ty - dy * tx
    curvature = tx * sy - ty * sx
    if speed2 == 0.0 or cross == 0.0:
        return 0.0, 0.0, 0.0
    cx = -ty
    cy = tx
    if kernel == codes.WACHSPRESS:
        mu = curvature / (cross * cross)
        return w * mu, w * (-2.0 * mu * cx / cross), w * (-2.0 * mu * cy / cross)
    r2 = dx * dx + dy * dy
    mu = (2.0 * speed2 * cross - r2 * curvature) / (cross * cross)
    gx = (2.0 * speed2 * cx + 2.0 * curvature * dx) / (cross * cross) - 2.0 * mu * cx / cross
    gy = (2.0 * speed2 * cy + 2.0 * curvature * dy) / (cross * cross) - 2.0 * mu * cy / cross
    return w * mu, w * gx, w * gy


@njit(cache=True, error_model="numpy")
def _corner_derivative(kernel, corners, c, bx, by, x, y):
    """The point mass of sharp corner c of the three-point family and its gradient.

    mass = q.A / q x A - q.B / q x B with q = corner - x (see `kernel_weights.kernel_weights`);
    Wachspress divides it by |q|^2, Laplace negates it.  Returns (a~, da~/dx, da~/dy).
    """
    qx = bx - x
    qy = by - y
    mass = 0.0
    gx = 0.0
    gy = 0.0
    for side in range(2):
        ex = corners[c, 1 + 2 * side]
        ey = corners[c, 2 + 2 * side]
        dot = qx * ex + qy * ey
        cross = qx * ey - qy * ex
        if cross == 0.0:
            return 0.0, 0.0, 0.0
        sign = 1.0 if side == 0 else -1.0
        mass += sign * dot / cross
        # d/dq (dot / cross) = e / cross - dot (e_y, -e_x) / cross^2; d/dx = -d/dq.
        gx -= sign * (ex / cross - dot * ey / (cross * cross))
        gy -= sign * (ey / cross + dot * ex / (cross * cross))
    if kernel == codes.WACHSPRESS:
        q2 = qx * qx + qy * qy
        return mass / q2, gx / q2 + 2.0 * mass * qx / (q2 * q2), gy / q2 + 2.0 * mass * qy / (q2 * q2)
    return -mass, -gx, -gy


@njit(cache=True, error_model="numpy", inline="always")
def _power(q, k):
    """q^k, by multiplication for the powers 3 and 4 of the named kernels."""
    if k == 3.0:
        return q * q * q
    if k == 4.0:
        q2 = q * q
        return q2 * q2
    return q**k


@njit(cache=True, error_model="numpy", fastmath={"contract", "arcp", "reassoc", "nsz"})
def _shift(settings, w, rays, r_min, count, omega):
    """omega_j = q_j^k (into `omega`) and the shift of Eq. 19-20 with its gradient: (c, dc/dx, dc/dy).

    Only for the power kernels (Eq. 19-20), in the units of q = r_min / r.
    """
    kernel, power, shift = settings.kernel, settings.power, settings.shift
    ux, uy, inv_r = rays
    if not (kernel == codes.POWER or kernel == codes.HARMONIC_LIKE):
        return 0.0, 0.0, 0.0
    mode = codes.SHIFT_INTEGRAL if kernel == codes.HARMONIC_LIKE else shift
    k = 4.0 if kernel == codes.HARMONIC_LIKE else power
    integral = 0.0
    gx = 0.0
    gy = 0.0
    length = 0.0
    for j in range(count):
        value = _power(r_min * inv_r[j], k)
        omega[j] = value
        integral += w[j] * value
        slope = w[j] * k * value * inv_r[j]
        gx += slope * ux[j]
        gy += slope * uy[j]
        length += w[j]
    if mode == codes.SHIFT_MEAN:
        return integral / length, gx / length, gy / length
    if mode == codes.SHIFT_INTEGRAL:
        return integral, gx, gy
    return 0.0, 0.0, 0.0


@njit(cache=True, error_model="numpy", fastmath={"contract", "arcp", "reassoc", "nsz"}, inline="always")
def _weight_gradients(settings, node_arrays, work, total, nodes, corners, point, r_min):
    """Pass 1 of `_differentiate` (same arguments): a~_j into `work.blend` and grad a~_j into
    `work.trial`, `work.trial_inv`, for the `nodes` nodes and the corner masses up to `total`."""
    kernel, power = settings.kernel, settings.power
    px, py, tx, ty, sx, sy, w = node_arrays
    ux, uy, inv_r, a, s, inv_s, grad_x, grad_y, omega = work
    x, y = point
    constant, shift_x, shift_y = _shift(settings, w, (ux, uy, inv_r), r_min, nodes, omega)
    # Pass 1: a~_j into `omega` and grad a~_j into grad_x, grad_y; the power kernels (the common
    # case) in a loop of their own without the kernel's branches, so that it vectorises.
    if kernel == codes.POWER or kernel == codes.HARMONIC_LIKE:
        k = 4.0 if kernel == codes.HARMONIC_LIKE else power
        for j in range(nodes):
            slope = w[j] * k * omega[j] * inv_r[j]  # |grad q^k| w: grad r = -u
            grad_x[j] = slope * ux[j] + w[j] * shift_x
            grad_y[j] = slope * uy[j] + w[j] * shift_y
            omega[j] = w[j] * (omega[j] + constant)
    else:
        for j in range(nodes):
            value, gx, gy = _weight_derivative(
                kernel, power, (px[j], py[j], tx[j], ty[j], sx[j], sy[j], w[j]), (x, y),
                (ux[j], uy[j], inv_r[j]), r_min, omega[j], constant,
            )  # fmt: skip
            omega[j] = value
            grad_x[j] = gx + w[j] * shift_x
            grad_y[j] = gy + w[j] * shift_y
    for j in range(nodes, total):
        omega[j], grad_x[j], grad_y[j] = _corner_derivative(kernel, corners, j - nodes, px[j], py[j], x, y)


@njit(cache=True, error_model="numpy", fastmath={"contract", "arcp", "reassoc", "nsz"})
def _differentiate(settings, node_arrays, work, total, nodes, corners, point, r_min):
    """grad lambda_j of the `total` nodes into grad_x, grad_y (each (total,) or longer).

    On entry `a` holds lambda_j (normalised, as `minimisation.finish` leaves it), `s`
    and `inv_s` hold s_j = 1 + phi . u_j and 1 / s_j for the maximum-likelihood
    family; nodes >= `nodes` are corner point masses (three-point family).
    `node_arrays` (`Nodes`) is the rule, `work` (`Work`) the minimisation's arrays, of which
    `blend` is scratch here (`omega`: q_j^k of the power kernels, then a~_j) and `trial`,
    `trial_inv` receive the gradients; `point` = (x, y).  See `core.gradients` for the formulas.
    """
    kernel = settings.kernel
    ux, uy, inv_r, a, s, inv_s, grad_x, grad_y, omega = work
    newton = kernel <= codes.MODIFIED_MEAN_VALUE_SQUARED
    _weight_gradients(settings, node_arrays, work, total, nodes, corners, point, r_min)
    sum_a = 0.0
    if not newton:
        # lambda_j = m_j / M: grad lambda_j = grad m_j / M - lambda_j sum_k grad m_k / M.
        for j in range(total):
            sum_a += omega[j]
        _normalise(grad_x, grad_y, a, total, 1.0 / sum_a)
        return
    # Pass 2: the sums of a~ and b, H, K, v, D~ and the least squares of phi from s_j - 1 = phi . u_j.
    sum_b = 0.0
    hxx = hxy = hyy = 0.0
    kxx = kxy = kyy = 0.0
    vx = vy = 0.0
    dxx = dxy = dyx = dyy = 0.0
    lxx = lxy = lyy = 0.0
    rx = ry = 0.0
    for j in range(total):
        gx = grad_x[j]
        gy = grad_y[j]
        sum_a += omega[j]
        u0 = ux[j]
        u1 = uy[j]
        inv = inv_s[j]
        lam = a[j] * inv
        hb = lam / inv_r[j]
        sum_b += hb * s[j] * s[j]
        hxx += hb * u0 * u0
        hxy += hb * u0 * u1
        hyy += hb * u1 * u1
        kxx += lam * u0 * u0
        kxy += lam * u0 * u1
        kyy += lam * u1 * u1
        vx += lam * u0
        vy += lam * u1
        dxx += u0 * gx * inv
        dxy += u0 * gy * inv
        dyx += u1 * gx * inv
        dyy += u1 * gy * inv
        lxx += u0 * u0
        lxy += u0 * u1
        lyy += u1 * u1
        rx += u0 * (s[j] - 1.0)
        ry += u1 * (s[j] - 1.0)
    kappa = sum_b / sum_a
    normal = lxx * lyy - lxy * lxy
    phix = (lyy * rx - lxy * ry) / normal
    phiy = (lxx * ry - lxy * rx) / normal
    # dg/dx (*), column beta: kappa D~ e_beta - e_beta + K e_beta + v phi_beta.
    mxx = kappa * dxx - 1.0 + kxx + vx * phix
    mxy = kappa * dxy + kxy + vx * phiy
    myx = kappa * dyx + kxy + vy * phix
    myy = kappa * dyy - 1.0 + kyy + vy * phiy
    determinant = hxx * hyy - hxy * hxy
    fxx = (hyy * mxx - hxy * myx) / determinant
    fxy = (hyy * mxy - hxy * myy) / determinant
    fyx = (hxx * myx - hxy * mxx) / determinant
    fyy = (hxx * myy - hxy * mxy) / determinant
    # Pass 3: dc_j = grad b_j / (r_j s_j) + lambda_j (u_j / r_j - grad s_j / s_j).
    for j in range(total):
        u0 = ux[j]
        u1 = uy[j]
        r_inv = inv_r[j]
        inv = inv_s[j]
        lam = a[j]
        excess = s[j] - 1.0
        # grad s_j at the moving phi: Phi^T u_j + d(phi . u_j)/dx, du/dx = -(I - u u^T) / r.
        dsx = fxx * u0 + fyx * u1 - (phix - excess * u0) * r_inv
        dsy = fxy * u0 + fyy * u1 - (phiy - excess * u1) * r_inv
        grad_x[j] = kappa * grad_x[j] * r_inv * inv + lam * (u0 * r_inv - dsx * inv)
        grad_y[j] = kappa * grad_y[j] * r_inv * inv + lam * (u1 * r_inv - dsy * inv)
    _normalise(grad_x, grad_y, a, total, 1.0)


@njit(cache=True, error_model="numpy", fastmath={"contract", "arcp", "reassoc", "nsz"})
def _normalise(grad_x, grad_y, a, total, scale):
    """grad_j <- scale grad_j - a_j sum_k scale grad_k: the derivative of dividing by the sum."""
    sum_x = 0.0
    sum_y = 0.0
    for j in range(total):
        grad_x[j] *= scale
        grad_y[j] *= scale
        sum_x += grad_x[j]
        sum_y += grad_y[j]
    for j in range(total):
        grad_x[j] -= a[j] * sum_x
        grad_y[j] -= a[j] * sum_y


@njit(cache=True, error_model="numpy")
def _accumulate_nodes(rows, settings, samples, a, gradient, t, total):
    """Add lambda_j and grad lambda_j at the nodes' parameters t_j into the output `rows` =
    (row, row_x, row_y); `gradient` = (grad_x, grad_y)."""
    row, row_x, row_y = rows
    grad_x, grad_y = gradient
    mode, control_count = settings.mode, settings.control_count
    count, step, out_step = samples.rule.x.shape[0], samples.step, samples.out_step
    period = count * step
    out_count = int(round(count * step / out_step))
    for j in range(total):
        tj = t[j] - math.floor(t[j] / period) * period
        if mode == codes.OUTPUT_SAMPLES:
            output_rows.accumulate(row, mode, a[j], tj, out_step, out_count, control_count)
            output_rows.accumulate(row_x, mode, grad_x[j], tj, out_step, out_count, control_count)
            output_rows.accumulate(row_y, mode, grad_y[j], tj, out_step, out_count, control_count)
            continue
        # The three B-spline basis functions non-zero at t_j (Sec. 4.3), as in `output_rows.accumulate`.
        segment = int(math.floor(tj))
        if segment >= control_count:
            segment = control_count - 1
        u = tj - segment
        b0 = 0.5 * (1.0 - u) * (1.0 - u)
        b1 = 0.5 * (-2.0 * u * u + 2.0 * u + 1.0)
        b2 = 0.5 * u * u
        before = segment - 1 if segment > 0 else control_count - 1
        after = segment + 1 if segment + 1 < control_count else 0
        for out, value in ((row, a[j]), (row_x, grad_x[j]), (row_y, grad_y[j])):
            out[before] += value * b0
            out[segment] += value * b1
            out[after] += value * b2


@njit(cache=True, error_model="numpy", fastmath={"contract", "arcp", "reassoc", "nsz"})
def _accumulate_samples(rows, a, gradient, count, samples, control_count):
    """Fold lambda_k and grad lambda_k at the N uniform samples onto the B-spline basis, span by span
    (`rows` and `gradient` as in `_accumulate_nodes`)."""
    row, row_x, row_y = rows
    grad_x, grad_y = gradient
    basis0, basis1, basis2 = samples.basis0, samples.basis1, samples.basis2
    per = count // control_count
    for i in range(control_count):
        before = i - 1 if i > 0 else control_count - 1
        after = i + 1 if i + 1 < control_count else 0
        # Views indexed from 0, as in `output_rows.fold_onto_basis`: a computed index i * per + k might
        # be negative for all numba knows, and the wrap-around check stops the loop vectorising.
        span_a = a[i * per : (i + 1) * per]
        span_x = grad_x[i * per : (i + 1) * per]
        span_y = grad_y[i * per : (i + 1) * per]
        span0 = basis0[i * per : (i + 1) * per]
        span1 = basis1[i * per : (i + 1) * per]
        span2 = basis2[i * per : (i + 1) * per]
        a0 = a1 = a2 = x0 = x1 = x2 = y0 = y1 = y2 = 0.0
        for k in range(span_a.shape[0]):
            b0 = span0[k]
            b1 = span1[k]
            b2 = span2[k]
            a0 += span_a[k] * b0
            a1 += span_a[k] * b1
            a2 += span_a[k] * b2
            x0 += span_x[k] * b0
            x1 += span_x[k] * b1
            x2 += span_x[k] * b2
            y0 += span_y[k] * b0
            y1 += span_y[k] * b1
            y2 += span_y[k] * b2
        row[before] += a0
        row[i] += a1
        row[after] += a2
        row_x[before] += x0
        row_x[i] += x1
        row_x[after] += x2
        row_y[before] += y0
        row_y[i] += y1
        row_y[after] += y2


# Inlined into gradient_points, as solver.solve_point is into solve_points.
@njit(cache=True, error_model="numpy", inline="always")
def _gradient_point(point, settings, samples, geometry, rows, scratch, windows):
    """Evaluate one point and its gradient; returns (iterations, status, residual).

    The nodes are those of `solver.solve_point`, by the same `point_rule.point_rule`, and so
    is the Newton start of the maximum-likelihood
    kernels (`minimisation.coarse_start`) and, for a far point, the bound that skips the peak
    scan; a point on the boundary gets its Lagrange-limit row and NaN gradients.  `rows` =
    (row, row_x, row_y) receive the values and their x- and y-derivatives; the other
    arguments are those of `solver.solve_point`.
    """
    x, y = point
    row, row_x, row_y = rows
    kernel, mode, control_count = settings.kernel, settings.mode, settings.control_count
    accuracy = settings.tolerance * settings.diameter
    corners, plain, sample_t = geometry.corners, samples.rule, samples.t
    step, out_step, largest_spacing = samples.step, samples.out_step, samples.largest_spacing
    work = scratch.work
    a, trial, trial_inv = work.a, work.trial, work.trial_inv
    t, coarse = scratch.t, scratch.coarse
    rays = Directions(work.ux, work.uy, work.inv_r)
    likelihood = kernel <= codes.MODIFIED_MEAN_VALUE_SQUARED
    count = plain.x.shape[0]
    out_count = int(round(count * step / out_step))
    period = count * step
    rule, value, nodes, run_count = point_rule.point_rule(
        (x, y), settings, samples, geometry, scratch, windows
    )
    if rule == point_rule.RULE_OUTSIDE:
        return 0, codes.STATUS_OUTSIDE, value
    if rule == point_rule.RULE_ON_BOUNDARY:
        wrapped = quadrature_nodes.wrap(value, period)
        output_rows.accumulate(row, mode, 1.0, wrapped, out_step, out_count, control_count)
        for i in range(row.shape[0]):
            row_x[i] = math.nan
            row_y[i] = math.nan
        return 0, codes.STATUS_CONVERGED, 0.0
    if rule == point_rule.RULE_SAMPLES:
        nearest = value
        # The trapezoid rule on the shared samples, as in the solver's common case.
        total = kernel_weights.kernel_weights(settings, plain, (x, y), count, corners, rays, nearest, a)
        phix, phiy = 0.0, 0.0
        if likelihood:
            phix, phiy = minimisation.coarse_start(
                rays, a, count, max(nearest / largest_spacing, solver.FAR_START_SEPARATION),
                coarse, accuracy, (0.0, 0.0),
            )  # fmt: skip
        iterations, status, residual = minimisation.finish(
            kernel, work, total, plain, step, (x, y),
            (accuracy, largest_spacing / nearest), (phix, phiy),
        )  # fmt: skip
        _differentiate(settings, plain, work, total, count, corners, (x, y), nearest)
        if mode == codes.OUTPUT_BASIS:
            _accumulate_samples(rows, a, (trial, trial_inv), count, samples, control_count)
        else:
            _accumulate_nodes(rows, settings, samples, a, (trial, trial_inv), sample_t, total)
        return iterations, status, residual
    r_min = value  # RULE_NODES
    total = kernel_weights.kernel_weights(settings, scratch.nodes, (x, y), nodes, corners, rays, r_min, a)
    phix, phiy = 0.0, 0.0
    if likelihood:
        phix, phiy = minimisation.coarse_start(
            rays, a, total, solver.NEAR_START_SEPARATION, coarse, accuracy, (0.0, 0.0)
        )
    limits = (accuracy, math.inf)
    iterations, status, residual = minimisation.finish(
        kernel, work, total, scratch.nodes, step, (x, y), limits, (phix, phiy)
    )
    _differentiate(settings, scratch.nodes, work, total, nodes, corners, (x, y), r_min)
    _accumulate_nodes(rows, settings, samples, a, (trial, trial_inv), t, total)
    return iterations, status, residual


@njit(cache=True, nogil=True, error_model="numpy")
def gradient_points(points, settings, samples, geometry, output, gradients, first, stride):
    """Values (M, columns) and gradients (M, 2, columns) of the points first, first + stride, ...

    Arguments as in `solver.solve_points`; gradients[m, 0] and gradients[m, 1]
    are the x- and y-derivatives of the row output.values[m].  Releases the GIL.
    """
    scratch, windows = thread_arrays(samples.rule.x.shape[0], geometry.corners.shape[0])
    for m in range(first, points.shape[0], stride):
        rows = (output.values[m], gradients[m, 0], gradients[m, 1])
        output.iterations[m], output.status[m], output.residual[m] = _gradient_point(
            (points[m, 0], points[m, 1]), settings, samples, geometry, rows, scratch, windows
        )
