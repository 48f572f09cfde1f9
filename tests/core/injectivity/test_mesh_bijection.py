"""core.injectivity.mesh_bijection: the proof that a mesh's piecewise-linear map is a bijection."""

from __future__ import annotations

import itertools

import numpy as np

import core
from core.curves.examples import ellipse, starfish
from core.injectivity.mesh_bijection import mesh_bijection, polygon_crossing


def brute_force_crossing(points: np.ndarray) -> bool:
    """Whether two non-adjacent edges of the closed polygon (B, 2) meet: every pair, in exact
    rational arithmetic on the floats' values (a reference for `polygon_crossing`)."""
    from fractions import Fraction

    p = [(Fraction(x), Fraction(y)) for x, y in points]
    n = len(p)

    def orient(a, b, c):
        value = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
        return (value > 0) - (value < 0)

    def on(a, b, c):
        return min(a[0], b[0]) <= c[0] <= max(a[0], b[0]) and min(a[1], b[1]) <= c[1] <= max(a[1], b[1])

    for i, j in itertools.combinations(range(n), 2):
        if j == i + 1 or (i == 0 and j == n - 1):
            continue
        a, b, c, d = p[i], p[(i + 1) % n], p[j], p[(j + 1) % n]
        o1, o2, o3, o4 = orient(c, d, a), orient(c, d, b), orient(a, b, c), orient(a, b, d)
        if o1 * o2 < 0 and o3 * o4 < 0:
            return True
        touching = ((o1, (c, d, a)), (o2, (c, d, b)), (o3, (a, b, c)), (o4, (a, b, d)))
        if any(o == 0 and on(*segment) for o, segment in touching):
            return True
    return False


def test_polygon_crossing_agrees_with_every_pair_on_random_polygons():
    rng = np.random.default_rng(46)
    found = 0
    for _ in range(300):
        count = int(rng.integers(4, 12))
        angles = np.sort(rng.uniform(0.0, 2.0 * np.pi, count))
        radii = rng.uniform(0.2, 1.0, count)
        points = np.stack([radii * np.cos(angles), radii * np.sin(angles)], axis=1)
        if rng.random() < 0.5:  # shuffle a few: crossings
            swap = rng.choice(count, size=2, replace=False)
            points[swap] = points[swap[::-1]]
        if rng.random() < 0.2:  # a grid: touching vertices and collinear edges
            points = np.round(points * 2.0) / 2.0
            if len(np.unique(points, axis=0)) < count:
                continue
        expected = brute_force_crossing(points)
        found += expected
        assert (polygon_crossing(points) is not None) == expected
    assert 30 < found < 270  # both kinds tested


def test_a_polygon_folding_back_on_itself_crosses():
    assert polygon_crossing(np.array([[0.0, 0.0], [2.0, 0.0], [1.0, 0.0], [1.0, 1.0]])) is not None
    assert polygon_crossing(np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [0.0, 1.0]])) is None


def test_the_identity_is_a_bijection_and_a_fold_or_a_crossing_boundary_is_not():
    mesh = core.triangulate(core.ClosedBSpline(starfish()), max_edge=0.2)
    loop = mesh.boundary[np.argsort(mesh.boundary_parameters)]
    identity = mesh_bijection(mesh.vertices, mesh.vertices, mesh.triangles, loop)
    assert identity.proven and identity.reason() == ""
    folded = mesh.vertices.copy()
    v = mesh.interior[0]
    ring = mesh.triangles[np.any(mesh.triangles == v, axis=1)]
    neighbour = ring[ring != v][0]
    folded[v] = folded[neighbour] + 3.0 * (folded[neighbour] - mesh.vertices[v])  # past its neighbour
    result = mesh_bijection(mesh.vertices, folded, mesh.triangles, loop)
    assert not result.proven and result.folded > 0
    assert result.reason() == f"{result.folded} triangles turned over or collapsed"
    # A thin ellipse rolled round an annulus 4 radians a unit: every triangle kept, the boundary
    # loop round more than once (8 radians), so that it crosses itself.
    thin = core.triangulate(core.ClosedBSpline(ellipse(12, 1.0, 0.1)), max_edge=0.05)
    angle, radius = 4.0 * thin.vertices[:, 0], 1.0 - thin.vertices[:, 1]
    rolled = np.stack([radius * np.cos(angle), radius * np.sin(angle)], axis=1)
    loop = thin.boundary[np.argsort(thin.boundary_parameters)]
    wound = mesh_bijection(thin.vertices, rolled, thin.triangles, loop)
    assert not wound.proven and wound.folded == 0 and wound.crossing is not None
    assert wound.reason().startswith("boundary edges ")
