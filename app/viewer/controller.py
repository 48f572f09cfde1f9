"""What the viewer's input does to `AppState`: mouse events and named commands.

The window turns glfw callbacks (and `ScriptPlayer` replays, and widget clicks)
into calls of `pointer` and `command`; nothing here touches GL or a window, so
the whole interaction is testable headless.  Every edit goes through `commit`,
which records one undo step and marks the session for saving.

Mouse (window pixels, canvas only):

- deform mode: drag a blue target handle to deform; drag on empty canvas to
  select the handles in a rubber band;
- cage mode: drag a green source handle to move it (its target follows); click
  elsewhere to add a point (appended while there are fewer than 3, otherwise
  inserted into the nearest span); right-click a handle to delete it;
- pins mode: click in the picture to pin it, drag a pin to warp (`app.viewer.pin_tool`), drag a
  blue handle to move it by hand (it becomes fixed), right-click a pin to remove it;
- Shift+click adds a handle to the selection or takes it out; dragging a selected
  handle moves the whole selection;
- middle or right drag pans, the wheel zooms around the cursor; Esc cancels a drag.
"""

from __future__ import annotations

import time

import numpy as np

from app.io.files import InputError, read_image
from app.render.viewport import View
from app.viewer import autokey, drawing, editing, pin_tool
from app.viewer.frame_grid import half_frame, on_grid
from app.viewer.state import AppState, Drag, Pins, Snapshot
from app.warp.keyframes import Keyframe, interpolate

LEFT, RIGHT, MIDDLE = 0, 1, 2
#: Window pixels of the status line at the bottom (kept in step with app.viewer.gui).
STATUS_HEIGHT = 28.0
#: Wheel zoom per notch.
ZOOM_STEP = 1.15
#: Zoom of the + and - keys.
KEY_ZOOM_STEP = 1.5


def commit(state: AppState, snapshot: Snapshot, message: str | None = None, pose: bool = False) -> bool:
    """Make `snapshot` the document as one undoable edit; False if nothing changed.

    `pose`: the edit moves the target (a drag, a reset), and with keyframes it is keyed at the
    timeline's time in the same step (`app.viewer.autokey`).
    """
    if pose:
        moment = on_grid(state.playback.time, state.playback.fps)
        snapshot, keyed = autokey.keyed(
            state.document.history.current, snapshot, moment, half_frame(state.playback.fps)
        )
        if keyed:
            message = f"{message}; {keyed}" if message else keyed
            state.playback.keyframe = next(i for i, k in enumerate(snapshot.keyframes) if k.time == moment)
    state.document.live = snapshot
    changed = state.document.history.push(snapshot)
    if changed:
        state.document.session_dirty = True
    if message:
        state.say(message)
    elif changed:
        state.say("")  # what the status line said belongs to an earlier action
    if state.selection.selected is not None and state.selection.selected >= snapshot.n:
        state.selection.selected = None
    state.selection.group = frozenset(i for i in state.selection.group if i < snapshot.n)
    if state.playback.keyframe is not None and state.playback.keyframe >= len(snapshot.keyframes):
        state.playback.keyframe = None
    return changed


def show(state: AppState, snapshot: Snapshot) -> None:
    """Show a snapshot of the history (undo, redo), reloading the image if it differs."""
    if snapshot.image != state.document.live.image:
        try:
            state.document.image = read_image(snapshot.image)
        except InputError as error:
            state.say(str(error), error=True)
    state.document.live = snapshot
    state.selection.drag = None
    state.document.session_dirty = True
    if state.selection.selected is not None and state.selection.selected >= snapshot.n:
        state.selection.selected = None
    state.selection.group = frozenset(i for i in state.selection.group if i < snapshot.n)
    if state.playback.keyframe is not None and state.playback.keyframe >= len(snapshot.keyframes):
        state.playback.keyframe = None


