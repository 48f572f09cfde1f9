"""core.injectivity.mesh_bijection: exact orientation, exact simplicity of a polygon, and the proof
that a mesh's piecewise-linear map is a bijection."""

from __future__ import annotations

import itertools
import time
from fractions import Fraction

import numpy as np
import pytest

import core
from core.curves.examples import ellipse, starfish
from core.injectivity.mesh_bijection import (
    mesh_bijection,
    orientation_signs,
    polygon_is_simple,
    prove_mesh_bijection,
)


def _grid_mesh(size: int = 8):
    """A unit square's grid of (size + 1)² vertices, its triangles counter-clockwise, and the boundary
    loop counter-clockwise."""
    axis = np.linspace(0.0, 1.0, size + 1)
    vertices = np.stack(np.meshgrid(axis, axis), axis=-1).reshape(
        -1, 2
    )  # row j, column i at j (size + 1) + i
    index = np.arange((size + 1) ** 2).reshape(size + 1, size + 1)
    a, b, c, d = (
        index[:-1, :-1].ravel(),
        index[:-1, 1:].ravel(),
        index[1:, 1:].ravel(),
        index[1:, :-1].ravel(),
    )
    triangles = np.concatenate([np.stack([a, b, c], axis=1), np.stack([a, c, d], axis=1)])
    boundary = np.concatenate([index[0, :-1], index[:-1, -1], index[-1, :0:-1], index[:0:-1, 0]])
    return vertices, triangles, boundary


def _exact_sign(a, b, c) -> int:
    ax, ay, bx, by, cx, cy = (Fraction(float(v)) for v in (*a, *b, *c))
    determinant = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
    return (determinant > 0) - (determinant < 0)


def test_orientation_is_exact_where_the_float_determinant_is_wrong():
    """Kettner et al.'s classroom example: a point p moved by single ulps around a line through
    q = (12, 12), r = (24, 24); every sign agrees with rational arithmetic, where the plain float
    determinant gets some wrong (so the test can tell)."""
    base = np.array([0.5, 0.5])
    q, r = np.array([12.0, 12.0]), np.array([24.0, 24.0])
    steps = np.arange(64) * np.spacing(0.5)
    points = np.stack(np.meshgrid(base[0] + steps, base[1] + steps), axis=-1).reshape(-1, 2)
    triangles = np.stack(
        [np.arange(len(points)), np.full(len(points), len(points)), np.full(len(points), len(points) + 1)],
        axis=1,
    )
    signs = orientation_signs(np.vstack([points, q, r]), triangles)
    expected = np.array([_exact_sign(p, q, r) for p in points])
    np.testing.assert_array_equal(signs, expected)
    naive = np.sign(
        (q[0] - points[:, 0]) * (r[1] - points[:, 1]) - (q[1] - points[:, 1]) * (r[0] - points[:, 0])
    )
    assert np.count_nonzero(naive != expected) > 0
    assert {-1, 0, 1} <= set(expected.tolist())


def test_a_mesh_and_its_orientation_preserving_affine_images_are_proven():
    vertices, triangles, boundary = _grid_mesh()
    rng = np.random.default_rng(0)
    for _ in range(5):
        matrix = rng.normal(size=(2, 2))
        if np.linalg.det(matrix) < 0:
            matrix[:, 0] *= -1
        images = vertices @ matrix.T + rng.normal(size=2)
        proof = prove_mesh_bijection(images, triangles, boundary)
        assert proof.proven and proof.turned_over == 0 and proof.boundary_simple
    mirrored = prove_mesh_bijection(vertices * [-1.0, 1.0], triangles, boundary)
    assert not mirrored.proven and mirrored.turned_over == len(triangles) and mirrored.boundary_simple


def test_an_interior_vertex_pushed_across_its_ring_turns_triangles_over():
    vertices, triangles, boundary = _grid_mesh()
    images = vertices.copy()
    images[4 * 9 + 4] += [0.2, 0.0]  # 1.6 spacings to the right: past its right neighbours
    proof = prove_mesh_bijection(images, triangles, boundary)
    assert not proof.proven and proof.turned_over > 0 and proof.boundary_simple


def test_a_collapsed_triangle_counts_as_turned_over():
    vertices, triangles, boundary = _grid_mesh()
    images = vertices.copy()
    centre = 4 * 9 + 4
    images[centre] = (images[centre - 9] + images[centre - 9 + 1]) / 2  # onto the edge below: area exactly 0
    assert prove_mesh_bijection(images, triangles, boundary).turned_over >= 1


def test_a_boundary_folded_over_itself_is_not_simple_though_every_triangle_is_positive():
    """A strip wound round more than once: all triangles positive, the boundary crosses itself; the
    proof needs both."""
    turns, count = 1.5, 60
    angles = np.linspace(0.0, 2 * np.pi * turns, count)
    inner = np.stack([np.cos(angles), np.sin(angles)], axis=1) * (1.0 + 0.05 * angles[:, None])
    vertices = np.vstack([inner, 1.4 * inner])  # images: inner row i, outer row count + i, overlapping
    source = np.stack([angles, np.zeros(count)], axis=1)
    source = np.vstack([source, source + [0.0, 1.0]])
    i = np.arange(count - 1)
    triangles = np.concatenate(
        [np.stack([i, i + 1, count + i + 1], axis=1), np.stack([i, count + i + 1, count + i], axis=1)]
    )
    boundary = np.concatenate([np.arange(count), count + np.arange(count)[::-1]])
    assert prove_mesh_bijection(source, triangles, boundary).proven
    # Angle along x and radius along y reverse the orientation: swapping the image's axes restores it.
    wound = prove_mesh_bijection(vertices[:, ::-1], triangles, boundary)
    assert wound.turned_over == 0 and not wound.boundary_simple and not wound.proven


