"""What input does to the viewer's state (app.viewer.controller), without a window."""

import json
from pathlib import Path

import numpy as np
import pytest

from app.io.files import kernel_names
from app.render.viewport import View
from app.viewer import commands, controller, editing
from app.viewer.controller import LEFT, MIDDLE, RIGHT
from app.viewer.state import AppState, Display, Document, History, Snapshot
from core.curves import examples
from core.curves.bspline import ClosedBSpline
from core.curves.interpolating_spline import interpolation_parameters

STAR = examples.starfish(points_per_arm=2) * np.array([150.0, -150.0]) + np.array([320.0, 240.0])


@pytest.fixture
def state():
    snapshot = Snapshot(Path("star.png"), STAR, STAR)
    image = np.zeros((480, 640, 4), np.uint8)
    return AppState(
        Document(History(snapshot), snapshot, image, Path("session.json")),
        display=Display(viewport=View(1.5, (100.0, 20.0))),
    )


def window_of(state, point):
    return editing.to_window(state.display.viewport, point)


def drag(state, start, end, steps=5, button=LEFT):
    controller.pointer(state, "press", *start, button=button)
    for fraction in np.linspace(0, 1, steps + 1)[1:]:
        controller.pointer(state, "move", *(np.asarray(start) + fraction * (np.asarray(end) - start)))


def test_dragging_a_target_point_is_one_undo_step(state):
    start = window_of(state, STAR[0])
    drag(state, start, start + [30, 15])
    assert state.selection.drag is not None and state.selection.drag.kind == "target"
    assert not state.document.history.can_undo  # committed only on release
    np.testing.assert_allclose(state.document.live.target[0], STAR[0] + np.array([30, 15]) / 1.5)
    controller.pointer(state, "release", *(start + [30, 15]))
    assert state.selection.drag is None and state.document.session_dirty
    assert state.document.history.current == state.document.live and state.selection.selected == 0
    np.testing.assert_array_equal(state.document.live.cage, STAR)
    commands.command(state, "undo")
    assert state.document.live == Snapshot(Path("star.png"), STAR, STAR)
    commands.command(state, "redo")
    np.testing.assert_allclose(state.document.live.target[0], STAR[0] + np.array([30, 15]) / 1.5)


def test_a_click_without_a_move_records_nothing(state):
    start = window_of(state, STAR[3])
    controller.pointer(state, "press", *start)
    controller.pointer(state, "release", *start)
    assert not state.document.history.can_undo and state.selection.selected == 3


def test_escape_cancels_the_drag(state):
    start = window_of(state, STAR[2])
    drag(state, start, start + [40, 0])
    commands.command(state, "cancel")
    assert state.selection.drag is None and state.document.live == state.document.history.current
    controller.pointer(state, "release", *(start + [40, 0]))
    assert not state.document.history.can_undo


def test_right_or_middle_drag_pans_and_wheel_and_keys_zoom(state):
    drag(state, (900.0, 900.0), (950.0, 880.0), button=RIGHT)
    controller.pointer(state, "release", 950.0, 880.0, button=RIGHT)
    assert (
        state.display.viewport.offset == (150.0, 0.0)
        and state.display.viewport_dirty
        and not state.display.viewport_fitted
    )
    assert not state.document.history.can_undo
    drag(state, (10.0, 10.0), (20.0, 20.0), button=MIDDLE)
    controller.pointer(state, "release", 20.0, 20.0, button=MIDDLE)
    assert state.display.viewport.offset == (160.0, 10.0)
    under = editing.to_image(state.display.viewport, (500, 400))
    controller.pointer(state, "scroll", 500, 400, amount=2)
    assert state.display.viewport.scale == pytest.approx(1.5 * 1.15**2)
    np.testing.assert_allclose(editing.to_image(state.display.viewport, (500, 400)), under)
    centre = (0.5 * (state.screen.canvas_left + 1280), 0.5 * (1024 - controller.STATUS_HEIGHT))
    under = editing.to_image(state.display.viewport, centre)
    commands.command(state, "zoom", 1.0)  # the 1 key: 100 % about the canvas centre
    assert state.display.viewport.scale == pytest.approx(1.0)
    np.testing.assert_allclose(editing.to_image(state.display.viewport, centre), under)
    commands.command(state, "zoom", "in")
    commands.command(state, "zoom", "in")
    commands.command(state, "zoom", "out")
    assert state.display.viewport.scale == pytest.approx(controller.KEY_ZOOM_STEP)
    commands.command(state, "fit_view")
    assert state.display.viewport_fitted


