"""The complex derivatives of the harmonic map of a cage onto a target: f_z and f_z̄.

The harmonic map of the domain Ω of a source curve is f(x) = Σ_i G_i(x) P'_i (`core.deform`
with the exact harmonic coordinates of `poisson`), whose boundary values are the target
curve at the same parameter.  On a simply connected Ω, f = h + conj(g) with h, g holomorphic,
and with the control points as complex numbers P'_i = x'_i + i y'_i and exact gradients
∂G_i (`core.boundary_integrals.poisson.poisson_gradients`):

    f_x = Σ_i ∂_x G_i P'_i,   f_y = Σ_i ∂_y G_i P'_i,
    f_z = h' = (f_x - i f_y) / 2,   f_z̄ = conj(g') = (f_x + i f_y) / 2.

The Jacobian's determinant is |f_z|² - |f_z̄|², its singular values |f_z| ± |f_z̄|.
"""

from __future__ import annotations

import numpy as np

from core.boundary_integrals.poisson import poisson_gradients
from core.curves.bspline import ClosedBSpline


def complex_derivatives(
    curve: ClosedBSpline, target: np.ndarray, x: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """f_z and f_z̄ of the harmonic map of `curve` onto target control points (n, 2) at interior
    points x (M, 2), two complex ndarrays of shape (M,) (NaN at points on the curve), and an
    estimate of their evaluation error (M,).

    The error estimate is the identity's: the same gradients reproduce the identity map
    (Σ_i ∇G_i P_i^T = I, differentiated linear precision) up to their error, so
    |f_z - 1| + |f_z̄| of the map onto the source itself is their error there; it is scaled by
    how much larger the target is than the source.  It grows where a point is close to the
    curve (the layer's error divided by the distance) and at tight bends.

    Raises
    ------
    ValueError
        Points of x outside the domain (from `core.boundary_integrals.poisson`).
    """
    source = curve.control_points
    # The gradients of the maps' four coordinates (target x, y; source x, y), (M, 4, 2).
    weights = np.concatenate([target, source], axis=1)
    gradients = poisson_gradients(curve, np.ascontiguousarray(x, dtype=np.float64), weights)
    f_x = gradients[:, 0::2, 0] + 1j * gradients[:, 1::2, 0]
    f_y = gradients[:, 0::2, 1] + 1j * gradients[:, 1::2, 1]
    f_z, f_zbar = 0.5 * (f_x - 1j * f_y), 0.5 * (f_x + 1j * f_y)
    scale = np.ptp(target, axis=0).max() / np.ptp(source, axis=0).max()
    error = scale * (np.abs(f_z[:, 1] - 1.0) + np.abs(f_zbar[:, 1]))
    return f_z[:, 0], f_zbar[:, 0], error


def linear_parts(matrix: np.ndarray) -> tuple[complex, complex]:
    """L_z and L_z̄ of a real linear map (2, 2): L(w) = L_z w + L_z̄ conj(w) in complex numbers."""
    (a, b), (c, d) = matrix
    return complex(0.5 * (a + d), 0.5 * (c - b)), complex(0.5 * (a - d), 0.5 * (c + b))


__all__ = ["complex_derivatives", "linear_parts"]
