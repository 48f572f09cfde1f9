"""Exact gradients of the transfinite kernels and basis functions with respect to x.

The paper's conclusion notes that the gradients follow by differentiating the
construction; this module does it for the discrete kernels the solver evaluates.
For a point x the solver uses nodes t_j with weights w_j (the trapezoid rule of
Sec. 4.1, refined near the boundary), p_j = p(t_j), r_j = |p_j - x|, u_j = (p_j -
x) / r_j (Eq. 10), and grad r_j = -u_j, grad u_j = -(I - u_j u_j^T) / r_j.

Weighted maximum-likelihood family (Eq. 14-17).  With a_j = w_j omega_x(t_j)
(Eq. 18-20, 23; any x-dependent common factor cancels below), phi minimises
F(phi) = -sum_j a_j log s_j, s_j = 1 + phi . u_j (Eq. 16 with phi_0 = 1), so

    g(phi, x) = sum_j a_j u_j / s_j = 0                       (grad F = 0).

The kernel is lambda_j = c_j / sum_k c_k with c_j = a_j / (r_j s_j) (Eq. 14, 17).
Write b_j = lambda_j r_j s_j (proportional to a_j),

    H = sum_j b_j u_j u_j^T / s_j^2   (the Hessian of F, positive definite),
    K = sum_j lambda_j u_j u_j^T / s_j,   v = sum_j lambda_j u_j / s_j,
    D = sum_j u_j (grad b_j)^T / s_j.

Differentiating g(phi(x), x) = 0 (the implicit function theorem):

    dphi/dx = Phi = H^-1 (D - I + K + v phi^T)                                (*)

(the terms come from grad a_j, grad u_j at fixed phi, and phi . grad u_j).  Then

    grad s_j = Phi^T u_j - (phi - (s_j - 1) u_j) / r_j,
    dc_j = grad b_j / (r_j s_j) + lambda_j (u_j / r_j - grad s_j / s_j),
    grad lambda_j = dc_j - lambda_j sum_k dc_k,

and grad b_j = kappa grad a_j with kappa = sum_k b_k / sum_k a_k.  The weights'
gradients, for omega = 1, 1 / r (Eq. 18), 1 / r^k + shift (Eq. 19-20: the shift's
gradient is the quadrature of grad r^-k = k r^-k u / r) and |d theta / dt| =
|(p - x) x p'| / r^2 (Eq. 23, and its square), are in `core.newton.gradient_solver`.

Explicit kernels (mean value Eq. 5, Wachspress and Laplace Sec. 1.1, with the
point masses of sharp corners): lambda_j = m_j / sum_k m_k with m_j = w_j mu(x, t_j),
so grad lambda_j = grad m_j / M - lambda_j sum_k grad m_k / M.

The basis functions are G_i = sum_j lambda_j N_i(t_j) (Sec. 4.3), so
grad G_i = sum_j grad lambda_j N_i(t_j).  Consequences, exact for any fixed nodes:
sum_i grad G_i = sum_j grad lambda_j = 0, and, because sum_j lambda_j (p_j - x) =
g / sum c = 0 holds for every x, sum_i P_i (grad G_i)^T = sum_j p_j (grad lambda_j)^T = I
(differentiated linear precision), both up to the Newton residual.

Which derivative this is.  Farther than `quadrature_nodes.NEAR_SPACINGS` sample spacings
from the boundary the nodes are the fixed samples and this is the exact derivative
of the discrete `core.basis_functions`.  Nearer, the graded rule's nodes follow x
(their centre is the closest parameter, their grading the distance), and the
window's integer extents jump with x, so the discrete value function is only
piecewise smooth there; the gradient returned is the derivative with the nodes of
x held fixed: the same rule applied to the x-derivative of the integrands, i.e.
the quadrature of the exact gradient of Eq. 17 at x.  It differs from the exact
derivative of the values by the x-derivative of the quadrature error, which
`tests/core/test_gradients.py` bounds against central differences near the boundary.
Points on the boundary (the Lagrange limit of the values) get NaN gradients.
"""

from __future__ import annotations

import numpy as np

from core import kernels
from core.curves.boundary import Boundary
from core.curves.bspline import ClosedBSpline
from core.kernel_table import DEFAULT_KERNEL
from core.kernels import DEFAULT_TOLERANCE, REFINEMENTS, checked_report
from core.library_threads import in_shares
from core.newton import codes, gradient_solver
from core.newton.solver_state import Geometry, Output, Settings
from core.validation import as_points, positive_float, positive_int


def basis_gradients(
    curve: ClosedBSpline,
    x,
    kernel: str = DEFAULT_KERNEL,
    samples_per_segment: int = 100,
    *,
    tolerance: float = DEFAULT_TOLERANCE,
    return_values: bool = False,
    return_report: bool = False,
    **params,
):
    """Gradients grad G_i(x_m) of the basis functions of the n control points.

    Parameters
    ----------
    curve : ClosedBSpline
        The source cage, n control points.
    x : array_like of shape (M, 2)
        Points in the closed domain; points on the curve get NaN gradients.
    kernel : str
        One of `core.KERNELS` (see `core.kernel` for parameters).
    samples_per_segment : int
        N / n, boundary samples per span, as for `core.basis_functions`.
    tolerance : float
        Newton tolerance on the linear-precision residual, relative to the diameter.
    return_values : bool
        Also return G (M, n), computed on the same nodes (equal to
        `core.basis_functions` up to rounding).
    return_report : bool
        Also return the `core.SolveReport`.

    Returns
    -------
    ndarray of shape (M, n, 2)
        ``[m, i]`` is grad G_i(x_m); ``sum_i grad G_i == 0`` and
        ``sum_i P_i (grad G_i)^T == I_2`` to the Newton tolerance.  Followed by
        the values and the report if asked for.
    """
    if not isinstance(curve, ClosedBSpline):
        raise ValueError(f"curve must be a core.ClosedBSpline, got {type(curve).__name__}")
    per = positive_int(samples_per_segment, "samples_per_segment", minimum=2)
    if kernel in kernels.BOUNDARY_INTEGRAL_KERNELS:
        return _boundary_integral_gradients(curve, x, kernel, return_values, return_report, params)
    boundary = curve.sample(per)
    values, gradients, report = _evaluate(boundary, x, kernel, codes.OUTPUT_BASIS, curve.n, tolerance, params)
    return _returned(gradients, values, report, return_values, return_report)


