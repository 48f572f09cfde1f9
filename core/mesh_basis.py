"""Basis functions G at the vertices of a domain mesh, for any kernel (Sec. 4.3), cached on disk.

This is the precompute of the deformation pipeline: G (V x n) once per (cage,
mesh, kernel); every drag then costs one product ``G @ P'``.  Boundary rows are
exactly the folded B-spline basis at the vertices' parameters (the Lagrange
property), interior rows come from

- the point kernels of `core.KERNELS` (`core.basis_functions`, Eq. 14-17),
- ``"pgw"``: transfinite positive Gordon-Wixom coordinates (`core.pgw_basis`),
- ``"harmonic"``: the linear finite-element harmonic basis on the mesh itself
  (`core.harmonic_basis`, Sec. 4.2).
"""

from __future__ import annotations

import secrets
import warnings
from collections.abc import Callable

import numpy as np

from core.curves.arc_length import checked_parameterization
from core.curves.bspline import ClosedBSpline
from core.kernel_table import (
    BY_NAME,
    COMPILED_KERNELS,
    COMPLEX_KERNELS,
    DEFAULT_KERNEL,
    MESH_ONLY_KERNELS,
    NEWTON_KERNELS,
    PARAMETERIZED_KERNELS,
    POINT_KERNELS,
)
from core.kernels import DEFAULT_TOLERANCE
from core.meshes.mesh import Mesh, require_mesh_of
from core.meshes.pgw import pgw_basis
from core.newton.compilation import compile_solver
from core.storage import cache as disk_cache
from core.validation import checked_samples_per_segment

#: Kernels whose G is not kept in the disk cache: complex, and cheaper to evaluate than to check.
UNCACHED_KERNELS = COMPLEX_KERNELS
#: Boundary samples per B-spline span of the point kernels unless told otherwise.
DEFAULT_SAMPLES_PER_SEGMENT = 100
#: Rows of a cached entry computed again on every read (`recomputed_rows_problem`), and how far
#: they may differ: Newton's iterations stop per point, so a row depends on its point only, up
#: to rounding (measured: 5e-12 for the Newton kernels, 1e-15 for poisson).
SPOT_CHECKS = 8
SPOT_CHECK_TOLERANCE = 1e-9
# Rounding allowance of the invariant checks, in units of n * machine epsilon.
ROUNDING_ULPS = 64


class CacheWarning(RuntimeWarning):
    """A cache entry that could not be used (damaged, or under another key) was recomputed and replaced."""