def test_rubber_band_and_shift_click_select_handles_that_move_together(state):
    points = window_of(state, STAR)
    low, high = points[[0, 1]].min(axis=0) - 5, points[[0, 1]].max(axis=0) + 5
    others = [i for i in range(len(STAR)) if np.all((points[i] >= low) & (points[i] <= high))]
    drag(state, low, high)  # on empty canvas: a rubber band, no pan
    assert controller.band_corners(state) is not None and state.display.viewport.offset == (100.0, 20.0)
    controller.pointer(state, "release", *high)
    assert (
        state.selection.group == frozenset(others)
        and {0, 1} <= state.selection.group
        and not state.document.history.can_undo
    )
    controller.pointer(state, "press", *points[4], shift=True)  # Shift+click adds one ...
    controller.pointer(state, "release", *points[4])
    controller.pointer(state, "press", *points[1], shift=True)  # ... and takes one out
    controller.pointer(state, "release", *points[1])
    group = sorted((set(others) | {4}) - {1})
    assert state.selection.group == frozenset(group) and state.document.live == state.document.history.current
    drag(state, points[4], points[4] + [30, -15])  # dragging one moves them all
    controller.pointer(state, "release", *(points[4] + [30, -15]))
    moved = np.array(STAR)
    moved[group] += np.array([30, -15]) / 1.5
    np.testing.assert_allclose(state.document.live.target, moved)
    np.testing.assert_array_equal(state.document.live.cage, STAR)
    assert state.status.message == f"moved {len(group)} control points"
    commands.command(state, "undo")  # one step
    np.testing.assert_array_equal(state.document.live.target, STAR)
    controller.pointer(state, "press", 1200.0, 1000.0)  # a click on empty canvas clears it
    controller.pointer(state, "release", 1200.0, 1000.0)
    assert state.selection.group == frozenset() and state.selection.selected is None


def test_a_cancelled_drag_leaves_nothing_selected_and_delete_needs_cage_mode(state):
    start = window_of(state, STAR[2])
    drag(state, start, start + [40, 0])
    commands.command(state, "cancel")
    assert state.selection.selected is None and state.selection.group == frozenset()
    controller.pointer(state, "press", *start)
    controller.pointer(state, "release", *start)
    assert state.selection.selected == 2
    for key in ("delete", "delete"):  # Delete and Backspace in deform mode: nothing happens
        commands.command(state, key)
        assert (
            state.document.live.n == len(STAR)
            and state.status.message_is_error
            and "cage mode" in state.status.message
        )
    commands.command(state, "edit_mode", "cage")
    points = window_of(state, STAR)
    controller.pointer(state, "press", *points[2], shift=True)
    controller.pointer(state, "release", *points[2])
    controller.pointer(state, "press", *points[5], shift=True)
    controller.pointer(state, "release", *points[5])
    commands.command(state, "delete")  # the selection, as one step
    np.testing.assert_array_equal(state.document.live.cage, np.delete(STAR, [2, 5], axis=0))
    assert state.status.message == "deleted control 2 points" and state.selection.group == frozenset()
    commands.command(state, "undo")
    assert state.document.live.n == len(STAR)


