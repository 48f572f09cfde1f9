"""The viewer's window: a glfw loop of our own, moderngl for the canvas, imgui-bundle for widgets.

One frame: poll input (glfw callbacks, chained after imgui's own, queue canvas
events only when imgui does not want the mouse), replay a script's events
through the same queue, apply them (`controller`), read the precompute's
messages, draw the widgets (`gui`) and run their commands, bring the GPU up to
date (`Scene.sync`: one in-place buffer write per drag), draw, swap, and save the
session if it changed.  The frame time is the wall time of that whole sequence.

With the environment variable ``TRANSFINITE_VIEWER_TEST=1`` the viewer prints
one line per milestone on stdout (``ready window=ID``, ``basis ...``,
``saved PATH``, ``exported PATH``, ``script done``) for tests that drive the real
window, and does not wait for vertical sync.
"""

from __future__ import annotations

import os
import signal
import sys
import time
from collections import deque
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from app.files import InputError, read_json, write_png
from app.framing import output_frame, output_region
from app.viewer import controller, editing
from app.viewer.file_dialogs import FileRequests
from app.viewer.precompute import Precompute, make_request
from app.viewer.session import Document, apply_preferences, open_document, save, start_snapshot
from app.viewer.state import AppState, History, Snapshot
from app.viewer.view_modes import BY_NAME as VIEW_MODE
from app.viewer.view_modes import MODES as VIEW_MODES

TEST_VARIABLE = "TRANSFINITE_VIEWER_TEST"
WINDOW_SIZE = (1280, 1024)
#: Seconds after the last zoom or pan before the view is saved.
VIEW_SAVE_DELAY = 0.5
#: Seconds after the last wheel zoom or pan motion during which the view counts as moving
#: (a dense mesh is drawn through its preview mesh meanwhile); below VIEW_SAVE_DELAY, so the
#: frames drawn while the zoom or pan waits to be saved show the dense mesh again.
VIEW_SETTLE = 0.25


@dataclass
class Options:
    """What the command line asks of the viewer."""

    stats: bool = False
    max_edge: float | None = None
    vertices: int | None = None  # mesh with about this many vertices (default editing.TARGET_VERTICES)
    script: Path | None = None  # a script to replay (demo --play or --script)
    play: bool = False  # start replaying the script at once
    playback: bool = False  # start playing the keyframes at once (looping)
    frames: Path | None = None  # write every replayed frame here (and quit at the end)
    fps: float = 30.0
    export: Path | None = None  # where Ctrl+E writes (default: ask; see `default_export_path`)
    size: tuple[int, int] | None = None  # the window's (default: as last closed, else fits the screen)


def _key_table():
    import glfw

    ctrl, shift = glfw.MOD_CONTROL, glfw.MOD_SHIFT
    # (key, modifiers, command, value, keys shown in the help, what it does)
    return [
        (glfw.KEY_Z, ctrl, "undo", None, "Ctrl+Z", "undo the last edit"),
        (glfw.KEY_Z, ctrl | shift, "redo", None, "Ctrl+Shift+Z, Ctrl+Y", "redo"),
        (glfw.KEY_Y, ctrl, "redo", None, None, None),
        (glfw.KEY_ESCAPE, 0, "cancel", None, "Esc", "cancel the drag in progress, close a list or the help"),
        (glfw.KEY_O, ctrl, "open", None, "Ctrl+O", "open an image (or drop a file on the window)"),
        (glfw.KEY_O, ctrl | shift, "open_session", None, "Ctrl+Shift+O", "open a session file"),
        (glfw.KEY_S, ctrl, "save", None, "Ctrl+S", "save the session now (it also saves itself)"),
        (
            glfw.KEY_E,
            ctrl,
            "export",
            None,
            "Ctrl+E",
            "export the warped image as PNG, full resolution, or the animation (name it .mp4, .gif, folder/)",
        ),
        (glfw.KEY_E, ctrl | shift, "export", "again", "Ctrl+Shift+E", "export again to the last file"),
        (glfw.KEY_Q, ctrl, "quit", None, "Ctrl+Q", "quit"),
        (glfw.KEY_TAB, 0, "mode", None, "Tab", "switch between deforming and editing the cage"),
        (glfw.KEY_D, 0, "mode", "deform", "D", "deform: drag the blue target points"),
        (glfw.KEY_C, 0, "mode", "cage", "C", "cage: drag green points, click to add, right-click to delete"),
        (
            glfw.KEY_N,
            0,
            "new_cage",
            None,
            "N",
            "draw a new cage: click to place points (Ctrl+click or a "
            "double click: a sharp corner), click the first point or Enter to close, Enter again to use it, "
            "Backspace removes the last point, Esc abandons",
        ),
        (glfw.KEY_ENTER, 0, "confirm", None, "Enter", "close the new cage; use it"),
        (glfw.KEY_KP_ENTER, 0, "confirm", None, None, None),
        (glfw.KEY_R, 0, "reset_target", None, "R", "reset the target to the source cage"),
        (
            glfw.KEY_F,
            0,
            "fit",
            None,
            "F",
            "fit the cage to the subject (on a photo: drag a rectangle around it first)",
        ),
        (glfw.KEY_S, 0, "subdivide", None, "S", "subdivide the cage (same curve, twice the points)"),
        (glfw.KEY_DELETE, 0, "delete", None, "Delete", "delete the selected control points (cage mode)"),
        (glfw.KEY_BACKSPACE, 0, "delete", None, None, None),
        (glfw.KEY_K, 0, "cycle_kernel", "next", "K, Shift+K", "next (previous) kernel"),
        (glfw.KEY_K, shift, "cycle_kernel", "previous", None, None),
        # The views, Shift+1, Shift+2, ... in the panel's order.
        *(
            (glfw.KEY_1 + k, shift, "content", mode.name, f"Shift+{k + 1}", mode.help)
            for k, mode in enumerate(VIEW_MODES)
        ),
        (glfw.KEY_EQUAL, 0, "zoom", "in", "+, -", "zoom in, out (about the canvas centre)"),
        (glfw.KEY_EQUAL, shift, "zoom", "in", None, None),
        (glfw.KEY_KP_ADD, 0, "zoom", "in", None, None),
        (glfw.KEY_MINUS, 0, "zoom", "out", None, None),
        (glfw.KEY_KP_SUBTRACT, 0, "zoom", "out", None, None),
        (glfw.KEY_1, 0, "zoom", 1.0, "1, 2, 3", "zoom to 100 %, 200 %, 400 %"),
        (glfw.KEY_2, 0, "zoom", 2.0, None, None),
        (glfw.KEY_3, 0, "zoom", 4.0, None, None),
        (glfw.KEY_0, 0, "fit_view", None, "0, Home", "fit the image in the window"),
        (glfw.KEY_X, 0, "toggle", "show_folds", "X", "show folded-over triangles"),
        (glfw.KEY_W, 0, "toggle", "show_wireframe", "W", "show the mesh edges"),
        (glfw.KEY_V, 0, "toggle", "show_overlay", "V", "show the curves and handles"),
        (glfw.KEY_HOME, 0, "fit_view", None, None, None),
        (glfw.KEY_P, 0, "play", None, "P", "play or stop the demo script"),
        (
            glfw.KEY_SPACE,
            0,
            "playback",
            None,
            "Space",
            "play or pause the keyframes (the timeline in the panel)",
        ),
        (glfw.KEY_I, 0, "add_keyframe", None, "I", "a keyframe at the current time from the target shown"),
        (glfw.KEY_RIGHT, 0, "seek_by", 0.1, "Left, Right", "the time 1/10 s back or on (Shift: 1 s)"),
        (glfw.KEY_LEFT, 0, "seek_by", -0.1, None, None),
        (glfw.KEY_RIGHT, shift, "seek_by", 1.0, None, None),
        (glfw.KEY_LEFT, shift, "seek_by", -1.0, None, None),
        (glfw.KEY_F1, 0, "help", None, "F1, H", "this help"),
        (glfw.KEY_H, 0, "help", None, None, None),
    ]


