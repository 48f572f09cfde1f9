"""The viewer's window: a glfw loop of our own, moderngl for the canvas, imgui-bundle for widgets.

One frame: poll input (glfw callbacks, chained after imgui's own, queue canvas
events only when imgui does not want the mouse: `app.viewer.window_input`), replay a
script's events through the same queue (`app.viewer.script_replay`), apply them
(`controller`, `commands`), read the precompute's messages (`app.viewer.basis_updates`),
draw the widgets (`gui`) and run their commands, bring the GPU up to date
(`Scene.sync`: one in-place buffer write per drag), draw, swap, write an export's frame
(`app.viewer.exports`), and save the session if it changed.  The frame time is the wall
time of that whole sequence.  `Viewer` only wires these parts.

With the environment variable ``TRANSFINITE_VIEWER_TEST=1`` the viewer prints
one line per milestone on stdout (``ready window=ID``, ``basis ...``,
``saved PATH``, ``exported PATH``, ``script done``: `app.viewer.milestones`) for tests
that drive the real window, and does not wait for vertical sync.
"""

from __future__ import annotations

import functools
import gc
import os
import signal
import sys
import time
from dataclasses import dataclass
from pathlib import Path

from app.io.files import CAGE_SUFFIXES, InputError, read_json
from app.viewer import commands, controller, pin_tool
from app.viewer.basis_updates import BasisUpdates
from app.viewer.cage_files import open_cage
from app.viewer.documents import OpenedDocument, apply_preferences, open_document, save, start_snapshot
from app.viewer.exports import Exporter
from app.viewer.file_dialogs import FileRequests
from app.viewer.fold_free import CheckUpdates, CheckWorker
from app.viewer.message_waker import SignalWaker
from app.viewer.milestones import Milestones
from app.viewer.playback_clock import PlaybackClock
from app.viewer.precompute import Precompute
from app.viewer.script_replay import ScriptReplay
from app.viewer.state import AppState, History
from app.viewer.window_fit import save_settings, screen_rectangle
from app.viewer.window_input import InputQueue

TEST_VARIABLE = "TRANSFINITE_VIEWER_TEST"
WINDOW_SIZE = (1280, 1024)
#: Seconds after the last zoom or pan before the view is saved.
VIEW_SAVE_DELAY = 0.5
#: Seconds after the last wheel zoom or pan motion during which the view counts as moving
#: (a dense mesh is drawn through its preview mesh meanwhile); below VIEW_SAVE_DELAY, so the
#: frames drawn while the zoom or pan waits to be saved show the dense mesh again.
VIEW_SETTLE = 0.25
#: Seconds an idle viewer sleeps between frames (input, and the workers' messages, wake it:
#: `app.viewer.message_waker`).
IDLE_WAIT = 2.0
#: Frames a second where the screen does not say its refresh rate (Xvfb says 0).
DEFAULT_REFRESH = 60.0


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