def test_cage_mode_moves_inserts_and_deletes_source_points(state):
    commands.command(state, "edit_mode", "cage")
    start = window_of(state, STAR[1])
    drag(state, start, start + [6, 3])
    controller.pointer(state, "release", *(start + [6, 3]))
    moved = state.document.live
    np.testing.assert_allclose(moved.cage[1] - STAR[1], np.array([6, 3]) / 1.5)
    np.testing.assert_allclose(moved.target, moved.cage)  # the target point came along
    # A click away from the handles inserts a point into the nearest span (and grabs it).
    curve = editing.curve_points(moved.cage)
    click = window_of(state, curve[5 * editing.SAMPLES_PER_SPAN + 2])
    controller.pointer(state, "press", *click)
    controller.pointer(state, "release", *click)
    assert state.document.live.n == len(STAR) + 1 and state.selection.selected is not None
    index = state.selection.selected
    # Right-click deletes it again.
    controller.pointer(state, "press", *window_of(state, state.document.live.cage[index]), button=RIGHT)
    controller.pointer(state, "release", *window_of(state, state.document.live.cage[index]), button=RIGHT)
    assert state.document.live == moved
    assert state.document.history.undo() is not None and state.document.history.current.n == len(STAR) + 1


def test_a_source_move_that_crosses_the_curve_is_undone(state):
    commands.command(state, "edit_mode", "cage")
    start = window_of(state, STAR[0])  # the top tip, dragged down through the whole star
    drag(state, start, window_of(state, STAR[5] + [0, 200]))
    controller.pointer(state, "release", *window_of(state, STAR[5] + [0, 200]))
    assert state.document.live == state.document.history.current and not state.document.history.can_undo
    assert state.status.message_is_error and "crosses or touches itself" in state.status.message


def test_commands(state):
    commands.command(state, "kernel", "mean-value")
    assert state.document.live.kernel == "mean-value"
    commands.command(state, "kernel", "nonsense")
    assert state.status.message_is_error and state.document.live.kernel == "mean-value"
    names = kernel_names()
    for step in range(len(names)):  # K walks through every kernel and back to the first
        assert state.document.live.kernel == names[(names.index("mean-value") + step) % len(names)]
        commands.command(state, "cycle_kernel", "next")
    assert state.document.live.kernel == "mean-value" and state.status.message == "kernel: mean-value"
    commands.command(state, "cycle_kernel", "previous")
    assert state.document.live.kernel == names[names.index("mean-value") - 1]
    commands.command(state, "kernel", "power")
    commands.command(state, "power", 2.5)
    commands.command(state, "shift", "integral")
    assert state.document.live.kernel_params() == {"power": 2.5, "shift": "integral"}
    commands.command(state, "subdivide")
    assert state.document.live.n == 2 * len(STAR)
    commands.command(state, "undo")
    target = state.document.live.target.copy()
    target[3] += 20
    controller.commit(state, state.document.live.replace(target=target))
    commands.command(state, "reset_target")
    np.testing.assert_array_equal(state.document.live.target, state.document.live.cage)
    commands.command(state, "view_mode", "basis")
    commands.command(state, "toggle", "show_wireframe")
    assert state.display.view_mode == "basis" and state.display.show_wireframe
    commands.command(state, "edit_mode", "cage")
    commands.command(state, "delete")
    assert "select a control point" in state.status.message
    assert not commands.command(state, "fly")


def test_fit_command_fits_the_silhouette(state):
    image = np.zeros((480, 640, 4), np.uint8)
    image[..., 3] = 255
    image[150:330, 200:460, :3] = 255
    state.document.image = image
    commands.command(state, "fit", 12)
    cage = state.document.live.cage
    assert len(cage) == 12 and np.array_equal(cage, state.document.live.target)
    assert 180 < cage[:, 0].min() < 220 and 440 < cage[:, 0].max() < 480


def test_fit_view_centres_the_image_right_of_the_panel(state):
    state.screen.canvas_left = 300.0
    controller.fit_view(state, (1280, 1024))  # the image fits: shown at 100%
    assert state.display.viewport.scale == 1.0
    corner, far = editing.to_window(state.display.viewport, [[0, 0], [640, 480]])
    assert corner[0] - 300 == pytest.approx(1280 - far[0], abs=0.1)
    assert corner[1] == pytest.approx(1024 - controller.STATUS_HEIGHT - far[1], abs=0.1)
    controller.fit_view(state, (700, 500))  # too small a window: fitted with a margin
    corner, far = editing.to_window(state.display.viewport, [[0, 0], [640, 480]])
    assert state.display.viewport.scale < 1 and corner[0] >= 300 + 23.9 and far[0] <= 700 - 23.9


