"""The weight function omega_x at the quadrature nodes (Eq. 18-20, 23, Sec. 3.1, 3.4), or the
explicit kernels (Eq. 5 and the three-point family of Sec. 1.1), times the nodes' weights."""

from __future__ import annotations

import math

from numba import njit

from core.newton.codes import (
    HARMONIC_LIKE,
    MAXIMUM_LIKELIHOOD,
    MEAN_VALUE,
    MODIFIED_MEAN_VALUE,
    MODIFIED_MEAN_VALUE_SQUARED,
    POWER,
    PSEUDO_HARMONIC,
    SHIFT_INTEGRAL,
    SHIFT_MEAN,
    WACHSPRESS,
)


@njit(cache=True, error_model="numpy", fastmath={"contract", "arcp", "reassoc", "nsz"})
def kernel_weights(settings, nodes, point, count, corners, directions, r_min, a):
    """Normalised weights a_j = w_j omega_j / sum (maximum-likelihood family), or
    normalised w_j mu_j for the explicit kernels (Eq. 5 and Sec. 1.1).

    Every omega and mu is scaled by a power of r_min, which cancels in the
    normalisation and keeps 1 / r^k far from overflow.  For the three-point family
    the point masses of sharp corners follow the `count` nodes (their px, py must be
    filled in); returns the total node count.
    """
    kernel, power, shift = settings.kernel, settings.power, settings.shift
    px, py, tx, ty, sx, sy, w = nodes
    x, y = point
    ux, uy, inv_r = directions
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