@pytest.mark.parametrize(
    ("polygon", "simple"),
    [
        ([[0, 0], [1, 0], [1, 1], [0, 1]], True),
        ([[0, 0], [1, 1], [1, 0], [0, 1]], False),  # a bow tie
        ([[0, 0], [2, 0], [2, 2], [1, 0], [0, 2]], False),  # a vertex on another edge
        ([[0, 0], [2, 0], [1, 0], [1, 1]], False),  # doubling back along itself
        ([[0, 0], [1, 0], [1, 1], [1, 0], [0, 1]], False),  # a repeated vertex
        ([[0, 0], [1, 0], [1, 0], [0, 1]], False),  # an edge of length 0
        ([[0, 0], [1, 0], [2, 0], [1, 1]], True),  # collinear neighbours going on
        ([[0, 0], [1, 0]], False),
    ],
)
def test_small_polygons(polygon, simple):
    assert polygon_is_simple(np.array(polygon, dtype=np.float64)) is simple


def _brute_force_simple(polygon: np.ndarray) -> bool:
    """Every pair of edges tested in rationals: the reference."""
    count = len(polygon)
    points = [(Fraction(float(x)), Fraction(float(y))) for x, y in polygon]

    def orient(a, b, c):
        value = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
        return (value > 0) - (value < 0)

    def on(a, b, c):
        return min(a[0], b[0]) <= c[0] <= max(a[0], b[0]) and min(a[1], b[1]) <= c[1] <= max(a[1], b[1])

    for i in range(count):
        a, b = points[i], points[(i + 1) % count]
        if a == b:
            return False
        for j in range(i + 1, count):
            c, d = points[j], points[(j + 1) % count]
            if j == i + 1 or (i == 0 and j == count - 1):
                shared, far_a, far_b = (b, a, d) if j == i + 1 else (a, b, c)
                if orient(far_a, shared, far_b) == 0 and (
                    on(far_a, shared, far_b) or on(far_b, shared, far_a)
                ):
                    return False
                continue
            o1, o2, o3, o4 = orient(a, b, c), orient(a, b, d), orient(c, d, a), orient(c, d, b)
            if o1 * o2 < 0 and o3 * o4 < 0:
                return False
            if (
                (o1 == 0 and on(a, b, c))
                or (o2 == 0 and on(a, b, d))
                or (o3 == 0 and on(c, d, a))
                or (o4 == 0 and on(c, d, b))
            ):
                return False
    return True


def test_random_polygons_agree_with_every_pair_tested_exactly():
    """Circles of 5-60 vertices with their radii and angles jittered (some cross themselves), some
    vertices snapped to a coarse grid so that touching and collinear cases occur."""
    rng = np.random.default_rng(3)
    outcomes = set()
    for _ in range(300):
        count = int(rng.integers(5, 60))
        angles = np.sort(rng.uniform(0.0, 2 * np.pi, count)) + rng.normal(0.0, 0.15, count)
        radii = 1.0 + rng.normal(0.0, 0.3, count)
        polygon = np.stack([np.cos(angles), np.sin(angles)], axis=1) * radii[:, None]
        if rng.random() < 0.5:
            polygon = np.round(polygon * 4) / 4
        expected = _brute_force_simple(polygon)
        outcomes.add(expected)
        assert polygon_is_simple(polygon) is expected
    assert outcomes == {True, False}


def test_thousands_of_boundary_edges_are_checked_in_linear_time():
    """A 20,000-gon (all pairs: 2·10⁸) within a generous limit; its one crossing is found."""
    count = 20_000
    angles = np.linspace(0.0, 2 * np.pi, count, endpoint=False)
    polygon = np.stack([np.cos(angles), np.sin(angles)], axis=1) * (1.0 + 0.01 * np.sin(40 * angles))[:, None]
    started = time.perf_counter()
    assert polygon_is_simple(polygon)
    assert time.perf_counter() - started < 1.0
    polygon[5000] = [0.0, 0.0]  # a spike to the centre crosses nothing; one through it crosses
    polygon[15000] = polygon[4000] * 1.5
    assert not polygon_is_simple(polygon)


def brute_force_crossing(points: np.ndarray) -> bool:
    """Whether two non-adjacent edges of the closed polygon (B, 2) meet: every pair, in exact
    rational arithmetic on the floats' values (a reference for `polygon_is_simple`)."""
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


def test_polygon_is_simple_agrees_with_every_pair_on_random_polygons():
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
        assert (not polygon_is_simple(points)) == expected
    assert 30 < found < 270  # both kinds tested


def test_a_polygon_folding_back_on_itself_crosses():
    assert not polygon_is_simple(np.array([[0.0, 0.0], [2.0, 0.0], [1.0, 0.0], [1.0, 1.0]]))
    assert polygon_is_simple(np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [0.0, 1.0]]))


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
    assert not result.proven and result.turned_over > 0
    assert result.reason() == f"{result.turned_over} triangles turned over or collapsed"
    # A thin ellipse rolled round an annulus 4 radians a unit: every triangle kept, the boundary
    # loop round more than once (8 radians), so that it crosses itself.
    thin = core.triangulate(core.ClosedBSpline(ellipse(12, 1.0, 0.1)), max_edge=0.05)
    angle, radius = 4.0 * thin.vertices[:, 0], 1.0 - thin.vertices[:, 1]
    rolled = np.stack([radius * np.cos(angle), radius * np.sin(angle)], axis=1)
    loop = thin.boundary[np.argsort(thin.boundary_parameters)]
    wound = mesh_bijection(thin.vertices, rolled, thin.triangles, loop)
    assert not wound.proven and wound.turned_over == 0 and not wound.boundary_simple
    assert wound.reason() == "the image's boundary polygon crosses itself"
