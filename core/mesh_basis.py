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

from collections.abc import Callable

import numpy as np

from core import cache as disk_cache
from core.bspline import ClosedBSpline
from core.compilation import compile_solver
from core.harmonic import harmonic_basis
from core.kernels import KERNELS
from core.mesh import Mesh, require_mesh_of
from core.pgw import pgw_basis
from core.validation import positive_int

# Kernels defined through the mesh or by line intersections rather than `core.kernel`.
MESH_ONLY_KERNELS = ("pgw", "harmonic")
_MESH_ONLY_PARAMETERS = {"pgw": ("angles",), "harmonic": ()}


def mesh_basis_functions(
    curve: ClosedBSpline,
    mesh: Mesh,
    kernel: str = "harmonic-like",
    samples_per_segment: int = 100,
    progress: Callable[[float], None] | None = None,
    cache: bool = True,
    compiling: Callable[[float], None] | None = None,
    **params,
) -> np.ndarray:
    """Basis functions G_i at every vertex of `mesh`.

    Parameters
    ----------
    curve : ClosedBSpline
        The source cage, n control points.
    mesh : Mesh
        A mesh of the domain made for this curve (`core.triangulate(curve)`).
    kernel : str
        One of `core.KERNELS`, ``"pgw"`` or ``"harmonic"``.
    samples_per_segment : int
        N / n boundary samples per span for the point kernels; for ``"pgw"`` it
        sets the default number of line directions (see `core.pgw_basis`);
        ``"harmonic"`` ignores it.
    progress : callable, optional
        Called with the fraction done in [0, 1].
    cache : bool
        Read and write the result in the disk cache (`core.cache`).
    compiling : callable, optional
        Called with the fraction compiled in [0, 1] when a point kernel needs the
        solver compiled first (the first run only, see `core.compile_solver`);
        not called when G comes from the cache or the compiled solver is cached.
    **params
        Kernel parameters: those of `core.basis_functions` for the point kernels,
        ``angles`` for ``"pgw"``, none for ``"harmonic"``.

    Returns
    -------
    ndarray of shape (V, n)
        Row v holds G_1..G_n at ``mesh.vertices[v]``; rows ``mesh.boundary`` are
        exactly ``curve.basis_matrix(mesh.boundary_parameters)``.

    Raises
    ------
    ValueError
        An unknown kernel or parameter, a mesh of another curve, or invalid
        arguments.
    """
    require_mesh_of(curve, mesh)
    valid = tuple(dict.fromkeys(tuple(KERNELS) + MESH_ONLY_KERNELS))
    if not isinstance(kernel, str) or kernel not in valid:
        raise ValueError(f"unknown kernel {kernel!r}; choose one of: {', '.join(valid)}")
    per = positive_int(samples_per_segment, "samples_per_segment", minimum=2)
    if kernel in MESH_ONLY_KERNELS:
        unknown = sorted(set(params) - set(_MESH_ONLY_PARAMETERS[kernel]))
        if unknown:
            allowed = ", ".join(_MESH_ONLY_PARAMETERS[kernel]) or "none"
            raise ValueError(
                f"kernel {kernel!r} does not take parameter(s) {', '.join(unknown)} (it takes: {allowed})"
            )
    for name, callback in (("progress", progress), ("compiling", compiling)):
        if callback is not None and not callable(callback):
            raise ValueError(f"{name} must be a callable taking a fraction, got {callback!r}")
    shape = (mesh.vertices.shape[0], curve.n)
    key = None
    if cache:
        key = disk_cache.cache_key(
            curve.control_points,
            mesh.vertices,
            mesh.triangles,
            mesh.boundary,
            mesh.boundary_parameters,
            kernel,
            per,
            params,
        )
        cached = disk_cache.load(key, shape)
        if cached is not None:
            if progress is not None:
                progress(1.0)
            return cached
    if kernel not in MESH_ONLY_KERNELS:
        compile_solver(compiling)
    values = _compute(curve, mesh, kernel, per, progress, params)
    if key is not None:
        disk_cache.store(key, values)
    return values


def _compute(curve, mesh, kernel, samples_per_segment, progress, params) -> np.ndarray:
    if kernel == "harmonic":
        if progress is not None:
            progress(0.0)
        values = harmonic_basis(curve, mesh)
        if progress is not None:
            progress(1.0)
        return values
    values = np.zeros((mesh.vertices.shape[0], curve.n))
    values[mesh.boundary] = curve.basis_matrix(mesh.boundary_parameters)
    interior = mesh.interior
    if interior.size == 0:
        if progress is not None:
            progress(1.0)
        return values
    points = mesh.vertices[interior]
    if kernel == "pgw":
        values[interior] = pgw_basis(
            curve,
            points,
            samples_per_segment=samples_per_segment,
            angles=params.get("angles"),
            progress=progress,
        )
    else:
        from core.basis import basis_functions

        values[interior] = basis_functions(
            curve,
            points,
            kernel=kernel,
            samples_per_segment=samples_per_segment,
            progress=progress,
            **params,
        )
    return values
