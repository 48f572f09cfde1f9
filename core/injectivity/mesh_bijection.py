"""A proof that a mesh's piecewise-linear map is a bijection: `prove_mesh_bijection`, and
`mesh_bijection`, which also counts as turned over a triangle whose area is a negligible share of
its own (as `core.folded_triangles` does, so that a fold-free map's proof and its fold count agree
at every scale of the target).

What the viewer draws is the mesh's piecewise-linear (PL) map: each triangle of a triangulated
disk mapped affinely onto the triangle of its vertices' images.  If every image triangle is
positively oriented (counter-clockwise, as the source triangles) and the images of the boundary
vertices, in order, form a simple polygon, the PL map is a bijection of the mesh onto the closed
region that polygon bounds: the map is a local homeomorphism inside (each interior vertex's
positive triangles wind once around it), its degree over any point not on the polygon is the
polygon's winding number there (1 inside, 0 outside: the polygon is simple and, the signed areas
adding up to its area, counter-clockwise), and a local homeomorphism of degree 1 takes each point
once.  Both tests are exact:

- orientation: the sign of each determinant (b - a) × (c - a) is decided by Shewchuk's filter
  (the float determinant is right in sign when its size exceeds (3 + 16 ε) ε times the sum of
  its two products' sizes, ε = 2⁻⁵³; "Adaptive precision floating-point arithmetic and fast robust
  geometric predicates", 1997); the few determinants it cannot decide are computed in rationals;
- simplicity: the polygon's edges are binned into a uniform grid of about B cells; only edges in
  a common cell are tested (exact segment predicates, touching counts as crossing), so that the
  test costs O(B) for a polygon whose edges are of about the same length, not O(B²).

At the default mesh (6,332 vertices, 12,155 triangles, 507 boundary vertices) it takes about a
millisecond.  It assumes that the triangles form a disk whose boundary loop is `boundary`
(what `core.triangulate` makes); it proves nothing about the continuous map between vertices.
(Lipman, "Bijective mappings of meshes with boundary and the degree in mesh processing", 2014,
has the degree argument.)
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction

import numpy as np

from core.meshes.mesh import folded_limits, triangle_signed_areas

#: Shewchuk's bound on the relative error of the float determinant: (3 + 16 ε) ε, ε = 2⁻⁵³.
ORIENTATION_ERROR = (3.0 + 16.0 * 2.0**-53) * 2.0**-53


@dataclass(frozen=True)
class MeshBijection:
    """The answer of `prove_mesh_bijection`.

    Attributes
    ----------
    proven : bool
        Every triangle positive and the boundary polygon simple: the PL map is a bijection.
    turned_over : int
        Triangles whose image is turned over or degenerate (determinant ≤ 0, exactly).
    boundary_simple : bool
        Whether the boundary vertices' images form a simple polygon.
    """

    proven: bool
    turned_over: int
    boundary_simple: bool

    def reason(self) -> str:
        """One clause: why the map is not proven a bijection (empty when it is)."""
        if self.turned_over:
            return f"{self.turned_over} triangles turned over or collapsed"
        if not self.boundary_simple:
            return "the image's boundary polygon crosses itself"
        return ""


def prove_mesh_bijection(images: np.ndarray, triangles: np.ndarray, boundary: np.ndarray) -> MeshBijection:
    """Whether the PL map of a triangulated disk onto `images` is proven a bijection.

    Parameters
    ----------
    images : ndarray of shape (V, 2)
        The vertices' images, float64.
    triangles : ndarray of shape (T, 3), int
        Counter-clockwise in the source.
    boundary : ndarray of shape (B,), int
        The boundary loop's vertices in order (counter-clockwise in the source).

    Returns
    -------
    MeshBijection
    """
    images = np.asarray(images, dtype=np.float64)
    positive = orientation_signs(images, triangles) > 0
    turned_over = int(len(positive) - np.count_nonzero(positive))
    simple = polygon_is_simple(images[np.asarray(boundary)])
    return MeshBijection(turned_over == 0 and simple, turned_over, simple)


def mesh_bijection(
    vertices: np.ndarray, images: np.ndarray, triangles: np.ndarray, boundary: np.ndarray
) -> MeshBijection:
    """`prove_mesh_bijection`, with a triangle counted as turned over also where its signed area is
    at most `core.meshes.mesh.folded_limits` of the source's (a negligible share of its own, scaled
    by the ratio of the images' total area to the mesh's): what `fold_free_deform` proves.

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
    images = np.asarray(images, dtype=np.float64)
    areas = triangle_signed_areas(images, triangles)
    kept = (areas > folded_limits(triangle_signed_areas(vertices, triangles), areas)) & (
        orientation_signs(images, triangles) > 0
    )
    turned_over = int(len(kept) - np.count_nonzero(kept))
    simple = polygon_is_simple(images[np.asarray(boundary)])
    return MeshBijection(turned_over == 0 and simple, turned_over, simple)


