"""Barycentric kernels lambda(x, t) of a sampled closed curve (`core.kernel`).

The table of kernels (names are a public contract; the list is `core.kernel_table`):

=============================  ===============================================  ==============
name                           weight omega_x or kernel                         paper
=============================  ===============================================  ==============
poisson (default)              the Poisson kernel: harmonic coordinates by a     Sec. 1.1, Eq. 2
                               boundary integral equation (`core.boundary_integrals.poisson`)
cauchy-green                   complex Cauchy-Green coordinates, conformal,      Sec. 1.1
                               not interpolating (`core.boundary_integrals.cauchy_green`)
mean-value                     mu = (p - x) x p' / r^3, may be negative          Eq. 5
modified-mean-value            omega = |d theta / dt|                            Eq. 22-23
modified-mean-value-squared    omega = |d theta / dt|^2                          Sec. 3.4
maximum-likelihood             omega = 1                                         Sec. 3.1
pseudo-harmonic                omega = 1 / r                                     Eq. 18
power                          omega = 1 / r^k, optional shift                   Eq. 19
harmonic-like                  omega = 1 / r^4 + int 1 / r^4                     Eq. 20
inverse-cube-mean              omega = 1 / r^3 + mean of 1 / r^3                 Eq. 19, k = 3
wachspress, laplace            three-point family, convex domains only           Sec. 1.1
=============================  ===============================================  ==============

The weighted maximum-likelihood kernels (Eq. 17) solve a two-variable convex
problem per point (Eq. 16); see `core.newton.solver`.  The two boundary-integral kernels
(`BOUNDARY_INTEGRAL_KERNELS`) solve one linear system per cage and need no Newton
solver and no compilation; `core.basis_functions` evaluates them, `kernel` (the
values lambda(x, t) at the samples) does not apply to them.

``inverse-cube-mean`` is the weight of Eq. 19 with k = 3 and the shift by the mean
instead of the integral,

    omega_x(t) = 1 / r(t)^3 + (1 / n) int_0^n 1 / r(s)^3 ds,

the winner of the search over the weights 1 / r^k, k in [1, 6], shifted by nothing,
the mean or the integral (``python -m app quality --search``, README "Which kernel?").
Of the weighted maximum-likelihood kernels that resolve every point, down to 1e-11 of
the diameter from the boundary, it comes closest to the finite-element harmonic map
and height interpolant on the standard suite, ties ``pseudo-harmonic`` on folded area
and spills out less (Eq. 20, whose integral shift grows with n and pulls the kernel
towards omega = 1, folds and spills about twice as much).  The unshifted 1 / r^2 folds
less but, like ``modified-mean-value-squared``, leaves points between 1e-5 and 1e-8 of
the diameter from the boundary unresolved (reported, Sec. 3.3).
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from core.curves import arc_length_compiled
from core.curves.arc_length import arc_length_boundary, checked_parameterization
from core.curves.boundary import Boundary
from core.curves.crossing_slabs import crossing_slabs
from core.kernel_table import BOUNDARY_INTEGRAL_KERNELS, CONVEX_ONLY, POINT_KERNELS
from core.library_threads import in_shares
from core.newton import codes, quadrature_nodes, solver
from core.newton.solver_state import Geometry, Nodes, Output, Samples, Settings
from core.validation import as_points, positive_float

#: The real point kernels: their coordinates G (M, n) satisfy G @ P == x (`core.kernel_table`).
KERNELS = POINT_KERNELS
#: The default of `kernel`, which needs kernel values: the quality study's best Newton kernel.
DEFAULT_VALUES_KERNEL = "inverse-cube-mean"

_IDENTIFIERS = {
    "maximum-likelihood": codes.MAXIMUM_LIKELIHOOD,
    "pseudo-harmonic": codes.PSEUDO_HARMONIC,
    "power": codes.POWER,
    "inverse-cube-mean": codes.POWER,
    "harmonic-like": codes.HARMONIC_LIKE,
    "modified-mean-value": codes.MODIFIED_MEAN_VALUE,
    "modified-mean-value-squared": codes.MODIFIED_MEAN_VALUE_SQUARED,
    "mean-value": codes.MEAN_VALUE,
    "wachspress": codes.WACHSPRESS,
    "laplace": codes.LAPLACE,
}
_SHIFTS = {"none": codes.SHIFT_NONE, "integral": codes.SHIFT_INTEGRAL, "mean": codes.SHIFT_MEAN}
#: The shifts of the ``power`` kernel's weights (Eq. 19): its ``shift`` parameter takes one of them.
SHIFTS = tuple(_SHIFTS)
# Named members of the power family: (k, shift) of omega = 1 / r^k (Eq. 19).
_FIXED_POWERS = {"inverse-cube-mean": (3.0, codes.SHIFT_MEAN)}
# Newton stops when the linear-precision residual is below this fraction of the diameter.
DEFAULT_TOLERANCE = 1e-11
# Quadrature refinements tried, in turn, for points whose kernel the samples do not resolve.
REFINEMENTS = (4, 16)
# Points per compiled call: bounds memory to chunk x columns and paces the progress callback.
CHUNK = 4096

Progress = Callable[[float], None]


class ConvergenceWarning(RuntimeWarning):
    """Some points did not reach the Newton tolerance, or sit at the feasible edge."""


@dataclass(frozen=True)
class SolveReport:
    """Per-point diagnostics of a kernel evaluation.

    Attributes
    ----------
    iterations : ndarray of shape (M,)
        Newton iterations on the point's full quadrature (0 for the explicit
        kernels and boundary points); those of the warm start on a subset of the
        nodes (`core.newton.minimisation.coarse_start`) are not counted.
    status : ndarray of shape (M,)
        0 converged, 1 not converged, 3 converged but the minimiser is at the edge
        of the feasible set (lambda-hat is under-resolved by the quadrature).
    residual : ndarray of shape (M,)
        Linear-precision error |sum_t lambda(x, t) p(t) h - x| in length units.
    """

    iterations: np.ndarray
    status: np.ndarray
    residual: np.ndarray

    @property
    def converged(self) -> np.ndarray:
        """bool ndarray of shape (M,): the point met the tolerance."""
        return self.status == codes.STATUS_CONVERGED

    @property
    def failed(self) -> np.ndarray:
        """bool ndarray of shape (M,): not converged or at the feasible edge."""
        return self.status != codes.STATUS_CONVERGED


def kernel_parameters(kernel: str, params: dict) -> tuple[int, float, int]:
    """Validate a Newton kernel's name and its parameters; return (identifier, power, shift mode)."""
    if kernel in BOUNDARY_INTEGRAL_KERNELS:
        raise ValueError(
            f"kernel {kernel!r} is a boundary-integral kernel: it has basis functions "
            "(core.basis_functions) but no kernel values lambda(x, t) here; use a Newton kernel "
            f"such as {DEFAULT_VALUES_KERNEL!r} for core.kernel"
        )
    if not isinstance(kernel, str) or kernel not in _IDENTIFIERS:
        raise ValueError(f"unknown kernel {kernel!r}; choose one of: {', '.join(KERNELS)}")
    params = dict(params)
    power = 0.0
    shift = codes.SHIFT_NONE
    if kernel == "power":
        power = positive_float(params.pop("power", 2.0), "power")
        shift_value = params.pop("shift", "none")
        if shift_value is True:
            shift_value = "integral"
        elif shift_value is False or shift_value is None:
            shift_value = "none"
        if shift_value not in _SHIFTS:
            raise ValueError(
                f"shift must be one of {', '.join(_SHIFTS)} (or True/False), got {shift_value!r}"
            )
        shift = _SHIFTS[shift_value]
    elif kernel in _FIXED_POWERS:
        power, shift = _FIXED_POWERS[kernel]
    if params:
        raise ValueError(
            f"kernel {kernel!r} does not take parameter(s) {', '.join(sorted(params))}"
            + ("" if kernel == "power" else "; only 'power' takes power= and shift=")
        )
    return _IDENTIFIERS[kernel], power, shift


