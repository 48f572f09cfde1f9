"""The viewer's pin tool (app.viewer.pin_tool) through the controller and the commands, without a window."""

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from app.render.viewport import View
from app.viewer import commands, controller, pin_tool
from app.viewer.changes import change_words
from app.viewer.controller import RIGHT
from app.viewer.state import AppState, BasisResult, Display, Document, History, Snapshot

ANGLES = np.linspace(0.0, 2.0 * np.pi, 16, endpoint=False)
#: An ellipse of 16 control points in a 640x480 picture; the view shows it at scale 1, offset 0.
CAGE = np.column_stack([320.0 + 200.0 * np.cos(ANGLES), 240.0 + 150.0 * np.sin(ANGLES)])


@pytest.fixture
def state():
    snapshot = Snapshot(Path("ellipse.png"), CAGE, CAGE)
    image = np.zeros((480, 640, 4), np.uint8)
    state = AppState(
        Document(History(snapshot), snapshot, image, Path("session.json")),
        display=Display(viewport=View(1.0, (0.0, 0.0))),
    )
    commands.command(state, "edit_mode", "pins")
    return state


def drag_pin(state, start, end, steps=4):
    """Press on `start`, move to `end` in steps (a frame's solve after each), release."""
    controller.pointer(state, "press", *start)
    for fraction in np.linspace(0, 1, steps + 1)[1:]:
        controller.pointer(state, "move", *(np.asarray(start) + fraction * (np.asarray(end) - start)))
        pin_tool.follow(state)
    controller.pointer(state, "release", *end)


def similarity_residual(source: np.ndarray, target: np.ndarray) -> float:
    """Largest distance of `target` from the best similarity image of `source` (complex least squares)."""
    z, w = source @ [1, 1j], target @ [1, 1j]
    design = np.column_stack([z, np.ones_like(z)])
    coefficients = np.linalg.lstsq(design, w, rcond=None)[0]
    return float(np.abs(design @ coefficients - w).max())


def test_a_click_pins_the_picture_there_as_one_undo_step_and_moves_nothing(state):
    controller.pointer(state, "press", 300.0, 250.0)
    controller.pointer(state, "release", 300.0, 250.0)
    live = state.document.live
    assert live.pins.points == (((300.0, 250.0), (300.0, 250.0)),)
    np.testing.assert_array_equal(live.target, CAGE)
    assert state.document.history.can_undo and state.document.session_dirty
    assert state.status_message() == "pin 0 added at 300, 250: drag it"
    assert state.selection.pin == 0
    commands.command(state, "undo")
    assert state.document.live.pins.points == ()


def test_a_click_outside_the_cage_or_with_another_kernel_says_so_and_records_nothing(state):
    controller.pointer(state, "press", 600.0, 20.0)
    assert state.document.live.pins.points == () and not state.document.history.can_undo
    assert state.status.message == "cannot pin there: pin 0 at (600, 20) is outside the cage"
    assert state.status.message_is_error
    commands.command(state, "kernel", "mean-value")
    controller.pointer(state, "press", 320.0, 240.0)
    assert state.document.live.pins.points == ()
    assert (
        state.status.message
        == "pins need the poisson or cauchy-green kernel, not mean-value: choose one in the Kernel section"
    )


def test_dragging_the_only_pin_translates_the_picture_and_the_release_says_what_is_proven(state):
    controller.pointer(state, "press", 320.0, 240.0)
    controller.pointer(state, "release", 320.0, 240.0)
    controller.pointer(state, "press", 320.0, 240.0)
    for step in range(1, 5):
        controller.pointer(state, "move", 320.0 + 10 * step, 240.0 - 5 * step)
        assert state.selection.drag.kind == "pin"
        pin_tool.follow(state)  # the frame's solve: the picture follows during the drag
        np.testing.assert_allclose(state.document.live.target, CAGE + [10 * step, -5 * step], atol=1e-9)
    assert len(state.document.history.undo_steps) == 1  # nothing recorded during the drag
    controller.pointer(state, "release", 360.0, 220.0)
    np.testing.assert_allclose(state.document.history.current.target, CAGE + [40, -20], atol=1e-9)
    assert state.document.history.current.pins.points == (((320.0, 240.0), (360.0, 220.0)),)
    said = state.status_message()
    assert said.startswith("moved pin 0; pins: K ≤ 1 proven (no bound), fold-free"), said
    commands.command(state, "undo")  # the move is one step: the pin and the picture go back
    assert state.document.live.pins.points == (((320.0, 240.0), (320.0, 240.0)),)
    np.testing.assert_array_equal(state.document.live.target, CAGE)


