"""core.meshes.core_front: the border of the lattice core."""

import numpy as np

from core.meshes.core_front import core_front
from core.meshes.hex_lattice import HexLattice


def test_the_front_is_the_edges_of_one_core_triangle_with_the_core_on_their_left():
    lattice = HexLattice([0.0, 0.0], [4.0, 3.0], 0.2)
    points = lattice.node_points(np.arange(lattice.node_count))
    centres = points[lattice.triangle_corners(np.arange(lattice.triangle_count))].mean(axis=1)
    # A disk of core with a hole and a notch.
    radius = np.linalg.norm(centres - [2.0, 1.5], axis=1)
    core = (radius < 1.2) & (radius > 0.4) & ~((centres[:, 0] > 2.5) & (np.abs(centres[:, 1] - 1.5) < 0.2))
    corners = lattice.triangle_corners(np.flatnonzero(core))
    count, front = core_front(corners, lattice.node_count)
    np.testing.assert_array_equal(count, np.bincount(corners.ravel(), minlength=lattice.node_count))
    sides = corners[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    keys = np.sort(sides, axis=1) @ [lattice.node_count, 1]
    unique, counts = np.unique(keys, return_counts=True)
    expected = sides[np.isin(keys, unique[counts == 1])]
    np.testing.assert_array_equal(front, expected)
    assert front.shape[0] > 50
    # The core is on the left: the third corner of the core triangle with that side.
    third = corners[np.repeat(np.arange(corners.shape[0]), 3), np.tile([2, 0, 1], corners.shape[0])]
    apex = points[third[np.isin(keys, unique[counts == 1])]]
    tail, head = points[front[:, 0]], points[front[:, 1]]
    left = (head - tail)[:, 0] * (apex - tail)[:, 1] - (head - tail)[:, 1] * (apex - tail)[:, 0]
    assert (left > 0).all()
