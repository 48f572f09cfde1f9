"""Whether the fold pass could mark a triangle at given positions: on the CPU, to skip the pass.

The fold pass (``folds.geom.glsl``) is a geometry shader over every triangle, which a
software rasteriser runs on the CPU; where no triangle nears a fold it emits nothing.
"""

from __future__ import annotations

import numpy as np

#: A triangle is safely unfolded when its deformed area is more than this fraction of its
#: undeformed one: the fold pass's float32 areas are off by ~1e-5 of that at most.
FOLD_MARGIN = 1e-3


class FoldMargins:
    """What decides whether one mesh may fold: its triangles' corners, orientations and margins.

    Parameters
    ----------
    vertices : ndarray of shape (V, 2)
        Undeformed vertices, image pixels, in the rows of the position buffer.
    triangles : ndarray of shape (T, 3)
        Triangles as indices of those rows.
    """

    def __init__(self, vertices: np.ndarray, triangles: np.ndarray):
        source = _signed_areas(vertices, triangles)
        self._corners = tuple(np.ascontiguousarray(triangles[:, k], dtype=np.intp) for k in range(3))
        # Undeformed triangles may turn either way: a fold flips the sign, a collapse nears zero.
        self._orientation = np.sign(source).astype(np.float32)
        self._threshold = (2.0 * FOLD_MARGIN * np.abs(source)).astype(np.float32)

    def may_fold(self, positions: np.ndarray) -> bool:
        """False when every triangle keeps its orientation with a margin (`FOLD_MARGIN`) far beyond
        the pass's float32 rounding, so that the pass would emit nothing.

        Parameters
        ----------
        positions : ndarray of shape (V, 2), float32
            Deformed vertices, image pixels, in the rows of the position buffer.
        """
        a, b, c = self._corners
        x, y = np.ascontiguousarray(np.asarray(positions, dtype=np.float32).T)
        xa, ya = x.take(a), y.take(a)
        # Twice the deformed signed areas in float32, like the pass: both err far below FOLD_MARGIN.
        twice = (x.take(b) - xa) * (y.take(c) - ya) - (x.take(c) - xa) * (y.take(b) - ya)
        return not bool(np.all(twice * self._orientation > self._threshold))


def _signed_areas(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Signed areas (T,) float64 of `triangles` (T, 3) over `points` (V, 2), image pixels (y down)."""
    corners = points[triangles].astype(np.float64)  # (T, 3, 2)
    edges = corners[:, 1:] - corners[:, :1]
    return 0.5 * (edges[:, 0, 0] * edges[:, 1, 1] - edges[:, 1, 0] * edges[:, 0, 1])
