"""app.viewer.autokey: with keyframes, an edit of the pose at a time becomes a keyframe there."""

from pathlib import Path

import numpy as np
import pytest

from app.render.viewport import View
from app.viewer import commands, controller, editing
from app.viewer.state import AppState, Display, Document, History, Snapshot
from app.warp.keyframes import Keyframe, interpolate
from core.curves import examples

STAR = examples.starfish(points_per_arm=2) * np.array([150.0, -150.0]) + np.array([320.0, 240.0])
#: The pose at 2 s: the first arm's tip pulled up and right.
POSE = STAR + np.where(np.arange(len(STAR))[:, None] == 0, [40.0, -30.0], 0.0)


def animated_state(times=(0.0, 2.0)) -> AppState:
    keyframes = tuple(Keyframe(time, pose) for time, pose in zip(times, (STAR, POSE), strict=False))
    snapshot = Snapshot(Path("star.png"), STAR, STAR, keyframes=keyframes)
    image = np.zeros((480, 640, 4), np.uint8)
    return AppState(
        Document(History(snapshot), snapshot, image, Path("session.json")),
        display=Display(viewport=View(1.5, (100.0, 20.0))),
    )


def drag_point(state: AppState, index: int, offset) -> None:
    start = editing.to_window(
        state.display.viewport,
        state.document.live.target[index]
        if state.selection.edit_mode == "deform"
        else state.document.live.cage[index],
    )
    controller.pointer(state, "press", *start)
    for fraction in (0.5, 1.0):
        controller.pointer(state, "move", *(start + fraction * np.asarray(offset)))
    controller.pointer(state, "release", *(start + offset))


def test_a_drag_between_keyframes_is_a_keyframe_there_and_undo_takes_it_back():
    state = animated_state()
    commands.command(state, "seek", 1.0)
    between = interpolate(state.document.live.keyframes, 1.0, state.document.live.interpolation)
    np.testing.assert_array_equal(state.document.live.target, between)
    drag_point(state, 5, [30.0, 15.0])
    keyframes = state.document.history.current.keyframes
    assert [k.time for k in keyframes] == [0.0, 1.0, 2.0]
    expected = between.copy()
    expected[5] += np.array([30.0, 15.0]) / 1.5
    np.testing.assert_allclose(keyframes[1].target, expected, atol=1e-12)
    assert state.status.message == "keyframe added at 1.00 s" and state.playback.keyframe == 1
    assert state.document.session_dirty
    # The next step of the timeline keeps the drag: the animation passes through it.
    commands.command(state, "seek_by", 0.1)
    commands.command(state, "seek_by", -0.1)
    np.testing.assert_allclose(state.document.live.target, expected, atol=1e-9)
    # Ctrl+Z removes the keyframe, and shows the animation's pose at 1 s again.
    commands.command(state, "undo")
    assert [k.time for k in state.document.live.keyframes] == [0.0, 2.0]
    np.testing.assert_array_equal(state.document.live.target, between)
    commands.command(state, "redo")
    np.testing.assert_allclose(state.document.live.target, expected, atol=1e-9)
    # Another drag at the same time updates that keyframe.
    drag_point(state, 5, [-6.0, 0.0])
    assert [k.time for k in state.document.history.current.keyframes] == [0.0, 1.0, 2.0]
    assert state.status.message == "keyframe at 1.00 s updated"
    np.testing.assert_allclose(
        state.document.history.current.keyframes[1].target[5], expected[5] - [4.0, 0.0]
    )


def test_a_group_drag_and_a_reset_are_keyed_too():
    state = animated_state()
    commands.command(state, "seek", 0.5)
    commands.command(state, "reset_target")
    assert state.status.message == "target reset to the source cage; keyframe added at 0.50 s"
    np.testing.assert_array_equal(state.document.history.current.keyframes[1].target, STAR)


@pytest.mark.parametrize(
    ("name", "value"), [("kernel", "mean-value"), ("interpolation", "linear"), ("edit_mode", "cage")]
)
def test_edits_that_are_not_poses_add_no_keyframe(name, value):
    state = animated_state()
    commands.command(state, "seek", 1.0)
    commands.command(state, name, value)
    if name == "edit_mode":  # a cage edit carries the keyframes along, it does not key the pose
        drag_point(state, 5, [10.0, 0.0])
    assert [k.time for k in state.document.history.current.keyframes] == [0.0, 2.0]


def test_without_keyframes_a_drag_is_only_a_drag():
    state = animated_state()
    commands.command(state, "delete_keyframe", 1)
    commands.command(state, "delete_keyframe", 0)
    drag_point(state, 5, [30.0, 15.0])
    assert state.document.history.current.keyframes == () and "keyframe" not in state.status.message


def test_one_keyframe_is_an_animation_already():
    state = animated_state(times=(0.0,))
    commands.command(state, "seek", 2.0)
    drag_point(state, 3, [0.0, 20.0])
    assert [k.time for k in state.document.history.current.keyframes] == [0.0, 2.0]
