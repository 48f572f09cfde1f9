"""Tests of core.meshes.hex_lattice: the triangular lattice that meshes the inside of a domain."""

import math

import numpy as np
import pytest

from core.meshes.hex_lattice import HexLattice


@pytest.fixture(scope="module")
def lattice():
    return HexLattice([-1.0, -0.5], [2.0, 1.7], 0.13)


def brute_inside(points, polygon):
    """Crossing parity of each point against the polygon, one point at a time."""
    result = []
    following = np.roll(polygon, -1, axis=0)
    for x, y in points:
        crossings = 0
        for a, b in zip(polygon, following, strict=True):
            if (a[1] > y) != (b[1] > y):
                crossings += a[0] + (y - a[1]) * (b[0] - a[0]) / (b[1] - a[1]) > x
        result.append(crossings % 2 == 1)
    return np.array(result)


def star(arms=7, count=140, seed=3):
    rng = np.random.default_rng(seed)
    angle = np.sort(rng.uniform(0, 2 * np.pi, count))
    radius = 0.8 + 0.5 * np.sin(arms * angle) + rng.uniform(0, 0.1, count)
    return np.stack([0.5 + radius * np.cos(angle), 0.6 + radius * np.sin(angle)], axis=1)


def test_triangles_are_equilateral_counter_clockwise_and_tile_the_lattice(lattice):
    corners = lattice.triangle_corners(np.arange(lattice.triangle_count))
    assert corners.min() >= 0 and corners.max() < lattice.node_count
    points = lattice.node_points(corners.ravel()).reshape(-1, 3, 2)
    sides = np.linalg.norm(points - np.roll(points, -1, axis=1), axis=2)
    np.testing.assert_allclose(sides, lattice.spacing, rtol=1e-12)
    u, v = points[:, 1] - points[:, 0], points[:, 2] - points[:, 0]
    area = 0.5 * (u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0])
    np.testing.assert_allclose(area, math.sqrt(3) / 4 * lattice.spacing**2, rtol=1e-12)
    # A tiling of the rectangle of nodes: no triangle twice, every inner edge in two triangles.
    assert np.unique(np.sort(corners, axis=1), axis=0).shape[0] == lattice.triangle_count
    edges = np.sort(corners[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    assert counts.max() == 2
    assert (counts == 1).sum() == 2 * (lattice.columns - 1) + 2 * (lattice.rows - 1)  # the border


def test_circumradius_is_that_of_the_triangles(lattice):
    points = lattice.node_points(lattice.triangle_corners(np.arange(5)).ravel()).reshape(-1, 3, 2)
    centre = points.mean(axis=1)
    np.testing.assert_allclose(
        np.linalg.norm(points - centre[:, None], axis=2), lattice.circumradius, rtol=1e-12
    )


def test_inside_matches_the_crossing_test_point_by_point(lattice):
    polygon = star()
    nodes = np.arange(lattice.node_count)
    inside = lattice.inside(polygon)
    assert 0 < inside.sum() < lattice.node_count
    np.testing.assert_array_equal(inside, brute_inside(lattice.node_points(nodes), polygon))
    np.testing.assert_array_equal(lattice.inside(polygon[::-1]), inside)


def test_triangles_within_are_those_with_three_corners_selected(lattice):
    rng = np.random.default_rng(7)
    nodes = rng.random(lattice.node_count) < 0.8
    within = lattice.triangles_within(nodes)
    corners = lattice.triangle_corners(np.arange(lattice.triangle_count))
    np.testing.assert_array_equal(within, nodes[corners].all(axis=1))


def test_nodes_near_holds_every_node_within_the_radius(lattice):
    rng = np.random.default_rng(11)
    points = rng.uniform([-1.2, -0.7], [2.2, 1.9], size=(40, 2))
    radius = 0.31
    near = lattice.nodes_near(points, radius)
    nodes = lattice.node_points(np.arange(lattice.node_count))
    distance = np.linalg.norm(nodes[:, None, :] - points[None, :, :], axis=2).min(axis=1)
    assert near[distance <= radius].all()
    # ...and only nodes in a window a little larger than the radius.
    reach = math.hypot(radius + 2 * lattice.spacing, radius + 2 * lattice.height)
    assert (distance[near] <= reach).all()
    assert not lattice.nodes_near(np.zeros((0, 2)), radius).any()


def test_circumdisk_hits_match_a_search_of_all_triangles(lattice):
    rng = np.random.default_rng(5)
    points = rng.uniform([-1.2, -0.7], [2.2, 1.9], size=(300, 2))
    selected = rng.random(lattice.triangle_count) < 0.7
    corners = lattice.node_points(lattice.triangle_corners(np.arange(lattice.triangle_count)).ravel())
    centres = corners.reshape(-1, 3, 2).mean(axis=1)
    distance = np.linalg.norm(points[:, None, :] - centres[None, :, :], axis=2)
    expected = np.flatnonzero(selected & (distance < lattice.circumradius * (1 - 1e-9)).any(axis=0))
    hits = lattice.circumdisk_hits(points, selected)
    assert expected.size > 20
    np.testing.assert_array_equal(hits, expected)
    assert lattice.circumdisk_hits(np.zeros((0, 2)), selected).size == 0
