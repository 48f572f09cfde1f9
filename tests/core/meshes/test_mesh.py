"""core.triangulate (core.meshes.triangulation): conforming quality triangulations of B-spline
domains."""

import numpy as np
import pytest
from support.shapes import l_polygon as l_shape
from support.shapes import near_cusp, pixel_blob, wavy_star

import core
from core.curves import examples
from core.curves.closest_point import distance_to_curve
from core.meshes.mesh import Mesh, folded_triangles
from core.meshes.refinement import Refinement
from core.meshes.sizing import Sizing
from core.meshes.triangulation import triangulate


def starfish(arms=5, n=20):
    """A non-convex star with `arms` arms and narrow armpits."""
    return wavy_star(n=n, arms=arms, depth=0.6)


def dumbbell(neck=0.02):
    """Two round lobes joined by a straight channel of half-width `neck` (curve neck ~ 2 * neck)."""

    def lobe(centre, angles):
        return [[centre + 0.8 * np.cos(a), 0.8 * np.sin(a)] for a in angles]

    return np.array(
        [[0.35, neck], [-0.35, neck]]
        + lobe(-1.1, np.linspace(0.2 * np.pi, 1.8 * np.pi, 8))
        + [[-0.35, -neck], [0.35, -neck]]
        + lobe(1.1, np.linspace(1.2 * np.pi, 2.8 * np.pi, 8))
    )


def slotted_square(gap=0.02):
    """A square polygon (doubled points: sharp corners) cut by a narrow slot from the top."""
    g = gap / 2
    polygon = [[-1, -1], [1, -1], [1, 1], [g, 1], [g, -0.5], [-g, -0.5], [-g, 1], [-1, 1]]
    return np.repeat(np.array(polygon, dtype=float), 2, axis=0)


def spike():
    """A blob with one very sharp corner (about 5.7 degrees) at (3, 0.15)."""
    return np.array([[0, 0], [3, 0.15], [3, 0.15], [0, 0.3], [-1, 1], [-1.5, -0.5]], dtype=float)


CAGES = {
    "starfish": starfish(),
    "clockwise-starfish": starfish()[::-1].copy(),
    "dumbbell": dumbbell(),
    "slotted-square": slotted_square(),
    "l-shape": l_shape(),
    "spike": spike(),
}
# Cages with no corner sharper than 90 degrees: every angle of the mesh must be >= 20 degrees.
SMOOTH_OR_RIGHT_ANGLED = ["starfish", "clockwise-starfish", "dumbbell", "slotted-square", "l-shape"]


@pytest.fixture(scope="module", params=list(CAGES))
def case(request):
    curve = core.ClosedBSpline(CAGES[request.param])
    return request.param, curve, triangulate(curve)


def chords(mesh):
    start = mesh.vertices[mesh.boundary]
    return start, np.roll(start, -1, axis=0)


# ---------------------------------------------------------------- properties


def test_boundary_vertices_lie_exactly_on_the_curve_in_parameter_order(case):
    _, curve, mesh = case
    np.testing.assert_allclose(
        mesh.vertices[mesh.boundary], curve(mesh.boundary_parameters), rtol=0, atol=1e-12 * curve.diameter
    )
    assert np.all(np.diff(mesh.boundary_parameters) > 0)
    assert mesh.boundary_parameters[0] >= 0 and mesh.boundary_parameters[-1] < curve.n
    assert np.unique(mesh.boundary).size == mesh.boundary.size


def test_triangles_are_counter_clockwise(case):
    _, _, mesh = case
    assert np.all(mesh.signed_areas() > 0)