MOUSE_HELP = [
    ("Wheel", "zoom around the cursor"),
    ("Middle or right drag", "pan"),
    ("Drag on empty canvas", "select the handles inside a rubber band (deform mode; Shift adds)"),
    ("Shift+click", "add a handle to the selection, or take it out; drag one to move them all"),
]
#: Frames drawn after any input without waiting: imgui opens a popup (a combo) one frame
#: after the click, and a widget may change the state it draws only on the next frame.
FRAMES_AFTER_INPUT = 3
#: Seconds an idle viewer sleeps between frames (input, and the precompute's messages, wake it).
IDLE_WAIT = 2.0
#: Seconds of an animation export's frames rendered between two window frames (the window's own
#: frame costs as much as several exported ones on a software rasteriser).
EXPORT_BUDGET = 0.25
#: Seconds between two updates of the status line's frame times (a median of every frame so far).
FIGURES_INTERVAL = 0.5


class Viewer:
    """The running viewer: state, window, renderer, precompute worker.

    Parameters
    ----------
    document : Document
        What to open.
    options : Options
    """

    def __init__(self, document: Document, options: Options):
        self.options = options
        self.test_mode = os.environ.get(TEST_VARIABLE) == "1"
        # The worker starts first: its imports overlap with the window's creation.  The Newton
        # solver compiles in the background meanwhile (the default kernel needs none).
        self.precompute = Precompute(warm_up=not self.test_mode)
        self.state = AppState(
            history=History(document.snapshot),
            live=document.snapshot,
            image=document.image,
            session_path=Path(document.session_path),
            window_size=options.size or WINDOW_SIZE,
        )
        self._edges: dict[bytes, float] = {}
        self._session_lock = None
        self._load(document)
        self._wanted: str | None = None
        self._failed: set[str] = set()
        self._events: deque = deque()
        self.dialogs = FileRequests()
        self._view_changed_at = 0.0
        self._player = None
        self._script_clock: float | None = None
        self._frames_written = 0
        self._announced_ready = False
        self._frames_to_draw = FRAMES_AFTER_INPUT
        self._close_popups = False
        self._popup_is_open = False
        self._typing = False
        self._panel_spot = None  # the panel's bottom and hidden height last announced (test mode)
        # Where the last export went, as typed (a folder of frames ends in a slash).
        self._last_export: str | None = None if options.export is None else str(options.export)
        self._export: AnimationExport | None = None
        self._playback_clock: float | None = None
        self._playback_first_frame = 0
        self._drag_first_frame: int | None = None
        #: Times (ms) of the frames drawn while a control point was dragged, for --stats.
        self._drag_frame_ms: list[float] = []
        self._previewing = False  # the last frame drew the preview mesh (announced in test mode)
        self._figures_at = -FIGURES_INTERVAL  # when the status line's frame times were last computed
        self.window = None

    # -- lifetime -------------------------------------------------------------------

    def run(self) -> int:
        """Open the window and loop until quit; returns the exit code."""
        previous = signal.signal(signal.SIGTERM, lambda *_: setattr(self.state, "quit", True))
        try:
            self._open_window()
            try:
                if self.options.script is not None and self.options.play:
                    self._toggle_script()
                if self.options.playback:
                    self.state.loop = True
                    self.state.time = 0.0
                    self.command("playback")
                while not self.state.quit:
                    self._frame()
            finally:
                self._close_window()
        finally:
            signal.signal(signal.SIGTERM, previous)
            self.precompute.close()
        if self.options.stats:
            from app.viewer.gui import frame_statistics

            count, median, p95 = frame_statistics(self.state.frame_ms)
            _, drag_median, _ = frame_statistics(self._drag_frame_ms)
            print(
                f"frames={count} median_frame_ms={median:.2f} p95_frame_ms={p95:.2f} "
                f"median_drag_frame_ms={drag_median:.2f}",
                flush=True,
            )
        return 0

    def _open_window(self) -> None:
        import glfw  # before imgui_bundle, so that the standard glfw module is the one used
        import moderngl
        from imgui_bundle import imgui

        from app.render import WarpRenderer
        from app.viewer.gui_renderer import GuiRenderer
        from app.viewer.scene import Scene

        if not glfw.init():
            raise _environment_error(
                f"cannot initialise glfw (is there a display? DISPLAY is {os.environ.get('DISPLAY')!r})"
            )
        glfw.window_hint(glfw.CONTEXT_VERSION_MAJOR, 3)
        glfw.window_hint(glfw.CONTEXT_VERSION_MINOR, 3)
        glfw.window_hint(glfw.OPENGL_PROFILE, glfw.OPENGL_CORE_PROFILE)
        glfw.window_hint(glfw.OPENGL_FORWARD_COMPAT, True)
        # 2D only: no depth or stencil buffer to clear every frame.
        glfw.window_hint(glfw.DEPTH_BITS, 0)
        glfw.window_hint(glfw.STENCIL_BITS, 0)
        # Hidden until it is placed where it fits (`app.viewer.window_fit`).
        glfw.window_hint(glfw.VISIBLE, False)
        from app.viewer.drawing import STYLES
        from app.viewer.settings import read_settings

        settings = read_settings()  # the last viewer's (`app.viewer.settings`)
        if settings.get("cage_drawing") in STYLES:
            self.state.cage_drawing = settings["cage_drawing"]
        x, y, width, height = self._opening_rectangle(glfw, settings)
        window = glfw.create_window(width, height, self._title(), None, None)
        if not window:
            glfw.terminate()
            raise _environment_error("cannot open an OpenGL 3.3 window")
        self.window = window
        glfw.set_window_pos(window, x, y)
        glfw.show_window(window)
        glfw.make_context_current(window)
        glfw.swap_interval(0 if self.test_mode else 1)
        self.ctx = moderngl.create_context()
        imgui.create_context()
        imgui.get_io().set_ini_filename("")
        self.imgui = imgui
        self.imgui_renderer = GuiRenderer(window, self.ctx)
        self._chain_callbacks(glfw)
        self.precompute.wake_on_message(glfw.post_empty_event)
        self.renderer = WarpRenderer(self.ctx)
        self.scene = Scene(self.renderer)
        self.shortcuts = [(keys, what) for *_, keys, what in _key_table() if keys] + MOUSE_HELP
        self._keys = _key_table()
        glfw.focus_window(window)
        self.state.window_size = glfw.get_window_size(window)
        # Kept by the size callbacks: asking the X server costs a round trip (~0.1 ms) each time.
        self._sizes = {"window": self.state.window_size, "pixels": glfw.get_framebuffer_size(window)}
        self.state.canvas_left = 300.0
        self._show_document_view()
        self.state.session_dirty = True  # the first save, so the session file exists at once

    def _opening_rectangle(self, glfw, settings: dict) -> tuple[int, int, int, int]:
        """(x, y, width, height) of the window: asked for, as last closed, or fitted to the screen."""
        from app.viewer.settings import window_rectangle
        from app.viewer.window_fit import monitor_work_area, opening_rectangle

        saved = window_rectangle(settings)
        monitors = [glfw.get_primary_monitor()] + [m for m in glfw.get_monitors() or [] if m]
        areas = [tuple(glfw.get_monitor_workarea(m)) for m in monitors if m]
        if not areas:  # no monitor reported: the size asked for, or the old default
            return (0, 0, *(self.options.size or WINDOW_SIZE))
        return opening_rectangle(monitor_work_area(areas, saved), saved, self.options.size)

    def _save_settings(self, glfw) -> None:
        """Remember the window's place and size, and how cages are drawn, for the next viewer."""
        from app.viewer.settings import write_settings

        x, y = glfw.get_window_pos(self.window)
        width, height = glfw.get_window_size(self.window)
        window = {"x": x, "y": y, "width": width, "height": height}
        try:
            write_settings({"window": window, "cage_drawing": self.state.cage_drawing})
        except (InputError, OSError) as error:
            print(f"note: cannot save the viewer's settings: {error}", file=sys.stderr)

    def _load(self, document: Document) -> None:
        """Make `document` the one shown and saved: its history, preferences and session file."""
        state = self.state
        state.history = History(document.snapshot, undo=document.undo, redo=document.redo)
        state.live = document.snapshot
        state.image = document.image
        state.session_path = Path(document.session_path)
        state.drag = state.drawing = None
        state.selected = None
        apply_preferences(state, document.preferences)
        if document.max_edge is not None and self.options.vertices is None:
            self._edges[document.snapshot.cage.tobytes()] = document.max_edge
        self._document_view = document.view
        self._start_cage = document.start_cage
        previous = self._session_lock
        if previous is not None and previous is not document.lock:
            previous.release()  # the session left behind is never written again: another viewer may open it
        self._session_lock = document.lock
        # What the session file holds now: an autosave of anything else is a new version.
        self._saved: Snapshot | None = document.snapshot if document.restored else None
        if document.notices:
            state.say(document.notices[-1])

    def _show_document_view(self) -> None:
        """The loaded session's view, or the image fitted to the window."""
        if self._document_view is not None:
            self.state.view = self._document_view
        else:
            controller.fit_view(self.state, None)
            self.state.view_dirty = False

    def _close_window(self) -> None:
        import glfw

        self._save_if_needed(force=True)
        if self.window is None:
            return
        self._save_settings(glfw)
        self.scene.release()
        self.renderer.release()
        self.imgui_renderer.shutdown()
        self.imgui.destroy_context()
        self.ctx.release()
        glfw.destroy_window(self.window)
        glfw.terminate()
        self.window = None

    # -- input --------------------------------------------------------------------------

    def _chain_callbacks(self, glfw) -> None:
        """Wrap imgui's glfw callbacks: imgui sees every event first, the canvas what imgui leaves."""
        window, io = self.window, self.imgui.get_io()
        # The pointer as of the event being handled.  glfw.get_cursor_pos asks the X server where
        # the pointer is now: after a slow frame (a dense mesh arriving) the queued press was placed
        # where the drag had already moved on to, and grabbed nothing.
        pointer = list(glfw.get_cursor_pos(window))

        def chained(setter, handler):
            previous = setter(window, None)

            def callback(*args):
                if previous is not None:
                    previous(*args)
                handler(*args)
                self._frames_to_draw = FRAMES_AFTER_INPUT

            setter(window, callback)

        def mouse_button(_, button, action, mods):
            x, y = pointer
            if action == glfw.RELEASE:
                self._events.append(("pointer", "release", x, y, button, 0.0, False, False))
            elif not io.want_capture_mouse_unless_popup_close:
                # A press that closes an open list (combo) also reaches the canvas.
                shift, ctrl = bool(mods & glfw.MOD_SHIFT), bool(mods & (glfw.MOD_CONTROL | glfw.MOD_SUPER))
                self._events.append(("pointer", "press", x, y, button, 0.0, shift, ctrl))

        def cursor(_, x, y):
            pointer[:] = x, y
            # A drag keeps its events even over a panel.
            if self.state.drag is not None or not io.want_capture_mouse:
                self._events.append(("pointer", "move", x, y, 0, 0.0, False, False))

        def scroll(_, dx, dy):
            if not io.want_capture_mouse:
                x, y = pointer
                self._events.append(("pointer", "scroll", x, y, 0, dy, False, False))

        def key(_, key, scancode, action, mods):
            if action not in (glfw.PRESS, glfw.REPEAT) or io.want_text_input:
                return
            if mods & glfw.MOD_SUPER:  # Cmd on macOS
                mods = (mods & ~glfw.MOD_SUPER) | glfw.MOD_CONTROL
            mods &= glfw.MOD_CONTROL | glfw.MOD_SHIFT | glfw.MOD_ALT
            for code, wanted, name, value, *_ in self._keys:
                if code == key and wanted == mods:
                    if io.want_capture_keyboard and not mods & glfw.MOD_CONTROL and name != "cancel":
                        return  # plain letters go to a focused widget
                    self._events.append(("command", name, value))
                    return

        def drop(_, paths):
            for path in paths[:1]:
                self._events.append(("command", "open_path", path))

        def close(_):
            self.state.quit = True

        def char(*_):
            self._frames_to_draw = FRAMES_AFTER_INPUT

        chained(glfw.set_mouse_button_callback, mouse_button)
        chained(glfw.set_cursor_pos_callback, cursor)
        chained(glfw.set_scroll_callback, scroll)
        chained(glfw.set_key_callback, key)
        chained(glfw.set_char_callback, char)
        chained(
            glfw.set_window_size_callback, lambda _, width, height: self._sizes.update(window=(width, height))
        )
        glfw.set_framebuffer_size_callback(
            window, lambda _, width, height: self._sizes.update(pixels=(width, height))
        )
        glfw.set_drop_callback(window, drop)
        glfw.set_window_close_callback(window, close)

    def _apply_events(self) -> None:
        while self._events:
            event = self._events.popleft()
            if event[0] == "pointer":
                _, kind, x, y, button, amount, shift, ctrl = event
                controller.pointer(self.state, kind, x, y, button, amount, shift, ctrl)
                if kind in ("scroll",) or (
                    kind == "move" and self.state.drag and self.state.drag.kind == "pan"
                ):
                    self._view_changed_at = time.perf_counter()
            else:
                self.command(event[1], event[2])

    #: The commands the window runs itself (they need files, dialogs or the loop), with what
    #: they do; the rest are the controller's (`app.viewer.controller.COMMANDS`).
    WINDOW_COMMANDS = {
        "quit": "quit",
        "save": "save the session now",
        "export": "export the warped image or the animation (value 'again': to the last file)",
        "export_path": "export to the path given",
        "open": "open an image",
        "open_session": "open a session file",
        "open_path": "open the image at the path given",
        "play": "play or stop the demo script",
        "start_over": "start over: the image without a cage",
        "fit_view": "fit the image in the window",
    }

    def command(self, name: str, value=None) -> None:
        """Run a command of the keyboard, the panel or a drop: the window's own
        (`WINDOW_COMMANDS`), else the controller's."""
        state = self.state
        if name == "cancel" and self._export is not None:
            self._export.writer.abort()
            self._export = None
            state.say("animation export stopped; nothing was written")
        elif name == "cancel" and self._popup_is_open:
            self._close_popups = True
        elif name in self.WINDOW_COMMANDS:
            getattr(self, f"_command_{name}")(value)
        elif not controller.command(state, name, value):
            state.say(f"unknown command {name!r}", error=True)

    def _command_quit(self, value) -> None:
        self.state.quit = True

    def _command_save(self, value) -> None:
        self._save_if_needed(force=True, announce=True)

    def _command_export(self, value) -> None:
        if value == "again" and self._last_export is not None:
            self.export(Path(self._last_export).expanduser(), self._last_export)
        else:
            self._ask_export_path()

    def _command_export_path(self, value) -> None:
        self.export(Path(value).expanduser(), value)

    def _command_open(self, value) -> None:
        self.dialogs.ask_open(self.state, "image", Path(self.state.live.image).parent)

    def _command_open_session(self, value) -> None:
        self.dialogs.ask_open(self.state, "session", self.state.session_path.parent)

    def _command_open_path(self, value) -> None:
        self.open_path(Path(value))

    def _command_play(self, value) -> None:
        self._toggle_script()

    def _command_start_over(self, value) -> None:
        self.start_over()

    def _command_fit_view(self, value) -> None:
        controller.fit_view(self.state, None)
        self._view_changed_at = time.perf_counter()

    def _follow_window_size(self, size: tuple[int, int]) -> None:
        """A resized window: fit the image again if it was fitted, else keep the canvas centre still."""
        state = self.state
        old = state.window_size
        state.window_size = size
        if tuple(size) == tuple(old) or size[0] <= 0 or size[1] <= 0:
            return
        if state.view_fitted:
            controller.fit_view(state, None)
        else:
            shift = 0.5 * (np.asarray(size, dtype=np.float64) - np.asarray(old, dtype=np.float64))
            state.view = editing.pan(state.view, shift)
            state.view_dirty = True
        self._view_changed_at = time.perf_counter()

    # -- files ----------------------------------------------------------------------------

    def _poll_dialog(self) -> None:
        for name, value in self.dialogs.poll():  # a file dialog answered (`app.viewer.file_dialogs`)
            self.command(name, value)

    def open_path(self, path: Path) -> None:
        """Open a dropped or chosen file: an image or a session (each in its own session file), or a cage.

        The current session is saved first and never written again after the
        switch; opening an image whose session exists restores that session.
        """
        state = self.state
        try:
            if path.suffix.lower() == ".json":
                value = read_json(path)
                if isinstance(value, dict) and "image" in value and "target" in value:
                    self._switch_to(open_document(session=path))
                    return
                from app.files import read_cage

                cage = read_cage(path)
                problem = editing.cage_problem(cage)
                if problem:
                    raise InputError(f"{path}: {problem}")
                controller.commit(
                    state, state.live.replace(cage=cage, target=cage, keyframes=()), f"cage from {path}"
                )
                return
            document = open_document(path)  # raises before the current session is left
        except (InputError, OSError) as error:
            state.say(str(error), error=True)
            return
        if not document.notices:
            document.notices.append(f"opened {path.name}")
        self._switch_to(document)

    def _switch_to(self, document: Document) -> None:
        """Save the current session if it changed, then show `document`."""
        self._save_if_needed(due=True)
        self._load(document)
        self._show_document_view()
        self.state.session_dirty = True
        if self.window is not None:
            import glfw

            glfw.set_window_title(self.window, self._title())

    def start_over(self) -> None:
        """Replace the document with a new start (the opening cage, or a fitted one), as one undoable edit."""
        state = self.state
        try:
            snapshot, note = start_snapshot(state.live, state.image, self._start_cage)
        except InputError as error:
            state.say(str(error), error=True)
            return
        if controller.commit(state, snapshot, f"started over: {note} (Ctrl+Z goes back)"):
            controller.fit_view(state, None)

    def _ask_export_path(self) -> None:
        """Ctrl+E: where to write (``--export`` if given, else a save dialog or the in-window prompt)."""
        if self.options.export is not None:
            self.export(self.options.export)
            return
        proposed = self._last_export or default_export_path(self.state.live.image)
        self.dialogs.ask_export(self.state, proposed)

    def export(self, path: Path, typed: str | None = None) -> Path | None:
        """Write the warped image at the image's full resolution, like ``warp --session``.

        A name ending in .mp4 or .gif, or in a slash (`typed`, the text as typed),
        starts exporting the animation instead, like ``animate``: one frame per
        drawn frame of the viewer, until it is complete (Esc stops it).
        """
        state = self.state
        if path.suffix.lower() in (".mp4", ".gif") or (typed or "").endswith(("/", os.sep)):
            self._start_animation_export(path, typed)
            return None
        if path.suffix.lower() != ".png":
            path = path.with_name(path.name + ".png")
        try:
            pixels = self._render_export()
        except ValueError as error:  # an output over app.framing.MAX_OUTPUT_PIXELS
            state.say(str(error), error=True)
            return None
        if pixels is None:
            state.say("nothing to export yet: the basis functions are still being computed", error=True)
            return None
        try:
            write_png(path, pixels)
        except InputError as error:
            state.say(str(error), error=True)
            return None
        self._last_export = str(path)
        state.say(f"exported {path} (Ctrl+Shift+E writes it again)")
        self._announce(f"exported {path}")
        return path

    def _start_animation_export(self, path: Path, typed: str | None) -> None:
        from app.animate import WRITERS, check_output, frame_region, output_kind
        from app.keyframes import frame_times

        state = self.state
        live = state.live
        if not live.keyframes:
            state.say("no keyframes to export: add some first (I, or the Keyframe button)", error=True)
            return
        if state.basis is None or state.basis.key != self._wanted or not self.scene.mesh_matches(state):
            state.say("nothing to export yet: the basis functions are still being computed", error=True)
            return
        try:
            kind = output_kind(path, typed)
            check_output(path, kind)
            times = frame_times(live.keyframes, self.options.fps)
            height, width = state.image.shape[:2]
            region = frame_region((width, height), live.keyframes, live.interpolation, times, state.canvas)
            size, view = output_frame(region)
            writer = WRITERS[kind](path, size, self.options.fps)
        except (InputError, ValueError, OSError) as error:
            state.say(str(error), error=True)
            return
        state.playing = False
        self._export = AnimationExport(
            writer, times, size, view, live, state.basis.deformation(), state.outside
        )
        self._last_export = str(path) + os.sep if kind == "png" else str(path)
        state.say(f"exporting {len(times)} frames to {path} (Esc stops)")

    def _export_frame(self) -> None:
        """Render and write the next frames of the animation being exported, for `EXPORT_BUDGET`
        seconds (a window frame between them keeps the progress shown and Esc heard); finish after
        the last.  Each frame is what `animate` renders (`app.warping.render`)."""
        export, state = self._export, self.state
        if export is None:
            return
        from app.keyframes import interpolate
        from app.warping import render

        snapshot = export.snapshot
        self.scene.invalidate_positions()
        started = time.perf_counter()
        try:
            while export.written < len(export.times) and time.perf_counter() - started < EXPORT_BUDGET:
                moment = float(export.times[export.written])
                target = interpolate(snapshot.keyframes, moment, snapshot.interpolation)
                export.writer.add(
                    render(
                        self.renderer, export.deformation, target, export.size, export.view, export.outside
                    )
                )
                export.written += 1
            if export.written == len(export.times):
                export.writer.finish()
        except (OSError, ValueError) as error:
            export.writer.abort()
            self._export = None
            state.say(f"cannot export the animation: {error}", error=True)
            return
        if export.written == len(export.times):
            self._export = None
            state.say(f"exported {len(export.times)} frames to {export.writer.path}")
            self._announce(f"exported {export.writer.path}")

    def _announce_drag_frames(self) -> None:
        """Test mode: the frame times of each drag of a target point, to compare playback with."""
        dragging = self.state.drag is not None and self.state.drag.kind == "target"
        if dragging and self._drag_first_frame is None:
            self._drag_first_frame = len(self.state.frame_ms)
        elif not dragging and self._drag_first_frame is not None:
            from app.viewer.gui import frame_statistics

            count, median, _ = frame_statistics(self.state.frame_ms[self._drag_first_frame :])
            self._announce(f"drag done frames={count} median_frame_ms={median:.2f}")
            self._drag_first_frame = None

    def _advance_playback(self) -> None:
        """Move the playing animation on by the wall time since the last frame."""
        state, now = self.state, time.perf_counter()
        if not state.playing:
            if self._playback_clock is not None:
                from app.viewer.gui import frame_statistics

                count, median, _ = frame_statistics(state.frame_ms[self._playback_first_frame :])
                self._announce(f"playback paused frames={count} median_frame_ms={median:.2f}")
            self._playback_clock = None
            return
        ready = state.basis is not None and state.basis.key == self._wanted and self.scene.mesh_matches(state)
        if self._playback_clock is None:
            self._playback_first_frame = len(state.frame_ms)
            self._announce("playback started")
        elif not ready:  # the animation waits, its time standing still, until it can be seen
            self._playback_first_frame = len(state.frame_ms)
        else:
            controller.advance(state, now - self._playback_clock)
        self._playback_clock = now

    def _render_export(self) -> np.ndarray | None:
        state = self.state
        if state.basis is None or state.basis.key != self._wanted:
            return None
        from app.warping import render

        deformation = self.scene.deformation(state)
        if deformation is None:
            return None
        self.scene.invalidate_positions()
        height, width = state.image.shape[:2]
        region = output_region((width, height), state.live.target, state.canvas)
        size, view = output_frame(region)
        return render(self.renderer, deformation, state.live.target, size, view, state.outside)

    def _save_if_needed(self, force: bool = False, announce: bool = False, due: bool = False) -> None:
        """Autosave after an edit, after a zoom or pan settles, or when asked.

        `force` writes in any case; `due` writes a pending zoom or pan at once.
        """
        state = self.state
        due = state.session_dirty or (
            state.view_dirty and (due or time.perf_counter() - self._view_changed_at >= VIEW_SAVE_DELAY)
        )
        if not (due or force) or state.drag is not None and not force:
            return
        current = state.history.current
        if current.n < 3:
            return  # a cage being placed is no session yet
        try:
            save(state, self._max_edge(current.cage), new_version=current != self._saved)
        except (InputError, OSError) as error:
            state.say(f"cannot save the session: {error}", error=True)
            return
        self._saved = current
        state.session_dirty = state.view_dirty = False
        if announce:
            state.say(f"saved {state.session_path}")
        self._announce(f"saved {state.session_path}")

    # -- precompute -----------------------------------------------------------------------

    def _max_edge(self, cage: np.ndarray) -> float:
        if self.options.max_edge is not None:
            return self.options.max_edge
        key = cage.tobytes()
        if key not in self._edges:
            vertices = self.options.vertices or editing.TARGET_VERTICES
            self._edges[key] = editing.default_max_edge(cage, vertices)
        return self._edges[key]

    def _update_precompute(self) -> None:
        state = self.state
        for message in self.precompute.poll():
            kind, key = message[0], message[1]
            if kind == "progress" and key == self.precompute.pending:
                state.progress, state.progress_label = message[2], message[3]
            elif kind == "done":
                state.progress = None if self.precompute.pending is None else state.progress
                if key == self._wanted:
                    self._apply(message[2])
            elif kind == "error":
                if self.precompute.pending is None:
                    state.progress = None
                self._failed.add(key)
                if key == self._wanted:
                    state.basis_error = message[2]
                    state.say(message[2], error=True)
        if state.drag is not None or state.drawing is not None or state.live.n < 3:
            return
        live = state.live
        wanted = make_request(live, self._max_edge(live.cage), gradients=VIEW_MODE[state.content].gradients)
        self._wanted = wanted.key
        if state.basis is not None and state.basis.key == wanted.key:
            return
        remembered = self.precompute.remembered(wanted.key)
        if remembered is not None:
            self._apply(remembered, cached=True)
        elif wanted.key in self._failed:
            return
        elif self.precompute.pending != wanted.key:
            self.precompute.submit(wanted)
            state.progress, state.progress_label = 0.0, "starting"
            state.basis_error = ""

    def _apply(self, result, cached: bool = False) -> None:
        state = self.state
        state.basis = result
        state.basis_error = ""
        if not cached:
            state.progress = None
        vertices = len(result.mesh.vertices)
        preview = 0 if result.preview is None else len(result.preview.vertices)
        self._announce(f"basis key={result.key} vertices={vertices} kernel={result.kernel} preview={preview}")

    # -- scripts --------------------------------------------------------------------------

    def _toggle_script(self) -> None:
        from app.viewer.demos import ScriptPlayer, read_script

        if self.options.script is None:
            self.state.say("no script: start a demo (python -m app demo NAME) or give --script", error=True)
            return
        if self._player is not None:
            self._player = None
            self._script_clock = None
            self.state.say("script stopped")
            return
        try:
            moves = read_script(self.options.script, self.state.live.n)
        except InputError as error:
            self.state.say(str(error), error=True)
            return
        self.state.mode = "deform"
        self._player = ScriptPlayer(moves)
        self._script_clock = None
        self.state.say(f"playing {self.options.script.name}")

    def _script_events(self) -> None:
        player, state = self._player, self.state
        if player is None:
            return
        ready = (
            state.basis is not None and state.basis.key == self._wanted and self.precompute.pending is None
        )
        if self._script_clock is None:
            if not ready:
                return  # replay once the deformation can be seen
            self._script_clock = time.perf_counter()
        if self.options.frames is not None:
            now = self._frames_written / self.options.fps
        else:
            now = time.perf_counter() - self._script_clock
        events = player.events(
            now,
            lambda index: state.live.target[index],
            lambda point: editing.to_window(state.view, point),
        )
        for kind, x, y in events:
            # The same path as the mouse: the queue that the glfw callbacks fill.
            self._events.append(("pointer", kind, x, y, controller.LEFT, 0.0, False, False))
        if player.finished and not events:
            self._player = None
            state.say("script finished")
            self._announce("script done")
            if self.options.frames is not None:
                state.quit = True

    def _write_frame(self) -> None:
        if self._player is None or self._script_clock is None or self.options.frames is None:
            return
        pixels = self._render_export()
        if pixels is None:
            return
        self.options.frames.mkdir(parents=True, exist_ok=True)
        write_png(self.options.frames / f"frame_{self._frames_written:05d}.png", pixels)
        self._frames_written += 1

    # -- one frame --------------------------------------------------------------------------

    def _frame(self) -> None:
        import glfw
        from OpenGL import GL

        imgui, state = self.imgui, self.state
        # Input wakes the loop at once; without input, draw only as often as something
        # changes on its own, so that an idle or waiting viewer leaves the CPU to the
        # precompute (the worker runs at lower priority and gets what the UI leaves).
        if (self._player is not None and self._script_clock is not None) or state.playing or self._export:
            glfw.poll_events()  # a replay, playback or an export animates every frame
        elif not imgui.get_current_context().input_events_queue.empty():
            glfw.poll_events()  # imgui takes queued input a few events a frame (typed text)
        elif self._events or self._frames_to_draw > 0:
            glfw.poll_events()
            self._frames_to_draw -= 1
        elif self.precompute.pending is not None or self._player is not None:
            glfw.wait_events_timeout(0.1)  # the progress bar
        elif state.view_dirty or self.dialogs.waiting:
            glfw.wait_events_timeout(0.05)
        else:
            glfw.wait_events_timeout(IDLE_WAIT)
        started = time.perf_counter()
        self._follow_window_size(self._sizes["window"])
        self._script_events()
        self._apply_events()
        # An edit is saved before this frame's drawing: on a dense mesh the frame after a release
        # (exact positions, fold count, the whole mesh drawn) takes ~0.7 s, and a viewer killed
        # meanwhile lost the drag.
        self._save_if_needed()
        if self.test_mode:
            self._announce_drag_frames()
        self._advance_playback()
        self._poll_dialog()
        self._update_precompute()

        self.imgui_renderer.process_inputs(self._sizes["window"], self._sizes["pixels"])
        imgui.new_frame()
        if self._close_popups:
            imgui.internal.close_popups_except_modals()
            self._close_popups = False
        from app.viewer.gui import gui

        extras = {
            "script": self.options.script is not None,
            "playing": self._player is not None,
            "exporting": None if self._export is None else self._export.written / len(self._export.times),
        }
        commands = gui(state, self.shortcuts, extras)
        any_popup = imgui.PopupFlags_.any_popup_id | imgui.PopupFlags_.any_popup_level
        popup = imgui.is_popup_open("", any_popup)
        if popup != self._popup_is_open:
            self._announce(f"popup {'open' if popup else 'closed'}")
        self._popup_is_open = popup
        panel = state.spots.get("panel")
        if panel != self._panel_spot:  # its layout settles over the first frames: each one for the tests
            self._panel_spot = panel
            self._announce(f"spot panel={panel[0]:.0f},{panel[1]:.0f}")
        typing = imgui.get_io().want_text_input
        if typing != self._typing:
            self._announce(f"text input {'on' if typing else 'off'}")  # keys go to a text field
            self._typing = typing
        for name, value in commands:
            self.command(name, value)
        self._update_precompute()  # a kernel chosen in the panel starts computing this frame

        shown = state.distortion
        state.view_moving = (state.drag is not None and state.drag.kind == "pan") or (
            time.perf_counter() - self._view_changed_at < VIEW_SETTLE
        )
        self.scene.sync(state)
        if self.test_mode and self.scene.previewing != self._previewing:
            self._previewing = self.scene.previewing
            self._announce(f"preview {'on' if self._previewing else 'off'}")
        if state.distortion is not shown and state.content == "distortion":
            d = state.distortion
            self._announce(
                f"distortion measure={state.distortion_measure} folded={d.folded} exact={d.exact} "
                f"vertices={d.vertices} min_det={d.min_det:.6g} "
                f"at={d.min_det_at[0]:.1f},{d.min_det_at[1]:.1f}"
            )
        width, height = self._sizes["pixels"]
        ratio = width / max(state.window_size[0], 1)
        self.ctx.screen.use()
        self.ctx.viewport = (0, 0, width, height)
        if width > 0 and height > 0:
            self.scene.draw(state, (width, height), ratio)
        # A software rasteriser starts on the canvas now, while imgui's draw data is prepared.
        GL.glFlush()
        imgui.render()
        self.imgui_renderer.render(imgui.get_draw_data())
        self._write_frame()
        self._export_frame()
        glfw.swap_buffers(self.window)
        state.frame_ms.append(1e3 * (time.perf_counter() - started))
        if state.drag is not None and state.drag.kind in ("target", "source"):
            self._drag_frame_ms.append(state.frame_ms[-1])
        self._update_frame_figures()
        self._save_if_needed()
        if not self._announced_ready:
            self._announced_ready = True
            window_id = glfw.get_x11_window(self.window) if sys.platform.startswith("linux") else 0
            self._announce(f"ready window={window_id}")
            for name in ("kernel", "arc-length"):
                x, y = state.spots.get(name, (0, 0))
                self._announce(f"spot {name}={x:.0f},{y:.0f}")
        if glfw.window_should_close(self.window):
            state.quit = True

    def _update_frame_figures(self) -> None:
        """The status line's frame times: what ``--stats`` would report now, twice a second."""
        now = time.perf_counter()
        if now - self._figures_at < FIGURES_INTERVAL:
            return
        from app.viewer.gui import frame_statistics

        self._figures_at = now
        _, median, _ = frame_statistics(self.state.frame_ms)
        _, drag_median, _ = frame_statistics(self._drag_frame_ms)
        self.state.frame_figures = (median, drag_median)

    def _announce(self, line: str) -> None:
        if self.test_mode:
            print(line, flush=True)

    def _title(self) -> str:
        return f"Transfinite warp - {Path(self.state.live.image).name}"