def handles(state: AppState, kind: str) -> np.ndarray:
    """Window positions of the source ("source") or target ("target") handles."""
    points = state.document.live.cage if kind == "source" else state.document.live.target
    return editing.to_window(state.display.viewport, points)


def pick(state: AppState, x: float, y: float) -> int | None:
    """The handle of the current mode under window position (x, y)."""
    return editing.nearest_handle(handles(state, _active(state)), (x, y))


# -- mouse ------------------------------------------------------------------------------


def pointer(
    state: AppState,
    kind: str,
    x: float,
    y: float,
    button: int = LEFT,
    amount: float = 0.0,
    shift: bool = False,
    ctrl: bool = False,
) -> None:
    """Handle one canvas mouse event.

    Parameters
    ----------
    kind : {"press", "release", "move", "scroll"}
    x, y : float
        Cursor, window pixels.
    button : int
        0 left, 1 right, 2 middle (press and release).
    amount : float
        Wheel notches (scroll), positive away from the user (zoom in).
    shift : bool
        Shift held (press): add to the selection instead of replacing it.
    ctrl : bool
        Ctrl held (press): while a new cage is drawn, place a sharp corner.
    """
    state.screen.cursor = (float(x), float(y))
    if (
        kind == "press"
        and state.selection.drawing is not None
        and button == LEFT
        and state.selection.drag is None
    ):
        drawing.press(state, x, y, ctrl, time.monotonic())
    elif kind == "press" and state.selection.fit_rect and button == LEFT and state.selection.drag is None:
        state.selection.drag = Drag("fit_rect", -1, np.array([x, y], dtype=np.float64), state.document.live)
    elif kind == "press":
        _press(state, x, y, button, shift)
    elif kind == "move":
        _move(state, x, y)
    elif kind == "release":
        _release(state, button)
    elif kind == "scroll":
        zoom(state, ZOOM_STEP**amount, (x, y))
    else:
        raise ValueError(f"unknown pointer event {kind!r}")


def _press(state: AppState, x: float, y: float, button: int, shift: bool = False) -> None:
    if state.selection.drag is not None:
        return
    state.playback.playing = False  # a hand on the cage stops the animation where it is
    cursor = editing.to_image(state.display.viewport, (x, y))
    index = pick(state, x, y)
    live = state.document.live
    if state.selection.edit_mode == "pins" and not shift and _pin_press(state, x, y, button, index):
        return
    if button == LEFT and index is not None:
        if shift:  # Shift+click: in or out of the selection, nothing moves
            state.selection.group = state.selection.group ^ {index}
            state.selection.selected = index if index in state.selection.group else None
            return
        selection = state.selection.group
        if index not in state.selection.group:
            state.selection.group = frozenset({index})
        kind = _active(state)
        points = live.cage if kind == "source" else live.target
        indices = (index, *sorted(state.selection.group - {index}))
        state.selection.drag = Drag(
            kind, index, points[index] - cursor, live, indices=indices, selection=selection
        )
        state.selection.selected = index
        return
    if button == LEFT and state.selection.edit_mode == "cage" and not shift:
        cage, target, index = editing.insert_point(live.cage, live.target, cursor)
        problem = editing.cage_problem(cage) if len(cage) >= 3 else None
        if problem:
            state.say(f"cannot add a point there: {problem}", error=True)
            return
        keyframes = map_keyframes(live, lambda points: editing.insert_point(live.cage, points, cursor)[1])
        pins = live.pins.replace(fixed=[i + (i >= index) for i in live.pins.fixed])
        commit(
            state,
            live.replace(cage=cage, target=target, keyframes=keyframes, pins=pins),
            f"added control point {index}",
        )
        state.selection.selected = index
        state.selection.group = frozenset({index})
        state.selection.drag = Drag("source", index, np.zeros(2), state.document.live, indices=(index,))
        return
    if button == RIGHT and index is not None and state.selection.edit_mode == "cage":
        delete(state, index)
        return
    if button == LEFT:
        start = np.array([x, y], dtype=np.float64)
        state.selection.drag = Drag(
            "band", -1, start, live, selection=state.selection.group if shift else frozenset()
        )
    elif button in (RIGHT, MIDDLE):
        state.selection.drag = Drag("pan", -1, np.array([x, y], dtype=np.float64), live)