def assert_disk_bounded_by_the_chords(mesh):
    edges = mesh.edges()
    assert mesh.vertices.shape[0] - edges.shape[0] + mesh.triangles.shape[0] == 1
    assert np.unique(mesh.triangles).size == mesh.vertices.shape[0]  # every vertex used
    sides = np.sort(
        np.concatenate([mesh.triangles[:, [0, 1]], mesh.triangles[:, [1, 2]], mesh.triangles[:, [2, 0]]]),
        axis=1,
    )
    unique, counts = np.unique(sides, axis=0, return_counts=True)
    assert counts.max() == 2
    border = {tuple(edge) for edge in unique[counts == 1]}
    polygon = {tuple(sorted(pair)) for pair in zip(mesh.boundary, np.roll(mesh.boundary, -1), strict=True)}
    assert border == polygon


def assert_simple_boundary_polygon(mesh):
    a, b = chords(mesh)
    count = a.shape[0]
    r = b - a
    qp = a[None, :, :] - a[:, None, :]
    denominator = r[:, None, 0] * r[None, :, 1] - r[:, None, 1] * r[None, :, 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        s = (qp[..., 0] * r[None, :, 1] - qp[..., 1] * r[None, :, 0]) / denominator
        u = (qp[..., 0] * r[:, None, 1] - qp[..., 1] * r[:, None, 0]) / denominator
    crossing = (s >= 0) & (s <= 1) & (u >= 0) & (u <= 1)
    index = np.arange(count)
    gap = np.abs(index[:, None] - index[None, :])
    neighbours = (gap <= 1) | (gap == count - 1)
    assert not np.any(crossing & ~neighbours)


def test_mesh_is_a_topological_disk_bounded_by_the_chords(case):
    _, _, mesh = case
    assert_disk_bounded_by_the_chords(mesh)


def test_boundary_polygon_is_simple(case):
    _, _, mesh = case
    assert_simple_boundary_polygon(mesh)


def test_interior_vertices_and_centroids_are_strictly_inside_the_curve(case):
    _, curve, mesh = case
    interior = mesh.vertices[mesh.interior]
    assert curve.contains(interior).all()
    assert curve.contains(mesh.vertices[mesh.triangles].mean(axis=1)).all()
    # Not on the curve either: farther than a small fraction of the shortest edge.
    shortest = np.linalg.norm(np.diff(mesh.vertices[mesh.edges()], axis=1), axis=2).min()
    assert distance_to_curve(curve.piecewise_polynomial(), interior).min() > 0.1 * shortest


@pytest.mark.parametrize("name", SMOOTH_OR_RIGHT_ANGLED)
def test_no_angle_below_20_degrees(name):
    curve = core.ClosedBSpline(CAGES[name])
    mesh = triangulate(curve)
    assert np.degrees(mesh.angles()).min() >= 20.0


def test_small_angles_only_next_to_a_sharp_corner():
    curve = core.ClosedBSpline(spike())
    mesh = triangulate(curve)
    tip = curve(curve.corners()[:, 0])[0]
    centroids = mesh.vertices[mesh.triangles].mean(axis=1)
    far = np.linalg.norm(centroids - tip, axis=1) > curve.diameter / 50
    assert np.degrees(mesh.angles()[far]).min() >= 20.0


def test_mesh_area_is_the_polygon_area_and_close_to_the_curve_area(case):
    _, curve, mesh = case
    a, b = chords(mesh)
    polygon_area = 0.5 * abs(np.sum(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]))
    assert mesh.signed_areas().sum() == pytest.approx(polygon_area, rel=1e-12)
    assert mesh.signed_areas().sum() == pytest.approx(abs(curve.area), rel=2e-3)


def test_chord_error_is_small_relative_to_the_edge(case):
    _, curve, mesh = case
    t = mesh.boundary_parameters
    following = np.append(t[1:], t[0] + curve.n)
    u = np.linspace(0, 1, 17)[1:-1]
    arc = curve((t[:, None] + u[None, :] * (following - t)[:, None]).ravel()).reshape(t.size, u.size, 2)
    a, b = chords(mesh)
    length = np.linalg.norm(b - a, axis=1)
    edge = (b - a)[:, None, :]
    relative = arc - a[:, None, :]
    offset = np.abs(edge[..., 0] * relative[..., 1] - edge[..., 1] * relative[..., 0]) / length[:, None]
    # TURNING_ANGLE = 0.3 rad bounds the sagitta by about 0.3 / 8 of the chord.
    assert (offset.max(axis=1) / length).max() <= 0.04


