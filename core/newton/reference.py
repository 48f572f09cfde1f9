"""A plain numpy implementation of the weighted maximum-likelihood kernels (Eq. 14-20).

Straightforward and slow on purpose: every point solved together with dense
(M, N) arrays, the periodic trapezoid rule with no refinement near the boundary,
Newton with Armijo backtracking from phi = 0 (Sec. 4.1).  It is the independent
oracle of the solver's tests and the baseline of `python -m app bench`; use
`core.kernel` for real work.
"""

from __future__ import annotations

import numpy as np

from core.curves.boundary import Boundary


def reference_kernel(
    boundary: Boundary, x: np.ndarray, power: float = 4.0, shift: bool = True, tolerance: float = 1e-13
) -> np.ndarray:
    """lambda(x_m, t_k) for omega = 1 / r^power (+ its integral if `shift`, Eq. 19-20).

    Parameters
    ----------
    boundary : Boundary
    x : ndarray of shape (M, 2)
        Points farther than a few sample spacings from the boundary.
    power, shift : the weight of Eq. 19 (the defaults give Eq. 20, harmonic-like).
    tolerance : stop when |grad F| is below this.

    Returns
    -------
    ndarray of shape (M, N), ``boundary.step * values.sum(axis=1) == 1``.
    """
    step = boundary.step
    difference = boundary.points[None, :, :] - x[:, None, :]  # (M, N, 2)
    r = np.linalg.norm(difference, axis=2)
    u = difference / r[:, :, None]
    omega = r ** (-power)
    if shift:
        omega = omega + step * omega.sum(axis=1, keepdims=True)
    a = step * omega / (step * omega.sum(axis=1, keepdims=True))  # phi_0 = 1 (Eq. 15)
    phi = np.zeros((x.shape[0], 2))
    for _ in range(100):
        s = 1.0 + np.einsum("mnd,md->mn", u, phi)
        gradient = -np.einsum("mn,mnd->md", a / s, u)
        if np.abs(gradient).max() < tolerance:
            break
        hessian = np.einsum("mn,mnd,mne->mde", a / s**2, u, u)
        delta = -np.linalg.solve(hessian, gradient[:, :, None])[:, :, 0]
        slope = (gradient * delta).sum(axis=1)
        direction = np.einsum("mnd,md->mn", u, delta) / s
        alpha = np.ones(x.shape[0])
        for _ in range(60):
            # F(trial) - F(phi) = -sum a log(1 + z): log1p avoids the cancellation of
            # subtracting two nearly equal values of F close to the minimum.
            z = alpha[:, None] * direction
            feasible = (z > -1).all(axis=1)
            with np.errstate(invalid="ignore", divide="ignore"):
                change = -(a * np.log1p(np.where(z > -1, z, 0.0))).sum(axis=1)
            accept = feasible & (change <= 1e-4 * alpha * slope)
            if accept.all():
                break
            alpha = np.where(accept, alpha, 0.5 * alpha)
        phi = phi + alpha[:, None] * delta
    s = 1.0 + np.einsum("mnd,md->mn", u, phi)
    weights = a / (r * s)  # Eq. 14 and 17
    return weights / (step * weights.sum(axis=1, keepdims=True))
