"""Transfinite basis functions G_i(x) of a closed B-spline domain (Sec. 4.3).

G_i(x) = sum_k h lambda(x, t_k) N_i(t_k), folded so that G_1..G_n belong to the n
user control points; then sum_i G_i(x) P_i = x (linear precision) and
sum_i G_i(x) = 1 (partition of unity), and g(x) = sum_i F_i G_i(x) interpolates
B-spline boundary data F(t) = sum_i F_i N_i(t).
"""

from __future__ import annotations

import numpy as np

from core.curves.arc_length import checked_parameterization
from core.curves.bspline import ClosedBSpline
from core.kernel_table import DEFAULT_KERNEL
from core.kernels import BOUNDARY_INTEGRAL_KERNELS, DEFAULT_TOLERANCE, Progress, evaluate
from core.newton import solver
from core.validation import as_points, positive_int


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
        One of `core.KERNELS` (see `core.kernel` for parameters).  ``"poisson"``
        (the default) gives the exact harmonic coordinates by a boundary integral
        equation (`core.boundary_integrals.poisson`), ``"cauchy-green"`` the complex Cauchy–Green
        coordinates (`core.boundary_integrals.cauchy_green`); neither takes parameters, and neither
        depends on the boundary's parameterization or on `samples_per_segment`
        (their panels are chosen for the accuracy stated in `core.boundary_integrals.panels`).
    samples_per_segment : int
        N / n, boundary samples per span for the Newton kernels (the paper uses 100).
    progress : callable, optional
        Called with the fraction done in [0, 1].
    tolerance : float
        Newton tolerance on the linear-precision residual, relative to the diameter.
    return_report : bool
        Also return the `core.SolveReport`.
    parameterization : str
        ``"natural"`` (the B-spline parameter t, the paper's choice) or
        ``"arc-length"``: the kernel's integrals run over the arc length s and
        G_i(x) = int lambda(x, s) N_i(t(s)) ds (Fig. 12, `core.curves.arc_length`).

    Returns
    -------
    ndarray of shape (M, n)
        Rows sum to 1 and ``G @ curve.control_points == x`` to the tolerance.
        Complex for ``"cauchy-green"``: then ``core.deform(G, P) == x``.
    """
    if not isinstance(curve, ClosedBSpline):
        raise ValueError(f"curve must be a core.ClosedBSpline, got {type(curve).__name__}")
    per = positive_int(samples_per_segment, "samples_per_segment", minimum=2)
    if kernel in BOUNDARY_INTEGRAL_KERNELS:
        return _boundary_integral_basis(curve, x, kernel, progress, return_report, parameterization, params)
    boundary = curve.sample(per, parameterization)
    values, report = evaluate(boundary, x, kernel, solver.OUTPUT_BASIS, curve.n, progress, tolerance, params)
    return (values, report) if return_report else values


def _boundary_integral_basis(curve, x, kernel, progress, return_report, parameterization, params):
    """`basis_functions` of the boundary-integral kernels; the report holds the linear-precision residuals."""
    from core.boundary_integrals.cauchy_green import cauchy_green_basis
    from core.boundary_integrals.poisson import poisson_basis

    checked_parameterization(parameterization)
    if params:
        raise ValueError(f"kernel {kernel!r} does not take parameter(s) {', '.join(sorted(params))}")
    points = as_points(x, "x")
    values = (poisson_basis if kernel == "poisson" else cauchy_green_basis)(curve, points, progress)
    if not return_report:
        return values
    from core.deformation import deform
    from core.kernels import SolveReport

    count = points.shape[0]
    residual = np.linalg.norm(deform(values, curve.control_points) - points, axis=1)
    zeros = np.zeros(count, dtype=np.int64)
    return values, SolveReport(zeros, zeros.copy(), residual)


__all__ = ["basis_functions"]
