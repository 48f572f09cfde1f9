"""The window's input: glfw callbacks chained after imgui's own (imgui sees every event first, the
canvas what imgui leaves), one queue of canvas events and commands that the frame applies in
order (`app.viewer.controller.pointer`, the commands), and the window's size."""

from __future__ import annotations

import time
from collections import deque
from collections.abc import Callable

import numpy as np

from app.viewer import controller, editing
from app.viewer.keys import MOUSE_HELP, key_table
from app.viewer.state import AppState

#: Frames drawn after any input without waiting: imgui opens a popup (a combo) one frame
#: after the click, and a widget may change the state it draws only on the next frame.
FRAMES_AFTER_INPUT = 3


class InputQueue:
    """The events of one window, waiting for the next frame.

    Attributes
    ----------
    events : deque
        ``("pointer", kind, x, y, button, amount, shift, ctrl)`` and ``("command", name, value)``.
    frames_to_draw : int
        Frames still to draw without waiting for input.
    sizes : dict
        ``"window"`` and ``"pixels"``: the window's size in window and framebuffer pixels, kept by
        the size callbacks (asking the X server costs a round trip, ~0.1 ms, each time).
    view_changed_at : float
        perf_counter of the last pan, wheel zoom, resize or fit: the view is saved, and the dense
        mesh drawn again, once it has settled.
    keys : list
        `app.viewer.keys.key_table`.
    close_popups : bool
        Esc asked to close imgui's open popups (a list): done when the next frame begins.
    """

    def __init__(self):
        self.events: deque = deque()
        self.frames_to_draw = FRAMES_AFTER_INPUT
        self.sizes: dict = {}
        self.view_changed_at = 0.0
        self.keys = key_table()
        self.close_popups = False

    @property
    def shortcuts(self) -> list[tuple[str, str]]:
        """(keys, what they do) of the help panel."""
        return [(keys, what) for *_, keys, what in self.keys if keys] + MOUSE_HELP

    def chain_callbacks(self, glfw, window, io, state: AppState) -> None:
        """Wrap imgui's glfw callbacks of `window` (imgui's `io`): imgui sees every event first, the
        canvas what imgui leaves."""
        # The pointer as of the event being handled.  glfw.get_cursor_pos asks the X server where
        # the pointer is now: after a slow frame (a dense mesh arriving) the queued press was placed
        # where the drag had already moved on to, and grabbed nothing.
        pointer = list(glfw.get_cursor_pos(window))
        events = self.events

        def chained(setter, handler):
            previous = setter(window, None)

            def callback(*args):
                if previous is not None:
                    previous(*args)
                handler(*args)
                self.frames_to_draw = FRAMES_AFTER_INPUT

            setter(window, callback)

        def over_panel(x: float, y: float) -> bool:
            return x < state.screen.canvas_left and y < state.screen.panel_bottom

        def mouse_button(_, button, action, mods):
            x, y = pointer
            if action == glfw.RELEASE:
                events.append(("pointer", "release", x, y, button, 0.0, False, False))
            elif not io.want_capture_mouse_unless_popup_close and not over_panel(x, y):
                # A press that closes an open list (combo) also reaches the canvas.  One on the panel
                # never does, though imgui may not know yet that the pointer is there (it moved
                # onto a heading and clicked before a frame was drawn): it would deselect the handle.
                shift, ctrl = bool(mods & glfw.MOD_SHIFT), bool(mods & (glfw.MOD_CONTROL | glfw.MOD_SUPER))
                events.append(("pointer", "press", x, y, button, 0.0, shift, ctrl))

        def cursor(_, x, y):
            pointer[:] = x, y
            # A drag keeps its events even over a panel.
            if state.selection.drag is not None or not io.want_capture_mouse:
                events.append(("pointer", "move", x, y, 0, 0.0, False, False))

        def scroll(_, dx, dy):
            if not io.want_capture_mouse:
                x, y = pointer
                events.append(("pointer", "scroll", x, y, 0, dy, False, False))

        def key(_, key, scancode, action, mods):
            if action not in (glfw.PRESS, glfw.REPEAT) or io.want_text_input:
                return
            if mods & glfw.MOD_SUPER:  # Cmd on macOS
                mods = (mods & ~glfw.MOD_SUPER) | glfw.MOD_CONTROL
            mods &= glfw.MOD_CONTROL | glfw.MOD_SHIFT | glfw.MOD_ALT
            for code, wanted, name, value, *_ in self.keys:
                if code == key and wanted == mods:
                    if io.want_capture_keyboard and not mods & glfw.MOD_CONTROL and name != "cancel":
                        return  # plain letters go to a focused widget
                    events.append(("command", name, value))
                    return

        def drop(_, paths):
            for path in paths[:1]:
                events.append(("command", "open_path", path))

        def close(_):
            state.status.quit = True

        def char(*_):
            self.frames_to_draw = FRAMES_AFTER_INPUT

        chained(glfw.set_mouse_button_callback, mouse_button)
        chained(glfw.set_cursor_pos_callback, cursor)
        chained(glfw.set_scroll_callback, scroll)
        chained(glfw.set_key_callback, key)
        chained(glfw.set_char_callback, char)
        chained(
            glfw.set_window_size_callback, lambda _, width, height: self.sizes.update(window=(width, height))
        )
        glfw.set_framebuffer_size_callback(
            window, lambda _, width, height: self.sizes.update(pixels=(width, height))
        )
        glfw.set_drop_callback(window, drop)
        glfw.set_window_close_callback(window, close)

    def apply(self, state: AppState, command: Callable[[str, object], None]) -> None:
        """Apply the queued events in order: pointer events to the state, commands by `command`."""
        while self.events:
            event = self.events.popleft()
            if event[0] == "pointer":
                _, kind, x, y, button, amount, shift, ctrl = event
                controller.pointer(state, kind, x, y, button, amount, shift, ctrl)
                drag = state.selection.drag
                if kind == "scroll" or (kind == "move" and drag and drag.kind == "pan"):
                    self.view_changed_at = time.perf_counter()
            else:
                command(event[1], event[2])

    def follow_window_size(self, state: AppState) -> None:
        """A resized window: fit the image again if it was fitted, else keep the canvas centre still."""
        size = self.sizes["window"]
        old = state.screen.window_size
        state.screen.window_size = size
        if tuple(size) == tuple(old) or size[0] <= 0 or size[1] <= 0:
            return
        if state.display.viewport_fitted:
            controller.fit_view(state, None)
        else:
            shift = 0.5 * (np.asarray(size, dtype=np.float64) - np.asarray(old, dtype=np.float64))
            state.display.viewport = editing.pan(state.display.viewport, shift)
            state.display.viewport_dirty = True
        self.view_changed_at = time.perf_counter()
