"""The session's frame grid: the playhead, pauses and keyframes sit at whole frames k / fps.

An animation is exported frame by frame (`app.warp.keyframes.frame_times`); a keyframe between
two frames is never shown as posed, and two keys a frame apart or less are one pose to the eye.
So the viewer rounds every time it sets (a seek, a pause, a new or moved keyframe) to the nearest
frame, and an edit within half a frame of a keyframe replaces that keyframe.
"""

from __future__ import annotations

import math

from app.warp.keyframes import MAX_FPS, MAX_TIME, MIN_FPS, Keyframe

#: Frames per second of a session that does not say.
DEFAULT_FPS = 30.0


def on_grid(time: float, fps: float) -> float:
    """`time` (seconds) rounded to the nearest frame of `fps`, within 0..`MAX_TIME`."""
    frame = round(min(max(float(time), 0.0), MAX_TIME) * fps)
    return min(frame / fps, math.floor(MAX_TIME * fps) / fps)


def half_frame(fps: float) -> float:
    """Half a frame, in seconds: keyframes nearer than this to a time are the keyframe at that time."""
    return 0.5 / fps


def key_near(keyframes: tuple[Keyframe, ...], time: float, fps: float) -> int | None:
    """The index of the keyframe within half a frame of `time` (the nearest), or None."""
    distances = [abs(keyframe.time - time) for keyframe in keyframes]
    if not distances or min(distances) >= half_frame(fps):
        return None
    return distances.index(min(distances))


def checked_fps(value) -> float | None:
    """`value` as frames per second if it is a number within `MIN_FPS`..`MAX_FPS`, else None."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return None
    return float(value) if MIN_FPS <= value <= MAX_FPS else None