def _pin_press(state: AppState, x: float, y: float, button: int, handle: int | None) -> bool:
    """A press in pins mode: a pin grabbed (left) or removed (right), or the picture pinned (left,
    off the target's handles); False where the press does what it does in deform mode."""
    pin = pin_tool.pick_pin(state, x, y)
    live = state.document.live
    if button == LEFT and pin is not None:
        grab = np.asarray(live.pins.points[pin][1]) - editing.to_image(state.display.viewport, (x, y))
        state.selection.drag = Drag("pin", pin, grab, live, solved=live.pins.points)
        state.selection.pin = pin
        return True
    if button == RIGHT and pin is not None:
        commit_pins(state, pin_tool.removed(state, pin))
        return True
    if button == LEFT and handle is None:
        edit = pin_tool.added(state, x, y)
        if edit is not None:
            commit(state, *edit)
            state.selection.pin = len(edit[0].pins.points) - 1
        return True
    return False


def commit_pins(state: AppState, edit) -> None:
    """Commit a `pin_tool.Edit` (None: refused, nothing to do) as one undo step, keyed with keyframes."""
    if edit is not None:
        commit(state, *edit, pose=True)


def fit(state: AppState, rect=None, points: int | None = None) -> None:
    """Fit the cage to the image's subject (inside `rect`, (x, y, width, height) image pixels) as one
    edit, with `points` control points (default: as many as now, at least 8, or 16)."""
    from app.viewer.documents import fit_or_ellipse

    state.selection.fit_rect = False
    live = state.document.live
    points = points or (live.n if live.n >= 8 else 16)
    cage, note = fit_or_ellipse(state.document.image, points, rect)
    commit(state, live.replace(cage=cage, target=cage, keyframes=(), pins=Pins()), note + dropped(live))


def band_corners(state: AppState) -> tuple[np.ndarray, np.ndarray] | None:
    """The rubber band (or fit rectangle) being dragged: its lowest and highest corner, window
    pixels; None if none."""
    drag = state.selection.drag
    if drag is None or drag.kind not in ("band", "fit_rect"):
        return None
    cursor = np.asarray(state.screen.cursor, dtype=np.float64)
    return np.minimum(drag.grab, cursor), np.maximum(drag.grab, cursor)


def _move(state: AppState, x: float, y: float) -> None:
    drag = state.selection.drag
    if drag is None:
        state.selection.hovered = pick(state, x, y)
        return
    if drag.kind == "pan":
        state.display.viewport = editing.pan(state.display.viewport, np.array([x, y]) - drag.grab)
        drag.grab = np.array([x, y], dtype=np.float64)
        drag.moved = True
        state.display.viewport_dirty = True
        state.display.viewport_fitted = False
        return
    drag.moved = True
    if drag.kind == "fit_rect":
        return
    if drag.kind == "band":
        low, high = band_corners(state)
        points = handles(state, _active(state))
        inside = np.all((points >= low) & (points <= high), axis=1)
        state.selection.group = drag.selection | frozenset(np.flatnonzero(inside).tolist())
        return
    position = editing.to_image(state.display.viewport, (x, y)) + drag.grab
    if drag.kind == "pin":
        pin_tool.move(state, drag.index, position)  # solved once a frame: `pin_tool.follow`
        return
    before, indices = drag.before, drag.indices or (drag.index,)
    if drag.kind == "target":
        shift = position - before.target[drag.index]
        state.document.live = state.document.live.replace(
            target=editing.move_points(before.target, indices, shift)
        )
    else:  # the target points come along with their source points
        shift = position - before.cage[drag.index]
        cage = editing.move_points(before.cage, indices, shift)
        # Every keyframe's points come along too: the animation keeps its moves relative to the cage.
        keyframes = map_keyframes(before, lambda points: editing.move_points(points, indices, shift))
        state.document.live = state.document.live.replace(
            cage=cage, target=editing.move_points(before.target, indices, shift), keyframes=keyframes
        )


