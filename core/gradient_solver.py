"""Per-point gradients of the barycentric kernels, compiled with numba next to `core.solver`.

One point x is evaluated exactly as `core.solver` evaluates it (the same nodes
t_j and weights w_j: the trapezoid rule far from the boundary, the graded sinh
rule near it; the same weights, Newton solve and normalisation, by calling the
solver's own helpers), and then the x-derivative of every quadrature-weighted
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
folded onto the B-spline basis, `solver._accumulate`).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from core import solver


@njit(cache=True, error_model="numpy")
def _weight_derivative(
    kernel, power, shift, px, py, tx, ty, sx, sy, w, x, y, j, ux, uy, inv_r, r_min, constant
):
    """a~_j and grad a~_j (a~ as in `solver._weights`, up to one factor common to all j).

    `constant` is the shift of Eq. 19-20 in the units of q = r_min / r (its
    gradient is added by the caller).  Returns (a~, da~/dx, da~/dy).
    """
    if kernel == solver.MAXIMUM_LIKELIHOOD:
        return w[j], 0.0, 0.0
    r_inv = inv_r[j]
    if kernel == solver.PSEUDO_HARMONIC:
        value = w[j] * r_min * r_inv
        return value, value * ux[j] * r_inv, value * uy[j] * r_inv
    if kernel == solver.POWER or kernel == solver.HARMONIC_LIKE:
        k = 4.0 if kernel == solver.HARMONIC_LIKE else power
        omega = (r_min * r_inv) ** k
        slope = w[j] * k * omega * r_inv  # |grad q^k| w: grad r = -u
        return w[j] * (omega + constant), slope * ux[j], slope * uy[j]
    if kernel == solver.MODIFIED_MEAN_VALUE or kernel == solver.MODIFIED_MEAN_VALUE_SQUARED:
        # omega = |(p - x) x p'| / r^2 (Eq. 23): grad (p - x) x p' = (-p'_y, p'_x), grad r = -u.
        turn = (ux[j] * ty[j] - uy[j] * tx[j]) * r_inv * r_min  # signed (u x p') / r
        sign = 1.0 if turn >= 0.0 else -1.0
        gx = sign * (-ty[j]) * r_inv * r_inv * r_min + 2.0 * abs(turn) * ux[j] * r_inv
        gy = sign * tx[j] * r_inv * r_inv * r_min + 2.0 * abs(turn) * uy[j] * r_inv
        if kernel == solver.MODIFIED_MEAN_VALUE:
            return w[j] * abs(turn), w[j] * gx, w[j] * gy
        return w[j] * turn * turn, 2.0 * w[j] * abs(turn) * gx, 2.0 * w[j] * abs(turn) * gy
    if kernel == solver.MEAN_VALUE:
        # mu = (p - x) x p' / r^3 (Eq. 5).
        q = r_min * r_inv
        cross = (ux[j] * ty[j] - uy[j] * tx[j]) * q * q
        gx = -ty[j] * r_inv * q * q + 3.0 * cross * ux[j] * r_inv
        gy = tx[j] * r_inv * q * q + 3.0 * cross * uy[j] * r_inv
        return w[j] * cross, w[j] * gx, w[j] * gy
    # WACHSPRESS or LAPLACE (Sec. 1.1), a curve node.
    speed2 = tx[j] * tx[j] + ty[j] * ty[j]
    dx = px[j] - x
    dy = py[j] - y
    cross = dx * ty[j] - dy * tx[j]
    curvature = tx[j] * sy[j] - ty[j] * sx[j]
    if speed2 == 0.0 or cross == 0.0:
        return 0.0, 0.0, 0.0
    cx = -ty[j]
    cy = tx[j]
    if kernel == solver.WACHSPRESS:
        mu = curvature / (cross * cross)
        return w[j] * mu, w[j] * (-2.0 * mu * cx / cross), w[j] * (-2.0 * mu * cy / cross)
    r2 = dx * dx + dy * dy
    mu = (2.0 * speed2 * cross - r2 * curvature) / (cross * cross)
    gx = (2.0 * speed2 * cx + 2.0 * curvature * dx) / (cross * cross) - 2.0 * mu * cx / cross
    gy = (2.0 * speed2 * cy + 2.0 * curvature * dy) / (cross * cross) - 2.0 * mu * cy / cross
    return w[j] * mu, w[j] * gx, w[j] * gy


@njit(cache=True, error_model="numpy")
def _corner_derivative(kernel, corners, c, bx, by, x, y):
    """The point mass of sharp corner c of the three-point family and its gradient.

    mass = q.A / q x A - q.B / q x B with q = corner - x (see `solver._weights`);
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
    if kernel == solver.WACHSPRESS:
        q2 = qx * qx + qy * qy
        return mass / q2, gx / q2 + 2.0 * mass * qx / (q2 * q2), gy / q2 + 2.0 * mass * qy / (q2 * q2)
    return -mass, -gx, -gy


