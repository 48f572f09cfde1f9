"""The triangular lattice of equilateral triangles that meshes the inside of a domain in one step.

`core.triangulate` covers the part of the domain away from the curve with this
lattice (its triangles are known, no Delaunay triangulation needed) and refines
only the band between the lattice and the curve.  Everything here is index
arithmetic on (row, column) pairs, vectorised over arrays (the circumdisk test,
run in every round of the refinement, is compiled).

Node (r, c) is at ``origin + ((c + (r % 2) / 2) s, r s sqrt(3) / 2)`` for the
spacing s; its id is ``r * columns + c``.  Cell (r, c), for ``r < rows - 1`` and
``c < columns - 1``, holds two triangles, apex up (kind 0) and apex down (kind 1),
with id ``2 (r (columns - 1) + c) + kind``.  Coordinates are (x, y), y up.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

SQRT3 = math.sqrt(3.0)


class HexLattice:
    """A triangular lattice of spacing `spacing` covering the box [low, high].

    Parameters
    ----------
    low, high : array_like of shape (2,)
        Corners of the box; the first node is half a spacing inside `low`.
    spacing : float
        Edge length of the triangles.
    """

    def __init__(self, low, high, spacing: float):
        low = np.asarray(low, dtype=np.float64)
        high = np.asarray(high, dtype=np.float64)
        self.spacing = float(spacing)
        self.height = 0.5 * SQRT3 * self.spacing  # between rows
        self.origin = low + 0.5 * self.spacing
        self.rows = max(int((high[1] - self.origin[1]) // self.height) + 1, 1)
        self.columns = max(int((high[0] - self.origin[0]) // self.spacing) + 1, 1)
        self.node_count = self.rows * self.columns
        self.triangle_count = 2 * max(self.rows - 1, 0) * max(self.columns - 1, 0)

    @property
    def circumradius(self) -> float:
        """Radius of the circumcircle of every triangle, s / sqrt(3)."""
        return self.spacing / SQRT3

    def node_points(self, nodes: np.ndarray) -> np.ndarray:
        """Positions (M, 2) of the nodes with ids `nodes` (M,)."""
        nodes = np.ascontiguousarray(nodes, dtype=np.int64).reshape(-1)
        return _node_points(nodes, self.columns, self.origin, self.spacing, self.height)

    def inside(self, polygon: np.ndarray) -> np.ndarray:
        """bool (rows * columns,): the nodes inside the closed polygon (B, 2), by crossing parity.

        Each polygon edge crosses the rows between its ends' heights; a node is
        inside when an odd number of crossings of its row lie to its right.
        """
        polygon = np.ascontiguousarray(polygon, dtype=np.float64)
        return _inside(polygon, self.origin, self.spacing, self.height, self.rows, self.columns)

    def triangle_corners(self, triangles: np.ndarray) -> np.ndarray:
        """Node ids (M, 3) of the corners of triangles `triangles` (M,), counter-clockwise (y up)."""
        return _triangle_corners(np.ascontiguousarray(triangles, dtype=np.int64).reshape(-1), self.columns)

    def triangles_within(self, nodes: np.ndarray) -> np.ndarray:
        """bool (triangle_count,): the triangles whose three corners are all in `nodes`.

        Parameters
        ----------
        nodes : ndarray of shape (node_count,), bool
        """
        grid = np.asarray(nodes, dtype=bool).reshape(self.rows, self.columns)
        bottom_left, bottom_right = grid[:-1, :-1], grid[:-1, 1:]
        top_left, top_right = grid[1:, :-1], grid[1:, 1:]
        odd = (np.arange(self.rows - 1) % 2 == 1)[:, None]
        up = bottom_left & bottom_right & np.where(odd, top_right, top_left)
        down = np.where(odd, bottom_left, bottom_right) & top_right & top_left
        return np.stack([up, down], axis=-1).ravel()

    def nodes_near(self, points: np.ndarray, radius: float) -> np.ndarray:
        """bool (node_count,): True for every node within `radius` of one of `points` (M, 2), and
        for some nodes a little farther (whole rows and columns of a window around each point)."""
        near = np.zeros(self.node_count, dtype=np.bool_)
        if points.shape[0] == 0:
            return near
        local = np.ascontiguousarray(points - self.origin, dtype=np.float64)
        rows = int(math.ceil(radius / self.height)) + 1
        columns = int(math.ceil(radius / self.spacing)) + 1
        _mark_windows(local, self.spacing, self.height, self.rows, self.columns, rows, columns, near)
        return near

    def circumdisk_hits(self, points: np.ndarray, selected: np.ndarray) -> np.ndarray:
        """Ids of the `selected` triangles whose open circumdisk holds one of `points` (M, 2).

        Parameters
        ----------
        selected : ndarray of shape (triangle_count,), bool
            The triangles to test.

        Returns
        -------
        ndarray of shape (H,), int64, sorted and unique.
        """
        if points.shape[0] == 0 or self.triangle_count == 0:
            return np.zeros(0, dtype=np.int64)
        local = np.ascontiguousarray(points - self.origin, dtype=np.float64)
        hit = _circumdisk_hits(
            local, np.asarray(selected, dtype=np.bool_), self.spacing, self.rows, self.columns
        )
        return np.flatnonzero(hit)


@njit(cache=True)
def _circumdisk_hits(local, selected, spacing, rows, columns):  # pragma: no cover - compiled
    """`HexLattice.circumdisk_hits` of points `local` (M, 2) relative to the origin, as a bool
    array (triangle_count,)."""
    hit = np.zeros(selected.size, dtype=np.bool_)
    height = 0.5 * SQRT3 * spacing
    radius = spacing / SQRT3 * (1.0 - 1e-9)
    for i in range(local.shape[0]):
        r0 = int(np.floor(local[i, 1] / height))
        c0 = int(np.floor(local[i, 0] / spacing))
        # A disk of radius s / sqrt(3) around a point reaches the centres of triangles
        # in the rows r0 - 1 .. r0 + 1 and the columns c0 - 2 .. c0 + 1 only.
        for r in range(max(r0 - 1, 0), min(r0 + 2, rows - 1)):
            p = r % 2
            for c in range(max(c0 - 2, 0), min(c0 + 2, columns - 1)):
                for kind in range(2):
                    if kind == 0:
                        centre_x, centre_y = (c + 0.5 + 0.5 * p) * spacing, (r + 1.0 / 3.0) * height
                    else:
                        centre_x, centre_y = (c + 1.0 - 0.5 * p) * spacing, (r + 2.0 / 3.0) * height
                    dx, dy = local[i, 0] - centre_x, local[i, 1] - centre_y
                    triangle = 2 * (r * (columns - 1) + c) + kind
                    if dx * dx + dy * dy < radius * radius and selected[triangle]:
                        hit[triangle] = True
    return hit


@njit(cache=True)
def _mark_windows(local, spacing, height, rows, columns, reach_rows, reach_columns, near):  # pragma: no cover
    """Mark in `near` (rows * columns,) the nodes in rows r0 -/+ reach_rows and columns c0 -/+
    reach_columns around the cell (r0, c0) of each point of `local` (M, 2) (relative to the origin)."""
    for i in range(local.shape[0]):
        r0 = int(np.floor(local[i, 1] / height))
        c0 = int(np.floor(local[i, 0] / spacing))
        for r in range(max(r0 - reach_rows, 0), min(r0 + reach_rows + 1, rows)):
            for c in range(max(c0 - reach_columns, 0), min(c0 + reach_columns + 1, columns)):
                near[r * columns + c] = True


@njit(cache=True)
def _triangle_corners(triangles, columns):  # pragma: no cover - compiled
    """`HexLattice.triangle_corners` of a lattice with `columns` columns."""
    result = np.empty((triangles.size, 3), dtype=np.int64)
    for i in range(triangles.size):
        cell, kind = triangles[i] // 2, triangles[i] % 2
        r, c = cell // (columns - 1), cell % (columns - 1)
        p = r & 1  # odd rows are shifted half a spacing to the right
        below = r * columns + c
        above = below + columns
        if kind == 0:  # apex up
            result[i, 0], result[i, 1], result[i, 2] = below, below + 1, above + p
        else:
            result[i, 0], result[i, 1], result[i, 2] = below + 1 - p, above + 1, above
    return result


@njit(cache=True)
def _node_points(nodes, columns, origin, spacing, height):  # pragma: no cover - compiled
    """`HexLattice.node_points` of a lattice with `columns` columns."""
    result = np.empty((nodes.size, 2))
    for i in range(nodes.size):
        r, c = nodes[i] // columns, nodes[i] % columns
        result[i, 0] = origin[0] + (c + 0.5 * (r & 1)) * spacing
        result[i, 1] = origin[1] + r * height
    return result


@njit(cache=True)
def _inside(polygon, origin, spacing, height, rows, columns):  # pragma: no cover - compiled
    """`HexLattice.inside`: each polygon edge flips the parity of the nodes to the left of where
    it crosses a row."""
    inside = np.zeros(rows * columns, dtype=np.bool_)
    count = polygon.shape[0]
    for e in range(count):
        ax, ay = polygon[e, 0], polygon[e, 1]
        bx, by = polygon[(e + 1) % count, 0], polygon[(e + 1) % count, 1]
        first = min(max(int(np.floor((min(ay, by) - origin[1]) / height)), 0), rows)
        last = min(max(int(np.ceil((max(ay, by) - origin[1]) / height)) + 1, 0), rows)
        for row in range(first, last):
            y = origin[1] + row * height
            if (ay > y) == (by > y):
                continue
            x = ax + (y - ay) * (bx - ax) / (by - ay)
            shift = 0.5 * (row & 1)
            for column in range(columns):
                if origin[0] + (column + shift) * spacing >= x:
                    break
                inside[row * columns + column] = not inside[row * columns + column]
    return inside