class Viewer:
    """The running viewer: it wires the model (`state`), the window and its input, the renderer,
    the precompute worker, the exports, the script and the session file.

    Parameters
    ----------
    document : OpenedDocument
        What to open.
    options : Options
    """

    def __init__(self, document: OpenedDocument, options: Options):
        self.options = options
        self.milestones = Milestones(os.environ.get(TEST_VARIABLE) == "1")
        announce = self.milestones.announce
        # The workers start first, before the window's X connection and GL context exist (see
        # `app.viewer.precompute.start_method`).  The injectivity check and fold-free map of the
        # live target run in a process that the precompute worker forks once it has loaded core.
        # The Newton solver compiles in the background meanwhile (the default kernel needs none).
        self.checks = CheckUpdates(CheckWorker(), announce)
        precompute = Precompute(warm_up=not self.milestones.test_mode, companion=self.checks.worker.hosted())
        self.basis = BasisUpdates(precompute, options.max_edge, options.vertices, announce)
        self.state = AppState.opened(History(document.snapshot), document.image, document.session_path)
        self.state.screen.window_size = options.size or WINDOW_SIZE
        self.opened: OpenedDocument | None = None  # the session file's lock, view and start cage
        self._load(document)
        self.basis.update(self.state)  # the worker meshes while the window opens (~1 s sooner)
        self.input = InputQueue()
        self.dialogs = FileRequests()
        self.script = ScriptReplay(options.script, options.frames, options.fps, announce)
        self.playback = PlaybackClock(announce)
        self.window = None
        # Made with the window: the scene holds the window's renderer, the exporter draws with it.
        self.ctx = self.imgui_renderer = self.scene = self.exporter = None

    # -- lifetime -------------------------------------------------------------------

    def run(self) -> int:
        """Open the window and loop until quit; returns the exit code."""
        previous = signal.signal(signal.SIGTERM, lambda *_: setattr(self.state.status, "quit", True))
        try:
            self._open_window()
            try:
                if self.options.script is not None and self.options.play:
                    self.toggle_script()
                if self.options.playback:
                    self.state.playback.loop = True
                    self.state.playback.time = 0.0
                    self.command("playback")
                self._frame()  # the first frame loads the last of the modules the frames use
                # What is loaded now lives as long as the program: kept out of the garbage
                # collector's full passes, the frames' collections and the exit skip it (the
                # collections at exit took ~0.3 s of CPU).
                gc.freeze()
                with SignalWaker(_initialised_glfw().post_empty_event):  # a SIGTERM ends a sleep
                    while not self.state.status.quit:
                        self._frame()
            finally:
                self._close_window()
        finally:
            signal.signal(signal.SIGTERM, previous)
            self.close_workers()
        if self.options.stats:
            print(self.milestones.statistics(self.state), flush=True)
        return 0

    def close_workers(self) -> None:
        """End the check worker and the precompute worker."""
        self.checks.worker.close()  # first: the precompute worker ends it as it ends itself
        self.basis.precompute.close()

    def _open_window(self) -> None:
        glfw = _initialised_glfw()  # before imgui_bundle, so that the standard glfw module is the one used
        import moderngl
        from imgui_bundle import imgui

        from app.render.renderer import WarpRenderer
        from app.viewer.gui_renderer import GuiRenderer
        from app.viewer.scene import Scene

        glfw.window_hint(glfw.CONTEXT_VERSION_MAJOR, 3)
        glfw.window_hint(glfw.CONTEXT_VERSION_MINOR, 3)
        glfw.window_hint(glfw.OPENGL_PROFILE, glfw.OPENGL_CORE_PROFILE)
        glfw.window_hint(glfw.OPENGL_FORWARD_COMPAT, True)
        # 2D only: no depth or stencil buffer to clear every frame.
        glfw.window_hint(glfw.DEPTH_BITS, 0)
        glfw.window_hint(glfw.STENCIL_BITS, 0)
        # Hidden until it is placed where it fits (`app.viewer.window_fit`).
        glfw.window_hint(glfw.VISIBLE, False)
        x, y, width, height = screen_rectangle(glfw, self.state, self.options.size, WINDOW_SIZE)
        window = glfw.create_window(width, height, self._title(), None, None)
        if not window:
            glfw.terminate()
            raise _environment_error("cannot open an OpenGL 3.3 window")
        self.window = window
        glfw.set_window_pos(window, x, y)
        glfw.show_window(window)
        glfw.make_context_current(window)
        glfw.swap_interval(0 if self.milestones.test_mode else 1)
        self.ctx = moderngl.create_context()
        imgui.create_context()
        imgui.get_io().set_ini_filename("")
        self.imgui_renderer = GuiRenderer(window, self.ctx)
        self.input.chain_callbacks(glfw, window, imgui.get_io(), self.state)
        self.basis.precompute.wake_on_message(glfw.post_empty_event)
        self.checks.worker.wake_on_message(glfw.post_empty_event)
        self.scene = Scene(WarpRenderer(self.ctx))
        options, announce = self.options, self.milestones.announce
        self.exporter = Exporter(
            self.state, self.scene, self.basis.ready, options.export, options.fps, announce, self.dialogs
        )
        glfw.focus_window(window)
        self.state.screen.window_size = glfw.get_window_size(window)
        self.input.sizes = {
            "window": self.state.screen.window_size,
            "pixels": glfw.get_framebuffer_size(window),
        }
        self.state.screen.canvas_left = 300.0
        self._show_document_view()
        self.state.document.session_dirty = True  # the first save, so the session file exists at once

    def _close_window(self) -> None:
        import glfw
        from imgui_bundle import imgui

        self._save_if_needed(force=True)
        if self.window is None:
            return
        save_settings(glfw, self.window, self.state)
        self.scene.release()
        self.scene.renderer.release()
        self.imgui_renderer.shutdown()
        imgui.destroy_context()
        self.ctx.release()
        glfw.destroy_window(self.window)
        glfw.terminate()
        self.window = None

    # -- documents ------------------------------------------------------------------------

    def _load(self, document: OpenedDocument) -> None:
        """Make `document` the one shown and saved: its history, preferences and session file."""
        state = self.state
        shown = state.document
        shown.history = History(document.snapshot, undo=document.undo, redo=document.redo)
        shown.live = document.snapshot
        shown.image = document.image
        shown.session_path = Path(document.session_path)
        # What the session file holds now: an autosave of anything else is a new version.
        shown.saved = document.snapshot if document.restored else None
        state.selection.drag = state.selection.drawing = None
        state.selection.selected = None
        apply_preferences(state, document.preferences)
        if document.max_edge is not None:
            self.basis.remember_edge(document.snapshot.cage, document.max_edge)
        previous = None if self.opened is None else self.opened.lock
        if previous is not None and previous is not document.lock:
            previous.release()  # the session left behind is never written again: another viewer may open it
        self.opened = document
        if document.notices:
            state.say(document.notices[-1])

    def _show_document_view(self) -> None:
        """The loaded session's view, or the image fitted to the window."""
        if self.opened.view is not None:
            self.state.display.viewport = self.opened.view
        else:
            controller.fit_view(self.state, None)
            self.state.display.viewport_dirty = False

    def open_path(self, path: Path) -> None:
        """Open a dropped or chosen file: an image or a session (each in its own session file), or a
        cage (JSON or SVG: `app.viewer.cage_files`).

        The current session is saved first and never written again after the
        switch; opening an image whose session exists restores that session.
        """
        try:
            if path.suffix.lower() in CAGE_SUFFIXES:
                value = read_json(path) if path.suffix.lower() == ".json" else None
                if isinstance(value, dict) and "image" in value and "target" in value:
                    self._switch_to(open_document(session=path))
                else:
                    open_cage(self.state, path)
                return
            document = open_document(path)  # raises before the current session is left
        except (InputError, OSError) as error:
            self.state.say(str(error), error=True)
            return
        if not document.notices:
            document.notices.append(f"opened {path.name}")
        self._switch_to(document)

    def _switch_to(self, document: OpenedDocument) -> None:
        """Save the current session if it changed, then show `document`."""
        self._save_if_needed(due=True)
        self._load(document)
        self._show_document_view()
        self.state.document.session_dirty = True
        if self.window is not None:
            import glfw

            glfw.set_window_title(self.window, self._title())

    def start_over(self) -> None:
        """Replace the document with a new start (the opening cage, or a fitted one), as one undoable edit."""
        state = self.state
        try:
            snapshot, note = start_snapshot(state.document.live, state.document.image, self.opened.start_cage)
        except InputError as error:
            state.say(str(error), error=True)
            return
        if controller.commit(state, snapshot, f"started over: {note} (Ctrl+Z goes back)"):
            controller.fit_view(state, None)

    def _save_if_needed(self, force: bool = False, announce: bool = False, due: bool = False) -> None:
        """Autosave after an edit, after a zoom or pan settles, or when asked.

        `force` writes in any case; `due` writes a pending zoom or pan at once.
        """
        state, document = self.state, self.state.document
        settled = due or time.perf_counter() - self.input.view_changed_at >= VIEW_SAVE_DELAY
        due = document.session_dirty or (state.display.viewport_dirty and settled)
        if not (due or force) or state.selection.drag is not None and not force:
            return
        current = document.history.current
        if current.n < 3:
            return  # a cage being placed is no session yet
        try:
            save(state, self.basis.max_edge(current.cage), new_version=current != document.saved)
        except (InputError, OSError) as error:
            state.say(f"cannot save the session: {error}", error=True)
            return
        document.saved = current
        document.session_dirty = state.display.viewport_dirty = False
        if announce:
            state.say(f"saved {document.session_path}")
        self.milestones.announce(f"saved {document.session_path}")

    # -- commands (`app.viewer.commands.WindowActions`) -------------------------------------

    def command(self, name: str, value=None) -> None:
        """Run a command of the keyboard, the panel or a drop (`app.viewer.commands.COMMANDS`):
        the window's own here, the others on the state."""
        state, entry = self.state, commands.COMMANDS.get(name)
        if name == "cancel" and self.exporter.cancel():
            return
        if name == "cancel" and self.milestones.popup_open:
            self.input.close_popups = True
        elif entry is not None and entry.window:
            entry.run(self, value)
        elif not commands.command(state, name, value):
            state.say(f"unknown command {name!r}", error=True)
        elif entry.moves_view:
            self.input.view_changed_at = time.perf_counter()

    def save_now(self) -> None:
        self._save_if_needed(force=True, announce=True)

    def export(self, path: Path, typed: str | None = None) -> Path | None:
        """Export to `path` (`app.viewer.exports.Exporter.export`)."""
        return self.exporter.export(path, typed)

    def ask_export_path(self, again: bool) -> None:
        self.exporter.ask_path(again)

    def ask_open_path(self, what: str) -> None:
        """Ctrl+O (`what` "image") or Ctrl+Shift+O ("session"): a file dialog where one can open,
        the in-window prompt otherwise (`app.viewer.file_dialogs`)."""
        document = self.state.document
        folder = Path(document.live.image if what == "image" else document.session_path).parent
        self.dialogs.ask_open(self.state, what, folder)

    def toggle_script(self) -> None:
        self.script.toggle(self.state)

    # -- one frame --------------------------------------------------------------------------

    def _frame(self) -> None:
        import glfw
        from imgui_bundle import imgui

        self._wait_for_input(glfw, imgui)
        started = time.perf_counter()
        state = self.state
        self.input.follow_window_size(state)
        ready = self.basis.ready(state) and self.basis.precompute.pending is None
        self.script.send_events(state, ready, self.input.events)
        self.input.apply(state, self.command)
        pin_tool.follow(state)  # a dragged pin: the pins solved once a frame, for the latest cursor
        # An edit is saved before this frame's drawing: on a dense mesh the frame after a release
        # (exact positions, fold count, the whole mesh drawn) takes ~0.7 s, and a viewer killed
        # meanwhile lost the drag.
        self._save_if_needed()
        self.milestones.drags(state)
        self.playback.tick(state, self._playback_ready())
        for name, value in self.dialogs.poll():  # a file dialog answered (`app.viewer.file_dialogs`)
            self.command(name, value)
        self.basis.update(state)
        self._widgets(imgui)
        self.basis.update(state)  # a kernel chosen in the panel starts computing this frame
        self.checks.update(state)
        self._draw(imgui)
        self.script.write_frame(self.exporter.render_still)
        self.exporter.next_frame()
        glfw.swap_buffers(self.window)
        state.status.frame_ms.append(1e3 * (time.perf_counter() - started))
        self._save_if_needed()
        window_id = glfw.get_x11_window(self.window) if sys.platform.startswith("linux") else 0
        basis = state.compute.basis  # the scene's since _draw's sync
        drawn = basis.key if basis is not None and self.scene.mesh_matches(state) else None
        self.milestones.frame_done(state, window_id, drawn)
        if glfw.window_should_close(self.window):
            state.status.quit = True

    def _wait_for_input(self, glfw, imgui) -> None:
        """Input wakes the loop at once, and so do the workers' messages (the precompute's progress
        and basis, a check's progress and result: `app.viewer.message_waker`); otherwise, draw
        only as often as something changes on its own, so that an idle or waiting viewer leaves
        the CPU to the workers (they run at lower priority and get what the UI leaves).  Playback
        held until its basis is drawn (`PlaybackClock.tick`) waits too: drawing the same frame
        again and again on a software renderer took the cores the precompute needed (the
        starfish demo's --play: basis 12.5 s instead of 1.6 s)."""
        playing = self.state.playback.playing and self._playback_ready()
        writing = self.script.moving and self.script.frames is not None
        if self.exporter.animation or self.scene.catching_up or writing:
            glfw.poll_events()  # an export, fold-free frames catching up, a replay writing its frames
        elif self.script.moving or playing:
            _wait_for_the_screen(glfw, self.state.status.frame_ms)  # in real time
        elif not imgui.get_current_context().input_events_queue.empty():
            glfw.poll_events()  # imgui takes queued input a few events a frame (typed text)
        elif self.input.events or self.input.frames_to_draw > 0:
            glfw.poll_events()
            self.input.frames_to_draw -= 1
        elif self.state.playback.playing:
            glfw.wait_events_timeout(0.1)  # playback waiting for its basis
        elif self.script.playing:
            glfw.wait_events_timeout(0.1)  # a script waiting for its basis
        elif self.state.selection.drag is not None:
            glfw.wait_events_timeout(0.1)  # a drag that pauses gets its check (`app.viewer.fold_free`)
        elif self.state.display.viewport_dirty or self.dialogs.waiting:
            glfw.wait_events_timeout(0.05)
        else:
            glfw.wait_events_timeout(IDLE_WAIT)

    def _playback_ready(self) -> bool:
        """Whether the basis drawn is the live snapshot's, on the mesh the renderer holds: playback
        moves on only then (`app.viewer.playback_clock`)."""
        return self.basis.ready(self.state) and self.scene.mesh_matches(self.state)

    def _widgets(self, imgui) -> None:
        """Draw the widgets (`app.viewer.gui`) and run the commands they give."""
        from app.viewer.gui import gui

        self.imgui_renderer.process_inputs(self.input.sizes["window"], self.input.sizes["pixels"])
        imgui.new_frame()
        if self.input.close_popups:
            imgui.internal.close_popups_except_modals()
            self.input.close_popups = False
        extras = {
            "script": self.options.script is not None,
            "playing": self.script.playing,
            "exporting": self.exporter.progress,
        }
        given = gui(self.state, self.input.shortcuts, extras, self.milestones.spots)
        any_popup = imgui.PopupFlags_.any_popup_id | imgui.PopupFlags_.any_popup_level
        self.milestones.widgets(imgui.is_popup_open("", any_popup), imgui.get_io().want_text_input)
        for name, value in given:
            self.command(name, value)

    def _draw(self, imgui) -> None:
        """Bring the renderer up to date and draw the canvas, then the widgets over it."""
        from OpenGL import GL

        state = self.state
        shown = state.display.distortion
        state.display.viewport_moving = (
            state.selection.drag is not None and state.selection.drag.kind == "pan"
        ) or (time.perf_counter() - self.input.view_changed_at < VIEW_SETTLE)
        self.scene.sync(state)
        self.milestones.drawn(state, self.scene.previewing, shown)
        if self.milestones.test_mode or state.document.live.fold_free:  # --stats times the proof
            from app.viewer.gui import status_check

            folded = state.compute.folded_count
            self.milestones.checked(status_check(state), self.scene.fold_free_drawn, folded)
        width, height = self.input.sizes["pixels"]
        ratio = width / max(state.screen.window_size[0], 1)
        self.ctx.screen.use()
        self.ctx.viewport = (0, 0, width, height)
        if width > 0 and height > 0:
            self.scene.draw(state, (width, height), ratio)
        # A software rasteriser starts on the canvas now, while imgui's draw data is prepared.
        GL.glFlush()
        imgui.render()
        self.imgui_renderer.render(imgui.get_draw_data())

    def _title(self) -> str:
        return f"Transfinite warp - {Path(self.state.document.live.image).name}"