def test_opening_dropped_files(tmp_path, monkeypatch):
    """What a file dropped on the window (or chosen in the dialog) does, without a window.

    An image or a session switches to that document's own session file, and the
    file left behind is never written again; a cage file is an undoable edit.
    """
    from app.io.files import write_cage
    from app.viewer.demos import demo_files
    from app.viewer.documents import open_document
    from app.viewer.session_files import session_path_for
    from app.viewer.window import Options, Viewer

    monkeypatch.setenv("TRANSFINITE_STATE_DIR", str(tmp_path))
    files, pattern = demo_files("starfish"), demo_files("pattern")
    first = tmp_path / "s.json"
    viewer = Viewer(open_document(files.image, files.cage, first), Options())
    try:
        state = viewer.state
        controller.commit(state, state.document.live.replace(kernel="mean-value"))
        viewer.open_path(pattern.image)  # an image: its own session, a fitted cage, no undo step
        assert state.document.live.image.name == "pattern.png" and state.document.image.shape == (480, 640, 4)
        assert not state.document.history.can_undo and np.array_equal(
            state.document.live.cage, state.document.live.target
        )
        assert state.document.session_path == session_path_for(pattern.image)
        assert json.loads(first.read_text())["kernel"] == "mean-value"  # saved when it was left
        left_behind = first.read_bytes()
        square = np.array([[100.0, 100.0], [500.0, 100.0], [500.0, 400.0], [100.0, 400.0]])
        write_cage(tmp_path / "cage.json", square)
        viewer.open_path(tmp_path / "cage.json")  # a cage file: an edit of this document
        np.testing.assert_array_equal(state.document.live.cage, square)
        assert state.document.history.can_undo
        viewer.open_path(first)  # a session: everything, and it saves there from now on
        assert state.document.session_path == first and state.document.live.kernel == "mean-value"
        assert state.document.live.image.name == "starfish.png" and state.document.image.shape[:2] == (
            480,
            640,
        )
        viewer.open_path(pattern.image)  # its session was saved when it was left: restored
        np.testing.assert_array_equal(state.document.live.cage, square)
        commands.command(state, "undo")
        assert not np.array_equal(state.document.live.cage, square)  # its history came back too
        assert first.read_bytes() == left_behind
        viewer.open_path(tmp_path / "missing.png")
        assert state.status.message_is_error and "no such file" in state.status.message
        assert state.document.session_path == session_path_for(pattern.image)
    finally:
        viewer.basis.precompute.close()


def click(state, point, ctrl=False):
    x, y = window_of(state, point)
    controller.pointer(state, "press", x, y, ctrl=ctrl)
    controller.pointer(state, "release", x, y)


