"""app.viewer.window_input: which glfw events reach the canvas (no window: glfw's callbacks stood in for)."""

from pathlib import Path
from types import SimpleNamespace

import glfw
import numpy as np

from app.viewer.state import AppState, Document, History, Snapshot
from app.viewer.window_input import InputQueue

SQUARE = np.array([[0.0, 0.0], [100.0, 0.0], [100.0, 100.0], [0.0, 100.0]])


class StandInGlfw:
    """glfw's constants, and callbacks kept in a dict instead of set on a window."""

    def __init__(self):
        self.callbacks = {}

    def __getattr__(self, name):
        if name.startswith("set_") and name.endswith("_callback"):
            return lambda window, callback: self.callbacks.setdefault(name, []).append(callback) or None
        return getattr(glfw, name)

    def get_cursor_pos(self, window):
        return (0.0, 0.0)

    def fire(self, name: str, *args) -> None:
        self.callbacks[name][-1](None, *args)


def test_a_press_on_the_panel_never_reaches_the_canvas_though_imgui_has_not_seen_the_pointer_there():
    snapshot = Snapshot(Path("a.png"), SQUARE, SQUARE)
    state = AppState(Document(History(snapshot), snapshot, np.zeros((120, 120, 4), np.uint8), Path("s.json")))
    state.screen.canvas_left, state.screen.panel_bottom = 300.0, 500.0
    fake = StandInGlfw()
    io = SimpleNamespace(want_capture_mouse=False, want_capture_mouse_unless_popup_close=False)
    queue = InputQueue()
    queue.chain_callbacks(fake, None, io, state)
    for x, y in ((150.0, 346.0), (150.0, 700.0), (640.0, 346.0)):  # a heading, below the panel, the canvas
        fake.fire("set_cursor_pos_callback", x, y)
        fake.fire("set_mouse_button_callback", glfw.MOUSE_BUTTON_LEFT, glfw.PRESS, 0)
    presses = [event[2:4] for event in queue.events if event[:2] == ("pointer", "press")]
    assert presses == [(150.0, 700.0), (640.0, 346.0)]