def test_edges_follow_max_edge_and_density_scales():
    curve = core.ClosedBSpline(starfish())
    coarse = triangulate(curve, max_edge=0.05)
    fine = triangulate(curve, max_edge=0.025)
    for mesh, max_edge in ((coarse, 0.05), (fine, 0.025)):
        lengths = np.linalg.norm(np.diff(mesh.vertices[mesh.edges()], axis=1), axis=2)
        assert lengths.max() <= 1.5 * max_edge
        assert np.median(lengths) >= 0.7 * max_edge
    assert np.median(coarse.signed_areas()) / np.median(fine.signed_areas()) == pytest.approx(4.0, rel=0.1)
    assert 3.0 <= fine.vertices.shape[0] / coarse.vertices.shape[0] <= 5.0


def test_default_max_edge_is_a_fiftieth_of_the_diameter():
    curve = core.ClosedBSpline(starfish())
    default = triangulate(curve)
    explicit = triangulate(curve, max_edge=curve.diameter / 50)
    np.testing.assert_array_equal(default.vertices, explicit.vertices)
    np.testing.assert_array_equal(default.triangles, explicit.triangles)


def test_sharp_corners_are_vertices():
    curve = core.ClosedBSpline(l_shape())
    mesh = triangulate(curve)
    corner_parameters = curve.corners()[:, 0]
    assert corner_parameters.size == 6
    position = np.searchsorted(mesh.boundary_parameters, corner_parameters)
    np.testing.assert_array_equal(mesh.boundary_parameters[position], corner_parameters)
    corners = mesh.vertices[mesh.boundary[position]]
    expected = curve.control_points[::2]
    assert {tuple(p) for p in corners} == {tuple(p) for p in expected}


def test_boundary_spacing_adapts_to_a_narrow_neck():
    curve = core.ClosedBSpline(dumbbell(neck=0.02))
    mesh = triangulate(curve)
    a, b = chords(mesh)
    in_neck = (np.abs(a[:, 0]) < 0.2) & (np.abs(a[:, 1]) < 0.1)
    assert in_neck.sum() >= 10
    width = 2 * np.abs(a[in_neck, 1]).min()  # the neck is symmetric about y = 0
    assert np.linalg.norm(b - a, axis=1)[in_neck].max() <= width
    # ...while far from it the boundary keeps the coarse spacing.
    assert np.linalg.norm(b - a, axis=1).max() >= 0.8 * curve.diameter / 50


def test_narrow_outside_slot_keeps_the_two_sides_apart():
    curve = core.ClosedBSpline(slotted_square(gap=0.01))
    mesh = triangulate(curve)
    # No triangle bridges the slot: every centroid is inside the curve (checked on
    # this cage too) and no triangle touches both walls of the slot.
    centroids = mesh.vertices[mesh.triangles].mean(axis=1)
    assert curve.contains(centroids).all()
    x = mesh.vertices[mesh.triangles][:, :, 0]
    high = mesh.vertices[mesh.triangles][:, :, 1].min(axis=1) > -0.5
    assert not np.any(high & (x.min(axis=1) <= -0.005) & (x.max(axis=1) >= 0.005))


def test_deterministic_and_independent_of_orientation():
    points = starfish()
    first = triangulate(core.ClosedBSpline(points))
    again = triangulate(core.ClosedBSpline(points))
    np.testing.assert_array_equal(first.vertices, again.vertices)
    np.testing.assert_array_equal(first.triangles, again.triangles)
    reverse = triangulate(core.ClosedBSpline(points[::-1].copy()))
    assert np.all(reverse.signed_areas() > 0)
    assert reverse.signed_areas().sum() == pytest.approx(first.signed_areas().sum(), rel=1e-3)


