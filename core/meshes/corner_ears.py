"""Opening the ears at sharp corners: `opened_corner_ears`, a step of `core.triangulate`.

An ear is a triangle made of a sharp corner's boundary vertex P and its two neighbours a, b on
the boundary.  Its edge ab crosses the domain's angle at P, so any map that keeps boundary vertices
on a target curve turns the ear over as soon as the corner there is reflex (an angle above π: the
three images are fixed and run clockwise).  A warp that opens a convex corner past a straight angle
(`core.fold_free_deform` does this along its path) would then always show a folded triangle.  So the
edge ab is flipped: the ear (P, a, b) and the triangle (b, a, y) across ab become (P, a, y) and
(P, y, b), giving P an interior neighbour y, where the quadrilateral P a y b is strictly convex.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from core.curves.bspline import ClosedBSpline
from core.meshes.mesh import Mesh, triangle_signed_areas

#: A flip is made only when both new triangles' areas exceed this share of the ear's.
MIN_SHARE = 0.05


def opened_corner_ears(curve: ClosedBSpline, mesh: Mesh) -> Mesh:
    """`mesh` (of `curve`'s domain) with the edge ab of every ear at a sharp corner flipped (module
    doc), where the two new triangles are counter-clockwise; the vertices are unchanged."""
    knots = curve.corners()[:, 0]
    if knots.size == 0:
        return mesh
    triangles = mesh.triangles.copy()
    count = mesh.boundary.size
    parameters = mesh.boundary_parameters
    for knot in knots:
        k = int(np.argmin(np.abs((parameters - knot + 0.5 * curve.n) % curve.n - 0.5 * curve.n)))
        corner, a, b = (mesh.boundary[(k + shift) % count] for shift in (0, 1, -1))
        _flip_ear(mesh.vertices, triangles, corner, a, b)
    return dataclasses.replace(mesh, triangles=triangles)


def _flip_ear(vertices: np.ndarray, triangles: np.ndarray, corner: int, a: int, b: int) -> None:
    """Flip the edge ab of the ear {corner, a, b} in `triangles` (T, 3), in place, if there is one."""
    ear = np.flatnonzero(np.all(np.isin(triangles, [corner, a, b]), axis=1))
    if ear.size != 1:
        return
    row = triangles[ear[0]]
    first = int(np.argmax(row == corner))
    _, a, b = np.roll(row, -first)  # counter-clockwise: corner, a, b
    across = np.flatnonzero(np.any(triangles == a, axis=1) & np.any(triangles == b, axis=1))
    across = across[across != ear[0]]
    if across.size != 1:
        return
    y = int(triangles[across[0]][~np.isin(triangles[across[0]], [a, b])][0])
    new = np.array([[corner, a, y], [corner, y, b]])
    ear_area = triangle_signed_areas(vertices, row[None])[0]
    if np.all(triangle_signed_areas(vertices, new) > MIN_SHARE * ear_area):
        triangles[ear[0]], triangles[across[0]] = new


__all__ = ["opened_corner_ears"]
