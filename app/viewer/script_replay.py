"""Replaying a demo's script (``demo --script``, ``--frames``, P): scripted drags sent through the
mouse's own input path, the window's event queue, once the deformation can be seen; with
``--frames`` every replayed frame is also written as a PNG, on a clock of frames, not of seconds."""

from __future__ import annotations

import time
from collections import deque
from collections.abc import Callable
from pathlib import Path

import numpy as np

from app.io.files import InputError, write_png
from app.viewer import editing
from app.viewer.controller import LEFT
from app.viewer.state import AppState


class ScriptReplay:
    """The script of one viewer, started and stopped by P (or at once with ``demo --script``).

    Parameters
    ----------
    script : Path, optional
        The script file (`app.viewer.demos.read_script`); None: nothing to play.
    frames : Path, optional
        Write every replayed frame as ``frames/frame_NNNNN.png``, and quit at the end.
    fps : float
        Frames per second of `frames`.
    announce : callable
        Called with ``script done`` at the end (the window tests read it).
    """

    def __init__(self, script: Path | None, frames: Path | None, fps: float, announce: Callable[[str], None]):
        self.script, self.frames, self.fps = script, frames, fps
        self.announce = announce
        self.player = None  # app.viewer.demos.ScriptPlayer while playing
        self.clock: float | None = None  # perf_counter when the replay started moving
        self.written = 0

    @property
    def playing(self) -> bool:
        return self.player is not None

    @property
    def moving(self) -> bool:
        """The replay has started: it sends events every frame."""
        return self.player is not None and self.clock is not None

    def toggle(self, state: AppState) -> None:
        """Start the script (in deform mode) or stop it."""
        from app.viewer.demos import ScriptPlayer, read_script

        if self.script is None:
            state.say("no script: start a demo (python -m app demo NAME) or give --script", error=True)
            return
        if self.player is not None:
            self.player = None
            self.clock = None
            state.say("script stopped")
            return
        try:
            moves = read_script(self.script, state.document.live.n)
        except InputError as error:
            state.say(str(error), error=True)
            return
        state.selection.edit_mode = "deform"
        self.player = ScriptPlayer(moves)
        self.clock = None
        state.say(f"playing {self.script.name}")

    def send_events(self, state: AppState, ready: bool, events: deque) -> None:
        """Queue this frame's scripted pointer events on `events`; `ready`: the deformation can
        be seen (the replay waits for it to start)."""
        player = self.player
        if player is None:
            return
        if self.clock is None:
            if not ready:
                return  # replay once the deformation can be seen
            self.clock = time.perf_counter()
        now = self.written / self.fps if self.frames is not None else time.perf_counter() - self.clock
        moves = player.events(
            now,
            lambda index: state.document.live.target[index],
            lambda point: editing.to_window(state.display.viewport, point),
        )
        for kind, x, y in moves:
            if kind == "fold_free":  # the switch, as B would set it
                if state.document.live.fold_free != x:
                    events.append(("command", "fold_free", None))
                continue
            # The same path as the mouse: the queue that the glfw callbacks fill.
            events.append(("pointer", kind, x, y, LEFT, 0.0, False, False))
        if player.finished and not moves:
            self.player = None
            state.say("script finished")
            self.announce("script done")
            if self.frames is not None:
                state.status.quit = True

    def write_frame(self, render: Callable[[], np.ndarray | None]) -> None:
        """With ``--frames``: write this frame of the replay (`render`: the export's pixels)."""
        if not self.moving or self.frames is None:
            return
        pixels = render()
        if pixels is None:
            return
        self.frames.mkdir(parents=True, exist_ok=True)
        write_png(self.frames / f"frame_{self.written:05d}.png", pixels)
        self.written += 1
