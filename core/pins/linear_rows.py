"""Everything `core.pin_deform` needs of a map f = G Q, as real linear rows acting on one vector.

The unknowns are x = [Q_x (n), Q_y (n), a, b, t_x, t_y] (2n + 4): the target control points in
normalised coordinates (the source's centroid at 0, its diameter 1) and a similarity
S(p) = [[a, -b], [b, a]] p + t that the departure energy compares them with.  Every quantity the
solver constrains is linear in x:

- the pins' images f(p_k) = Σ_i G_i(p_k) Q_i (`pin_rows`), with real G (``"poisson"``) or
  complex G acting on Q as complex numbers (``"cauchy-green"``, `core.deform`);
- f_z and f_z̄ at a sample: with gradients ∂_x G_i, ∂_y G_i (`core.basis_gradients`; for
  Cauchy-Green (C_i', i C_i')) and Q_i as complex numbers, f_x = Σ ∂_x G_i Q_i and
  f_z = Σ (∂_x G_i - i ∂_y G_i) Q_i / 2, f_z̄ = Σ (∂_x G_i + i ∂_y G_i) Q_i / 2 (so f_z̄ = 0 for
  Cauchy-Green, whose maps are holomorphic);
- the departure from the similarity, Q_i - S(P_i) - t (`departure_rows`).

The gradients are per cage (the slow part, about a second at 40 control points); the solver
keeps them (`core.pins.precompute`).
"""

from __future__ import annotations

import numpy as np


def complex_rows(coefficients: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The real and imaginary parts, two ndarrays (M, 2n + 4), of Σ_i c_i Q_i for complex (or real)
    coefficients c (M, n) and Q_i = x_i + i y_i."""
    real, imaginary = np.real(coefficients), np.imag(coefficients)
    padding = np.zeros((coefficients.shape[0], 4))
    return (
        np.hstack([real, -imaginary, padding]),
        np.hstack([imaginary, real, padding]),
    )


def derivative_coefficients(gradients: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Complex coefficients (M, n) of f_z and of f_z̄ from basis gradients (M, n, 2) in normalised units."""
    along, across = gradients[:, :, 0], gradients[:, :, 1]
    return 0.5 * (along - 1j * across), 0.5 * (along + 1j * across)


def departure_rows(source: np.ndarray) -> np.ndarray:
    """Rows (2n, 2n + 4) of Q_i - S(P_i) - t for the normalised source control points (n, 2), divided
    by sqrt(n): the departure energy is the mean squared distance of the target control points from
    the similarity's image of the source."""
    n = source.shape[0]
    identity, zero = np.eye(n), np.zeros((n, n))
    ones, nothing = np.ones((n, 1)), np.zeros((n, 1))
    x, y = source[:, :1], source[:, 1:]
    rows = np.block(
        [
            [identity, zero, -x, y, -ones, nothing],
            [zero, identity, -y, -x, nothing, -ones],
        ]
    )
    return rows / np.sqrt(n)


def control_points(x: np.ndarray, n: int) -> np.ndarray:
    """The normalised target control points (n, 2) of a solution x (2n + 4,)."""
    return np.stack([x[:n], x[n : 2 * n]], axis=1)


__all__ = ["complex_rows", "control_points", "departure_rows", "derivative_coefficients"]