def _active(state: AppState) -> str:
    return "source" if state.selection.edit_mode == "cage" else "target"


def _release(state: AppState, button: int) -> None:
    drag = state.selection.drag
    if drag is None:
        return
    state.selection.drag = None
    if drag.kind == "fit_rect":
        _fit_in_rectangle(state, drag)
        return
    if drag.kind == "band":
        if not drag.moved:  # a click on empty canvas: nothing selected any more
            state.selection.group, state.selection.selected = drag.selection, None
        elif state.selection.group:
            state.say(f"{len(state.selection.group)} handles selected: drag one to move them together")
        return
    if drag.kind == "pan" or not drag.moved:
        return
    if drag.kind == "pin":
        commit_pins(state, pin_tool.released(state, drag.index, drag.before))
        return
    if drag.kind == "source":
        problem = editing.cage_problem(state.document.live.cage) if state.document.live.n >= 3 else None
        if problem:
            state.document.live = drag.before
            state.say(f"move undone: {problem}", error=True)
            return
    moved = len(drag.indices)
    message = f"moved {moved} control points" if moved > 1 else None
    live = state.document.live
    if drag.kind == "target" and live.pins.points:  # moved by hand: the pins' solves hold it from now on
        live = pin_tool.held(live, drag.indices)
        message = f"{message or f'moved control point {drag.index}'}; fixed for the pins"
    commit(state, live, message, pose=drag.kind == "target")


def _fit_in_rectangle(state: AppState, drag) -> None:
    """The rectangle dragged in fit mode, clipped to the image, is where the subject is."""
    height, width = state.document.image.shape[:2]
    corners = editing.to_image(state.display.viewport, [drag.grab, state.screen.cursor])
    low = np.clip(corners.min(axis=0), 0, [width, height])
    high = np.clip(corners.max(axis=0), 0, [width, height])
    if np.any(high - low < 4):
        state.say("drag a larger rectangle around the subject (Enter: the whole picture)", error=True)
        return
    fit(state, (float(low[0]), float(low[1]), float(high[0] - low[0]), float(high[1] - low[1])))


def cancel_drag(state: AppState) -> bool:
    """Esc: put back what the drag changed; False if there was no drag."""
    drag = state.selection.drag
    if drag is None:
        return False
    state.selection.drag = None
    if drag.kind != "pan":
        state.document.live = drag.before
    if drag.kind in ("target", "source", "band"):
        state.selection.group = drag.selection
        if drag.index not in drag.selection:
            state.selection.selected = None  # the press selected it: a cancelled drag leaves nothing selected
    state.say("drag cancelled")
    return True


# -- commands -----------------------------------------------------------------------------


def delete(state: AppState, index: int | None = None) -> None:
    """Delete source control point `index` (default: the selected ones) and their targets (cage mode);
    in pins mode, the selected pin."""
    if state.selection.edit_mode == "pins":
        commit_pins(state, pin_tool.removed(state))
        return
    if state.selection.edit_mode != "cage":
        state.say("points are deleted in cage mode (C); deforming never removes them", error=True)
        return
    indices = sorted(
        {index} if index is not None else state.selection.group or {state.selection.selected} - {None},
        reverse=True,
    )
    if not indices:
        state.say("select a control point first (click it)", error=True)
        return
    cage, target = state.document.live.cage, state.document.live.target
    try:
        for i in indices:
            cage, target = editing.delete_point(cage, target, i)
    except ValueError as error:
        state.say(str(error), error=True)
        return
    keyframes = map_keyframes(state.document.live, lambda points: np.delete(points, indices, axis=0))
    what = f"point {indices[0]}" if len(indices) == 1 else f"{len(indices)} points"
    problem = editing.cage_problem(cage)
    if problem:
        state.say(f"cannot delete {what}: {problem}", error=True)
        return
    pins = state.document.live.pins
    gone = np.searchsorted(indices[::-1], pins.fixed)  # the deleted points before each fixed one
    pins = pins.replace(fixed=[i - k for i, k in zip(pins.fixed, gone, strict=True) if i not in indices])
    commit(
        state,
        state.document.live.replace(cage=cage, target=target, keyframes=keyframes, pins=pins),
        f"deleted control {what}",
    )
    state.selection.selected = None
    state.selection.group = frozenset()