def mesh_basis_functions(
    curve: ClosedBSpline,
    mesh: Mesh,
    kernel: str = DEFAULT_KERNEL,
    samples_per_segment: int = DEFAULT_SAMPLES_PER_SEGMENT,
    progress: Callable[[float], None] | None = None,
    cache: bool = True,
    compiling: Callable[[float], None] | None = None,
    gradients: bool = False,
    parameterization: str = "natural",
    **params,
):
    """Basis functions G_i at every vertex of `mesh`, and optionally their gradients.

    Parameters
    ----------
    curve : ClosedBSpline
        The source cage, n control points.
    mesh : Mesh
        A mesh of the domain made for this curve (`core.triangulate(curve)`).
    kernel : str
        One of `core.KERNELS` (``"poisson"``, the exact harmonic coordinates, is
        the default), ``"pgw"`` or ``"harmonic"`` (the finite-element harmonic basis).
    samples_per_segment : int
        N / n boundary samples per span for the point kernels; for ``"pgw"`` it
        sets the default number of line directions (see `core.pgw_basis`);
        ``"harmonic"`` ignores it.
    progress : callable, optional
        Called with the fraction done in [0, 1].
    cache : bool
        Read and write the result in the disk cache (`core.storage.cache`).  An entry
        that fails its checksum or `invariant_problem` is recomputed and
        replaced, with a `CacheWarning` saying so.
    compiling : callable, optional
        Called with the fraction compiled in [0, 1] when a point kernel needs the
        solver compiled first (the first run only, see `core.compile_solver`);
        not called when G comes from the cache or the compiled solver is cached.
    gradients : bool
        Also return grad G_i at the vertices (`core.basis_gradients`), for the
        point kernels of `core.KERNELS` and the natural parameterisation only:
        ``"harmonic"`` and ``"pgw"`` have no pointwise gradients (the
        per-triangle Jacobians of `core.meshes.distortion` are exact for the piecewise
        linear ``"harmonic"`` basis).  Cached like G, in an entry of its own
        checked by `gradient_invariant_problem`.
    parameterization : str
        ``"natural"`` or ``"arc-length"``: the boundary parameter of the point
        kernels' integrals (Fig. 12, `core.basis_functions`); part of the cache
        key.  ``"pgw"`` and ``"harmonic"`` do not depend on one and take only
        ``"natural"``.
    **params
        Kernel parameters: those of `core.basis_functions` for the point kernels,
        ``angles`` for ``"pgw"``, none for ``"harmonic"``.

    Returns
    -------
    ndarray of shape (V, n)
        Row v holds G_1..G_n at ``mesh.vertices[v]``; rows ``mesh.boundary`` are
        exactly ``curve.basis_matrix(mesh.boundary_parameters)``.
    ndarray of shape (V, n, 2), with gradients=True
        ``[v, i]`` is grad G_i at ``mesh.vertices[v]``; NaN on the boundary rows
        (the Lagrange limit has no gradient there).

    Raises
    ------
    ValueError
        An unknown kernel or parameter, a mesh of another curve, or invalid
        arguments.
    """
    callbacks = {"progress": progress, "compiling": compiling}
    per = _checked_arguments(
        curve, mesh, kernel, (samples_per_segment, parameterization, gradients), callbacks, params
    )
    if gradients:
        values = mesh_basis_functions(curve, mesh, kernel, per, progress, cache, compiling, **params)
        return values, _vertex_gradients(curve, mesh, kernel, per, cache, params)
    if not cache or kernel in UNCACHED_KERNELS:
        if kernel in COMPILED_KERNELS:
            compile_solver(compiling)
        return _compute(curve, mesh, kernel, per, progress, parameterization, params)
    key = _cache_key(curve, mesh, kernel, per, params, parameterization=parameterization)
    entry = disk_cache.load(key, (mesh.vertices.shape[0], curve.n))
    problem = entry.problem
    if entry.values is not None:
        problem = _cached_problem(curve, mesh, kernel, per, parameterization, params, entry, compiling)
        if problem is None:
            if progress is not None:
                progress(1.0)
            return entry.values
    if kernel in COMPILED_KERNELS:
        compile_solver(compiling)
    values = _compute(curve, mesh, kernel, per, progress, parameterization, params)
    replaced = disk_cache.store(key, values, invariant_errors(curve, mesh, values))
    if problem is not None:
        warnings.warn(
            f"the cached basis functions {disk_cache.entry_path(key)} could not be used ({problem}); "
            f"recomputed them{' and replaced the file' if replaced else ''}",
            CacheWarning,
            stacklevel=2,
        )
    return values


def _cached_problem(curve, mesh, kernel, per, parameterization, params, entry, compiling) -> str | None:
    """Why the intact cache `entry` of G cannot be used (`invariant_problem`, then rows recomputed
    by `recomputed_rows_problem`), or None."""
    problem = invariant_problem(curve, mesh, kernel, params, entry.values, entry.errors)
    if problem is None and kernel != "harmonic":  # the finite-element basis has no pointwise values
        if kernel in COMPILED_KERNELS:
            compile_solver(compiling)  # shown as such (the first run only), not as reading the cache
        problem = recomputed_rows_problem(
            entry.values[mesh.interior],
            mesh.vertices[mesh.interior],
            lambda points: _point_values(curve, points, kernel, per, parameterization, params),
        )
    return problem


def _checked_arguments(curve, mesh, kernel, settings, callbacks, params) -> int:
    """The checks of `mesh_basis_functions` on its arguments, one ValueError each; `settings` =
    (samples_per_segment, parameterization, gradients), `callbacks` by name.  Returns the checked
    samples per segment."""
    samples_per_segment, parameterization, gradients = settings
    require_mesh_of(curve, mesh)
    valid = POINT_KERNELS + COMPLEX_KERNELS + MESH_ONLY_KERNELS
    if not isinstance(kernel, str) or kernel not in valid:
        raise ValueError(f"unknown kernel {kernel!r}; choose one of: {', '.join(valid)}")
    per = checked_samples_per_segment(samples_per_segment, curve.n)
    if kernel in MESH_ONLY_KERNELS:
        unknown = sorted(set(params) - set(BY_NAME[kernel].parameters))
        if unknown:
            allowed = ", ".join(BY_NAME[kernel].parameters) or "none"
            raise ValueError(
                f"kernel {kernel!r} does not take parameter(s) {', '.join(unknown)} (it takes: {allowed})"
            )
    if checked_parameterization(parameterization) != "natural" and kernel not in PARAMETERIZED_KERNELS:
        raise ValueError(
            f"kernel {kernel!r} does not depend on the boundary's parameterization; "
            f"parameterization={parameterization!r} applies to {', '.join(PARAMETERIZED_KERNELS)}"
        )
    for name, callback in callbacks.items():
        if callback is not None and not callable(callback):
            raise ValueError(f"{name} must be a callable taking a fraction, got {callback!r}")
    if gradients and kernel in MESH_ONLY_KERNELS:
        raise ValueError(
            f"kernel {kernel!r} has no pointwise gradients; use the per-triangle Jacobians "
            "(core.meshes.distortion.triangle_jacobians) or a kernel of core.KERNELS"
        )
    if gradients and parameterization != "natural":
        raise ValueError(
            "gradients are computed for the natural parameterization only, "
            f"not for parameterization={parameterization!r}"
        )
    return per


