"""Moving a piecewise-linear field from one mesh of a domain to another mesh of it.

The deformation drawn from a mesh is the P1 interpolant of x' = G P' (Sec. 4.3):
inside each triangle, x' is the affine interpolant of its vertices' rows of G.
`interpolation_matrix` evaluates that interpolant at arbitrary points, and
`transfer_basis` gives a coarser mesh of the same curve the rows of G that draw,
at its vertices, exactly what the fine mesh draws there.  The viewer uses it for a
light preview mesh while a handle of a dense mesh is dragged.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse
from scipy.spatial import cKDTree

from core.curves.bspline import ClosedBSpline
from core.meshes.mesh import Mesh, require_mesh_of

#: Nearest triangles (by centroid) tried per point, in rounds, until one contains it.
CANDIDATE_ROUNDS = (8, 64, 512)
#: Smallest barycentric coordinate that still counts as inside a triangle (round-off).
INSIDE_TOLERANCE = -1e-12


def interpolation_matrix(mesh: Mesh, points) -> scipy.sparse.csr_matrix:
    """Barycentric weights of `points` in the triangles of `mesh`.

    Each row holds the three barycentric coordinates of a point in the triangle
    that contains it, so ``interpolation_matrix(mesh, points) @ f`` is the P1
    interpolant of the vertex values ``f`` at the points.  A point outside every
    triangle (between a boundary chord and the curve) gets the unclipped
    coordinates of the triangle it is most nearly inside: rows still sum to 1 and
    still reproduce linear functions exactly.

    Parameters
    ----------
    mesh : Mesh
        V vertices, T triangles.
    points : array_like of shape (M, 2)

    Returns
    -------
    scipy.sparse.csr_matrix of shape (M, V)
        Three entries a row (some may be 0), each row summing to 1.
    """
    points = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    corners = mesh.vertices[mesh.triangles]  # (T, 3, 2)
    tree = cKDTree(corners.mean(axis=1))
    chosen = np.zeros(len(points), dtype=np.int64)
    weights = np.full((len(points), 3), np.nan)
    best = np.full(len(points), -np.inf)
    pending = np.arange(len(points))
    for count in CANDIDATE_ROUNDS:
        count = min(count, len(corners))
        _, candidates = tree.query(points[pending], k=count)
        candidates = candidates.reshape(len(pending), count)
        coordinates = _barycentric(corners[candidates], points[pending, None, :])  # (P, k, 3)
        scores = coordinates.min(axis=2)
        pick = scores.argmax(axis=1)
        rows = np.arange(len(pending))
        better = scores[rows, pick] > best[pending]
        update = pending[better]
        chosen[update] = candidates[rows, pick][better]
        weights[update] = coordinates[rows, pick][better]
        best[update] = scores[rows, pick][better]
        pending = pending[best[pending] < INSIDE_TOLERANCE]
        if not len(pending) or count == len(corners):
            break
    columns = mesh.triangles[chosen]
    return scipy.sparse.csr_matrix(
        (weights.ravel(), columns.ravel(), np.arange(0, 3 * len(points) + 1, 3)),
        shape=(len(points), len(mesh.vertices)),
    )


def transfer_basis(curve: ClosedBSpline, mesh: Mesh, basis: np.ndarray, other: Mesh) -> np.ndarray:
    """Rows of G for the vertices of `other`, drawing there what `mesh` draws.

    Interior vertices of `other` get the P1 interpolant of ``basis`` (`interpolation_matrix`);
    its boundary vertices get the exact boundary values ``curve.basis_matrix(t)``,
    which is what every mesh's boundary rows are (the curve is reproduced exactly).
    Partition of unity and linear precision carry over from ``basis`` row by row.

    Parameters
    ----------
    curve : ClosedBSpline
        The curve both meshes belong to (n control points).
    mesh : Mesh
        The mesh `basis` belongs to, V vertices.
    basis : ndarray of shape (V, n)
    other : Mesh
        Another mesh of `curve`, V' vertices.

    Returns
    -------
    ndarray of shape (V', n), float64
    """
    require_mesh_of(curve, other)
    basis = np.asarray(basis, dtype=np.float64)
    if basis.shape != (len(mesh.vertices), curve.n):
        raise ValueError(f"basis must have shape ({len(mesh.vertices)}, {curve.n}), got {basis.shape}")
    result = np.empty((len(other.vertices), curve.n))
    interior = np.ones(len(other.vertices), dtype=bool)
    interior[other.boundary] = False
    result[interior] = interpolation_matrix(mesh, other.vertices[interior]) @ basis
    result[other.boundary] = curve.basis_matrix(other.boundary_parameters)
    return result


def _barycentric(triangles: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Barycentric coordinates, shape (..., 3), of points (..., 2) in triangles (..., 3, 2)."""
    a, b, c = triangles[..., 0, :], triangles[..., 1, :], triangles[..., 2, :]
    ab, ac, ap = b - a, c - a, points - a
    area = ab[..., 0] * ac[..., 1] - ab[..., 1] * ac[..., 0]
    second = (ap[..., 0] * ac[..., 1] - ap[..., 1] * ac[..., 0]) / area
    third = (ab[..., 0] * ap[..., 1] - ab[..., 1] * ap[..., 0]) / area
    return np.stack([1.0 - second - third, second, third], axis=-1)
