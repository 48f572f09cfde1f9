"""The wall clock of keyframe playback (Space): each frame moves the animation on by the time since
the last one (`app.viewer.controller.advance`), and stands still while the deformation cannot be
seen (a precompute running)."""

from __future__ import annotations

import time
from collections.abc import Callable

from app.viewer import controller
from app.viewer.milestones import frame_statistics
from app.viewer.state import AppState


class PlaybackClock:
    """When playback last moved, and the first frame it drew (for the test mode's frame times)."""

    def __init__(self, announce: Callable[[str], None]):
        self.announce = announce
        self.last: float | None = None  # perf_counter of the last frame that played
        self.first_frame = 0
        self.since = 0.0  # perf_counter of that first frame

    def tick(self, state: AppState, ready: bool) -> None:
        """Move the playing animation on by the wall time since the last frame; `ready`: the
        basis drawn is the live snapshot's, on the mesh the renderer holds."""
        now = time.perf_counter()
        if not state.playback.playing:
            if self.last is not None:
                count, median, _ = frame_statistics(state.status.frame_ms[self.first_frame :])
                rate = count / max(now - self.since, 1e-9)
                self.announce(
                    f"playback paused frames={count} median_frame_ms={median:.2f} per_second={rate:.1f}"
                )
            self.last = None
            return
        if self.last is None:
            self.first_frame, self.since = len(state.status.frame_ms), now
            self.announce("playback started")
        elif not ready:  # the animation waits, its time standing still, until it can be seen
            self.first_frame, self.since = len(state.status.frame_ms), now
        else:
            controller.advance(state, now - self.last)
        self.last = now
