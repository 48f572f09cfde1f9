"""The largest empty disks tangent to a sampled curve, compiled: `empty_disk_radii`, the local
feature size of `core.meshes.sizing`.

The shrinking-ball iteration: a disk touching the curve at sample p on the side of the normal n
starts at the largest radius wanted; while it holds another sample q, it is replaced by the disk
tangent at p through q, of radius |q - p|^2 / (2 (q - p) . n), q the sample nearest its centre.
The samples are sorted into a grid of square cells (`core.meshes.point_grid`), so each disk is
checked against the samples of the cells it overlaps only.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from core.meshes.point_grid import grid_buckets, grid_layout

#: At most this many shrinking steps per disk.
MAX_STEPS = 100


def empty_disk_radii(
    points: np.ndarray, normals: np.ndarray, wedge: np.ndarray, largest: float
) -> np.ndarray:
    """Radius (at most `largest`) of the largest disk touching each sample on the side of its
    normal and empty of the other samples (those on its circle do not count).

    Parameters
    ----------
    points : ndarray of shape (S, 2)
        The samples.
    normals : ndarray of shape (S, 2)
        Unit normals, toward the side of the disks.
    wedge : ndarray of shape (S,), int64
        Samples with the same index >= 0 (the two straight spans at a sharp corner) do not limit
        each other's disks.
    largest : float

    Returns
    -------
    ndarray of shape (S,)
    """
    points = np.ascontiguousarray(points, dtype=np.float64)
    low, cell, columns, rows = grid_layout(points, 0.5 * largest)  # cells of half the largest disk
    return _radii(
        points, np.ascontiguousarray(normals, dtype=np.float64), np.ascontiguousarray(wedge, dtype=np.int64),
        float(largest), low, cell, columns, rows,
    )  # fmt: skip


@njit(cache=True)
def _radii(points, normals, wedge, largest, low, cell, columns, rows):  # pragma: no cover - compiled
    """`empty_disk_radii`, the samples in a grid of `rows` x `columns` cells of side `cell` from `low`."""
    count = points.shape[0]
    start, members = grid_buckets(points, low, cell, columns, rows)
    radius = np.full(count, largest)
    for i in range(count):
        px, py, nx, ny = points[i, 0], points[i, 1], normals[i, 0], normals[i, 1]
        r = largest
        for _ in range(MAX_STEPS):
            cx, cy = px + r * nx, py + r * ny
            nearest, within = -1, r * (1.0 - 1e-9)
            first_column = max(int(np.floor((cx - r - low[0]) / cell)), 0)
            last_column = min(int(np.floor((cx + r - low[0]) / cell)), columns - 1)
            first_row = max(int(np.floor((cy - r - low[1]) / cell)), 0)
            last_row = min(int(np.floor((cy + r - low[1]) / cell)), rows - 1)
            for row in range(first_row, last_row + 1):
                for m in range(start[row * columns + first_column], start[row * columns + last_column + 1]):
                    q = members[m]
                    if q == i or (wedge[i] >= 0 and wedge[q] == wedge[i]):
                        continue
                    distance = math.sqrt((points[q, 0] - cx) ** 2 + (points[q, 1] - cy) ** 2)
                    if distance < within:
                        nearest, within = q, distance
            if nearest < 0:
                break
            ox, oy = points[nearest, 0] - px, points[nearest, 1] - py
            height = 2.0 * (ox * nx + oy * ny)
            shrunk = (ox * ox + oy * oy) / height if height > 0.0 else np.inf
            if shrunk >= r * (1.0 + 1e-12):
                break
            r = min(r, shrunk)
        radius[i] = r
    return radius