def orientation_signs(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """The exact sign of each triangle's doubled area, ndarray of shape (T,) of -1, 0 or 1.

    Parameters
    ----------
    points : ndarray of shape (V, 2), float64
    triangles : ndarray of shape (T, 3), int
    """
    triangles = np.asarray(triangles)
    return _orientations(points[triangles[:, 0]], points[triangles[:, 1]], points[triangles[:, 2]])


def _orientations(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Exact signs (K,) of (a - c) × (b - c) for point arrays (K, 2) (Shewchuk's orient2d: the same
    sign as (b - a) × (c - a)), the float determinant where the filter certifies it."""
    left = (a[:, 0] - c[:, 0]) * (b[:, 1] - c[:, 1])
    right = (a[:, 1] - c[:, 1]) * (b[:, 0] - c[:, 0])
    determinant = left - right
    signs = np.sign(determinant).astype(np.int8)
    unsure = np.flatnonzero(np.abs(determinant) <= ORIENTATION_ERROR * (np.abs(left) + np.abs(right)))
    for k in unsure:
        signs[k] = _exact_orientation(a[k], b[k], c[k])
    return signs


def _exact_orientation(a, b, c) -> int:
    """The sign of (a - c) × (b - c) in rationals (every float is one)."""
    ax, ay, bx, by, cx, cy = (Fraction(float(v)) for v in (a[0], a[1], b[0], b[1], c[0], c[1]))
    determinant = (ax - cx) * (by - cy) - (ay - cy) * (bx - cx)
    return (determinant > 0) - (determinant < 0)


def polygon_is_simple(polygon: np.ndarray) -> bool:
    """Whether a closed polygon has no two edges that meet except consecutive ones at their vertex.

    Exact: two edges that touch or overlap count as meeting; a repeated vertex makes the polygon
    not simple.

    Parameters
    ----------
    polygon : ndarray of shape (B, 2)
        Its vertices in order; the last joins the first.
    """
    polygon = np.asarray(polygon, dtype=np.float64)
    count = len(polygon)
    if count < 3 or not np.isfinite(polygon).all():
        return False
    following = np.roll(polygon, -1, axis=0)
    if np.any(np.all(polygon == following, axis=1)):
        return False
    first, second = _candidate_pairs(polygon, following)
    adjacent = (second - first == 1) | (second - first == count - 1)
    if _adjacent_overlap(polygon, first[adjacent], second[adjacent]):
        return False
    first, second = first[~adjacent], second[~adjacent]
    return not np.any(_segments_meet(polygon[first], following[first], polygon[second], following[second]))


def _candidate_pairs(starts: np.ndarray, ends: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pairs of edges (first < second, each (P,)) whose bounding boxes share a cell of a uniform grid
    of about B cells and overlap: every pair of edges that could meet."""
    count = len(starts)
    low, high = np.minimum(starts, ends), np.maximum(starts, ends)
    origin, extent = low.min(axis=0), high.max(axis=0) - low.min(axis=0)
    cells = max(1, int(np.sqrt(count)))
    size = np.maximum(extent / cells, np.finfo(np.float64).tiny)
    first_cell = np.clip(((low - origin) / size).astype(np.int64), 0, cells - 1)
    last_cell = np.clip(((high - origin) / size).astype(np.int64), 0, cells - 1)
    spans = last_cell - first_cell + 1
    per_edge = spans[:, 0] * spans[:, 1]
    edge = np.repeat(np.arange(count), per_edge)
    offset = np.arange(len(edge)) - np.repeat(np.cumsum(per_edge) - per_edge, per_edge)
    column = first_cell[edge, 0] + offset % spans[edge, 0]
    row = first_cell[edge, 1] + offset // spans[edge, 0]
    cell = row * cells + column
    order = np.lexsort((edge, cell))
    cell, edge = cell[order], edge[order]
    firsts, seconds, cells_found = [], [], []
    for gap in range(1, len(cell)):
        same = cell[gap:] == cell[:-gap]
        if not same.any():
            break
        firsts.append(edge[:-gap][same])
        seconds.append(edge[gap:][same])
        cells_found.append(cell[gap:][same])
    if not firsts:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    first, second, found = np.concatenate(firsts), np.concatenate(seconds), np.concatenate(cells_found)
    overlap = np.all((low[first] <= high[second]) & (low[second] <= high[first]), axis=1)
    # A pair of overlapping boxes shares every cell of their intersection: keep it in one, the cell of
    # the intersection's lowest corner (no sort to drop the repeats).
    corner = np.clip(((np.maximum(low[first], low[second]) - origin) / size).astype(np.int64), 0, cells - 1)
    once = overlap & (found == corner[:, 1] * cells + corner[:, 0])
    return first[once], second[once]


def _adjacent_overlap(polygon: np.ndarray, first: np.ndarray, second: np.ndarray) -> bool:
    """Whether some pair of consecutive edges (first, second indices (K,)) folds back over itself:
    the three vertices collinear and the far end of one on the other edge."""
    count = len(polygon)
    # Order each pair so that edge `before` ends where edge `after` starts.
    wrap = second - first == count - 1
    before, after = np.where(wrap, second, first), np.where(wrap, first, second)
    a, b, c = polygon[before], polygon[after], polygon[(after + 1) % count]
    collinear = _orientations(a, b, c) == 0
    return bool(np.any(collinear & (_on_box(a, b, c) | _on_box(c, b, a))))


def _on_box(p: np.ndarray, q: np.ndarray, r: np.ndarray) -> np.ndarray:
    """For points r collinear with segments pq: whether r lies on pq (within its bounding box)."""
    low, high = np.minimum(p, q), np.maximum(p, q)
    return np.all((low <= r) & (r <= high), axis=1)


def _segments_meet(p1: np.ndarray, p2: np.ndarray, p3: np.ndarray, p4: np.ndarray) -> np.ndarray:
    """Whether segments p1p2 and p3p4 (each (K, 2)) share a point, exactly."""
    o1, o2 = _orientations(p1, p2, p3), _orientations(p1, p2, p4)
    o3, o4 = _orientations(p3, p4, p1), _orientations(p3, p4, p2)
    crossing = (o1 * o2 < 0) & (o3 * o4 < 0)
    touching = (
        ((o1 == 0) & _on_box(p1, p2, p3))
        | ((o2 == 0) & _on_box(p1, p2, p4))
        | ((o3 == 0) & _on_box(p3, p4, p1))
        | ((o4 == 0) & _on_box(p3, p4, p2))
    )
    return crossing | touching


__all__ = [
    "MeshBijection",
    "mesh_bijection",
    "orientation_signs",
    "polygon_is_simple",
    "prove_mesh_bijection",
]