@njit(cache=True, error_model="numpy")
def _shift(kernel, power, shift, w, inv_r, ux, uy, r_min, count):
    """The shift of Eq. 19-20 (q = r_min / r units) and its gradient: (c, dc/dx, dc/dy)."""
    mode = solver.SHIFT_INTEGRAL if kernel == solver.HARMONIC_LIKE else shift
    if not (kernel == solver.POWER or kernel == solver.HARMONIC_LIKE) or mode == solver.SHIFT_NONE:
        return 0.0, 0.0, 0.0
    k = 4.0 if kernel == solver.HARMONIC_LIKE else power
    integral = 0.0
    gx = 0.0
    gy = 0.0
    length = 0.0
    for j in range(count):
        omega = (r_min * inv_r[j]) ** k
        integral += w[j] * omega
        slope = w[j] * k * omega * inv_r[j]
        gx += slope * ux[j]
        gy += slope * uy[j]
        length += w[j]
    if mode == solver.SHIFT_MEAN:
        return integral / length, gx / length, gy / length
    return integral, gx, gy


@njit(cache=True, error_model="numpy")
def _differentiate(
    kernel, power, shift, px, py, tx, ty, sx, sy, w, t, ux, uy, inv_r, a, s, total, nodes, corners,
    x, y, r_min, row, row_x, row_y, mode, period, out_step, out_count, control_count,
):  # fmt: skip
    """Accumulate lambda_j and grad lambda_j of the `total` nodes into row, row_x, row_y.

    On entry `a` holds lambda_j (normalised, as `solver._finish` leaves it), `s`
    holds s_j = 1 + phi . u_j for the maximum-likelihood family; nodes >= `nodes`
    are corner point masses (three-point family).  See `core.gradients`.
    """
    newton = kernel <= solver.MODIFIED_MEAN_VALUE_SQUARED
    constant, shift_x, shift_y = _shift(kernel, power, shift, w, inv_r, ux, uy, r_min, nodes)
    # Pass 1: sums of a~ and b, H, K, v, D~ and the least squares of phi from s - 1 = phi . u.
    sum_a = 0.0
    sum_b = 0.0
    hxx = hxy = hyy = 0.0
    kxx = kxy = kyy = 0.0
    vx = vy = 0.0
    dxx = dxy = dyx = dyy = 0.0
    lxx = lxy = lyy = 0.0
    rx = ry = 0.0
    for j in range(total):
        if j < nodes:
            value, gx, gy = _weight_derivative(
                kernel, power, shift, px, py, tx, ty, sx, sy, w, x, y, j, ux, uy, inv_r, r_min, constant
            )
            gx += w[j] * shift_x
            gy += w[j] * shift_y
        else:
            value, gx, gy = _corner_derivative(kernel, corners, j - nodes, px[j], py[j], x, y)
        sum_a += value
        if not newton:
            continue
        u0 = ux[j]
        u1 = uy[j]
        inv = 1.0 / s[j]
        lam = a[j] * inv
        b = a[j] * s[j] / inv_r[j]
        sum_b += b
        hb = lam / inv_r[j]
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
    phix = phiy = 0.0
    fxx = fxy = fyx = fyy = 0.0
    if newton:
        kappa = sum_b / sum_a
        normal = lxx * lyy - lxy * lxy
        phix = (lyy * rx - lxy * ry) / normal
        phiy = (lxx * ry - lxy * rx) / normal
        # dg/dx, column beta = kappa D~ e_beta - e_beta + K e_beta + v phi_beta.
        mxx = kappa * dxx - 1.0 + kxx + vx * phix
        mxy = kappa * dxy + kxy + vx * phiy
        myx = kappa * dyx + kxy + vy * phix
        myy = kappa * dyy - 1.0 + kyy + vy * phiy
        determinant = hxx * hyy - hxy * hxy
        fxx = (hyy * mxx - hxy * myx) / determinant
        fxy = (hyy * mxy - hxy * myy) / determinant
        fyx = (hxx * myx - hxy * mxx) / determinant
        fyy = (hxx * myy - hxy * mxy) / determinant
    else:
        kappa = 1.0 / sum_a
    # Pass 2: dc_j, accumulated; the normalisation's share is removed below.
    total_x = 0.0
    total_y = 0.0
    for j in range(total):
        if j < nodes:
            _, gx, gy = _weight_derivative(
                kernel, power, shift, px, py, tx, ty, sx, sy, w, x, y, j, ux, uy, inv_r, r_min, constant
            )
            gx += w[j] * shift_x
            gy += w[j] * shift_y
        else:
            _, gx, gy = _corner_derivative(kernel, corners, j - nodes, px[j], py[j], x, y)
        gx *= kappa
        gy *= kappa
        lam = a[j]
        if newton:
            u0 = ux[j]
            u1 = uy[j]
            r_inv = inv_r[j]
            inv = 1.0 / s[j]
            # grad s_j at the moving phi: Phi^T u_j + d(phi . u_j)/dx, du/dx = -(I - u u^T) / r.
            dsx = fxx * u0 + fyx * u1 - (phix - (s[j] - 1.0) * u0) * r_inv
            dsy = fxy * u0 + fyy * u1 - (phiy - (s[j] - 1.0) * u1) * r_inv
            gx = gx * r_inv * inv + lam * (u0 * r_inv - dsx * inv)
            gy = gy * r_inv * inv + lam * (u1 * r_inv - dsy * inv)
        total_x += gx
        total_y += gy
        tj = t[j] - math.floor(t[j] / period) * period
        solver._accumulate(row, mode, lam, tj, out_step, out_count, control_count)
        solver._accumulate(row_x, mode, gx, tj, out_step, out_count, control_count)
        solver._accumulate(row_y, mode, gy, tj, out_step, out_count, control_count)
    for i in range(row.shape[0]):
        row_x[i] -= total_x * row[i]
        row_y[i] -= total_y * row[i]


