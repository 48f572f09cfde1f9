"""The refinement's final mesh in one compiled pass: `assembled_triangles`, the lattice core's
triangles and the band's, on the vertices that some triangle uses (`core.meshes.refinement`).
"""

from __future__ import annotations

import numpy as np
from numba import njit


def assembled_triangles(
    points: np.ndarray, core_corners: np.ndarray, band_index: np.ndarray, band_triangles: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The used vertices and the triangles on them.

    Parameters
    ----------
    points : ndarray of shape (P, 2)
        All candidate vertices.
    core_corners : ndarray of shape (C, 3), int64
        Core triangles, as indices into `points`.
    band_index : ndarray of shape (Q,), int64
        Index into `points` of each point of the band's triangulation.
    band_triangles : ndarray of shape (T, 3), int64
        Band triangles, as indices into `band_index`.

    Returns
    -------
    vertices : ndarray of shape (V, 2)
        The points some triangle uses, in their order.
    triangles : ndarray of shape (C + T, 3), int64
        The core triangles then the band's, as indices into `vertices`.
    used : ndarray of shape (P,), bool
        Which points are vertices.
    """
    return _assembled(
        np.ascontiguousarray(points, dtype=np.float64),
        np.ascontiguousarray(core_corners, dtype=np.int64),
        np.ascontiguousarray(band_index, dtype=np.int64),
        np.ascontiguousarray(band_triangles, dtype=np.int64),
    )


@njit(cache=True)
def _assembled(points, core_corners, band_index, band_triangles):  # pragma: no cover - compiled
    """`assembled_triangles`."""
    triangles = np.empty((core_corners.shape[0] + band_triangles.shape[0], 3), dtype=np.int64)
    for t in range(core_corners.shape[0]):
        for k in range(3):
            triangles[t, k] = core_corners[t, k]
    for t in range(band_triangles.shape[0]):
        for k in range(3):
            triangles[core_corners.shape[0] + t, k] = band_index[band_triangles[t, k]]
    renumber = np.full(points.shape[0], -1, dtype=np.int64)
    for t in range(triangles.shape[0]):
        for k in range(3):
            renumber[triangles[t, k]] = 0
    used = 0
    for v in range(points.shape[0]):
        if renumber[v] == 0:
            renumber[v] = used
            used += 1
    vertices = np.empty((used, 2))
    for v in range(points.shape[0]):
        if renumber[v] >= 0:
            vertices[renumber[v], 0] = points[v, 0]
            vertices[renumber[v], 1] = points[v, 1]
    for t in range(triangles.shape[0]):
        for k in range(3):
            triangles[t, k] = renumber[triangles[t, k]]
    return vertices, triangles, renumber >= 0