def test_two_pins_give_the_similarity_that_places_both(state):
    for x in (250.0, 390.0):
        controller.pointer(state, "press", x, 240.0)
        controller.pointer(state, "release", x, 240.0)
    drag_pin(state, (390.0, 240.0), (380.0, 290.0))
    live = state.document.history.current
    assert live.pins.points[1][1] == (380.0, 290.0)
    assert similarity_residual(CAGE, live.target) < 1e-9
    # The similarity takes the first pin to itself and the second where it was dropped.
    z, w = CAGE @ [1, 1j], live.target @ [1, 1j]
    a = (w[1] - w[0]) / (z[1] - z[0])
    image = lambda p: w[0] + a * (complex(*p) - z[0])  # noqa: E731
    assert abs(image((250.0, 240.0)) - complex(250.0, 240.0)) < 1e-9
    assert abs(image((390.0, 240.0)) - complex(380.0, 290.0)) < 1e-9


def test_a_bound_is_one_undo_step_and_the_solve_proves_it(state):
    for x, y in ((250.0, 240.0), (390.0, 240.0), (320.0, 180.0)):
        controller.pointer(state, "press", x, y)
        controller.pointer(state, "release", x, y)
    drag_pin(state, (320.0, 180.0), (320.0, 120.0))
    free = state.document.live.target
    commands.command(state, "max_distortion", 1.5)
    live = state.document.live
    assert live.pins.bound == 1.5 and state.document.history.current is live
    said = state.status_message()
    assert said.startswith("pins: K = 1.50; pins: K ≤ "), said
    proven = float(said.split("K ≤ ")[1].split()[0])
    assert 1.0 <= proven <= 1.5 and "(bound 1.5), fold-free" in said
    assert not np.allclose(live.target, free)  # the bound pulled the pins short of their places
    assert "misses by" in said
    commands.command(state, "undo")
    assert state.document.live.pins.bound is None
    np.testing.assert_array_equal(state.document.live.target, free)
    commands.command(state, "max_distortion", 0.5)
    assert state.status.message == "K must be 1 (rigid) or more, got 0.5" and state.status.message_is_error


def test_right_click_and_delete_remove_pins_and_the_others_are_solved_again(state):
    for x in (250.0, 390.0):
        controller.pointer(state, "press", x, 240.0)
        controller.pointer(state, "release", x, 240.0)
    drag_pin(state, (390.0, 240.0), (410.0, 240.0))
    controller.pointer(state, "press", 410.0, 240.0, button=RIGHT)
    live = state.document.live
    assert live.pins.points == (((250.0, 240.0), (250.0, 240.0)),)
    np.testing.assert_allclose(live.target, CAGE, atol=1e-9)  # one pin where it was: no move
    assert state.status_message().startswith("removed pin 1; pins: K ≤ 1 proven")
    controller.pointer(state, "press", 250.0, 240.0)
    controller.pointer(state, "release", 250.0, 240.0)  # a click on a pin selects it
    commands.command(state, "delete")
    assert state.document.live.pins.points == () and state.status_message() == "removed pin 0"
    commands.command(state, "delete")
    assert state.status.message == "click a pin first (pins mode), or right-click one to remove it"


def test_a_pin_dropped_onto_another_is_refused(state):
    for x in (250.0, 390.0):
        controller.pointer(state, "press", x, 240.0)
        controller.pointer(state, "release", x, 240.0)
    before = state.document.live
    drag_pin(state, (390.0, 240.0), (250.5, 240.0))
    assert state.document.live is before and state.document.history.current is before
    assert state.status.message == "pin 1 cannot go onto another pin: drop it elsewhere"


def test_a_control_point_moved_by_hand_is_held_by_later_solves(state):
    controller.pointer(state, "press", 320.0, 240.0)
    controller.pointer(state, "release", 320.0, 240.0)
    handle = CAGE[4]
    drag_pin(state, handle, handle + [0.0, 30.0])  # a blue handle: moved by hand, not pinned
    live = state.document.live
    assert live.pins.fixed == (4,) and len(live.pins.points) == 1
    assert state.status_message() == "moved control point 4; fixed for the pins"
    drag_pin(state, (320.0, 240.0), (340.0, 240.0))
    target = state.document.history.current.target
    np.testing.assert_allclose(target[4], handle + [0.0, 30.0], atol=1e-9)
    # Across the cage from it, a point moves about as the pin did.
    assert np.linalg.norm(target[0] - CAGE[0] - [20.0, 0.0]) < 5.0
    marks = pin_tool.fixed_marks(state)  # an orange ring under the held handle
    np.testing.assert_array_equal(marks[:, :2], target[[4]])
    np.testing.assert_array_equal(marks[:, 2:5], [pin_tool.FIXED_COLOUR])
    commands.command(state, "reset_target")  # the pins back where they are on the source, nothing held
    live = state.document.live
    assert live.pins.fixed == () and live.pins.points == (((320.0, 240.0), (320.0, 240.0)),)


