"""What ``warp`` says of a deformation besides its pixels: the fold warning, and ``--report``'s worst
Jacobians (`core.meshes.distortion.worst_distortion`)."""

from __future__ import annotations

import numpy as np

from app.console import ProgressBar, note
from app.io.files import reported_as_input
from app.warp.pipeline import Deformation
from core import COMPILED_KERNELS, DEFAULT_KERNEL
from core import GRADIENT_COMPILE_MESSAGE as GRADIENT_COMPILING


def examined(job, deformation: Deformation, target_source: str, report: bool, proven=None) -> list[str]:
    """Examine the deformation of a ``warp`` job (`app.warp.job.WarpJob`) to its target before it is
    drawn: the fold warning (a note), and with `report` the lines of ``--report`` (returned); the
    certificate is `proven` (what the pins' solve proved of the plain map) where given."""
    target = job.targets[0]
    with reported_as_input(f"{job.source}: fold-free"):  # a fold-free path may cross itself
        deformed = deformation.positions(target)
    lines = []
    if report:
        settings = job.settings
        with reported_as_input(f"{job.source}: kernel {settings.kernel!r}: gradients"):
            lines += distortion_report(
                job.curve,
                deformation.mesh,
                settings.kernel,
                target,
                deformed,
                settings.params,
                settings.fold_free,
            )
        plain = not deformation.fold_free and deformation.kernel == DEFAULT_KERNEL
        certificate = proven if proven is not None and plain else deformation.certificate(target)
        lines.append(f"certificate: {'n/a (not a harmonic map)' if certificate is None else certificate}")
    warn_of_folds(deformation, deformed, target, target_source)
    return lines


def warn_of_folds(
    deformation: Deformation, deformed: np.ndarray, target: np.ndarray, target_source: str
) -> None:
    """Note how many triangles the deformed vertices (V, 2) fold over, if any, and why they may."""
    import core

    mesh = deformation.mesh
    folded = np.count_nonzero(core.folded_triangles(mesh, deformed))
    if folded:
        note(
            f"warning: the deformation folds over in {folded} of {len(mesh.triangles)} triangles "
            f"({why_folded(target, target_source)})"
        )


def why_folded(target: np.ndarray, target_source: str) -> str:
    """What to say of a target that folds the deformation: that it crosses itself, if it does."""
    import core

    try:
        core.ClosedBSpline(target)
    except ValueError as error:
        return f"{target_source}: {error}"
    return f"{target_source} may need a gentler move"


def distortion_report(
    curve, mesh, kernel: str, target: np.ndarray, deformed: np.ndarray, params: dict, fold_free: bool = False
) -> list[str]:
    """The lines of ``warp --report``: worst det J, worst sigma1/sigma2, folded count, with where.

    Parameters
    ----------
    curve : core.ClosedBSpline
        The source cage.
    mesh : core.Mesh
    kernel : str
    target : ndarray of shape (n, 2)
    deformed : ndarray of shape (V, 2)
        The mesh vertices deformed to `target`.
    params : dict
        The kernel's parameters.
    fold_free : bool
        `deformed` is a composite of maps (`core.fold_free_deform`): no pointwise gradients.
    """
    import core
    from core import triangle_jacobians, vertex_jacobians, worst_distortion

    if (
        kernel in core.MESH_ONLY_KERNELS
        or params.get("parameterization", "natural") != "natural"
        or fold_free
    ):
        # No pointwise gradients (FEM, PGW; the arc-length parameterisation; a composite of maps): the
        # Jacobians of the piecewise linear map, exact for the FEM basis.
        jacobians = triangle_jacobians(mesh.vertices, deformed, mesh.triangles)
        where = mesh.vertices[mesh.triangles].mean(axis=1)
        points = "triangles (per-triangle Jacobian, at centroids)"
    else:
        if kernel in COMPILED_KERNELS:
            with ProgressBar(GRADIENT_COMPILING, announce=True) as compiling:
                core.compile_solver(compiling, gradients=True)
        _, gradients = core.mesh_basis_functions(curve, mesh, kernel=kernel, gradients=True, **params)
        jacobians = vertex_jacobians(gradients[mesh.interior], target)
        where = mesh.vertices[mesh.interior]
        points = "interior vertices (exact Jacobian)"
    worst = worst_distortion(jacobians, where)

    def at(point) -> str:
        return (
            f"at ({point[0]:.1f}, {point[1]:.1f}) px" if np.isfinite(point).all() else "(no unfolded point)"
        )

    return [
        f"min det J: {worst.smallest_determinant:.6g} {at(worst.smallest_at)}",
        f"max sigma1/sigma2: {worst.largest_distortion:.6g} {at(worst.largest_at)}",
        f"det J <= 0: {worst.folded} of {worst.count} {points}",
    ]