def _initialised_glfw():
    """The glfw module, initialised (a second call returns at once); an environment error
    without a display."""
    import glfw

    if not glfw.init():
        raise _environment_error(
            f"cannot initialise glfw (is there a display? DISPLAY is {os.environ.get('DISPLAY')!r})"
        )
    return glfw


def _environment_error(message: str) -> Exception:
    from app.render.renderer import ContextUnavailableError

    return ContextUnavailableError(message)


def _wait_for_the_screen(glfw, frame_ms: list[float]) -> None:
    """Draw the next frame (input wakes it at once) no sooner than the screen can show it, where
    swapping buffers does not wait for the screen (a software renderer, a virtual screen: a replay
    or playback drew ~80 frames a second, each ~12 ms of a core, on this project's 2-core machines).
    `frame_ms`: the frames' times so far, the last one's just ended."""
    pause = 0.95 / _refresh_rate(glfw) - 1e-3 * (frame_ms[-1] if frame_ms else 0.0)
    if pause > 0:
        glfw.wait_events_timeout(pause)
    else:
        glfw.poll_events()


@functools.cache
def _refresh_rate(glfw) -> float:
    """The primary screen's refresh rate in Hz, or `DEFAULT_REFRESH` where it says none."""
    monitor = glfw.get_primary_monitor()
    mode = glfw.get_video_mode(monitor) if monitor else None
    return float(mode.refresh_rate) if mode is not None and mode.refresh_rate > 0 else DEFAULT_REFRESH


def run(document: OpenedDocument, options: Options) -> int:
    """Open the viewer on `document`; returns the exit code when it is closed."""
    viewer = Viewer(document, options)  # its workers start (forked: in milliseconds)
    try:
        _initialised_glfw()  # without a display, say so now
    except Exception:
        viewer.close_workers()
        raise
    return viewer.run()