def test_mesh_arrays_are_read_only():
    mesh = triangulate(core.ClosedBSpline(starfish()), max_edge=0.2)
    with pytest.raises(ValueError):
        mesh.vertices[0, 0] = 1.0
    assert mesh.triangles.dtype == np.int64 and mesh.boundary.dtype == np.int64
    assert mesh.interior.size == mesh.vertices.shape[0] - mesh.boundary.size


# ---------------------------------------------------------------- the lattice core


def test_dense_mesh_is_the_lattice_away_from_the_curve_with_the_expected_vertex_count():
    curve = core.ClosedBSpline(examples.blob() * 1000.0)
    count = 20_000  # as `python -m app bench` picks max_edge from a vertex count
    max_edge = np.sqrt(2.0 * abs(curve.area) / (np.sqrt(3.0) * count))
    mesh = triangulate(curve, max_edge=max_edge)
    assert 0.98 * count <= mesh.vertices.shape[0] <= 1.04 * count
    assert np.degrees(mesh.angles()).min() >= 20.0
    sides = np.linalg.norm(
        mesh.vertices[mesh.triangles] - mesh.vertices[np.roll(mesh.triangles, 1, axis=1)], axis=2
    )
    equilateral = (np.abs(sides - max_edge) <= 1e-9 * max_edge).all(axis=1)
    assert equilateral.mean() >= 0.9
    assert_disk_bounded_by_the_chords(mesh)


def refined(points):
    curve = core.ClosedBSpline(points)
    mesher = Refinement(curve, Sizing(curve, curve.diameter / 50))
    mesher.refine()
    return curve, mesher


def assert_valid_mesh(curve, mesh):
    assert np.all(mesh.signed_areas() > 0)
    assert_disk_bounded_by_the_chords(mesh)
    assert_simple_boundary_polygon(mesh)
    assert curve.contains(mesh.vertices[mesh.interior]).all()
    assert curve.contains(mesh.vertices[mesh.triangles].mean(axis=1)).all()
    assert np.unique(mesh.vertices, axis=0).shape[0] == mesh.vertices.shape[0]


def test_a_point_entering_a_core_circumcircle_moves_that_triangle_to_the_band():
    curve, mesher = refined(pixel_blob())
    kept = mesher.core_kept.sum()
    _, _, front = mesher._front()
    tail, head = mesher.nodes[front[0]]
    right = np.array([head[1] - tail[1], tail[0] - head[0]])  # the band side: the core is on the left
    point = 0.5 * (tail + head) + 0.05 * right  # inside the circumcircle of the core triangle
    mesher.steiner = np.vstack([mesher.steiner, point])
    mesher.conformed = False
    mesher.refine()
    assert mesher.core_kept.sum() < kept
    mesh = mesher.mesh()
    assert np.linalg.norm(mesh.vertices - point, axis=1).min() == 0.0
    assert_valid_mesh(curve, mesh)
    assert np.degrees(mesh.angles()).min() >= 20.0


def test_a_core_corner_encroaching_a_boundary_edge_leaves_the_core_and_is_deleted():
    curve, mesher = refined(pixel_blob())
    band, fixed, _ = mesher._front()
    corner = band[fixed[band]][0]
    a, b = mesher.boundary_points[:2]
    mesher.nodes[corner] = 0.5 * (a + b) + 0.01 * np.array([b[1] - a[1], a[0] - b[0]]) * mesher.orientation
    mesher.conformed = False
    mesher.refine()
    assert not mesher.alive[corner]
    assert not np.isin(mesher.core_corners[mesher.core_kept], corner).any()
    assert_valid_mesh(curve, mesher.mesh())


def test_a_point_on_a_band_node_is_dropped():
    curve, mesher = refined(pixel_blob())
    band, fixed, _ = mesher._front()
    node = mesher.nodes[band[~fixed[band]][0]]
    mesher.steiner = np.vstack([mesher.steiner, node])
    mesher.conformed = False
    mesher.refine()
    points = mesher.band_points
    assert np.unique(points, axis=0).shape[0] == points.shape[0]
    mesh = mesher.mesh()
    assert_valid_mesh(curve, mesh)
    assert np.linalg.norm(mesh.vertices - node, axis=1).min() == 0.0


