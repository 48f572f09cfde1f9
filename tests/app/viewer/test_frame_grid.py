"""app.viewer.frame_grid: the playhead, pauses and keyframes on the session's frame grid."""

from pathlib import Path

import numpy as np
import pytest

from app.viewer import commands, controller
from app.viewer.frame_grid import checked_fps, key_near, on_grid
from app.viewer.state import AppState, Document, History, Snapshot
from app.warp.keyframes import MAX_TIME, Keyframe

SQUARE = np.array([[0.0, 0.0], [100.0, 0.0], [100.0, 100.0], [0.0, 100.0]])


def animated(times) -> AppState:
    keyframes = tuple(Keyframe(t, SQUARE + [10.0 * i, 0.0]) for i, t in enumerate(times))
    snapshot = Snapshot(Path("a.png"), SQUARE, SQUARE, keyframes=keyframes)
    return AppState(Document(History(snapshot), snapshot, np.zeros((120, 120, 4), np.uint8), Path("s.json")))


def test_times_round_to_the_nearest_frame():
    assert on_grid(1.95285, 30.0) == 59 / 30
    assert on_grid(0.512, 24.0) == 12 / 24
    assert on_grid(-3.0, 30.0) == 0.0 and on_grid(1e9, 30.0) <= MAX_TIME
    keys = (Keyframe(1.0, SQUARE), Keyframe(1.96, SQUARE))
    assert key_near(keys, 59 / 30, 30.0) == 1 and key_near(keys, 1.5, 30.0) is None
    assert checked_fps(24) == 24.0 and checked_fps(True) is None and checked_fps(0.0) is None


def test_a_pause_stops_on_a_frame():
    state = animated([0.0, 2.0])
    commands.command(state, "playback")
    controller.advance(state, 1.95285)
    commands.command(state, "playback")
    assert state.playback.time == 59 / 30 and state.status_message() == "paused at 1.97 s (frame 59)"


def test_a_seek_and_a_new_keyframe_sit_on_frames():
    state = animated([0.0, 2.0])
    commands.command(state, "seek", 0.123)
    assert state.playback.time == 4 / 30
    commands.command(state, "add_keyframe", 1.01)
    assert [k.time for k in state.document.live.keyframes] == [0.0, 1.0, 2.0]


def test_an_edit_within_half_a_frame_of_a_key_replaces_it():
    """The issue's case: a key left off the grid (1.96 s, an older session), the playhead paused on
    the frame beside it: the drag replaces that key, it does not add one 0.2 frames away."""
    state = animated([0.0, 1.96, 3.0])
    commands.command(state, "seek", 1.97)
    assert state.playback.time == 59 / 30
    target = state.document.live.target + [0.0, 7.0]
    controller.commit(state, state.document.live.replace(target=target), "moved", pose=True)
    times = [k.time for k in state.document.live.keyframes]
    assert times == [0.0, 59 / 30, 3.0] and state.status_message() == "moved; keyframe at 1.97 s updated"
    np.testing.assert_array_equal(state.document.live.keyframes[1].target, target)


def test_moving_a_key_snaps_it_and_a_frame_holds_one_key():
    state = animated([0.0, 1.0, 2.0])
    commands.command(state, "keyframe_time", (1, 1.512))
    assert [k.time for k in state.document.live.keyframes] == [0.0, 1.5, 2.0]
    commands.command(state, "keyframe_time", (1, 2.01))
    assert state.status_message() == "there is a keyframe at 2.00 s already" and state.status.message_is_error
    assert [k.time for k in state.document.live.keyframes] == [0.0, 1.5, 2.0]


@pytest.mark.parametrize("fps", [24.0, 60.0])
def test_the_grid_is_the_sessions_frame_rate(fps):
    state = animated([0.0, 2.0])
    state.playback.fps = fps
    commands.command(state, "seek", 0.7)
    assert state.playback.time == round(0.7 * fps) / fps
