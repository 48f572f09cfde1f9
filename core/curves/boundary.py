"""Uniformly sampled closed curves: the input of every point kernel.

A `Boundary` is any closed curve p sampled at t_k = k h, k = 0..N-1, with period
N h, together with p'(t_k) and p''(t_k) (Sec. 4.1).  The periodic trapezoid rule
on these samples is the quadrature of the paper; near the boundary the solver
refines it, and for that it needs the curve between samples: the exact curve when
the boundary comes from `ClosedBSpline.sample`, otherwise the quintic Hermite
interpolant of the samples (error O(h^6)).
"""

from __future__ import annotations

import numpy as np

from core.curves.diameter import point_set_diameter
from core.validation import as_parameters, as_points, positive_float


class PiecewisePolynomial:
    """A closed curve made of polynomial pieces in power form.

    Piece k covers t in [k L, (k+1) L) with local u = t / L - k in [0, 1] and
    p(u) = sum_d coefficients[k, d] u^d.

    Parameters
    ----------
    coefficients : ndarray of shape (P, D + 1, 2)
    piece_length : float
        L, the parameter length of one piece.
    """

    def __init__(self, coefficients: np.ndarray, piece_length: float):
        self.coefficients = np.ascontiguousarray(coefficients, dtype=np.float64)
        self.piece_length = float(piece_length)

    @property
    def period(self) -> float:
        """Parameter length of the whole curve."""
        return self.coefficients.shape[0] * self.piece_length

    def evaluate(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """p(t), p'(t), p''(t) (derivatives in t), each of shape (m, 2)."""
        t = np.mod(as_parameters(t), self.period)
        scaled = t / self.piece_length
        piece = np.minimum(np.floor(scaled).astype(np.int64), self.coefficients.shape[0] - 1)
        u = (scaled - piece)[:, None]
        c = self.coefficients[piece]  # (m, D + 1, 2)
        degree = c.shape[1] - 1
        value = c[:, degree].copy()
        first = np.zeros_like(value)
        second = np.zeros_like(value)
        for d in range(degree - 1, -1, -1):
            second = second * u + 2.0 * first
            first = first * u + value
            value = value * u + c[:, d]
        return value, first / self.piece_length, second / self.piece_length**2


def hermite_pieces(
    points: np.ndarray, tangents: np.ndarray, second: np.ndarray, step: float
) -> PiecewisePolynomial:
    """Quintic Hermite interpolant matching p, p', p'' at every sample (shapes (N, 2))."""
    p0, p1 = points, np.roll(points, -1, axis=0)
    d0, d1 = tangents * step, np.roll(tangents, -1, axis=0) * step
    s0, s1 = second * step**2, np.roll(second, -1, axis=0) * step**2
    delta = p1 - p0
    c3 = 10 * delta - 6 * d0 - 4 * d1 - 1.5 * s0 + 0.5 * s1
    c4 = -15 * delta + 8 * d0 + 7 * d1 + 1.5 * s0 - s1
    c5 = 6 * delta - 3 * d0 - 3 * d1 - 0.5 * s0 + 0.5 * s1
    coefficients = np.stack([p0, d0, 0.5 * s0, c3, c4, c5], axis=1)
    return PiecewisePolynomial(coefficients, step)


class Boundary:
    """A closed curve sampled uniformly in its parameter.

    Parameters
    ----------
    points : array_like of shape (N, 2)
        p(t_k) for t_k = k * step, k = 0..N-1; the curve closes after N samples.
    tangents : array_like of shape (N, 2)
        p'(t_k).
    second_derivatives : array_like of shape (N, 2)
        p''(t_k) (used by the Wachspress and Laplace kernels and the refinement).
    step : float
        h, the parameter spacing of the samples.
    """

    def __init__(
        self, points, tangents, second_derivatives, step, *, _curve=None, _corners=None, _diameter=None
    ):
        self.points = as_points(points, "points", min_count=3)
        self.tangents = as_points(tangents, "tangents")
        self.second_derivatives = as_points(second_derivatives, "second_derivatives")
        count = self.points.shape[0]
        if self.tangents.shape[0] != count or self.second_derivatives.shape[0] != count:
            raise ValueError(
                f"points, tangents and second_derivatives must have the same length, got "
                f"{count}, {self.tangents.shape[0]} and {self.second_derivatives.shape[0]}"
            )
        self.step = positive_float(step, "step")
        self.curve = (
            _curve
            if _curve is not None
            else hermite_pieces(self.points, self.tangents, self.second_derivatives, self.step)
        )
        self.corners = np.zeros((0, 5)) if _corners is None else np.asarray(_corners, dtype=np.float64)
        extent = np.ptp(self.points, axis=0)
        if not np.all(extent > 0):
            raise ValueError("the boundary samples are collinear; the domain has no area")
        self.diameter = point_set_diameter(self.points) if _diameter is None else float(_diameter)
        area = (
            0.5
            * self.step
            * float(np.sum(self.points[:, 0] * self.tangents[:, 1] - self.points[:, 1] * self.tangents[:, 0]))
        )
        if abs(area) <= 1e-10 * self.diameter**2:
            raise ValueError("the boundary encloses (almost) no area")
        self.area = area

    @property
    def count(self) -> int:
        """N, the number of samples."""
        return self.points.shape[0]

    @property
    def period(self) -> float:
        """N h, the parameter length of the whole curve."""
        return self.count * self.step

    @property
    def parameters(self) -> np.ndarray:
        """t_k = k h, ndarray of shape (N,)."""
        return np.arange(self.count) * self.step

    def evaluate(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """p(t), p'(t), p''(t) between samples too, each of shape (m, 2)."""
        return self.curve.evaluate(t)

    def refined(self, factor: int) -> Boundary:
        """The same curve sampled `factor` times more densely (t_k = k h / factor)."""
        t = np.arange(self.count * factor) * (self.step / factor)
        value, first, second = self.evaluate(t)
        return Boundary(
            value,
            first,
            second,
            self.step / factor,
            _curve=self.curve,
            _corners=self.corners,
            _diameter=self.diameter,
        )

    def __repr__(self) -> str:
        return f"Boundary(N={self.count}, step={self.step:.6g})"