# ---------------------------------------------------------------- near-cusps


NEAR_CUSP_GAPS = [1e-4, 1e-3, 1e-2, 0.1, 0.9, 2.0]


@pytest.fixture(scope="module")
def blob_vertex_count():
    return triangulate(core.ClosedBSpline(pixel_blob())).vertices.shape[0]


@pytest.mark.parametrize("turn_degrees", [60, 120, 135])
@pytest.mark.parametrize("gap", NEAR_CUSP_GAPS)
def test_near_cusp_cages_mesh(gap, turn_degrees, blob_vertex_count):
    # Two almost equal control points make a near-cusp; unless the cage turns back over
    # them (then the curve loops and ClosedBSpline rejects it, see test_bspline) it meshes.
    curve = core.ClosedBSpline(near_cusp(gap, turn_degrees))
    mesh = triangulate(curve)
    np.testing.assert_allclose(
        mesh.vertices[mesh.boundary], curve(mesh.boundary_parameters), rtol=0, atol=1e-12 * curve.diameter
    )
    t = mesh.boundary_parameters
    assert np.all(np.diff(t) > 0) and t[0] >= 0 and t[-1] < curve.n
    assert np.all(mesh.signed_areas() > 0)
    assert_disk_bounded_by_the_chords(mesh)
    assert_simple_boundary_polygon(mesh)
    assert curve.contains(mesh.vertices[mesh.interior]).all()
    assert mesh.vertices.shape[0] <= 1.2 * blob_vertex_count


# ---------------------------------------------------------------- folded triangles


def test_folded_triangles():
    mesh = triangulate(core.ClosedBSpline(starfish()), max_edge=0.2)
    assert not folded_triangles(mesh, mesh.vertices).any()
    rotated = mesh.vertices @ np.array([[0.0, -1.0], [1.0, 0.0]]) * 3.0 + 5.0
    assert not folded_triangles(mesh, rotated).any()
    mirrored = mesh.vertices * np.array([-1.0, 1.0])
    assert folded_triangles(mesh, mirrored).all()
    collapsed = mesh.vertices.copy()
    v = mesh.interior[0]
    ring = np.flatnonzero((mesh.triangles == v).any(axis=1))
    a, b, _ = np.roll(mesh.triangles[ring[0]], -list(mesh.triangles[ring[0]]).index(v))
    collapsed[v] = 0.5 * (mesh.vertices[b] + mesh.vertices[_])  # onto the opposite side
    folded = folded_triangles(mesh, collapsed)
    assert folded[ring[0]]
    assert not folded[np.setdiff1d(np.arange(mesh.triangles.shape[0]), ring)].any()


def test_a_uniform_shrink_folds_nothing_at_any_scale_and_a_collapse_at_that_scale_does():
    """Areas are compared at the deformation's scale: a shrink to 1e-6 scales every area by 1e-12
    (below the tolerance of the mesh's own areas), which is no fold; a triangle collapsed within
    that shrink is."""
    mesh = triangulate(core.ClosedBSpline(starfish()), max_edge=0.2)
    shrunk = 1e-6 * mesh.vertices + 3.0
    assert not folded_triangles(mesh, shrunk).any()
    v = mesh.interior[0]
    ring = np.flatnonzero((mesh.triangles == v).any(axis=1))
    _, b, c = np.roll(mesh.triangles[ring[0]], -list(mesh.triangles[ring[0]]).index(v))
    shrunk[v] = 0.5 * (shrunk[b] + shrunk[c])
    assert folded_triangles(mesh, shrunk)[ring[0]]


# ---------------------------------------------------------------- errors


