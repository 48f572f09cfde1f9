"""Pure editing rules of the viewer (app.viewer.editing): no GL, no window."""

import numpy as np
import pytest

import core
from app.render.viewport import View
from app.viewer import editing
from core.curves import examples


@pytest.fixture
def star():
    return examples.starfish(points_per_arm=2) * 100 + 300


def test_window_and_image_coordinates_are_inverse():
    view = View(1.7, (40.0, -12.5))
    points = np.random.default_rng(0).uniform(-50, 500, (20, 2))
    window = editing.to_window(view, points)
    np.testing.assert_allclose(window, view.offset + 1.7 * points)
    np.testing.assert_allclose(editing.to_image(view, window), points)


def test_nearest_handle_within_radius_only():
    handles = np.array([[10.0, 10.0], [50.0, 10.0], [50.0, 10.0], [100.0, 100.0]])
    assert editing.nearest_handle(handles, (13, 14)) == 0  # 5 px away
    assert editing.nearest_handle(handles, (13, 14), radius=4.9) is None
    assert editing.nearest_handle(handles, (51, 11)) == 2  # a doubled point: the one drawn on top
    assert editing.nearest_handle(np.zeros((0, 2)), (0, 0)) is None


def test_curve_points_match_core(star):
    curve = core.ClosedBSpline(star)
    t = np.arange(len(star) * editing.SAMPLES_PER_SPAN) / editing.SAMPLES_PER_SPAN
    np.testing.assert_allclose(editing.curve_points(star), curve(t), atol=1e-12)


def test_insert_point_goes_into_the_nearest_span(star):
    target = star + np.array([5.0, -3.0])
    target[4] += 20  # a deformed target
    curve = core.ClosedBSpline(star)
    # A point just outside the curve where it touches polygon edge (6, 7) at its midpoint t = 7.
    on_curve = curve(np.array([7.0]))[0]
    click = on_curve + 3.0
    first, second = editing.insertion_span(star, click)
    assert (first, second) == (6, 7)
    cage, new_target, index = editing.insert_point(star, target, click)
    assert index == 7 and len(cage) == len(star) + 1
    np.testing.assert_array_equal(cage[7], click)
    np.testing.assert_array_equal(np.delete(cage, 7, axis=0), star)
    np.testing.assert_allclose(new_target[7], click + np.array([5.0, -3.0]))  # neighbours' mean displacement
    core.ClosedBSpline(cage)  # still a simple curve


def test_insert_on_the_closing_span_and_while_placing():
    square = np.array([[0.0, 0.0], [100.0, 0.0], [100.0, 100.0], [0.0, 100.0]])
    cage, _, index = editing.insert_point(square, square, (-2.0, 50.0))  # the edge from the last to the first
    assert index == 4
    placed = np.zeros((0, 2))
    for point in [(1, 2), (5, 6), (9, 1)]:
        placed, target, index = editing.insert_point(placed, placed, point)
        assert index == len(placed) - 1
    np.testing.assert_array_equal(placed, [[1, 2], [5, 6], [9, 1]])


def test_delete_point(star):
    cage, target = editing.delete_point(star, star + 1, 3)
    np.testing.assert_array_equal(cage, np.delete(star, 3, axis=0))
    np.testing.assert_array_equal(target, np.delete(star + 1, 3, axis=0))
    with pytest.raises(ValueError, match="at least 3 control points"):
        editing.delete_point(star[:3], star[:3], 0)
    with pytest.raises(ValueError, match="no control point 99"):
        editing.delete_point(star, star, 99)


def test_moving_points_moves_only_those(star):
    moved = editing.move_points(star, (2, 5), [10, -4])
    np.testing.assert_allclose(moved[[2, 5]], star[[2, 5]] + [10, -4])
    np.testing.assert_array_equal(np.delete(moved, [2, 5], axis=0), np.delete(star, [2, 5], axis=0))
    assert moved is not star and np.array_equal(editing.move_points(star, (), [1, 1]), star)


def test_subdivide_keeps_the_curve(star):
    refined = editing.subdivide(star)
    np.testing.assert_allclose(refined, core.ClosedBSpline(star).subdivide().control_points)
    t = np.linspace(0, len(star), 200, endpoint=False)
    np.testing.assert_allclose(core.ClosedBSpline(refined)(2 * t), core.ClosedBSpline(star)(t), atol=1e-10)
    crossing = np.array([[0.0, 0.0], [10.0, 10.0], [10.0, 0.0], [0.0, 10.0]])  # a target may cross itself
    assert editing.subdivide(crossing).shape == (8, 2)


def test_cage_problem_messages(star):
    assert editing.cage_problem(star) is None
    assert "place 1 more control point" in editing.cage_problem(star[:2])
    crossing = np.array([[0.0, 0.0], [10.0, 10.0], [10.0, 0.0], [0.0, 10.0]])
    assert "crosses or touches itself" in editing.cage_problem(crossing)


def test_default_max_edge_aims_at_the_vertex_count(star):
    edge = editing.default_max_edge(star, target_vertices=3000)
    vertices = len(core.triangulate(core.ClosedBSpline(star), max_edge=edge).vertices)
    assert 0.6 * 3000 < vertices < 1.6 * 3000
    assert edge == float(f"{edge:.3g}")  # stable in a session file


def test_zoom_keeps_the_point_under_the_cursor_and_pan_moves():
    view = View(1.5, (30.0, 40.0))
    cursor = (400.0, 300.0)
    under = editing.to_image(view, cursor)
    zoomed = editing.zoom_about(view, cursor, 1.15**3)
    assert zoomed.scale == pytest.approx(1.5 * 1.15**3)
    np.testing.assert_allclose(editing.to_image(zoomed, cursor), under)
    assert editing.zoom_about(view, cursor, 1e9).scale == 64.0  # limited
    assert editing.pan(view, (5, -7)).offset == (35.0, 33.0)


def test_ellipse_cage_is_inside_the_image():
    cage = editing.ellipse_cage(640, 480)
    assert editing.cage_problem(cage) is None
    assert (cage >= 0).all() and (cage[:, 0] <= 640).all() and (cage[:, 1] <= 480).all()