@njit(cache=True, error_model="numpy")
def _gradient_point(x, y, settings, curve, geometry, row, row_x, row_y, scratch, windows):
    """Evaluate one point and its gradient; returns (iterations, status, residual).

    The nodes are built exactly as in `solver._solve_point` (pass 1, the windows
    and `solver._refined_nodes`); a point on the boundary gets its Lagrange-limit
    row and NaN gradients.
    """
    kernel, power, shift, mode, orientation, diameter, control_count, tolerance = settings
    coefficients, piece_length, corners = geometry
    window_start, window_stop, window_t, window_d = windows
    (
        sample_x, sample_y, tangent_x, tangent_y, second_x, second_y, spacing, uniform, sample_t,
        _, _, _, step, sinh_step, out_step,
    ) = curve  # fmt: skip
    (px, py, tx, ty, sx, sy, w, t, ux, uy, inv_r, a, s, inv_s, trial, trial_inv, blend) = scratch
    count = sample_x.shape[0]
    out_count = int(round(count * step / out_step))
    period = count * step
    window_count = 0
    in_run = False
    nearest = 1e300
    nearest_index = np.int64(0)
    for k in range(count):
        dx = sample_x[k] - x
        dy = sample_y[k] - y
        r = math.sqrt(dx * dx + dy * dy)
        inv = 1.0 / r
        ux[k] = dx * inv
        uy[k] = dy * inv
        inv_r[k] = inv
        if r < nearest:
            nearest = r
            nearest_index = k
        if r < solver.NEAR_SPACINGS * spacing[k]:
            if not in_run:
                if window_count < solver.MAX_WINDOWS:
                    window_start[window_count] = k
                window_count += 1
                in_run = True
            if window_count <= solver.MAX_WINDOWS:
                window_stop[window_count - 1] = k
        else:
            in_run = False
    window_count = solver._merge_windows(
        window_start, window_stop, min(window_count, solver.MAX_WINDOWS), count, nearest_index
    )
    three_point = kernel == solver.WACHSPRESS or kernel == solver.LAPLACE
    corner_count = corners.shape[0] if three_point else 0
    if window_count == 0:
        if not solver._inside_polygon(sample_x, sample_y, x, y):
            return 0, solver.STATUS_OUTSIDE, nearest
        if corner_count == 0:
            # The trapezoid rule on the shared samples, as in the solver's common case.
            total = solver._weights(
                kernel, power, shift, sample_x, sample_y, tangent_x, tangent_y, second_x, second_y,
                uniform, x, y, count, corners, ux, uy, inv_r, nearest, a,
            )  # fmt: skip
            iterations, status, residual = solver._finish(
                kernel, ux, uy, inv_r, a, s, inv_s, trial, trial_inv, blend, total,
                sample_x, sample_y, uniform, step, x, y, tolerance * diameter,
            )  # fmt: skip
            _differentiate(
                kernel, power, shift, sample_x, sample_y, tangent_x, tangent_y, second_x, second_y,
                uniform, sample_t, ux, uy, inv_r, a, s, total, count, corners, x, y, nearest,
                row, row_x, row_y, mode, period, out_step, out_count, control_count,
            )  # fmt: skip
            return iterations, status, residual
        nodes = 0
        for k in range(count):
            t[nodes] = sample_t[k]
            w[nodes] = step
            nodes += 1
    else:
        closest_t = nearest_index * step
        closest_d = nearest
        for i in range(window_count):
            ti, di = solver._closest_parameter(
                coefficients, piece_length, x, y, window_start[i] * step, window_stop[i] * step
            )
            window_t[i] = ti
            window_d[i] = di
            if di < closest_d:
                closest_d = di
                closest_t = ti
        if closest_d <= solver.ON_BOUNDARY * diameter:
            solver._accumulate(
                row, mode, 1.0, solver._wrap(closest_t, period), out_step, out_count, control_count
            )
            for i in range(row.shape[0]):
                row_x[i] = math.nan
                row_y[i] = math.nan
            return 0, solver.STATUS_CONVERGED, 0.0
        if solver._side_of_curve(coefficients, piece_length, closest_t, x, y, orientation) < 0:
            return 0, solver.STATUS_OUTSIDE, closest_d
        nodes = solver._refined_nodes(
            window_start, window_stop, window_t, window_d, window_count, count, step, sinh_step,
            coefficients, piece_length, t, w,
        )  # fmt: skip
    for j in range(nodes):
        k = int(round(t[j] / step))
        if abs(t[j] - k * step) <= 1e-12 * step:
            k = k % count
            px[j] = sample_x[k]
            py[j] = sample_y[k]
            tx[j] = tangent_x[k]
            ty[j] = tangent_y[k]
            sx[j] = second_x[k]
            sy[j] = second_y[k]
        else:
            px[j], py[j], tx[j], ty[j], sx[j], sy[j] = solver._evaluate_curve(
                coefficients, piece_length, t[j]
            )
    for c in range(corner_count):
        px[nodes + c], py[nodes + c], _, _, _, _ = solver._evaluate_curve(
            coefficients, piece_length, corners[c, 0]
        )
        t[nodes + c] = corners[c, 0]
        w[nodes + c] = 1.0
    r_min = solver._directions(px, py, x, y, nodes, ux, uy, inv_r)
    total = solver._weights(
        kernel, power, shift, px, py, tx, ty, sx, sy, w, x, y, nodes, corners, ux, uy, inv_r, r_min, a
    )
    iterations, status, residual = solver._finish(
        kernel, ux, uy, inv_r, a, s, inv_s, trial, trial_inv, blend, total,
        px, py, w, step, x, y, tolerance * diameter,
    )  # fmt: skip
    _differentiate(
        kernel, power, shift, px, py, tx, ty, sx, sy, w, t, ux, uy, inv_r, a, s, total, nodes, corners,
        x, y, r_min, row, row_x, row_y, mode, period, out_step, out_count, control_count,
    )  # fmt: skip
    return iterations, status, residual