def kernel(
    boundary: Boundary,
    x,
    kernel: str = DEFAULT_VALUES_KERNEL,
    *,
    progress: Progress | None = None,
    tolerance: float = DEFAULT_TOLERANCE,
    return_report: bool = False,
    parameterization: str = "natural",
    **params,
):
    """Kernel values lambda(x_m, t_k) at the N samples of a boundary.

    Parameters
    ----------
    boundary : Boundary
        The closed curve, sampled at t_k = k h.
    x : array_like of shape (M, 2)
        Points in the closed domain.
    kernel : str
        One of `KERNELS`; ``power`` takes ``power=k`` and ``shift="none" |
        "integral" | "mean"`` (Eq. 19; True means "integral").
    progress : callable, optional
        Called with the fraction done in [0, 1].
    tolerance : float
        Newton stops when the linear-precision residual is below
        tolerance * diameter.
    return_report : bool
        Also return a `SolveReport`.
    parameterization : str
        ``"natural"``: the boundary's own parameter t.  ``"arc-length"``: the
        kernel in the arc length s (Fig. 12c) at the N samples s_k = k n / N (normalised arc length) of
        `core.curves.arc_length.arc_length_boundary`; needs a boundary
        from `ClosedBSpline.sample` (natural).

    Returns
    -------
    ndarray of shape (M, N)
        ``h * values.sum(axis=1) == 1``.  Farther than a few sample spacings from
        the boundary this is exactly the trapezoid rule of Sec. 4.1 (and
        ``h * values @ boundary.points == x`` to the Newton tolerance).  Nearer,
        the refined quadrature is lumped onto the samples by linear interpolation
        in t, which keeps the partition of unity exact.  Points on the boundary
        get the Lagrange limit (a discrete delta at their parameter).
    """
    if not isinstance(boundary, Boundary):
        raise ValueError(f"boundary must be a core.Boundary, got {type(boundary).__name__}")
    if checked_parameterization(parameterization) == "arc-length":
        boundary = arc_length_boundary(boundary.curve, boundary.count, boundary.corners)
    values, report = evaluate(
        boundary, x, kernel, codes.OUTPUT_SAMPLES, boundary.count, progress, tolerance, params
    )
    return (values, report) if return_report else values