def invariant_errors(curve: ClosedBSpline, mesh: Mesh, values: np.ndarray) -> np.ndarray:
    """Partition-of-unity and linear-precision errors of G, ndarray of shape (2,).

    ``max_v |sum_i G_vi - 1|`` and ``max_v |G_v P - x_v|`` (length units) over the
    rows of `values` (V, n).
    """
    partition = float(np.abs(values.sum(axis=1) - 1.0).max())
    linear = float(np.linalg.norm(values @ curve.control_points - mesh.vertices, axis=1).max())
    return np.array([partition, linear])


def invariant_problem(
    curve: ClosedBSpline, mesh: Mesh, kernel: str, params: dict, values: np.ndarray, recorded: np.ndarray
) -> str | None:
    """What is wrong with a stored G (V, n), or None if it holds every invariant it should.

    Boundary rows must be exactly the B-spline basis (the Lagrange property, by
    construction for every kernel).  Rows must sum to 1 and reproduce the
    vertices to the bounds the computation guarantees: rounding for the partition
    of unity, the Newton tolerance times the diameter for the linear precision of
    the weighted maximum-likelihood kernels, or, where a computation was less
    accurate than that (explicit kernels, points that did not converge), the
    errors `recorded` (2,) when it was stored, twice over for rounding.
    """
    if not np.array_equal(values[mesh.boundary], curve.basis_matrix(mesh.boundary_parameters)):
        return "its boundary rows are not the B-spline basis"
    rounding = ROUNDING_ULPS * curve.n * np.finfo(np.float64).eps
    partition, linear = invariant_errors(curve, mesh, values)
    allowed = 2.0 * max(float(recorded[0]), rounding)
    if not partition <= allowed:
        return f"rows sum to 1 only within {partition:.3g}, not {allowed:.3g}"
    guaranteed = rounding * float(np.abs(curve.control_points).max())
    if kernel in NEWTON_KERNELS:
        guaranteed += params.get("tolerance", DEFAULT_TOLERANCE) * curve.diameter
    allowed = 2.0 * max(float(recorded[1]), guaranteed)
    if not linear <= allowed:
        return f"G @ P misses the vertices by {linear:.3g}, more than {allowed:.3g}"
    return None


def recomputed_rows_problem(stored: np.ndarray, points: np.ndarray, compute) -> str | None:
    """What is wrong with stored rows (M, n) or (M, n, 2) at `points` (M, 2), or None: `SPOT_CHECKS`
    rows chosen at random (unpredictably, so that no forged row can count on being skipped) are
    computed again by ``compute(points)`` and must agree to `SPOT_CHECK_TOLERANCE`.

    The invariants prove that rows sum to 1 and reproduce the vertices; rows of
    another kernel, or of this one moved within those constraints, hold them too.
    """
    if len(points) == 0:
        return None
    rows = np.random.default_rng(secrets.randbits(64)).choice(
        len(points), min(SPOT_CHECKS, len(points)), replace=False
    )
    rows.sort()
    expected = compute(points[rows])
    scale = max(1.0, float(np.abs(expected).max(initial=0.0)))
    difference = float(np.abs(stored[rows] - expected).max(initial=0.0))
    if not difference <= SPOT_CHECK_TOLERANCE * scale:
        return f"{len(rows)} rows computed again differ from it by up to {difference:.3g}"
    return None


def gradient_invariant_errors(curve: ClosedBSpline, gradients: np.ndarray) -> np.ndarray:
    """Errors of the differentiated invariants of grad G (M, n, 2), ndarray of shape (2,).

    ``max |sum_i grad G_i|`` and ``max |sum_i P_i (grad G_i)^T - I_2|`` over the rows.
    """
    partition = float(np.abs(gradients.sum(axis=1)).max(initial=0.0))
    identity = np.einsum("id,mie->mde", curve.control_points, gradients) - np.eye(2)
    return np.array([partition, float(np.abs(identity).max(initial=0.0))])


