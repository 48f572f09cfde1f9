"""A proof that a mesh's piecewise-linear map is a bijection: `mesh_bijection`.

The map that is drawn is the piecewise-linear one: each triangle of a disc-like mesh mapped affinely
onto the triangle of its vertices' images.  If every image triangle keeps its orientation (signed
area positive) and the images of the boundary vertices, in order, form a simple polygon, the map is
a bijection of the mesh onto that polygon's inside: for a point y off the images of the edges, the
number of triangles whose image holds it is the map's degree at y, which is the winding number of
the boundary polygon around y, 1 inside and 0 outside (a degree argument; Lipman, "Bijective
mappings of meshes with boundary and the degree in mesh processing", 2014).  Both tests are exact
up to rounding and cost about O(T + B log B) for T triangles and B boundary vertices.

A triangle counts as kept when its signed area is above `FOLDED_AREA_SHARE` of its own, scaled by
the ratio of the images' total area to the mesh's (as `core.folded_triangles` counts folds), so that
the proof and the fold count agree, and do at every scale of the target.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from core.meshes.mesh import folded_limits, triangle_signed_areas


@dataclass(frozen=True)
class MeshBijection:
    """What `mesh_bijection` found.

    Attributes
    ----------
    proven : bool
        Every triangle kept and the boundary polygon simple: a bijection onto the polygon.
    folded : int
        Triangles turned over or collapsed.
    crossing : tuple of int or None
        Two boundary edges (by their first vertex's place in the boundary order) that meet, if any.
    """

    proven: bool
    folded: int
    crossing: tuple[int, int] | None

    def reason(self) -> str:
        """One clause: why the map is not proven a bijection (empty when it is)."""
        if self.folded:
            return f"{self.folded} triangles turned over or collapsed"
        if self.crossing is not None:
            return f"boundary edges {self.crossing[0]} and {self.crossing[1]} of the image meet"
        return ""


def mesh_bijection(
    vertices: np.ndarray, images: np.ndarray, triangles: np.ndarray, boundary: np.ndarray
) -> MeshBijection:
    """Whether the piecewise-linear map of the mesh onto `images` is a bijection onto its boundary polygon.

    Parameters
    ----------
    vertices : ndarray of shape (V, 2)
        The mesh, its triangles counter-clockwise, one boundary loop.
    images : ndarray of shape (V, 2)
    triangles : ndarray of shape (T, 3), int
    boundary : ndarray of shape (B,), int
        The boundary vertices in order along the loop (counter-clockwise).

    Returns
    -------
    MeshBijection
    """
    source = triangle_signed_areas(vertices, triangles)
    areas = triangle_signed_areas(images, triangles)
    folded = int(np.count_nonzero(areas <= folded_limits(source, areas)))
    if folded:
        return MeshBijection(False, folded, None)
    crossing = polygon_crossing(images[boundary])
    return MeshBijection(crossing is None, 0, crossing)


def polygon_crossing(points: np.ndarray) -> tuple[int, int] | None:
    """Two non-adjacent edges of the closed polygon (B, 2) that meet (touching counts), or None.

    Each edge is tested against the edges that share a cell of a uniform grid with its bounding
    box (cells twice the median edge long, so that an edge covers a few); a pair of adjacent edges
    meets only if they fold back onto each other (collinear and overlapping), which counts too.
    """
    count = len(points)
    following = np.roll(points, -1, axis=0)
    low, high = np.minimum(points, following), np.maximum(points, following)
    size = 2.0 * float(np.median(np.linalg.norm(following - points, axis=1)))
    if not size > 0.0:
        size = float(np.ptp(points, axis=0).max()) or 1.0
    first, last = np.floor((low - low.min(axis=0)) / size), np.floor((high - low.min(axis=0)) / size)
    first, last = first.astype(np.int64), last.astype(np.int64)
    spans = last - first + 1
    cells = spans[:, 0] * spans[:, 1]
    edge = np.repeat(np.arange(count), cells)
    offset = np.arange(edge.size) - np.repeat(np.cumsum(cells) - cells, cells)
    column = first[edge, 0] + offset % spans[edge, 0]
    row = first[edge, 1] + offset // spans[edge, 0]
    key = column * (int(last[:, 1].max()) + 1) + row
    order = np.lexsort((edge, key))
    key, edge = key[order], edge[order]
    pairs = []
    for gap in range(1, count):
        same = np.flatnonzero(key[gap:] == key[:-gap])
        if same.size == 0:
            break
        pairs.append(np.stack([edge[same], edge[same + gap]], axis=1))
    if not pairs:
        return None
    a, b = np.unique(np.sort(np.concatenate(pairs), axis=1), axis=0).T
    close = np.all(low[a] <= high[b], axis=1) & np.all(low[b] <= high[a], axis=1) & (a != b)
    a, b = a[close], b[close]
    adjacent = (b == (a + 1) % count) | (a == (b + 1) % count)
    meet = np.where(
        adjacent,
        _folded_back(points, following, a, b, count),
        _segments_meet(points[a], following[a], points[b], following[b]),
    )
    if meet.any():
        k = int(np.flatnonzero(meet)[0])
        return int(a[k]), int(b[k])
    return None


def _orientation(p: np.ndarray, q: np.ndarray, r: np.ndarray) -> np.ndarray:
    return (q[:, 0] - p[:, 0]) * (r[:, 1] - p[:, 1]) - (q[:, 1] - p[:, 1]) * (r[:, 0] - p[:, 0])


def _segments_meet(p1, p2, q1, q2) -> np.ndarray:
    """Whether segments p1p2 and q1q2 (each (K, 2)) share a point (touching and collinear overlap count)."""
    d1, d2 = _orientation(q1, q2, p1), _orientation(q1, q2, p2)
    d3, d4 = _orientation(p1, p2, q1), _orientation(p1, p2, q2)
    proper = (d1 * d2 < 0) & (d3 * d4 < 0)
    touching = (
        ((d1 == 0) & _within(q1, q2, p1))
        | ((d2 == 0) & _within(q1, q2, p2))
        | ((d3 == 0) & _within(p1, p2, q1))
        | ((d4 == 0) & _within(p1, p2, q2))
    )
    return proper | touching


def _within(p, q, r) -> np.ndarray:
    """Whether r (K, 2), collinear with p and q, lies in the box of segment pq."""
    return (
        (np.minimum(p[:, 0], q[:, 0]) <= r[:, 0])
        & (r[:, 0] <= np.maximum(p[:, 0], q[:, 0]))
        & (np.minimum(p[:, 1], q[:, 1]) <= r[:, 1])
        & (r[:, 1] <= np.maximum(p[:, 1], q[:, 1]))
    )


def _folded_back(points, following, a, b, count) -> np.ndarray:
    """Whether adjacent edges a and b (K,) fold back onto each other at their shared vertex."""
    first = np.where(b == (a + 1) % count, a, b)  # the edge that ends at the shared vertex
    start, shared, end = points[first], following[first], following[(first + 1) % count]
    incoming, outgoing = shared - start, end - shared
    collinear = _orientation(start, shared, end) == 0
    return collinear & (np.einsum("kd,kd->k", incoming, outgoing) < 0)


__all__ = ["MeshBijection", "mesh_bijection", "polygon_crossing"]