@njit(cache=True, nogil=True, error_model="numpy")
def gradient_points(
    points, settings, curve, geometry, out, gradients, iterations, status, residual, first, stride
):
    """Values (M, columns) and gradients (M, 2, columns) of the points first, first + stride, ...

    Arguments as in `solver.solve_points`; gradients[m, 0] and gradients[m, 1]
    are the x- and y-derivatives of the row out[m].  Releases the GIL.
    """
    count = curve[0].shape[0]
    capacity = count + solver.MAX_WINDOWS * solver.MAX_WINDOW_NODES + geometry[2].shape[0] + 8
    scratch = (
        np.empty(capacity), np.empty(capacity), np.empty(capacity), np.empty(capacity),
        np.empty(capacity), np.empty(capacity), np.empty(capacity), np.empty(capacity),
        np.empty(capacity), np.empty(capacity), np.empty(capacity), np.empty(capacity),
        np.empty(capacity), np.empty(capacity), np.empty(capacity), np.empty(capacity),
        np.empty(capacity),
    )  # fmt: skip
    windows = (
        np.empty(solver.MAX_WINDOWS + 1, dtype=np.int64),
        np.empty(solver.MAX_WINDOWS + 1, dtype=np.int64),
        np.empty(solver.MAX_WINDOWS + 1),
        np.empty(solver.MAX_WINDOWS + 1),
    )
    for m in range(first, points.shape[0], stride):
        iterations[m], status[m], residual[m] = _gradient_point(
            points[m, 0], points[m, 1], settings, curve, geometry, out[m], gradients[m, 0], gradients[m, 1],
            scratch, windows,
        )  # fmt: skip
