"""The viewer's distortion view: how much the deformation stretches, shears or folds, per vertex.

The deformation x' = sum_i G_i(x) P'_i has the Jacobian J(x) = sum_i P'_i (grad G_i(x))^T
(`core.meshes.distortion.vertex_jacobians`).  With the gradients of a point kernel
(`core.mesh_basis_functions(gradients=True)`), J is exact at every interior
vertex, and so is the fold test det J <= 0: the vertex-exact fold overlay.
Without them (the FEM ``harmonic`` kernel is piecewise linear, ``pgw`` has no
gradients, or they are still being computed), and on the boundary where point
gradients are not defined, a vertex gets the area-weighted mean of the exact
Jacobians of its triangles, and is folded if one of its triangles is.

Two measures, drawn by ``shaders/distortion.frag.glsl``:

- ``area``: log2 det J, the area change (0: kept, 1: doubled, -1: halved);
- ``conformal``: log2 (sigma_1 / sigma_2), the anisotropy of the stretch (0: angles kept).

Folded vertices get `FOLDED`, a value far below both ranges, which the shader
paints in a colour of its own.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from app.viewer.state import MEASURES
from core import deform, signed_singular_values, triangle_jacobians, vertex_jacobians

#: The per-vertex value of a folded vertex (the shader paints values below -50 as folds).
FOLDED = -100.0
#: Values drawn are clipped to [-CLIP, CLIP] (log2 units), so folds stay apart from them.
CLIP = 8.0


@dataclass(frozen=True)
class DistortionSummary:
    """What the status line and tests read of the distortion view.

    Attributes
    ----------
    min_det, max_ratio : float
        Smallest det J and largest sigma_1 / sigma_2 (over unfolded vertices).
    min_det_at, max_ratio_at : tuple of float
        Where they are, source image pixels.
    folded : int
        Vertices with det J <= 0.
    exact : int
        Vertices whose J came from the gradients (the others from their triangles).
    vertices : int
    """

    min_det: float
    min_det_at: tuple[float, float]
    max_ratio: float
    max_ratio_at: tuple[float, float]
    folded: int
    exact: int
    vertices: int


def vertex_distortion(
    vertices: np.ndarray,
    triangles: np.ndarray,
    basis: np.ndarray,
    gradients: np.ndarray | None,
    target: np.ndarray,
    measure: str,
) -> tuple[np.ndarray, DistortionSummary]:
    """The field drawn by the distortion view and its summary.

    Parameters
    ----------
    vertices : ndarray of shape (V, 2)
        Undeformed mesh vertices, image pixels.
    triangles : ndarray of shape (T, 3)
    basis : ndarray of shape (V, n)
        G at the vertices.
    gradients : ndarray of shape (V, n, 2) or None
        grad G at the vertices (NaN rows on the boundary), if known.
    target : ndarray of shape (n, 2)
        Deformed control points.
    measure : {"area", "conformal"}

    Returns
    -------
    values : ndarray of shape (V,), float32
        log2 det J or log2 (sigma_1 / sigma_2), clipped to [-CLIP, CLIP]; `FOLDED` where det J <= 0.
    summary : DistortionSummary
    """
    if measure not in MEASURES:
        raise ValueError(f"measure must be one of {MEASURES}, got {measure!r}")
    target = np.asarray(target, dtype=np.float64)
    count = vertices.shape[0]
    per_triangle = triangle_jacobians(vertices, deform(basis, target), triangles)
    edges = vertices[triangles[:, 1:]] - vertices[triangles[:, :1]]
    areas = 0.5 * np.abs(edges[:, 0, 0] * edges[:, 1, 1] - edges[:, 0, 1] * edges[:, 1, 0])
    corners = triangles.ravel()
    weight = np.bincount(corners, np.repeat(areas, 3), minlength=count)
    jacobians = np.empty((count, 2, 2))
    for d in range(2):
        for e in range(2):
            weighted = np.repeat(areas * per_triangle[:, d, e], 3)
            jacobians[:, d, e] = np.bincount(corners, weighted, minlength=count) / weight
    folded_triangle = np.linalg.det(per_triangle) <= 0.0
    folded = np.bincount(corners, np.repeat(folded_triangle, 3).astype(np.float64), minlength=count) > 0
    exact = np.zeros(count, dtype=bool)
    if gradients is not None:
        exact = np.isfinite(gradients).all(axis=(1, 2))
        jacobians[exact] = vertex_jacobians(gradients[exact], target)
    determinant = jacobians[:, 0, 0] * jacobians[:, 1, 1] - jacobians[:, 0, 1] * jacobians[:, 1, 0]
    folded[exact] = determinant[exact] <= 0.0
    sigma = signed_singular_values(jacobians)
    ratio = np.full(count, np.inf)
    good = ~folded & (sigma[:, 1] > 0)
    ratio[good] = sigma[good, 0] / sigma[good, 1]
    with np.errstate(divide="ignore", invalid="ignore"):
        shown = np.log2(determinant) if measure == "area" else np.log2(ratio)
    values = np.where(folded, FOLDED, np.clip(np.nan_to_num(shown, nan=CLIP), -CLIP, CLIP))
    lowest = int(np.argmin(determinant))
    highest = int(np.argmax(np.where(good, ratio, -np.inf))) if good.any() else lowest
    summary = DistortionSummary(
        min_det=float(determinant[lowest]),
        min_det_at=(float(vertices[lowest, 0]), float(vertices[lowest, 1])),
        max_ratio=float(ratio[highest]) if good.any() else float("inf"),
        max_ratio_at=(float(vertices[highest, 0]), float(vertices[highest, 1])),
        folded=int(folded.sum()),
        exact=int(exact.sum()),
        vertices=count,
    )
    return values.astype(np.float32), summary
