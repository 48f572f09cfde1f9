"""Transfinite basis functions G_i(x) of a closed B-spline domain (Sec. 4.3).

G_i(x) = sum_k h lambda(x, t_k) N_i(t_k), folded so that G_1..G_n belong to the n
user control points; then sum_i G_i(x) P_i = x (linear precision) and
sum_i G_i(x) = 1 (partition of unity), and g(x) = sum_i F_i G_i(x) interpolates
B-spline boundary data F(t) = sum_i F_i N_i(t).
"""

from __future__ import annotations

from core import solver
from core.bspline import ClosedBSpline
from core.kernels import DEFAULT_KERNEL, DEFAULT_TOLERANCE, Progress, evaluate
from core.validation import positive_int


def basis_functions(
    curve: ClosedBSpline,
    x,
    kernel: str = DEFAULT_KERNEL,
    samples_per_segment: int = 100,
    *,
    progress: Progress | None = None,
    tolerance: float = DEFAULT_TOLERANCE,
    return_report: bool = False,
    parameterization: str = "natural",
    **params,
):
    """Basis functions G_i(x_m) of the n control points.

    Parameters
    ----------
    curve : ClosedBSpline
        The source cage, n control points.
    x : array_like of shape (M, 2)
        Points in the closed domain (on the curve: the Lagrange limit, i.e. the
        B-spline basis at the closest parameter).
    kernel : str
        One of `core.KERNELS` (see `core.kernel` for parameters).
    samples_per_segment : int
        N / n, boundary samples per span (the paper uses 100).
    progress : callable, optional
        Called with the fraction done in [0, 1].
    tolerance : float
        Newton tolerance on the linear-precision residual, relative to the diameter.
    return_report : bool
        Also return the `core.SolveReport`.
    parameterization : str
        ``"natural"`` (the B-spline parameter t, the paper's choice) or
        ``"arc-length"``: the kernel's integrals run over the arc length s and
        G_i(x) = int lambda(x, s) N_i(t(s)) ds (Fig. 12, `core.arc_length`).

    Returns
    -------
    ndarray of shape (M, n)
        Rows sum to 1 and ``G @ curve.control_points == x`` to the tolerance.
    """
    if not isinstance(curve, ClosedBSpline):
        raise ValueError(f"curve must be a core.ClosedBSpline, got {type(curve).__name__}")
    per = positive_int(samples_per_segment, "samples_per_segment", minimum=2)
    boundary = curve.sample(per, parameterization)
    values, report = evaluate(boundary, x, kernel, solver.OUTPUT_BASIS, curve.n, progress, tolerance, params)
    return (values, report) if return_report else values


__all__ = ["basis_functions"]