@dataclass
class AnimationExport:
    """An animation export in progress in the viewer: one frame written per drawn frame.

    Attributes
    ----------
    writer : app.animate.FrameWriter
    times : ndarray of shape (F,)
        Seconds of every frame (`app.keyframes.frame_times`).
    size, view
        Output size (width, height) and image-to-output `View` (`app.framing`).
    snapshot : Snapshot
        The document when the export started (its keyframes and interpolation).
    deformation : app.warping.Deformation
        The mesh drawn and its G.
    outside : str
    written : int
        Frames written so far.
    """

    writer: object
    times: np.ndarray
    size: tuple[int, int]
    view: object
    snapshot: Snapshot
    deformation: object  # app.warping.Deformation
    outside: str
    written: int = 0


def default_export_path(image: Path) -> Path:
    """Where Ctrl+E proposes to write: ``STEM-warped.png`` beside the image, numbered if it exists;
    in the current folder for a bundled demo (inside the installed package) or a read-only folder."""
    from app.viewer.demos import is_demo_file

    image = Path(image)
    if is_demo_file(image) or not os.access(image.parent, os.W_OK):
        image = Path.cwd() / image.name
    for number in range(1, 1000):
        suffix = "" if number == 1 else f"-{number}"
        path = image.with_name(f"{image.stem}-warped{suffix}.png")
        if not path.exists():
            return path
    return image.with_name(f"{image.stem}-warped.png")


def _environment_error(message: str) -> Exception:
    from app.render import ContextUnavailableError

    return ContextUnavailableError(message)


def run(document: Document, options: Options) -> int:
    """Open the viewer on `document`; returns the exit code when it is closed."""
    return Viewer(document, options).run()
