"""core.injectivity.mesh_untangling: a tangle's free vertices move together until nothing is turned over."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import Delaunay

from core.injectivity.mesh_untangling import RINGS, relaxed, untangle_triangles
from core.meshes.mesh import triangle_signed_areas

#: An L-shaped polygon (counter-clockwise; the reflex corner at (1, 1)) and the grid's spacing.
L_SHAPE = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [1.0, 1.0], [1.0, 2.0], [0.0, 2.0]])
SPACING = 0.125


def l_shaped_mesh():
    """A grid's Delaunay triangles (counter-clockwise) inside `L_SHAPE`, and which vertices are
    interior (free)."""
    axis = np.arange(0.0, 2.0 + SPACING / 2, SPACING)
    grid = np.stack(np.meshgrid(axis, axis), axis=-1).reshape(-1, 2)
    vertices = grid[~np.all(grid > 1.0 + 1e-9, axis=1)]
    triangles = Delaunay(vertices).simplices
    triangles = triangles[~np.all(vertices[triangles].mean(axis=1) > 1.0, axis=1)]  # not in the notch
    turned = triangle_signed_areas(vertices, triangles) < 0
    triangles[turned] = triangles[turned][:, ::-1]
    on_boundary = (
        np.any(np.isclose(vertices, 0.0) | np.isclose(vertices, 2.0), axis=1)
        | (np.isclose(vertices[:, 0], 1.0) & (vertices[:, 1] >= 1.0 - 1e-9))
        | (np.isclose(vertices[:, 1], 1.0) & (vertices[:, 0] >= 1.0 - 1e-9))
    )
    return vertices, triangles, ~on_boundary


def inside_polygon(points, polygon) -> np.ndarray:
    """Whether each point (M, 2) is strictly inside the polygon (N, 2), by crossing counts."""
    start, end = polygon, np.roll(polygon, -1, axis=0)
    x, y = points[:, :1], points[:, 1:]
    spans = (start[:, 1] > y) != (end[:, 1] > y)
    rise = np.where(spans, end[:, 1] - start[:, 1], 1.0)  # edges that do not span y never count
    crossing_x = start[:, 0] + (y - start[:, 1]) * (end[:, 0] - start[:, 0]) / rise
    return np.count_nonzero(spans & (x < crossing_x), axis=1) % 2 == 1


def turned_over(vertices, images, triangles) -> int:
    return int(
        np.count_nonzero(
            triangle_signed_areas(images, triangles) <= 1e-9 * triangle_signed_areas(vertices, triangles)
        )
    )


@pytest.mark.parametrize(("seed", "pushed", "reach"), [(0, 6, 1.6), (1, 12, 2.5), (2, 40, 1.2)])
def test_a_tangled_grid_in_an_l_is_untangled_with_the_boundary_fixed(seed, pushed, reach):
    """Interior vertices pushed across their neighbours (by `reach` grid spacings in random
    directions): afterwards no triangle is turned over, the boundary's images are unchanged to the
    bit, only free vertices moved, and every image lies inside the L (the degree argument)."""
    vertices, triangles, free = l_shaped_mesh()
    rng = np.random.default_rng(seed)
    images = vertices.copy()
    chosen = rng.choice(np.flatnonzero(free), size=pushed, replace=False)
    angles = rng.uniform(0.0, 2.0 * np.pi, size=pushed)
    images[chosen] += reach * SPACING * np.column_stack([np.cos(angles), np.sin(angles)])
    images[chosen] = np.clip(images[chosen], 0.01, 1.99)
    assert turned_over(vertices, images, triangles) > 0

    untangled, moves = untangle_triangles(vertices, images, triangles, free)

    assert turned_over(vertices, untangled, triangles) == 0
    np.testing.assert_array_equal(untangled[~free], images[~free])
    assert np.all(moves[~free] == 0.0) and np.count_nonzero(moves) > 0
    np.testing.assert_allclose(moves, np.linalg.norm(untangled - images, axis=1), rtol=0, atol=0)
    assert inside_polygon(untangled[free], L_SHAPE).all()


def test_interior_vertices_shuffled_among_themselves_are_untangled():
    """A tangle with no local structure left: 30 interior vertices' images permuted at random."""
    vertices, triangles, free = l_shaped_mesh()
    rng = np.random.default_rng(7)
    images = vertices.copy()
    chosen = rng.choice(np.flatnonzero(free), size=30, replace=False)
    images[chosen] = images[rng.permutation(chosen)]
    assert turned_over(vertices, images, triangles) > 10

    untangled, _ = untangle_triangles(vertices, images, triangles, free)

    assert turned_over(vertices, untangled, triangles) == 0
    np.testing.assert_array_equal(untangled[~free], images[~free])
    assert inside_polygon(untangled[free], L_SHAPE).all()


def test_a_mesh_with_nothing_turned_over_is_left_as_it_is():
    vertices, triangles, free = l_shaped_mesh()
    images = vertices @ np.array([[1.1, 0.2], [-0.1, 0.9]]).T
    untangled, moves = untangle_triangles(vertices, images, triangles, free)
    np.testing.assert_array_equal(untangled, images)
    assert np.all(moves == 0.0)


