"""Auto-key: once an animation has keyframes, an edit of the pose at a time is a keyframe at that time.

As After Effects does once a property is animated: a drag (or a reset) of the target
while the timeline stands at t adds a keyframe at t holding the new pose, or updates the
one there, in the same undoable step as the edit, so the next Left/Right or Space keeps
it instead of replacing it with the in-between pose.  Edits that are not poses (the
kernel, the cage, the keyframes themselves) are left as they are.
"""

from __future__ import annotations

import numpy as np

from app.viewer.state import Snapshot
from app.warp.keyframes import MAX_TIME, TIME_RESOLUTION, Keyframe, interpolate


def keyed(
    before: Snapshot, edited: Snapshot, time: float, near: float = TIME_RESOLUTION
) -> tuple[Snapshot, str | None]:
    """`edited` with its pose keyed at `time`, and what the status line says about it.

    Parameters
    ----------
    before : Snapshot
        The document before the edit (the history's current state).
    edited : Snapshot
        The document the edit makes.
    time : float
        The timeline's time, seconds.
    near : float
        A keyframe nearer than this (seconds) to `time` is the one there: the edit replaces it
        (the viewer gives half a frame: `app.viewer.frame_grid`).

    Returns
    -------
    (Snapshot, str or None)
        `edited` unchanged and None when there is nothing to key: no keyframes, an edit of
        the cage or of the keyframes, a time off the timeline, or a pose that is already the
        animation's at `time`.  Otherwise `edited` with a keyframe at `time` (new, or the
        one within `near` of it replaced) and
        ``"keyframe added at 0.80 s"`` or ``"keyframe at 0.80 s updated"``.
    """
    keyframes = edited.keyframes
    if (
        not keyframes
        or keyframes != before.keyframes
        or edited.interpolation != before.interpolation
        or not np.array_equal(edited.cage, before.cage)
        or not 0.0 <= time <= MAX_TIME
    ):
        return edited, None
    if np.array_equal(edited.target, interpolate(keyframes, time, edited.interpolation)):
        return edited, None
    kept = tuple(keyframe for keyframe in keyframes if abs(keyframe.time - time) >= near)
    replaced = len(kept) < len(keyframes)
    what = f"keyframe at {time:.2f} s updated" if replaced else f"keyframe added at {time:.2f} s"
    return edited.replace(keyframes=(*kept, Keyframe(time, edited.target))), what