def kernel_gradients(
    boundary: Boundary,
    x,
    kernel: str = DEFAULT_KERNEL,
    *,
    tolerance: float = DEFAULT_TOLERANCE,
    return_values: bool = False,
    return_report: bool = False,
    **params,
):
    """Gradients grad_x lambda(x_m, t_k) of the kernel values of `core.kernel`.

    Parameters and returns as `basis_gradients`, with the N samples of `boundary`
    in place of the n control points: ndarray of shape (M, N, 2), and the values
    (M, N) of `core.kernel` if asked for.
    """
    if not isinstance(boundary, Boundary):
        raise ValueError(f"boundary must be a core.Boundary, got {type(boundary).__name__}")
    values, gradients, report = _evaluate(
        boundary, x, kernel, codes.OUTPUT_SAMPLES, boundary.count, tolerance, params
    )
    return _returned(gradients, values, report, return_values, return_report)


def _boundary_integral_gradients(curve, x, kernel, return_values, return_report, params):
    """`basis_gradients` of ``"poisson"`` (real) and ``"cauchy-green"`` ((dC/dz, i dC/dz), complex)."""
    from core.basis import basis_functions
    from core.boundary_integrals.cauchy_green import cauchy_green_derivatives
    from core.boundary_integrals.poisson import poisson_gradients

    if params:
        raise ValueError(f"kernel {kernel!r} does not take parameter(s) {', '.join(sorted(params))}")
    points = as_points(x, "x")
    if kernel == "poisson":
        gradients = poisson_gradients(curve, points)
    else:
        derivative = cauchy_green_derivatives(curve, points)
        gradients = np.stack([derivative, 1j * derivative], axis=2)
    values, report = basis_functions(curve, points, kernel, return_report=True)
    return _returned(gradients, values, report, return_values, return_report)


def _returned(gradients, values, report, return_values, return_report):
    result = (gradients,) + ((values,) if return_values else ()) + ((report,) if return_report else ())
    return result[0] if len(result) == 1 else result


def _evaluate(boundary, x, kernel, mode, columns, tolerance, params):
    """Like `core.kernels.evaluate`, with gradients: validate, solve, refine, check."""
    identifier, power, shift = kernels.kernel_parameters(kernel, params)
    tolerance = positive_float(tolerance, "tolerance")
    points = as_points(x, "x")
    if kernel in kernels.CONVEX_ONLY:
        kernels.require_convex(boundary, kernel)
    count = points.shape[0]
    values = np.zeros((count, columns))
    gradients = np.zeros((count, 2, columns))
    iterations = np.zeros(count, dtype=np.int64)
    status = np.zeros(count, dtype=np.int64)
    residual = np.zeros(count)
    orientation = 1.0 if boundary.area > 0 else -1.0
    settings = Settings(identifier, power, shift, mode, orientation, boundary.diameter, columns, tolerance)
    indices = np.arange(count)
    quadrature, factor = boundary, 1
    for refinement in (None, *REFINEMENTS):
        if refinement is not None:
            indices = np.flatnonzero(
                (status == codes.STATUS_NOT_CONVERGED) | (status == codes.STATUS_AT_FEASIBLE_EDGE)
            )
            if indices.size == 0:
                break
            quadrature, factor = boundary.refined(refinement), refinement
        curve = kernels.curve_arrays(quadrature, mode, columns, factor, boundary.step)
        geometry = Geometry(quadrature.curve.coefficients, quadrature.curve.piece_length, quadrature.corners)
        for start in range(0, indices.size, kernels.CHUNK):
            chunk = indices[start : start + kernels.CHUNK]
            rows = np.zeros((chunk.size, columns))
            derivatives = np.zeros((chunk.size, 2, columns))
            diagnostics = [np.zeros(chunk.size, dtype=np.int64), np.zeros(chunk.size, dtype=np.int64)]
            diagnostics.append(np.zeros(chunk.size))
            _in_threads(points[chunk], settings, curve, geometry, rows, derivatives, diagnostics)
            broken = ~np.isfinite(rows).all(axis=1) & (diagnostics[1] != codes.STATUS_OUTSIDE)
            diagnostics[1][broken] = codes.STATUS_NOT_CONVERGED
            diagnostics[2][broken] = np.inf
            values[chunk], gradients[chunk] = rows, derivatives
            iterations[chunk], status[chunk], residual[chunk] = diagnostics
    report = checked_report(points, kernel, iterations, status, residual, stacklevel=4)
    return values, np.ascontiguousarray(gradients.transpose(0, 2, 1)), report


def _in_threads(points, settings, curve, geometry, rows, derivatives, diagnostics) -> None:
    """`gradient_solver.gradient_points` on every point, one strided share per thread."""
    arguments = (points, settings, curve, geometry, Output(rows, *diagnostics), derivatives)
    in_shares(gradient_solver.gradient_points, points.shape[0], *arguments)


__all__ = ["basis_gradients", "kernel_gradients"]
