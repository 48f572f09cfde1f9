"""Unfolding a mesh's images: `unfold_triangles` moves a few free vertices so that no triangle turns over.

A map proven to be a bijection (`core.fold_free_deform`) still has a piecewise-linear interpolant
on a straight-edged mesh that may turn a triangle over: where the map compresses hard towards a
curved part of the target, the chord between two boundary vertices' images (both on the target
curve) cuts off the image of a triangle's third vertex, though that image lies inside the target;
and where a layer of triangles is squeezed against the target curve thinner than the curve's
sagitta over their width, whole rows of them turn over.  The exact images are correct; the straight
edges between them are not.

The repair (after Freitag & Plassmann's local untangling): in sweeps, each free vertex (not on the
boundary) of a turned-over triangle gets the position within the bounding box of its one-ring's
images that maximises the smallest Jacobian determinant t* of its triangles (a linear program in
three unknowns; determinants relative to the source triangles' areas).  In the first sweep a vertex
moves only as far as needed (the smallest max-norm move) to give all its triangles a determinant of
at least `MARGIN` t*; the share doubles each sweep, so that a tangle of several rows, where no
vertex alone can unfold its ring, is untangled by moving to the best positions.

What it guarantees: only free vertices of turned-over triangles move; each stays inside the
bounding box of its neighbours' images (so it moves by at most its ring's width); the moves are
returned, for the caller to report.  It does not guarantee success (a triangle with no free vertex
cannot be unfolded; a tangle may need more than `MAX_SWEEPS` sweeps) nor that a moved vertex stays
inside the target: check both (`core.folded_triangles`, the target's `contains`).
"""

from __future__ import annotations

import numpy as np

from core.meshes.mesh import FOLDED_AREA_SHARE, triangle_signed_areas

#: In the first sweep a moved vertex's triangles get a Jacobian determinant of at least this share
#: of the best that it can give them all; the share doubles with every sweep, up to 1.
MARGIN = 0.1
#: Sweeps over the vertices of turned-over triangles before giving up.
MAX_SWEEPS = 40
#: A triangle counts as turned over when its image's signed area is at most this share of its own
#: (as `core.folded_triangles`).
TOLERANCE = FOLDED_AREA_SHARE


def unfold_triangles(
    vertices: np.ndarray,
    images: np.ndarray,
    triangles: np.ndarray,
    free: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Images with free vertices of turned-over triangles moved so that no triangle turns over.

    Parameters
    ----------
    vertices : ndarray of shape (V, 2)
        The mesh's vertices, its triangles counter-clockwise.
    images : ndarray of shape (V, 2)
        Their images.
    triangles : ndarray of shape (T, 3), int
    free : ndarray of shape (V,), bool
        Vertices that may move (the interior ones).

    Returns
    -------
    images : ndarray of shape (V, 2)
        A copy, moved where needed; triangles with no free vertex, or in a tangle that the sweeps
        do not undo, may still be turned over (check with `core.folded_triangles`).
    moves : ndarray of shape (V,)
        How far each vertex moved (0 for most).
    """
    original, images = images, images.copy()
    source_areas = _doubled_areas(vertices, triangles)
    order = np.argsort(triangles.ravel(), kind="stable")
    starts = np.searchsorted(triangles.ravel()[order], np.arange(len(vertices) + 1))
    for sweep in range(MAX_SWEEPS):
        margin = min(1.0, MARGIN * 2.0**sweep)
        turned = _doubled_areas(images, triangles) <= TOLERANCE * source_areas
        queue = np.unique(triangles[turned][free[triangles[turned]]])
        if queue.size == 0:
            break
        for vertex in queue:
            around = order[starts[vertex] : starts[vertex + 1]] // 3
            position = _unfolded_position(vertex, images, triangles[around], source_areas[around], margin)
            if position is not None:
                images[vertex] = position
    return images, np.linalg.norm(images - original, axis=1)


def _doubled_areas(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Doubled signed areas (T,) (the determinants the programs below are written in)."""
    return 2.0 * triangle_signed_areas(points, triangles)


def _unfolded_position(vertex, images, around, source_areas, margin) -> np.ndarray | None:
    """The vertex's new image (2,): the closest (max-norm) at which each triangle of `around` (K, 3)
    has a determinant of at least `margin` times the best smallest one t*; the best position if t*
    is not positive or `margin` is 1; None if the programs fail."""
    from scipy.optimize import linprog  # here: at the top it cost every process importing core 0.05 CPU-s

    # Roll each triangle so that the vertex comes first: the doubled area of (x, a, b) is
    # a × b + x · (a_y - b_y, b_x - a_x), linear in the vertex's image x.
    first = np.argmax(around == vertex, axis=1)
    rows = np.arange(len(around))
    a, b = images[around[rows, (first + 1) % 3]], images[around[rows, (first + 2) % 3]]
    normals = np.stack([a[:, 1] - b[:, 1], b[:, 0] - a[:, 0]], axis=1) / source_areas[:, None]
    constants = (a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]) / source_areas
    ring = np.concatenate([a, b])
    low, high = ring.min(axis=0), ring.max(axis=0)
    bounds = [(low[0], high[0]), (low[1], high[1]), (None, None)]
    # Largest t with constants + normals · x >= t for all triangles.
    best = linprog(
        [0.0, 0.0, -1.0],
        A_ub=np.column_stack([-normals, np.ones(len(around))]),
        b_ub=constants,
        bounds=bounds,
        method="highs",
    )
    if best.status != 0:
        return None
    if best.x[2] <= 0.0 or margin >= 1.0:
        return best.x[:2]
    # Smallest s with |x - x0| <= s componentwise and constants + normals · x >= margin t*.
    start = images[vertex]
    closest = linprog(
        [0.0, 0.0, 1.0],
        A_ub=np.vstack(
            [
                np.column_stack([-normals, np.zeros(len(around))]),
                [[1.0, 0.0, -1.0], [-1.0, 0.0, -1.0], [0.0, 1.0, -1.0], [0.0, -1.0, -1.0]],
            ]
        ),
        b_ub=np.concatenate([constants - margin * best.x[2], [start[0], -start[0], start[1], -start[1]]]),
        bounds=[bounds[0], bounds[1], (0.0, None)],
        method="highs",
    )
    return closest.x[:2] if closest.status == 0 else best.x[:2]


__all__ = ["unfold_triangles"]