def test_a_new_cage_is_drawn_click_by_click_with_gimps_keys(state, monkeypatch):
    clock = iter(np.arange(0.0, 100.0, 1.0))  # a second between clicks: no double clicks
    monkeypatch.setattr(controller.time, "monotonic", lambda: next(clock))
    before = state.document.history.current
    commands.command(state, "cage_drawing", "control")  # the clicks are the control points
    commands.command(state, "new_cage")
    assert (
        state.selection.edit_mode == "cage"
        and state.document.live.n == 0
        and state.selection.drawing is not None
    )
    square = [[100, 100], [400, 120], [420, 380], [90, 300]]
    for point in square:
        click(state, point)
    commands.command(state, "delete")  # Backspace removes the last point ...
    assert state.document.live.n == 3
    click(state, square[3], ctrl=True)  # ... and Ctrl+click puts it back as a sharp corner
    np.testing.assert_array_equal(state.document.live.cage, np.array([*square, square[3]], float))
    assert (
        not state.document.history.can_undo and state.document.history.current == before
    )  # nothing committed yet
    commands.command(state, "kernel", "mean-value")  # edits wait until the cage is made
    assert state.status.message_is_error and state.document.live.kernel == before.kernel
    click(state, square[0])  # the first point closes the curve
    assert state.selection.drawing.closed and state.document.live.n == 5
    click(state, [250, 250])  # a closed curve takes no more points
    assert state.document.live.n == 5
    commands.command(state, "confirm")  # Enter makes it the cage, one undo step
    assert state.selection.drawing is None and state.selection.edit_mode == "deform"
    np.testing.assert_array_equal(state.document.live.cage, np.array([*square, square[3]], float))
    np.testing.assert_array_equal(state.document.live.target, state.document.live.cage)
    assert state.document.history.current == state.document.live and state.document.live.image == before.image
    commands.command(state, "undo")
    assert state.document.live == before


def test_by_default_the_new_cage_passes_through_the_clicks_with_corners_where_asked(state, monkeypatch):
    clock = iter(np.arange(0.0, 100.0, 1.0))
    monkeypatch.setattr(controller.time, "monotonic", lambda: next(clock))
    commands.command(state, "new_cage")
    house = np.array([[100.0, 300.0], [300.0, 300.0], [300.0, 150.0], [200.0, 60.0], [100.0, 150.0]])
    corners = [True, True, False, True, False]
    for point, corner in zip(house, corners, strict=True):
        click(state, point, ctrl=corner)
    # The handles are the clicks; the control points those of the curve through them.
    np.testing.assert_allclose(controller.drawing.clicked_points(state), house, atol=1e-12)
    commands.command(state, "confirm")
    commands.command(state, "confirm")
    cage = state.document.history.current.cage
    assert len(cage) == 8
    spline = ClosedBSpline(cage)
    t = interpolation_parameters(corners)
    np.testing.assert_allclose(spline(t), house, rtol=0, atol=1e-9)
    for corner in house[[0, 1, 3]]:  # a corner is a doubled control point there
        (rows,) = np.nonzero(np.all(np.abs(cage - corner) < 1e-12, axis=1))
        assert len(rows) == 2 and rows[1] == rows[0] + 1
    # Switching to control points while drawing redraws the cage being placed from the same clicks.
    commands.command(state, "new_cage")
    for point in house[:3]:
        click(state, point)
    assert not np.allclose(state.document.live.cage, house[:3])
    commands.command(state, "cage_drawing", "control")
    np.testing.assert_allclose(state.document.live.cage, house[:3])
    commands.command(state, "cage_drawing", "nonsense")
    assert state.status.message_is_error and state.selection.cage_drawing == "control"


def test_a_double_click_makes_a_corner_and_crossing_cages_are_refused(state, monkeypatch):
    times = iter([0.0, 1.0, 1.2, 5.0, 9.0])  # the 2nd and 3rd clicks are 0.2 s apart
    monkeypatch.setattr(controller.time, "monotonic", lambda: next(times))
    commands.command(state, "new_cage")
    for point in ([100, 100], [400, 100], [400, 100]):
        click(state, point)
    assert state.document.live.n == 3 and np.array_equal(
        state.document.live.cage[1], state.document.live.cage[2]
    )
    for point in ([100, 400], [400, 400]):  # a bow tie: the closing span crosses the others
        click(state, point)
    commands.command(state, "confirm")  # Enter closes ... or says why it cannot
    assert (
        not state.selection.drawing.closed
        and state.status.message_is_error
        and "cannot close" in state.status.message
    )
    commands.command(state, "delete")
    commands.command(state, "confirm")  # a triangle with one sharp corner closes
    assert state.selection.drawing.closed and not state.status.message_is_error
    commands.command(state, "delete")  # Backspace reopens a closed curve
    assert not state.selection.drawing.closed and state.document.live.n == 4
    commands.command(state, "cancel")  # Esc abandons the whole new cage
    assert state.selection.drawing is None and state.document.live == state.document.history.current
    np.testing.assert_array_equal(state.document.live.cage, STAR)