def test_the_overlay_marks_each_pin_at_and_to_and_the_selected_one(state):
    controller.pointer(state, "press", 320.0, 240.0)
    controller.pointer(state, "release", 320.0, 240.0)
    drag_pin(state, (320.0, 240.0), (330.0, 250.0))
    segments, marks = pin_tool.overlay(state)
    np.testing.assert_array_equal(segments[0, :, :2], [[320.0, 240.0], [330.0, 250.0]])
    np.testing.assert_array_equal(marks[:, :2], [[320.0, 240.0], [330.0, 250.0]])
    np.testing.assert_array_equal(marks[1, 2:5], pin_tool.SELECTED_PIN_COLOUR)
    np.testing.assert_array_equal(marks[0, 2:5], pin_tool.PIN_COLOUR)


def test_a_pin_on_a_warped_picture_holds_the_source_point_under_the_click(state):
    """With a basis drawn, ``at`` is where the mesh's map came from: the same barycentric point of the
    source triangle as the click's in the deformed one."""
    vertices = np.array([[300.0, 200.0], [360.0, 200.0], [300.0, 280.0], [360.0, 280.0]])
    deformed = np.array([[290.0, 190.0], [370.0, 210.0], [295.0, 290.0], [380.0, 300.0]])  # no fold
    basis = deformed @ np.linalg.pinv(CAGE)  # (4, 16): basis @ CAGE is `deformed`
    mesh = SimpleNamespace(vertices=vertices, triangles=np.array([[0, 1, 2], [1, 3, 2]]))
    state.compute.basis = BasisResult("key", CAGE, mesh, basis, basis, "poisson", 0.0)
    np.testing.assert_allclose(basis @ CAGE, deformed, atol=1e-9)
    state.document.live = state.document.live.replace(target=CAGE + 1.0)  # a warped picture
    deformed = basis @ (CAGE + 1.0)
    weights = np.array([0.2, 0.5, 0.3])
    click = weights @ deformed[[1, 3, 2]]
    np.testing.assert_allclose(pin_tool.source_point(state, click), weights @ vertices[[1, 3, 2]], atol=1e-9)
    assert pin_tool.source_point(state, deformed.max(axis=0) + 50.0) is None
    controller.pointer(state, "press", *(deformed.max(axis=0) + 50.0))
    assert state.status.message == "cannot pin there: click inside the cage's picture"
    state.compute.basis = None  # a warped picture whose basis is not drawn yet: no source point known
    controller.pointer(state, "press", *click)
    assert state.document.live.pins.points == ()
    assert state.status.message.startswith("cannot pin yet: the warp of this cage is being computed")


def test_the_k_slider_runs_from_rigid_to_free():
    assert pin_tool.bound_of(0.0) == 1.0 and pin_tool.bound_of(0.5) == 2.0 and pin_tool.bound_of(1.0) is None
    assert pin_tool.position_of(None) == 1.0 and pin_tool.position_of(4.0) == 0.75
    assert pin_tool.bound_words(None) == "K = ∞ (free)" and pin_tool.bound_words(2.0) == "K = 2.00"


def test_undo_says_what_a_pin_step_changed(state):
    controller.pointer(state, "press", 320.0, 240.0)
    controller.pointer(state, "release", 320.0, 240.0)
    first = state.document.live
    drag_pin(state, (320.0, 240.0), (330.0, 240.0))
    moved = state.document.live
    assert change_words(Snapshot(Path("ellipse.png"), CAGE, CAGE), first) == "pins 0 → 1"
    assert change_words(first, moved) == "moved 1 pin; moved 16 target points"
    assert change_words(moved, moved.replace(pins=moved.pins.replace(bound=2.0))) == "K → 2"


def test_with_keyframes_a_pin_move_keys_the_target_it_produces(state):
    controller.pointer(state, "press", 320.0, 240.0)
    controller.pointer(state, "release", 320.0, 240.0)
    commands.command(state, "add_keyframe")  # a keyframe at 0 s: auto-key from now on
    state.playback.time = 1.0
    drag_pin(state, (320.0, 240.0), (335.0, 240.0))
    live = state.document.history.current
    assert [key.time for key in live.keyframes] == [0.0, 1.0]
    np.testing.assert_allclose(live.keyframes[1].target, CAGE + [15.0, 0.0], atol=1e-9)
    np.testing.assert_array_equal(live.keyframes[1].target, live.target)


def test_a_new_cage_clears_the_pins_one_undo_away(state):
    controller.pointer(state, "press", 320.0, 240.0)
    controller.pointer(state, "release", 320.0, 240.0)
    pinned = state.document.live
    controller.fit(state)
    assert state.document.live.pins.points == ()
    assert state.status_message().endswith("; its 1 pin cleared (Ctrl+Z brings them back)")
    commands.command(state, "undo")
    assert state.document.live == pinned