def evaluate(
    boundary: Boundary,
    x,
    kernel: str,
    mode: int,
    columns: int,
    progress: Progress | None,
    tolerance: float,
    params: dict,
) -> tuple[np.ndarray, SolveReport]:
    """Shared driver of `kernel` and `basis_functions`: validate, chunk, solve, check."""
    identifier, power, shift = kernel_parameters(kernel, params)
    tolerance = positive_float(tolerance, "tolerance")
    points = as_points(x, "x")
    if kernel in CONVEX_ONLY:
        require_convex(boundary, kernel)
    count = points.shape[0]
    out = np.zeros((count, columns))
    iterations = np.zeros(count, dtype=np.int64)
    status = np.zeros(count, dtype=np.int64)
    residual = np.zeros(count)
    run = _Run(points, identifier, power, shift, mode, columns, tolerance, boundary)
    run.solve(boundary, np.arange(count), out, iterations, status, residual, progress)
    # Points whose lambda-hat peaks more sharply than the quadrature resolves (or
    # that did not converge) are solved again on finer quadratures.
    for factor in REFINEMENTS:
        again = np.flatnonzero(
            (status == codes.STATUS_NOT_CONVERGED) | (status == codes.STATUS_AT_FEASIBLE_EDGE)
        )
        if again.size == 0:
            break
        out[again] = 0.0
        run.solve(boundary.refined(factor), again, out, iterations, status, residual, None, factor)
    return out, checked_report(points, kernel, iterations, status, residual, stacklevel=4)


def checked_report(points, kernel: str, iterations, status, residual, stacklevel: int) -> SolveReport:
    """The `SolveReport` of a solve of `points` (M, 2), after its two checks.

    Raises
    ------
    ValueError
        Some points are outside the domain (how many, and the first).

    Warns
    -----
    ConvergenceWarning
        Some points did not converge cleanly (`stacklevel` is that of `warnings.warn`,
        counted from this function).
    """
    count = points.shape[0]
    outside = status == codes.STATUS_OUTSIDE
    if outside.any():
        first = int(np.flatnonzero(outside)[0])
        raise ValueError(
            f"{int(outside.sum())} of {count} points of x are outside the domain "
            f"(first: index {first}, {points[first].tolist()})"
        )
    report = SolveReport(iterations, status, residual)
    failed = report.failed
    if failed.any():
        warnings.warn(
            f"{int(failed.sum())} of {count} points did not converge cleanly with kernel "
            f"{kernel!r} (worst linear-precision residual {residual[failed].max():.3g}, "
            f"{int((status == codes.STATUS_AT_FEASIBLE_EDGE).sum())} at the feasible edge); "
            "see return_report=True for which",
            ConvergenceWarning,
            stacklevel=stacklevel,
        )
    return report