def test_fit_on_a_photo_asks_for_a_rectangle_around_the_subject(state, monkeypatch):
    import app.viewer.documents as sessions

    asked = []

    def fake_fit(image, points=16, rect=None):
        asked.append((points, rect))
        return np.array([[10.0, 10.0], [60.0, 10.0], [60.0, 50.0], [10.0, 50.0]]), "fitted"

    monkeypatch.setattr(sessions, "fit_or_ellipse", fake_fit)
    state.document.image[..., 3] = 255  # an opaque picture: a photograph
    commands.command(state, "fit")
    assert state.selection.fit_rect and not asked and "rectangle" in state.status.message
    drag(state, window_of(state, [100, 80]), window_of(state, [300, 200]))  # not a pan, not a band
    assert state.display.viewport.offset == (100.0, 20.0) and state.selection.group == frozenset()
    controller.pointer(state, "release", *window_of(state, [300, 200]))
    ((points, rect),) = asked
    assert points == len(STAR) and rect == pytest.approx((100.0, 80.0, 200.0, 120.0))
    assert not state.selection.fit_rect and state.document.live.n == 4 and state.document.history.can_undo
    commands.command(state, "fit")  # Enter: the whole picture
    commands.command(state, "confirm")
    assert asked[-1] == (16, None) and not state.selection.fit_rect  # 4 points now: the default count
    commands.command(state, "fit")  # Esc: nothing
    commands.command(state, "cancel")
    assert not state.selection.fit_rect and len(asked) == 2
    state.document.image[..., 3] = 0  # an image with a silhouette in its alpha channel fits at once
    commands.command(state, "fit")
    assert len(asked) == 3 and asked[-1][1] is None and not state.selection.fit_rect


# -- keyframes and the timeline ---------------------------------------------------------------


def test_keyframes_are_added_moved_and_deleted_as_undoable_edits(state):
    commands.command(state, "add_keyframe")  # the rest pose at 0 s
    commands.command(state, "seek", 1.0)
    start = window_of(state, STAR[0])
    drag(state, start, start + [30, 0])
    controller.pointer(state, "release", *(start + [30, 0]))
    commands.command(state, "add_keyframe")
    keyframes = state.document.live.keyframes
    assert [k.time for k in keyframes] == [0.0, 1.0] and state.playback.keyframe == 1
    np.testing.assert_allclose(keyframes[1].target[0], STAR[0] + [20, 0])
    np.testing.assert_array_equal(keyframes[0].target, STAR)
    assert state.document.session_dirty and state.document.history.current == state.document.live
    commands.command(state, "undo")  # one step: the second keyframe
    assert len(state.document.live.keyframes) == 1
    commands.command(state, "redo")
    commands.command(state, "keyframe_time", (1, 2.0))
    assert [k.time for k in state.document.live.keyframes] == [0.0, 2.0] and state.playback.time == 2.0
    commands.command(state, "keyframe_time", (1, 0.0))  # onto the other one: refused
    assert state.status.message_is_error and [k.time for k in state.document.live.keyframes] == [0.0, 2.0]
    commands.command(state, "undo")
    assert [k.time for k in state.document.live.keyframes] == [0.0, 1.0]
    commands.command(state, "select_keyframe", 0)
    commands.command(state, "delete_keyframe")
    assert [k.time for k in state.document.live.keyframes] == [1.0] and state.playback.keyframe is None
    commands.command(state, "undo")
    assert len(state.document.live.keyframes) == 2


def two_keyframes(state):
    moved = STAR.copy()
    moved[0] += [40, 0]
    from app.warp.keyframes import Keyframe

    snapshot = state.document.live.replace(keyframes=(Keyframe(0.0, STAR), Keyframe(2.0, moved)))
    controller.commit(state, snapshot)
    return moved