def test_a_turned_over_triangle_with_no_free_vertex_is_reported_not_hidden():
    """A corner triangle whose three vertices are all on the boundary, turned over by their images
    (the corner vertex pulled across the chord of its two neighbours): no free vertex can unfold it,
    so the images come back unchanged and the triangle still turned over, for the caller to count."""
    vertices, triangles, free = l_shaped_mesh()
    corner = np.flatnonzero(np.all(np.isclose(vertices, [2.0, 0.0]), axis=1))[0]
    fixed_triangle = triangles[np.all(~free[triangles], axis=1) & np.any(triangles == corner, axis=1)]
    assert len(fixed_triangle) == 1
    images = vertices.copy()
    images[corner] = [2.0 - 1.5 * SPACING, 1.5 * SPACING]
    before = turned_over(vertices, images, triangles)
    assert before > 0

    untangled, moves = untangle_triangles(vertices, images, triangles, free)

    np.testing.assert_array_equal(untangled, images)
    assert np.all(moves == 0.0)
    assert triangle_signed_areas(untangled, fixed_triangle)[0] < 0
    assert turned_over(vertices, untangled, triangles) == before


def test_one_vertex_pushed_across_moves_only_vertices_near_it():
    """One interior vertex pushed over its neighbours: only free vertices within `RINGS` rings of
    triangles around the turned-over ones move (the first region untangles it)."""
    vertices, triangles, free = l_shaped_mesh()
    pushed = np.flatnonzero(np.all(np.isclose(vertices, [0.5, 0.5]), axis=1))[0]
    images = vertices.copy()
    images[pushed] += [1.6 * SPACING, 0.3 * SPACING]
    source_areas = triangle_signed_areas(vertices, triangles)
    near = np.zeros(len(vertices), dtype=bool)
    near[triangles[triangle_signed_areas(images, triangles) <= 0].ravel()] = True
    for _ in range(RINGS):
        near[triangles[np.any(near[triangles], axis=1)].ravel()] = True

    untangled, moves = untangle_triangles(vertices, images, triangles, free)

    assert np.all(triangle_signed_areas(untangled, triangles) > 1e-9 * source_areas)
    assert moves[pushed] > 0 and np.all(moves[~(near & free)] == 0.0)
    assert np.count_nonzero(~near & free) > 50  # the region is a part of the mesh, not all of it


def test_collapsed_triangles_are_opened_too():
    """Interior vertices' images put on the midpoints of neighbours' edges (signed area exactly 0,
    counted as turned over as by `core.folded_triangles`): afterwards every area is positive."""
    vertices, triangles, free = l_shaped_mesh()
    images = vertices.copy()
    for corner in ([0.5, 0.5], [1.5, 0.25], [0.25, 1.5]):
        vertex = np.flatnonzero(np.all(np.isclose(vertices, corner), axis=1))[0]
        images[vertex] = vertices[vertex] + [SPACING / 2, SPACING / 2]  # onto its diagonal neighbours' edge
    assert np.any(triangle_signed_areas(images, triangles) == 0.0)

    untangled, _ = untangle_triangles(vertices, images, triangles, free)

    assert turned_over(vertices, untangled, triangles) == 0
    np.testing.assert_array_equal(untangled[~free], images[~free])


def test_a_vertex_whose_fixed_ring_has_no_kernel_is_left_turned_over():
    """One free vertex in a fan of 8 triangles whose fixed ring maps onto a C (two arms' edges face
    each other: no point sees the whole ring, so some triangle turns over wherever the vertex goes):
    the barrier method fails and says so, the images coming back unchanged."""
    angles = np.arange(8) * np.pi / 4
    vertices = np.vstack([[0.0, 0.0], np.column_stack([np.cos(angles), np.sin(angles)])])
    triangles = np.array([[0, 1 + k, 1 + (k + 1) % 8] for k in range(8)])
    images = np.vstack([[0.5, 1.5], [[0, 0], [3, 0], [3, 1], [1, 1], [1, 2], [3, 2], [3, 3], [0, 3]]]).astype(
        float
    )
    free = np.array([True] + [False] * 8)
    before = turned_over(vertices, images, triangles)
    assert before > 0

    untangled, moves = untangle_triangles(vertices, images, triangles, free)

    np.testing.assert_array_equal(untangled, images)
    assert np.all(moves == 0.0) and turned_over(vertices, untangled, triangles) == before


def test_relaxed_opens_a_squeezed_triangle_and_turns_none_over():
    """An interior vertex pushed almost onto its ring's edge (a sliver, still positive): a few
    barrier Newton steps move it back in; no triangle turns over, fixed vertices stay."""
    vertices, triangles, free = l_shaped_mesh()
    images = vertices.copy()
    vertex = int(np.flatnonzero(free)[10])
    ring = triangles[np.any(triangles == vertex, axis=1)]
    neighbour = ring[ring != vertex][0]
    images[vertex] = vertices[vertex] + 0.99 * (vertices[neighbour] - vertices[vertex])
    before = triangle_signed_areas(images, triangles) / triangle_signed_areas(vertices, triangles)
    assert before.min() > 0
    relaxed_images = relaxed(vertices, images, triangles, free, 3)
    after = triangle_signed_areas(relaxed_images, triangles) / triangle_signed_areas(vertices, triangles)
    assert after.min() > 2 * before.min()  # 0.01 of its area to 0.025 in three steps
    np.testing.assert_array_equal(relaxed_images[~free], images[~free])
