"""Cauchy–Green coordinates on a curved cage: the conformal, non-interpolating kernel.

For a closed B-spline p with basis N_i, the Cauchy–Green coordinates are the Cauchy
integrals of the basis functions (Weber, Ben-Chen and Gotsman's Cauchy–Green
coordinates, extended to curved cages by transfinite integration),

    C_i(z) = (1 / 2πi) ∮ N_i(t) p'(t) / (p(t) - z) dt,

complex numbers.  The deformation f(z) = Σ_i C_i(z) P'_i (control points as complex
numbers) is holomorphic, so it keeps angles everywhere inside (σ₁/σ₂ = 1), and
Σ_i C_i(z) P_i = z reproduces the identity (Cauchy's formula for p).  It does not
interpolate: the image of the curve is the boundary limit of f, not the target curve.

N_i is a polynomial on every panel of `core.boundary_integrals.panels.coarse_panels` (they are cut at the
knots), so the panel rule and the near-field rule of `cauchy_integrals` integrate it without
an interpolation error: no grading towards knots or corners is needed.
As in `core.boundary_integrals.poisson` the coordinates are taken in barycentric form,
C_i = C[N_i] / C[1], which keeps Σ_i C_i = 1 to rounding and f holomorphic.
"""

from __future__ import annotations

import functools

import numpy as np

from core.boundary_integrals.cauchy_integrals import Levels, bisected, cauchy_derivatives, cauchy_integrals
from core.boundary_integrals.panels import coarse_panels, span_panels
from core.boundary_integrals.poisson import CHUNK, boundary_limit_rows, centred, refuse_far_outside
from core.curves.bspline import ClosedBSpline
from core.library_threads import one_blas_thread


@functools.lru_cache(maxsize=4)
def _levels(points: bytes, count: int) -> Levels:
    """Spans, coarse panels and their `bisected` halves with N_1..N_n and 1 at their nodes
    (polynomials on each panel)."""
    curve = ClosedBSpline(np.frombuffer(points).reshape(count, 2))
    coarse = coarse_panels(curve)
    spans = span_panels(curve)

    def data(panels):
        values = curve.basis_matrix(panels.t)
        return np.concatenate([values, np.ones((values.shape[0], 1))], axis=1)

    span_of = np.floor(coarse.bounds[:, 0] + 1e-12).astype(np.int64)
    return bisected(curve, Levels((spans, coarse), (span_of,), (data(spans), data(coarse))))


@one_blas_thread
def cauchy_green_basis(curve: ClosedBSpline, x: np.ndarray, progress=None) -> np.ndarray:
    """C_i(x), complex ndarray of shape (M, n), at points x (M, 2) in the closed domain.

    On the curve (within ~1e-10 of the diameter) a row is the interior limit of the
    Cauchy integral, C_i = N_i(t) / 2 + (1 / 2πi) PV ∮ ..., computed as the limit of
    the points 1e-7 of the diameter inside along the normal (`boundary_limit_rows`).
    """
    refuse_far_outside(curve, x)
    shown = x
    curve, x = centred(curve, x)
    levels = _levels(curve.control_points.tobytes(), curve.n)
    out = np.empty((x.shape[0], curve.n), dtype=np.complex128)
    for first in range(0, x.shape[0], CHUNK):
        points = x[first : first + CHUNK]
        real, imag, _ = cauchy_integrals(curve, levels, points, imaginary=True)
        values = real + 1j * imag
        out[first : first + CHUNK] = values[:, :-1] / values[:, -1:]
        boundary = boundary_limit_rows(curve, points, real[:, -1], shown, first)
        if boundary[0].size:
            inner = boundary[1]
            real, imag, _ = cauchy_integrals(curve, levels, inner, imaginary=True)
            values = real + 1j * imag
            out[first + boundary[0]] = values[:, :-1] / values[:, -1:]
        if progress is not None:
            progress(min(1.0, (first + CHUNK) / x.shape[0]))
    return out


@one_blas_thread
def cauchy_green_derivatives(curve: ClosedBSpline, x: np.ndarray) -> np.ndarray:
    """dC_i/dz, complex ndarray of shape (M, n), at interior points x (M, 2).

    The real gradient of C_i is (dC_i/dz, i dC_i/dz): `core.basis_gradients` returns
    that pair, shape (M, n, 2) complex.
    """
    refuse_far_outside(curve, x)
    curve, x = centred(curve, x)
    levels = _levels(curve.control_points.tobytes(), curve.n)
    real, imag, _ = cauchy_integrals(curve, levels, x, imaginary=True)
    values = real + 1j * imag
    derivative = cauchy_derivatives(curve, levels, x)
    total, total_derivative = values[:, -1:], derivative[:, -1:]
    return (derivative[:, :-1] * total - values[:, :-1] * total_derivative) / total**2