@dataclass
class _Run:
    """One evaluation request: what `solver.solve_points` needs besides the quadrature."""

    points: np.ndarray
    identifier: int
    power: float
    shift: int
    mode: int
    columns: int
    tolerance: float
    reference: Boundary  # the boundary whose samples (and diameter) define the output

    def solve(self, boundary, indices, out, iterations, status, residual, progress, factor=1):
        """Solve the points `indices` on `boundary` (the reference one or a refinement)."""
        curve = curve_arrays(boundary, self.mode, self.columns, factor, self.reference.step)
        orientation = 1.0 if self.reference.area > 0 else -1.0
        settings = Settings(
            self.identifier, self.power, self.shift, self.mode, orientation,
            self.reference.diameter, self.columns, self.tolerance,
        )  # fmt: skip
        geometry = Geometry(boundary.curve.coefficients, boundary.curve.piece_length, boundary.corners)
        for start in range(0, indices.size, CHUNK):
            chunk = indices[start : start + CHUNK]
            rows = np.zeros((chunk.size, self.columns))
            diagnostics = [
                np.zeros(chunk.size, dtype=np.int64),
                np.zeros(chunk.size, dtype=np.int64),
                np.zeros(chunk.size),
            ]
            _solve_in_threads(self.points[chunk], settings, curve, geometry, rows, diagnostics)
            # A safety net: a row that is not finite is never returned as converged.
            broken = ~np.isfinite(rows).all(axis=1) & (diagnostics[1] != codes.STATUS_OUTSIDE)
            diagnostics[1][broken] = codes.STATUS_NOT_CONVERGED
            diagnostics[2][broken] = np.inf
            out[chunk] = rows
            iterations[chunk], status[chunk], residual[chunk] = diagnostics
            if progress is not None:
                progress((start + chunk.size) / indices.size)


def _solve_in_threads(points, settings, curve, geometry, rows, diagnostics) -> None:
    """`solver.solve_points` on every point, one strided share per thread (it releases the GIL)."""
    output = Output(rows, *diagnostics)
    in_shares(solver.solve_points, points.shape[0], points, settings, curve, geometry, output)


def curve_arrays(boundary: Boundary, mode: int, columns: int, factor: int, out_step: float) -> Samples:
    """The per-sample arrays `core.newton.solver.solve_points` shares between points."""
    count = boundary.count
    if mode == codes.OUTPUT_BASIS:
        u = _local_parameters(boundary, columns)
        basis = (0.5 * (1 - u) ** 2, 0.5 * (-2 * u * u + 2 * u + 1), 0.5 * u * u)
    else:
        basis = (np.zeros(count),) * 3
    column = np.ascontiguousarray
    spacing = _sample_spacing(boundary.points)
    rule = Nodes(
        column(boundary.points[:, 0]),
        column(boundary.points[:, 1]),
        column(boundary.tangents[:, 0]),
        column(boundary.tangents[:, 1]),
        column(boundary.second_derivatives[:, 0]),
        column(boundary.second_derivatives[:, 1]),
        np.full(count, boundary.step),
    )
    return Samples(
        rule,
        spacing,
        boundary.parameters,
        *basis,
        float(boundary.step),
        quadrature_nodes.SINH_STEP / factor,
        float(out_step),
        crossing_slabs(boundary.points[:, 1]),
        float(spacing.max()),
    )


def _local_parameters(boundary: Boundary, spans: int) -> np.ndarray:
    """u in [0, 1] of every sample within the B-spline span the solver files it under, shape (N,).

    The spans' sample ranges are `core.curves.arc_length_compiled.span_first_sample`'s: `per` samples
    each in the natural parameter, the samples from ceil(S_j / h) on in arc length
    (`core.curves.arc_length`), where u = t(s_k) - j.
    """
    count = boundary.count
    coefficients = boundary.curve.coefficients
    if coefficients.shape[2] == 2:
        per = count // spans
        return (np.arange(count) % per) / per
    firsts = [
        arc_length_compiled.span_first_sample(coefficients, count, spans, boundary.step, j)
        for j in range(spans + 1)
    ]
    span = np.repeat(np.arange(spans), np.diff(firsts))
    return np.clip(boundary.curve.natural(boundary.parameters) - span, 0.0, 1.0)


def _sample_spacing(points: np.ndarray) -> np.ndarray:
    """Largest distance from each sample to its two neighbours, shape (N,)."""
    chord = np.linalg.norm(np.roll(points, -1, axis=0) - points, axis=1)
    return np.maximum(chord, np.roll(chord, 1))


def require_convex(boundary: Boundary, kernel: str) -> None:
    orientation = 1.0 if boundary.area > 0 else -1.0
    tangents, second = boundary.tangents, boundary.second_derivatives
    turning = orientation * (tangents[:, 0] * second[:, 1] - tangents[:, 1] * second[:, 0])
    scale = np.abs(turning).max()
    corner_turns = orientation * (
        boundary.corners[:, 1] * boundary.corners[:, 4] - boundary.corners[:, 2] * boundary.corners[:, 3]
    )
    if (turning < -1e-9 * scale).any() or (corner_turns < -1e-12).any():
        raise ValueError(
            f"kernel {kernel!r} is defined for convex domains only and this curve is not "
            "convex; use 'harmonic-like' or another maximum-likelihood kernel"
        )