def gradient_invariant_problem(
    curve: ClosedBSpline, gradients: np.ndarray, recorded: np.ndarray
) -> str | None:
    """What is wrong with stored interior gradients (M, n, 2), or None.

    Both differentiated invariants must hold as well as when they were stored
    (`recorded` (2,)), twice over for rounding.
    """
    rounding = ROUNDING_ULPS * curve.n * np.finfo(np.float64).eps
    partition, linear = gradient_invariant_errors(curve, gradients)
    scale = float(np.abs(gradients).max(initial=0.0)) * max(1.0, float(np.abs(curve.control_points).max()))
    if not partition <= 2.0 * max(float(recorded[0]), rounding * scale):
        return f"gradients sum to 0 only within {partition:.3g}"
    if not linear <= 2.0 * max(float(recorded[1]), rounding * scale):
        return f"sum_i P_i grad G_i misses the identity by {linear:.3g}"
    return None


def _vertex_gradients(curve, mesh, kernel, samples_per_segment, cache, params) -> np.ndarray:
    """grad G (V, n, 2) at the vertices: NaN rows on the boundary; interior rows cached."""
    from core.gradients import basis_gradients

    complex_valued = kernel in UNCACHED_KERNELS
    result = np.full((mesh.vertices.shape[0], curve.n, 2), np.nan, dtype=complex if complex_valued else float)
    interior = mesh.interior
    if interior.size == 0:
        return result
    shape = (interior.size, curve.n, 2)
    key = None
    problem = None
    if cache and not complex_valued:
        key = _cache_key(curve, mesh, kernel, samples_per_segment, params, quantity="basis gradients")
        entry = disk_cache.load(key, shape)
        problem = entry.problem
        if entry.values is not None:
            problem = gradient_invariant_problem(curve, entry.values, entry.errors)
            problem = problem or recomputed_rows_problem(
                entry.values,
                mesh.vertices[interior],
                lambda points: basis_gradients(
                    curve, points, kernel=kernel, samples_per_segment=samples_per_segment, **params
                ),
            )
            if problem is None:
                result[interior] = entry.values
                return result
    computed = basis_gradients(
        curve, mesh.vertices[interior], kernel=kernel, samples_per_segment=samples_per_segment, **params
    )
    if key is not None:
        replaced = disk_cache.store(key, computed, gradient_invariant_errors(curve, computed))
        if problem is not None:
            warnings.warn(
                f"the cached basis gradients {disk_cache.entry_path(key)} could not be used ({problem}); "
                f"recomputed them{' and replaced the file' if replaced else ''}",
                CacheWarning,
                stacklevel=3,
            )
    result[interior] = computed
    return result


def _cache_key(curve, mesh, kernel, samples_per_segment, params, **what) -> str:
    """`core.storage.cache.cache_key` of this cage, mesh and kernel (`what`: parameterization, quantity)."""
    return disk_cache.cache_key(
        curve.control_points,
        mesh.vertices,
        mesh.triangles,
        mesh.boundary,
        mesh.boundary_parameters,
        kernel,
        samples_per_segment,
        params,
        **what,
    )


def _compute(curve, mesh, kernel, samples_per_segment, progress, parameterization, params) -> np.ndarray:
    if kernel == "harmonic":
        from core.meshes.harmonic import harmonic_basis  # scipy.sparse: only for this kernel

        if progress is not None:
            progress(0.0)
        values = harmonic_basis(curve, mesh)
        if progress is not None:
            progress(1.0)
        return values
    if kernel == "cauchy-green":  # no Lagrange property: its boundary rows are its own limits
        from core.basis import basis_functions

        return basis_functions(curve, mesh.vertices, kernel, progress=progress)
    values = np.zeros((mesh.vertices.shape[0], curve.n))
    values[mesh.boundary] = curve.basis_matrix(mesh.boundary_parameters)
    interior = mesh.interior
    if interior.size == 0:
        if progress is not None:
            progress(1.0)
        return values
    if kernel == "poisson" and not params and interior[-1] - interior[0] + 1 == interior.size:  # a view
        from core.boundary_integrals.poisson import poisson_basis

        rows = slice(int(interior[0]), int(interior[-1]) + 1)
        poisson_basis(curve, mesh.vertices[rows], progress, out=values[rows])
        return values
    values[interior] = _point_values(
        curve, mesh.vertices[interior], kernel, samples_per_segment, parameterization, params, progress
    )
    return values


def _point_values(curve, points, kernel, samples_per_segment, parameterization, params, progress=None):
    """G (M, n) at interior `points` (M, 2) for a kernel with pointwise values (not ``"harmonic"``)."""
    if kernel == "pgw":
        return pgw_basis(
            curve,
            points,
            samples_per_segment=samples_per_segment,
            angles=params.get("angles"),
            progress=progress,
        )
    from core.basis import basis_functions

    return basis_functions(
        curve,
        points,
        kernel=kernel,
        samples_per_segment=samples_per_segment,
        progress=progress,
        parameterization=parameterization,
        **params,
    )
