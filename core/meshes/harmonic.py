"""Finite-element harmonic basis functions on a domain mesh (the paper's Sec. 4.2 comparison).

The harmonic interpolant has the Poisson kernel (Sec. 1.1, Eq. 7 on a disk) and no
closed form on other domains.  Here it is approximated, as in Sec. 4.2, by the
piecewise linear finite-element solution over a triangulation: with the
cotangent stiffness matrix K (the linear FEM discretisation of the Laplacian),
the basis functions G (V x n) solve

    K_II G_I = -K_IB G_B,   G_B = N(t_B)  (the folded B-spline basis, Sec. 4.3)

for the interior vertices I, with the boundary vertices B at curve(t_B).  One
sparse LU factorisation of K_II serves all n right-hand sides.  Linear FEM
reproduces linear functions exactly, so rows sum to 1 and G @ P equals the
vertices up to rounding (both are harmonic with the same boundary values).
"""

from __future__ import annotations

import numpy as np
from scipy.sparse import csc_matrix, csr_matrix
from scipy.sparse.linalg import splu

from core.curves.bspline import ClosedBSpline
from core.meshes.mesh import Mesh, require_mesh_of


def harmonic_basis(curve: ClosedBSpline, mesh: Mesh) -> np.ndarray:
    """Harmonic basis functions G_i at the mesh vertices (linear finite elements).

    Parameters
    ----------
    curve : ClosedBSpline
        The source cage with n control points.
    mesh : Mesh
        A triangulation of the domain whose boundary vertices are
        ``curve(mesh.boundary_parameters)`` (as made by `core.triangulate`).

    Returns
    -------
    ndarray of shape (V, n)
        Row v holds G_1..G_n at vertex v: boundary rows are exactly
        ``curve.basis_matrix(mesh.boundary_parameters)``, rows sum to 1 and
        ``G @ curve.control_points == mesh.vertices`` up to rounding.

    Raises
    ------
    ValueError
        If `curve` or `mesh` has the wrong type or the mesh was not made for
        this curve.
    """
    require_mesh_of(curve, mesh)
    values = np.zeros((mesh.vertices.shape[0], curve.n))
    values[mesh.boundary] = curve.basis_matrix(mesh.boundary_parameters)
    interior = mesh.interior
    if interior.size == 0:
        return values
    stiffness = stiffness_matrix(mesh.vertices, mesh.triangles)
    rows = stiffness[interior]
    right_hand_side = -(rows[:, mesh.boundary] @ values[mesh.boundary])
    # K_II is symmetric positive definite; a symmetric fill-reducing ordering suits it.
    factor = splu(csc_matrix(rows[:, interior]), permc_spec="MMD_AT_PLUS_A")
    values[interior] = factor.solve(right_hand_side)
    return values


def stiffness_matrix(vertices: np.ndarray, triangles: np.ndarray) -> csr_matrix:
    """Linear finite-element stiffness matrix (the cotangent Laplacian), sparse (V, V).

    K_ij = -(cot alpha_ij + cot beta_ij) / 2 for an edge ij with opposite angles
    alpha_ij and beta_ij, and K_ii = -sum_j K_ij, so that K @ u = 0 for every
    linear u at vertices no boundary touches.

    Parameters
    ----------
    vertices : ndarray of shape (V, 2)
    triangles : ndarray of shape (T, 3)
        Vertex indices (either orientation).
    """
    corners = vertices[triangles]  # (T, 3, 2)
    rows, columns, entries = [], [], []
    for k in range(3):
        i, j = (k + 1) % 3, (k + 2) % 3
        u = corners[:, i] - corners[:, k]
        v = corners[:, j] - corners[:, k]
        # cot of the angle at corner k, which faces the edge (i, j)
        cotangent = np.einsum("td,td->t", u, v) / np.abs(u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0])
        half = 0.5 * cotangent
        a, b = triangles[:, i], triangles[:, j]
        rows += [a, b, a, b]
        columns += [b, a, a, b]
        entries += [-half, -half, half, half]
    count = vertices.shape[0]
    return csr_matrix(
        (np.concatenate(entries), (np.concatenate(rows), np.concatenate(columns))), shape=(count, count)
    )