@pytest.mark.parametrize(
    ("max_edge", "message"),
    [
        (0.0, "max_edge must be a finite number > 0"),
        (-1.0, "max_edge must be a finite number > 0"),
        (float("nan"), "max_edge must be a finite number > 0"),
        ("big", "max_edge must be a number"),
        (
            1e-5,
            r"max_edge=1e-05 is too small: the mesh would have about .* vertices, more than the 5,000,000",
        ),
        (
            1e300,
            r"max_edge=1e\+300 is longer than the domain; use 0 < max_edge <= \d\.\d+ "
            r"\(the curve's diameter\)",
        ),
    ],
)
def test_triangulate_rejects_bad_max_edge(max_edge, message):
    curve = core.ClosedBSpline(starfish())
    with pytest.raises(ValueError, match=message):
        triangulate(curve, max_edge=max_edge)


def test_the_longest_max_edge_allowed_is_the_diameter():
    curve = core.ClosedBSpline(starfish())
    assert triangulate(curve, max_edge=curve.diameter).triangles.shape[0] > 0  # the limit itself meshes
    with pytest.raises(ValueError, match="longer than the domain"):
        triangulate(curve, max_edge=curve.diameter * (1 + 1e-12))


def test_triangulate_rejects_a_non_curve():
    with pytest.raises(ValueError, match="curve must be a core.ClosedBSpline"):
        triangulate(starfish())


def test_mesh_validates_its_arrays():
    vertices = np.array([[0, 0], [1, 0], [0, 1]], dtype=float)
    with pytest.raises(ValueError, match=r"triangles must have shape \(T, 3\)"):
        Mesh(vertices, np.array([[0, 1]]), np.arange(3), np.zeros(3))
    with pytest.raises(ValueError, match="triangles must index vertices 0..2"):
        Mesh(vertices, np.array([[0, 1, 3]]), np.arange(3), np.zeros(3))
    with pytest.raises(ValueError, match="the same length"):
        Mesh(vertices, np.array([[0, 1, 2]]), np.arange(3), np.zeros(2))
    mesh = Mesh(vertices, np.array([[0, 1, 2]]), np.arange(3), np.zeros(3))
    with pytest.raises(ValueError, match="vertices must have 3 rows like the mesh"):
        mesh.signed_areas(np.zeros((4, 2)))
    with pytest.raises(ValueError, match="mesh must be a core.Mesh"):
        folded_triangles("mesh", vertices)


def test_progress_rises_to_one_and_can_abandon_the_meshing():
    curve = core.ClosedBSpline(wavy_star())
    seen = []
    mesh = triangulate(curve, max_edge=curve.diameter / 120, progress=seen.append)
    assert len(seen) >= 6 and seen[-1] == 1.0 and 0.0 < seen[0] <= 0.05
    assert np.all(np.diff(seen) >= 0) and all(0.0 <= f <= 1.0 for f in seen)
    assert len(mesh.vertices) > 5000  # phases and rounds reported along the way, not only at the end

    class Stop(Exception):
        pass

    def stop_halfway(fraction):
        if fraction > 0.5:
            raise Stop

    with pytest.raises(Stop):
        triangulate(curve, max_edge=curve.diameter / 120, progress=stop_halfway)


def test_sizing_that_stops_resampling_keeps_its_samples_measured(monkeypatch):
    # The crowded circle needs 3 resampling rounds; allowed 1, the sizing must still measure the
    # samples it ends with (a 400-point star at max_edge = diameter / 20 needs more than 12
    # rounds: triangulate raised numpy's "fp and xp are not of the same length").
    monkeypatch.setattr("core.meshes.sizing.MAX_RESAMPLING", 1)
    curve = core.ClosedBSpline(examples.crowded(12, 4, 0.1))
    sizing = Sizing(curve, curve.diameter / 50)
    assert sizing.points.shape == (sizing.t.size, 2)
    assert sizing.h.shape == (sizing.t.size,) and sizing.arc.shape == (sizing.t.size + 1,)
    np.testing.assert_array_equal(sizing.points, curve(sizing.t))
    mesh = triangulate(curve)
    np.testing.assert_array_equal(mesh.vertices[mesh.boundary], curve(mesh.boundary_parameters))