def zoom(state: AppState, factor: float, about=None) -> None:
    """Zoom the view by `factor` about window point `about` (default: the canvas centre)."""
    if about is None:
        width, height = state.screen.window_size
        about = (0.5 * (state.screen.canvas_left + width), 0.5 * (height - STATUS_HEIGHT))
    state.display.viewport = editing.zoom_about(state.display.viewport, about, factor)
    state.display.viewport_dirty = True
    state.display.viewport_fitted = False


# -- keyframes and the timeline ---------------------------------------------------------


def map_keyframes(snapshot: Snapshot, change) -> tuple[Keyframe, ...]:
    """`snapshot`'s keyframes with ``change(target)`` applied to each target (n, 2) -> (n', 2)."""
    return tuple(Keyframe(keyframe.time, change(keyframe.target)) for keyframe in snapshot.keyframes)


def dropped(snapshot: Snapshot) -> str:
    """What a new cage does to the keyframes and the pins of `snapshot`, for the status line."""
    counts = ((len(snapshot.keyframes), "keyframe"), (len(snapshot.pins.points), "pin"))
    gone = [f"{count} {name}{'s' * (count != 1)}" for count, name in counts if count]
    return f"; its {' and '.join(gone)} cleared (Ctrl+Z brings them back)" if gone else ""


def show_time(state: AppState) -> None:
    """Show the animation at ``state.playback.time``: the live target becomes the keyframes' interpolation.

    Nothing is recorded in the history: the document's target changes only when
    the user edits what is shown (a drag, a new keyframe).  Does nothing without
    keyframes, or while a drag or a new cage is in progress.
    """
    live = state.document.live
    if not live.keyframes or state.selection.drag is not None or state.selection.drawing is not None:
        return
    state.document.live = live.replace(
        target=interpolate(live.keyframes, state.playback.time, live.interpolation)
    )


def advance(state: AppState, seconds: float) -> None:
    """Playback: move the time on by `seconds`, looping or stopping at the last keyframe, and show it."""
    span = state.document.live.time_span
    if not state.playback.playing or span is None:
        state.playback.playing = False
        return
    first, last = span
    time = state.playback.time + seconds
    if time > last:
        if state.playback.loop and last > first:
            time = first + (time - first) % (last - first)
        else:
            time, state.playback.playing = last, False
    state.playback.time = max(time, first)
    show_time(state)


def fit_view(state: AppState, window_size: tuple[int, int] | None) -> None:
    """Show the whole image centred in the canvas (the window right of the side panel).

    Small images are shown at 100%, not enlarged (the wheel zooms in): pixels
    sharp, and no more pixels to fill per frame than the image has.
    """
    width, height = window_size or state.screen.window_size
    image_height, image_width = state.document.image.shape[:2]
    left = state.screen.canvas_left
    canvas = (max(width - left, 1), max(height - STATUS_HEIGHT, 1))
    scale = min(View.fit((0.0, 0.0, image_width, image_height), canvas, margin=24).scale, 1.0)
    offset = (left + 0.5 * (canvas[0] - scale * image_width), 0.5 * (canvas[1] - scale * image_height))
    state.display.viewport = View(scale, (round(offset[0], 1), round(offset[1], 1)))
    state.display.viewport_dirty = True
    state.display.viewport_fitted = True
