"""The boundary parameterised by arc length, the alternative of the paper's Fig. 12c.

Every kernel but the modified mean value one depends on the boundary's
parameterisation through the parametric differential dt of its integrals
(Sec. 5, Fig. 12).  The natural parameter t of a quadratic B-spline gives each
span the same parameter length whatever its length in the plane; the arc length

    s(t) = int_0^t |p'(tau)| d tau,   S_j = s(j),  l_j = S_{j+1} - S_j,

gives every stretch of curve a parameter length proportional to its length.  Like
the reparameterisations of Fig. 12 it keeps the parameter interval [0, n): the
parameter is the normalised arc length n s(t) / L (L the curve's length), written s
from here on, so that a curve of uniform speed keeps its parameter and the kernels
whose weights depend on the parameter's scale (the integral shift of Eq. 19-20)
compare like with like.  The map is monotone on each span j (|p'| > 0 there but
possibly at a sharp corner's knot) and computed once per cage: the span lengths in
closed form (`core.newton.solver.span_arc_length`), the inverse t(s) = j + u by safeguarded
Newton (`core.newton.solver.natural_parameter`).

The curve q(s) = p(t(s)) is sampled uniformly in s, s_k = k n / N, and handed to
the solver like any `Boundary`: the quadrature (the trapezoid rule of Sec. 4.1 and
the near-boundary refined rule) is uniform in s, while the B-spline basis N_i of
Sec. 4.3 is evaluated at t(s).  The solver recognises the curve by the third
channel of its coefficients (n, 3, 3): channels 0, 1 are the natural quadratic
pieces of `ClosedBSpline.piecewise_polynomial`, channel 2 holds (S_j, l_j, L / n)
per span, S_j and l_j the span's start and length in s.
"""

from __future__ import annotations

import numpy as np

from core.curves.boundary import Boundary, PiecewisePolynomial
from core.newton import solver
from core.validation import as_parameters

PARAMETERIZATIONS = ("natural", "arc-length")
DEFAULT_PARAMETERIZATION = "natural"


def checked_parameterization(value) -> str:
    """`value` if it is one of `PARAMETERIZATIONS`, else raise `ValueError`."""
    if not isinstance(value, str) or value not in PARAMETERIZATIONS:
        raise ValueError(f"unknown parameterization {value!r}; choose one of: {', '.join(PARAMETERIZATIONS)}")
    return value


class ArcLengthCurve:
    """A closed quadratic piecewise curve as a function of its normalised arc length s in [0, n).

    Parameters
    ----------
    pieces : PiecewisePolynomial
        The curve in its natural parameter: n quadratic pieces of parameter
        length 1 (`ClosedBSpline.piecewise_polynomial`).
    """

    def __init__(self, pieces: PiecewisePolynomial):
        natural = pieces.coefficients
        if natural.ndim != 3 or natural.shape[1:] != (3, 2) or pieces.piece_length != 1.0:
            raise ValueError(
                "the arc-length parameterization needs the quadratic B-spline pieces of the curve "
                "(a boundary from ClosedBSpline.sample)"
            )
        spans = natural.shape[0]
        coefficients = np.zeros((spans, 3, 3))
        coefficients[:, :, :2] = natural
        lengths = np.array([solver.span_arc_length(coefficients, j, 1.0) for j in range(spans)])
        self.length = float(lengths.sum())
        scale = self.length / spans
        coefficients[:, 0, 2] = np.concatenate([[0.0], np.cumsum(lengths)[:-1]]) / scale
        coefficients[:, 1, 2] = lengths / scale
        coefficients[:, 2, 2] = scale
        self.coefficients = coefficients
        self.piece_length = 1.0

    @property
    def period(self) -> float:
        """n, the parameter length of the whole curve (as in the natural parameter)."""
        return float(self.coefficients.shape[0])

    @property
    def knots(self) -> np.ndarray:
        """s(j), the parameter s at the natural knots j = 0..n-1, ndarray of shape (n,)."""
        return self.coefficients[:, 0, 2].copy()

    def evaluate(self, s) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """q(s), q'(s), q''(s) (derivatives in s, |q'| = L / n), each of shape (m, 2)."""
        values = solver.arc_length_samples(self.coefficients, as_parameters(s))
        return values[:, 0:2], values[:, 2:4], values[:, 4:6]

    def natural(self, s) -> np.ndarray:
        """t(s), the natural parameter in [0, n] of parameters s of shape (m,)."""
        spans, local = solver.natural_parameters(self.coefficients, as_parameters(s))
        return spans + local

    def arc_length(self, t) -> np.ndarray:
        """s(t) = n (arc length from p(0) to p(t)) / L in [0, n] for natural t of shape (m,) (periodic)."""
        spans = self.coefficients.shape[0]
        t = np.mod(as_parameters(t), spans)
        span = np.minimum(np.floor(t).astype(np.int64), spans - 1)
        within = [
            solver.span_arc_length(self.coefficients, j, u) for j, u in zip(span, t - span, strict=True)
        ]
        return self.coefficients[span, 0, 2] + np.array(within) / self.coefficients[0, 2, 2]


def arc_length_boundary(pieces: PiecewisePolynomial, count: int, corners: np.ndarray) -> Boundary:
    """The curve sampled at N = `count` normalised arc lengths s_k = k n / N (a `Boundary` in s).

    Parameters
    ----------
    pieces : PiecewisePolynomial
        The natural quadratic pieces (n, 3, 2) of a closed B-spline.
    count : int
        N, the number of samples.
    corners : ndarray of shape (C, 5)
        Sharp corners as `ClosedBSpline.corners` gives them (natural parameter
        first); returned at their arc length.
    """
    curve = ArcLengthCurve(pieces)
    step = curve.period / count
    s = np.arange(count) * step
    value, first, second = curve.evaluate(s)
    # s = 0 is the knot t = 0, where q'' jumps: the trapezoid rule wants the mean of both sides.
    last = curve.coefficients.shape[0] - 1
    _, _, before = _span_end(curve, last)
    second[0] = 0.5 * (second[0] + before)
    moved = np.array(corners, dtype=np.float64).reshape(-1, 5).copy()
    if moved.shape[0]:
        moved[:, 0] = curve.arc_length(moved[:, 0])
    return Boundary(value, first, second, step, _curve=curve, _corners=moved)


def _span_end(curve: ArcLengthCurve, span: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """q, q', q'' at the end of span `span` (u = 1, the one-sided values at its last knot)."""
    c = curve.coefficients[span, :, :2]
    first = c[1] + 2.0 * c[2]
    second = 2.0 * c[2]
    speed = np.linalg.norm(first)
    if speed == 0.0:
        return c.sum(axis=0), np.zeros(2), np.zeros(2)
    tangent = first / speed
    scale = curve.coefficients[span, 2, 2]
    return c.sum(axis=0), scale * tangent, (second - (second @ tangent) * tangent) * (scale / speed) ** 2
