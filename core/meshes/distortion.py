"""How a piecewise linear deformation of a triangle mesh distorts it: per-triangle singular
values, conformal distortion, folded area and vertices that leave the target domain.

A deformation x -> x' of the mesh (Sec. 4.3: x' = G P' at the vertices, linear on each
triangle) has a constant Jacobian J on every triangle.  Its singular values
sigma_1 >= |sigma_2| describe how the triangle is stretched; sigma_2 is taken with
the sign of det J, so sigma_2 <= 0 exactly where the triangle is folded over or
collapsed.  The conformal distortion sigma_1 / sigma_2 is 1 for a similarity and
grows with the anisotropy of the stretch.  These are the measures of the quality
study (`app.studies.quality`), which compares kernels by how well the deformations they give
keep the mapping injective and inside the target curve (the paper's Fig. 11).

The transfinite deformation itself, x -> sum_i P'_i G_i(x), has the Jacobian
J(x) = sum_i P'_i (grad G_i(x))^T (`vertex_jacobians`, from `core.basis_gradients`),
exact at any point, not per triangle; `worst_distortion` summarises J over points.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from core.validation import as_points, positive_float

#: Conformal distortion given to folded and collapsed triangles, and the largest one reported.
DISTORTION_CAP = 10.0
#: A triangle whose area shrinks to this fraction or less (det J) counts as collapsed, like
#: `core.folded_triangles`.
COLLAPSE = 1e-9


def triangle_jacobians(vertices, deformed, triangles) -> np.ndarray:
    """Jacobian of the linear map of each triangle, ndarray of shape (T, 2, 2).

    Parameters
    ----------
    vertices : array_like of shape (V, 2)
        Undeformed positions; triangles must not be degenerate there.
    deformed : array_like of shape (V, 2)
        Deformed positions of the same vertices.
    triangles : array_like of shape (T, 3)
        Vertex indices.

    Returns
    -------
    ndarray of shape (T, 2, 2)
        J with ``J @ (v_b - v_a) == v'_b - v'_a`` for every edge of the triangle.
    """
    vertices = as_points(vertices, "vertices", min_count=3)
    deformed = as_points(deformed, "deformed")
    if deformed.shape != vertices.shape:
        raise ValueError(f"deformed must have shape {vertices.shape} like vertices, got {deformed.shape}")
    triangles = np.asarray(triangles, dtype=np.int64)
    if triangles.ndim != 2 or triangles.shape[1] != 3:
        raise ValueError(f"triangles must have shape (T, 3), got {triangles.shape}")
    source = _edge_matrices(vertices, triangles)
    target = _edge_matrices(deformed, triangles)
    determinant = np.linalg.det(source)
    if not (np.abs(determinant) > 0).all():
        raise ValueError(f"{int((determinant == 0).sum())} triangles are degenerate in vertices")
    return target @ np.linalg.inv(source)


def signed_singular_values(jacobians) -> np.ndarray:
    """sigma_1 >= |sigma_2| of each 2 x 2 matrix, with sigma_2 signed like the determinant.

    Parameters
    ----------
    jacobians : array_like of shape (T, 2, 2)

    Returns
    -------
    ndarray of shape (T, 2)
        Column 0 is sigma_1 >= 0, column 1 is sigma_2 with ``sigma_1 * sigma_2 == det J``.
        Writing J = [[a, b], [c, d]] as a conformal part of size q =
        |((a + d) / 2, (c - b) / 2)| plus an anti-conformal part of size
        r = |((a - d) / 2, (c + b) / 2)|, sigma_1 = q + r and sigma_2 = q - r.
    """
    j = np.asarray(jacobians, dtype=np.float64)
    a, b, c, d = j[:, 0, 0], j[:, 0, 1], j[:, 1, 0], j[:, 1, 1]
    conformal = np.hypot(0.5 * (a + d), 0.5 * (c - b))
    anticonformal = np.hypot(0.5 * (a - d), 0.5 * (c + b))
    return np.stack([conformal + anticonformal, conformal - anticonformal], axis=1)


def conformal_distortion(singular_values, cap: float = DISTORTION_CAP) -> np.ndarray:
    """sigma_1 / sigma_2 per triangle, ndarray of shape (T,), at most `cap`.

    Parameters
    ----------
    singular_values : array_like of shape (T, 2)
        From `signed_singular_values`.
    cap : float
        The value of folded or collapsed triangles (sigma_2 <= 0) and the largest
        value returned, so that a few folds do not make every average infinite.
    """
    cap = positive_float(cap, "cap")
    sigma = np.asarray(singular_values, dtype=np.float64)
    largest, smallest = sigma[:, 0], sigma[:, 1]
    ratio = np.full(largest.shape, cap)
    good = smallest > largest / cap
    ratio[good] = largest[good] / smallest[good]
    return ratio


def weighted_quantile(values, weights, quantile: float) -> float:
    """The smallest value v with at least `quantile` of the total weight at or below v.

    Parameters
    ----------
    values, weights : array_like of shape (T,)
        Weights >= 0 with a positive sum (triangle areas).
    quantile : float
        In [0, 1].
    """
    values = np.asarray(values, dtype=np.float64)
    weights = np.asarray(weights, dtype=np.float64)
    if not 0.0 <= quantile <= 1.0:
        raise ValueError(f"quantile must be in [0, 1], got {quantile!r}")
    order = np.argsort(values, kind="stable")
    cumulative = np.cumsum(weights[order])
    index = int(np.searchsorted(cumulative, quantile * cumulative[-1], side="left"))
    return float(values[order][min(index, values.size - 1)])


def folded_area_fraction(source_areas, singular_values) -> float:
    """Share of the source area whose triangles fold over or collapse (det J <= `COLLAPSE`), in [0, 1].

    Parameters
    ----------
    source_areas : array_like of shape (T,)
        Undeformed triangle areas (> 0).
    singular_values : array_like of shape (T, 2)
        From `signed_singular_values`.
    """
    areas = np.asarray(source_areas, dtype=np.float64)
    sigma = np.asarray(singular_values, dtype=np.float64)
    folded = sigma[:, 0] * sigma[:, 1] <= COLLAPSE
    return float(areas[folded].sum() / areas.sum())


def vertex_jacobians(gradients, target) -> np.ndarray:
    """J = sum_i P'_i (grad G_i)^T at each point, ndarray of shape (M, 2, 2).

    Parameters
    ----------
    gradients : array_like of shape (M, n, 2)
        grad G_i at M points (`core.basis_gradients`, `core.mesh_basis_functions`
        with gradients=True); complex for the Cauchy–Green coordinates, whose
        target points act as complex numbers (`core.deform`).
    target : array_like of shape (n, 2)
        The deformed control points P'_i.

    Returns
    -------
    ndarray of shape (M, 2, 2)
        ``J[m, d, e]`` = d x'_d / d x_e at point m; rows of NaN gradients give NaN.
    """
    gradients = np.asarray(gradients)
    if not np.iscomplexobj(gradients):
        gradients = gradients.astype(np.float64, copy=False)
    target = as_points(target, "target")
    if gradients.ndim != 3 or gradients.shape[1:] != (target.shape[0], 2):
        raise ValueError(
            f"gradients must have shape (M, {target.shape[0]}, 2) for {target.shape[0]} target points, "
            f"got {gradients.shape}"
        )
    if np.iscomplexobj(gradients):
        columns = np.einsum("mie,i->me", gradients, target[:, 0] + 1j * target[:, 1])
        return np.stack([columns.real, columns.imag], axis=1)
    return np.einsum("id,mie->mde", target, gradients)


@dataclass(frozen=True)
class WorstDistortion:
    """The extremes of a set of Jacobians J (`worst_distortion`).

    Attributes
    ----------
    smallest_determinant : float
        min det J (area change; <= 0 where the map folds over or collapses).
    smallest_at : ndarray of shape (2,)
        Where it is.
    largest_distortion : float
        max sigma_1 / sigma_2 over the points with det J > 0 (inf if there are none).
    largest_at : ndarray of shape (2,)
        Where it is (NaN if there are none).
    folded : int
        Points with det J <= 0.
    count : int
        Points with a finite J (NaN rows, e.g. boundary vertices, are left out).
    """

    smallest_determinant: float
    smallest_at: np.ndarray
    largest_distortion: float
    largest_at: np.ndarray
    folded: int
    count: int


def worst_distortion(jacobians, locations) -> WorstDistortion:
    """min det J, max sigma_1 / sigma_2 and the folded count of Jacobians at `locations`.

    Parameters
    ----------
    jacobians : array_like of shape (M, 2, 2)
        Rows with NaN are left out.
    locations : array_like of shape (M, 2)
        Where each J holds (reported with the extremes).
    """
    j = np.asarray(jacobians, dtype=np.float64)
    where = np.asarray(locations, dtype=np.float64)
    if j.ndim != 3 or j.shape[1:] != (2, 2) or where.shape != (j.shape[0], 2):
        raise ValueError(
            f"jacobians (M, 2, 2) and locations (M, 2) must match, got {j.shape} and {where.shape}"
        )
    finite = np.isfinite(j).all(axis=(1, 2))
    j, where = j[finite], where[finite]
    if j.shape[0] == 0:
        raise ValueError("no finite Jacobian to report on")
    sigma = signed_singular_values(j)
    determinant = sigma[:, 0] * sigma[:, 1]
    smallest = int(np.argmin(determinant))
    unfolded = np.flatnonzero(determinant > 0)
    if unfolded.size:
        ratio = sigma[unfolded, 0] / sigma[unfolded, 1]
        largest = int(unfolded[np.argmax(ratio)])
        distortion, largest_at = float(ratio.max()), where[largest].copy()
    else:
        distortion, largest_at = float("inf"), np.full(2, np.nan)
    return WorstDistortion(
        float(determinant[smallest]),
        where[smallest].copy(),
        distortion,
        largest_at,
        int((determinant <= 0).sum()),
        int(j.shape[0]),
    )


def _edge_matrices(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Columns v_b - v_a and v_c - v_a of each triangle, shape (T, 2, 2)."""
    a, b, c = (points[triangles[:, k]] for k in range(3))
    return np.stack([b - a, c - a], axis=2)