def test_scrubbing_and_playback_show_the_interpolation_without_editing(state):
    moved = two_keyframes(state)
    steps = len(state.document.history.undo_steps)
    commands.command(state, "seek", 1.0)
    np.testing.assert_allclose(state.document.live.target[0], STAR[0] + [20, 0])  # halfway, by symmetry
    commands.command(state, "interpolation", "linear")
    commands.command(state, "seek", 0.5)
    np.testing.assert_allclose(state.document.live.target[0], STAR[0] + [10, 0])
    assert len(state.document.history.undo_steps) == steps + 1  # the interpolation; seeking records nothing
    commands.command(state, "playback")
    assert state.playback.playing and state.playback.time == 0.5
    controller.advance(state, 1.0)
    np.testing.assert_allclose(state.document.live.target[0], STAR[0] + [30, 0])
    controller.advance(state, 1.0)  # past the end: loops
    assert state.playback.playing and state.playback.time == pytest.approx(0.5)
    state.playback.loop = False
    controller.advance(state, 5.0)
    assert not state.playback.playing and state.playback.time == 2.0
    np.testing.assert_array_equal(state.document.live.target, moved)
    commands.command(state, "playback")
    controller.pointer(state, "press", *window_of(state, STAR[3]))  # a hand on the cage pauses
    assert not state.playback.playing


def test_cage_edits_carry_the_keyframes_along_and_a_new_cage_drops_them(state):
    moved = two_keyframes(state)
    state.selection.edit_mode = "cage"
    start = window_of(state, STAR[5])
    drag(state, start, start + [15, 0])
    controller.pointer(state, "release", *(start + [15, 0]))
    for keyframe, pose in zip(state.document.live.keyframes, (STAR, moved), strict=True):
        np.testing.assert_allclose(keyframe.target[5], pose[5] + [10, 0])  # came along
    commands.command(state, "subdivide")
    assert all(len(k.target) == state.document.live.n == 2 * len(STAR) for k in state.document.live.keyframes)
    commands.command(state, "undo")
    state.selection.selected = 2
    commands.command(state, "delete")
    assert all(len(k.target) == len(STAR) - 1 for k in state.document.live.keyframes)
    commands.command(state, "undo")
    commands.command(state, "fit")  # a new cage: its keyframes cleared, in one undoable step
    assert state.document.live.keyframes == () and "keyframes cleared" in state.status.message
    commands.command(state, "undo")
    assert len(state.document.live.keyframes) == 2


def test_every_command_of_the_keys_and_the_panel_is_registered():
    import ast
    import inspect

    from app.viewer import gui, keys, window

    registered = set(commands.COMMANDS)
    keyed = {entry[2] for entry in keys.key_table()}
    panel = {
        node.args[0].elts[0].value
        for node in ast.walk(ast.parse(inspect.getsource(gui)))
        if isinstance(node, ast.Call)
        and getattr(node.func, "attr", None) == "append"
        and getattr(node.func.value, "id", None) == "commands"
        and isinstance(node.args[0], ast.Tuple)
        and isinstance(node.args[0].elts[0], ast.Constant)
    }
    assert keyed <= registered and panel <= registered, (keyed | panel) - registered
    assert len(panel) > 20
    for entry in commands.COMMANDS.values():
        assert entry.label and callable(entry.run)
    # What refuses to run while a new cage is drawn is what edits the document or the time.
    blocked = {name for name, entry in commands.COMMANDS.items() if not entry.while_drawing}
    assert {"redo", "kernel", "subdivide", "add_keyframe", "seek"} <= blocked
    assert not {"undo", "cancel", "confirm", "delete", "zoom"} & blocked
    # The window's own commands ask of the viewer only what it provides.
    provided = {name for name in dir(commands.WindowActions) if not name.startswith("_")}
    assert provided <= set(dir(window.Viewer))
    assert {name for name, entry in commands.COMMANDS.items() if entry.window} == {
        "save",
        "export",
        "export_path",
        "open",
        "open_session",
        "open_path",
        "play",
        "start_over",
        "save_cage",
        "save_target",
    }
