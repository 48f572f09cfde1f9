"""core.meshes.delaunay: the compiled Bowyer-Watson Delaunay triangulation of the band."""

import numpy as np
import pytest
from scipy.spatial import Delaunay

from core.meshes.delaunay import delaunay
from core.meshes.hex_lattice import HexLattice
from core.meshes.mesh import triangle_signed_areas


def check_delaunay(points, simplices, neighbors, tolerance=1e-9):
    """Counter-clockwise triangles, neighbours that share the side opposite each corner, no point
    inside a circumdisk (up to `tolerance` times its radius), every point used once or more."""
    assert (triangle_signed_areas(points, simplices) > 0).all()
    for k in range(3):
        side = np.sort(simplices[:, [(k + 1) % 3, (k + 2) % 3]], axis=1)
        across = neighbors[:, k]
        has = across >= 0
        shared = np.sort(simplices[across[has]], axis=1)
        assert ((shared == side[has, :1]).any(axis=1) & (shared == side[has, 1:]).any(axis=1)).all()
        assert (neighbors[across[has]] == np.flatnonzero(has)[:, None]).any(axis=1).all()
    a, b, c = (points[simplices[:, k]] for k in range(3))
    d = 2.0 * ((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))
    bb, cc = ((b - a) ** 2).sum(axis=1), ((c - a) ** 2).sum(axis=1)
    centre = a + np.stack(
        [((c[:, 1] - a[:, 1]) * bb - (b[:, 1] - a[:, 1]) * cc) / d,
         ((b[:, 0] - a[:, 0]) * cc - (c[:, 0] - a[:, 0]) * bb) / d],
        axis=1,
    )  # fmt: skip
    radius = np.linalg.norm(a - centre, axis=1)
    distance = np.linalg.norm(points[None, :, :] - centre[:, None, :], axis=2)
    assert (distance >= radius[:, None] * (1.0 - tolerance)).all()


def test_random_points_give_the_delaunay_triangles_of_qhull():
    points = np.random.default_rng(7).random((400, 2))
    ours = delaunay(points)
    check_delaunay(points, ours.simplices, ours.neighbors)
    assert ours.duplicates.size == 0
    found = set(map(tuple, np.sort(ours.simplices, axis=1)))
    reference = Delaunay(points)
    inner = (reference.neighbors >= 0).all(axis=1)  # the enclosing triangle may cut hull slivers
    assert set(map(tuple, np.sort(reference.simplices[inner], axis=1))) <= found
    assert len(found) <= reference.simplices.shape[0]


def test_cocircular_lattice_with_holes_and_collinear_rows():
    lattice = HexLattice([0.0, 0.0], [3.0, 3.0], 0.25)
    keep = np.random.default_rng(3).random(lattice.node_count) > 0.2  # holes: hexagons on circles
    points = lattice.node_points(np.flatnonzero(keep))
    ours = delaunay(points)
    check_delaunay(points, ours.simplices, ours.neighbors)
    used = np.zeros(points.shape[0], dtype=bool)
    used[ours.simplices] = True
    assert used.all()


def test_repeated_points_are_left_out_and_listed():
    rng = np.random.default_rng(11)
    points = rng.random((50, 2))
    repeated = np.vstack([points, points[[4, 9, 9]]])
    ours = delaunay(repeated)
    assert sorted(ours.duplicates.tolist()) == [50, 51, 52]
    assert ours.simplices.max() < 50
    check_delaunay(points, ours.simplices, ours.neighbors)


@pytest.mark.parametrize("count", [1, 2, 3])
def test_too_few_points_for_a_triangle_give_none(count):
    ours = delaunay(np.eye(3, 2)[:count] + 0.5)
    assert ours.simplices.shape == (max(count - 2, 0), 3)
