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
- Shift+click adds a handle to the selection or takes it out; dragging a selected
  handle moves the whole selection;
- middle or right drag pans, the wheel zooms around the cursor; Esc cancels a drag.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from app.files import InputError, kernel_names, read_image
from app.framing import CANVASES, OUTSIDES
from app.keyframes import INTERPOLATIONS, MAX_TIME, TIME_RESOLUTION, Keyframe, interpolate
from app.view import View
from app.viewer import drawing, editing
from app.viewer.state import EDIT_MODES, MEASURES, PARAMETERIZATIONS, SHIFTS, AppState, Drag, Snapshot
from app.viewer.view_modes import CONTENTS

LEFT, RIGHT, MIDDLE = 0, 1, 2
#: Window pixels of the status line at the bottom (kept in step with app.viewer.gui).
STATUS_HEIGHT = 28.0
#: Wheel zoom per notch.
ZOOM_STEP = 1.15
#: Zoom of the + and - keys.
KEY_ZOOM_STEP = 1.5


def commit(state: AppState, snapshot: Snapshot, message: str | None = None) -> bool:
    """Make `snapshot` the document as one undoable edit; False if nothing changed."""
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
        keyframes = _map_keyframes(live, lambda points: editing.insert_point(live.cage, points, cursor)[1])
        commit(
            state, live.replace(cage=cage, target=target, keyframes=keyframes), f"added control point {index}"
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


def fit(state: AppState, rect=None, points: int | None = None) -> None:
    """Fit the cage to the image's subject (inside `rect`, (x, y, width, height) image pixels) as one
    edit, with `points` control points (default: as many as now, at least 8, or 16)."""
    from app.viewer.session import fit_or_ellipse

    state.selection.fit_rect = False
    live = state.document.live
    points = points or (live.n if live.n >= 8 else 16)
    cage, note = fit_or_ellipse(state.document.image, points, rect)
    commit(state, live.replace(cage=cage, target=cage, keyframes=()), note + _dropped(live))


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
        keyframes = _map_keyframes(before, lambda points: editing.move_points(points, indices, shift))
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
    if drag.kind == "source":
        problem = editing.cage_problem(state.document.live.cage) if state.document.live.n >= 3 else None
        if problem:
            state.document.live = drag.before
            state.say(f"move undone: {problem}", error=True)
            return
    moved = len(drag.indices)
    commit(state, state.document.live, f"moved {moved} control points" if moved > 1 else None)


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
    """Delete source control point `index` (default: the selected ones) and their targets (cage mode)."""
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
    keyframes = _map_keyframes(state.document.live, lambda points: np.delete(points, indices, axis=0))
    what = f"point {indices[0]}" if len(indices) == 1 else f"{len(indices)} points"
    problem = editing.cage_problem(cage)
    if problem:
        state.say(f"cannot delete {what}: {problem}", error=True)
        return
    commit(
        state,
        state.document.live.replace(cage=cage, target=target, keyframes=keyframes),
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


# -- named commands ---------------------------------------------------------------------


@dataclass(frozen=True)
class Command:
    """One named command of the keyboard, the panel or a script.

    Attributes
    ----------
    name : str
        What `command` is called with (the key table of `app.viewer.window` and the
        panel's widgets name it).
    run : callable
        ``run(state, value)``: does it.
    label : str
        What it does, in a few words.
    undoable : bool
        It changes the document as one step of the undo history (through `commit`).
    while_drawing : bool
        It may run while a new cage is drawn; the others are refused then.
    """

    name: str
    run: Callable[[AppState, object], None]
    label: str
    undoable: bool = False
    while_drawing: bool = True


#: Every command of the controller, by name (`command` runs them).
COMMANDS: dict[str, Command] = {}


def _command(name: str, label: str, undoable: bool = False, while_drawing: bool = True):
    """Register the decorated ``run(state, value)`` as the command `name`."""

    def register(run):
        COMMANDS[name] = Command(name, run, label, undoable, while_drawing)
        return run

    return register


def command(state: AppState, name: str, value=None) -> bool:
    """Run a named command of the panel or the keyboard (`COMMANDS`); False if there is none.

    A new cage being drawn gives cancel, confirm, delete and undo their drawing meaning
    and refuses the commands that edit the document; the rectangle of a fit on a photo
    takes confirm and cancel.  The window handles the commands that need it (open, save,
    export, quit: `app.viewer.window.Viewer.command`).
    """
    if state.selection.drawing is not None and _drawing_command(state, name):
        return True
    if state.selection.fit_rect and name in ("confirm", "cancel") and state.selection.drag is None:
        if name == "confirm":
            fit(state)
        else:
            state.selection.fit_rect = False
            state.say("fit cancelled")
        return True
    entry = COMMANDS.get(name)
    if entry is None:
        return False
    entry.run(state, value)
    return True


@_command("undo", "undo the last edit")
def _undo(state: AppState, value) -> None:
    if state.selection.drag is not None:
        cancel_drag(state)
    snapshot = state.document.history.undo()
    show(state, snapshot) if snapshot is not None else state.say("nothing to undo")


@_command("redo", "redo the edit undone", while_drawing=False)
def _redo(state: AppState, value) -> None:
    if state.selection.drag is not None:
        cancel_drag(state)
    snapshot = state.document.history.redo()
    show(state, snapshot) if snapshot is not None else state.say("nothing to redo")


@_command("cancel", "cancel the drag in progress, close a list or the help")
def _cancel(state: AppState, value) -> None:
    if not cancel_drag(state):
        state.display.show_help = False
        state.status.open_prompt = state.status.export_prompt = None


@_command("new_cage", "draw a new cage by clicking")
def _new_cage(state: AppState, value) -> None:
    drawing.start(state)


@_command("confirm", "close the new cage; use it")
def _confirm(state: AppState, value) -> None:
    pass  # Enter means something only while a new cage is drawn (`_drawing_command`)


@_command("reset_target", "reset the target to the source cage", undoable=True, while_drawing=False)
def _reset_target(state: AppState, value) -> None:
    live = state.document.live
    commit(state, live.replace(target=live.cage), "target reset to the source cage")


@_command("fit", "fit the cage to the subject", undoable=True, while_drawing=False)
def _fit(state: AppState, value) -> None:
    if value is None and (state.document.image[..., 3] == 255).all():
        # A photograph: the user shows where the subject is first.
        state.selection.fit_rect = True
        state.say("drag a rectangle around the subject (Enter: the whole picture, Esc: cancel)")
    else:  # an image with a silhouette (alpha), or a number of control points
        fit(state, points=int(value) if value else None)


@_command(
    "subdivide", "subdivide the cage (same curve, twice the points)", undoable=True, while_drawing=False
)
def _subdivide(state: AppState, value) -> None:
    live = state.document.live
    if live.n < 3:
        state.say("place at least 3 control points first", error=True)
        return
    cage, target = editing.subdivide(live.cage), editing.subdivide(live.target)
    keyframes = _map_keyframes(live, editing.subdivide)
    message = f"subdivided: {len(cage)} control points"
    commit(state, live.replace(cage=cage, target=target, keyframes=keyframes), message)
    state.selection.selected = None


@_command("delete", "delete the selected control points (cage mode)", undoable=True)
def _delete(state: AppState, value) -> None:
    delete(state, value)


@_command("mode", "deform (drag the target) or cage (edit the source)", while_drawing=False)
def _mode(state: AppState, value) -> None:
    state.selection.edit_mode = (
        value if value in EDIT_MODES else ("cage" if state.selection.edit_mode == "deform" else "deform")
    )
    state.selection.hovered = None
    state.selection.group = frozenset()
    state.document.session_dirty = True


@_command("content", "what the canvas shows: image, basis, height or distortion")
def _content(state: AppState, value) -> None:
    if value in CONTENTS:
        state.display.view_mode = value
        state.document.session_dirty = True


@_command("distortion_measure", "the distortion view's measure: area or conformal")
def _distortion_measure(state: AppState, value) -> None:
    if value in MEASURES:
        state.display.distortion_measure = value
        state.document.session_dirty = True


@_command("kernel", "deform with this kernel", undoable=True, while_drawing=False)
def _kernel(state: AppState, value) -> None:
    if value not in kernel_names():
        state.say(f"unknown kernel {value!r}", error=True)
    else:
        commit(state, state.document.live.replace(kernel=value), f"kernel: {value}")


@_command(
    "cycle_kernel", "the next (value 'previous': the previous) kernel", undoable=True, while_drawing=False
)
def _cycle_kernel(state: AppState, value) -> None:
    names = kernel_names()
    index = names.index(state.document.live.kernel) if state.document.live.kernel in names else -1
    kernel = names[(index + (-1 if value == "previous" else 1)) % len(names)]
    commit(state, state.document.live.replace(kernel=kernel), f"kernel: {kernel}")


@_command(
    "parameterization", "the boundary's parameter: natural or arc-length", undoable=True, while_drawing=False
)
def _parameterization(state: AppState, value) -> None:
    if value not in PARAMETERIZATIONS:
        state.say(f"unknown parameterization {value!r}", error=True)
    else:
        commit(state, state.document.live.replace(parameterization=value), f"parameterization: {value}")


@_command("power", "the power kernel's exponent", undoable=True, while_drawing=False)
def _power(state: AppState, value) -> None:
    if float(value) > 0:
        commit(state, state.document.live.replace(power=float(value)))


@_command("shift", "the power kernel's shift", undoable=True, while_drawing=False)
def _shift(state: AppState, value) -> None:
    if value in SHIFTS:
        commit(state, state.document.live.replace(shift=value))


@_command("outside", "what an export shows outside the warp: transparent or original")
def _outside(state: AppState, value) -> None:
    if value in OUTSIDES:
        state.document.outside = value
        state.document.session_dirty = True


@_command("canvas", "an export's frame: the source image, or grown to the target")
def _canvas(state: AppState, value) -> None:
    if value in CANVASES:
        state.document.canvas = value
        state.document.session_dirty = True


#: The settings that "toggle" switches, and the part of the state that holds each.
TOGGLES = {
    "show_folds": "display",
    "show_wireframe": "display",
    "show_overlay": "display",
    "loop": "playback",
}


@_command("toggle", f"switch a setting on or off (value: its name, one of {', '.join(TOGGLES)})")
def _toggle(state: AppState, value) -> None:
    if value not in TOGGLES:
        state.say(f"unknown setting {value!r}; toggle one of {', '.join(TOGGLES)}", error=True)
        return
    part = getattr(state, TOGGLES[value])
    setattr(part, value, not getattr(part, value))
    state.document.session_dirty = True


@_command("fit_view", "fit the image in the window")
def _fit_view(state: AppState, value) -> None:
    fit_view(state, value)


@_command("zoom", "zoom in, out, or to a scale (1.0: 100 %)")
def _zoom(state: AppState, value) -> None:
    if value in ("in", "out"):
        zoom(state, KEY_ZOOM_STEP if value == "in" else 1 / KEY_ZOOM_STEP)
    else:
        zoom(state, float(value) / state.display.viewport.scale)


@_command("help", "show or hide the help")
def _help(state: AppState, value) -> None:
    state.display.show_help = not state.display.show_help


# -- keyframes and the timeline ---------------------------------------------------------


def _map_keyframes(snapshot: Snapshot, change) -> tuple[Keyframe, ...]:
    """`snapshot`'s keyframes with ``change(target)`` applied to each target (n, 2) -> (n', 2)."""
    return tuple(Keyframe(keyframe.time, change(keyframe.target)) for keyframe in snapshot.keyframes)


def _dropped(snapshot: Snapshot) -> str:
    """What a new cage does to the keyframes of `snapshot`, for the status line."""
    count = len(snapshot.keyframes)
    return f"; its {count} keyframe{'s' * (count != 1)} cleared (Ctrl+Z brings them back)" if count else ""


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


# -- the timeline's commands ------------------------------------------------------------


@_command(
    "add_keyframe",
    "a keyframe at the current time (or at time value) from the target shown",
    undoable=True,
    while_drawing=False,
)
def _add_keyframe(state: AppState, value) -> None:
    live = state.document.live
    keyframes = live.keyframes
    time = state.playback.time if value is None else float(value)
    if not 0.0 <= time <= MAX_TIME:
        state.say(f"a keyframe needs a time within 0..{MAX_TIME:g} s", error=True)
        return
    kept = tuple(k for k in keyframes if abs(k.time - time) >= TIME_RESOLUTION)
    replaced = len(kept) < len(keyframes)
    snapshot = live.replace(keyframes=(*kept, Keyframe(time, live.target)))
    count = len(snapshot.keyframes)
    verb = "replaced" if replaced else "added"
    commit(state, snapshot, f"{verb} the keyframe at {time:.2f} s ({count} keyframe{'s' * (count != 1)})")
    state.playback.time = time
    state.playback.keyframe = next(i for i, k in enumerate(snapshot.keyframes) if k.time == time)


@_command(
    "delete_keyframe",
    "delete a keyframe (value: its index; the selected one)",
    undoable=True,
    while_drawing=False,
)
def _delete_keyframe(state: AppState, value) -> None:
    live = state.document.live
    keyframes = live.keyframes
    index = state.playback.keyframe if value is None else int(value)
    if index is None or not 0 <= index < len(keyframes):
        state.say("select a keyframe first (click it on the timeline)", error=True)
        return
    time = keyframes[index].time
    remaining = keyframes[:index] + keyframes[index + 1 :]
    commit(state, live.replace(keyframes=remaining), f"deleted the keyframe at {time:.2f} s")
    state.playback.keyframe = None
    show_time(state)


@_command(
    "keyframe_time", "move a keyframe in time (value: index, seconds)", undoable=True, while_drawing=False
)
def _keyframe_time(state: AppState, value) -> None:
    live = state.document.live
    keyframes = live.keyframes
    index, time = int(value[0]), float(value[1])
    if not 0 <= index < len(keyframes):
        return
    if not 0.0 <= time <= MAX_TIME:
        state.say(f"keyframe times lie within 0..{MAX_TIME:g} s", error=True)
        return
    others = keyframes[:index] + keyframes[index + 1 :]
    if any(abs(k.time - time) < TIME_RESOLUTION for k in others):
        state.say(f"there is a keyframe at {time:.2f} s already", error=True)
        return
    moved = Keyframe(time, keyframes[index].target)
    snapshot = live.replace(keyframes=(*others, moved))
    commit(state, snapshot, f"moved a keyframe from {keyframes[index].time:.2f} s to {time:.2f} s")
    state.playback.keyframe = snapshot.keyframes.index(moved)
    state.playback.time = time
    show_time(state)


@_command("select_keyframe", "select a keyframe (value: its index, or None)")
def _select_keyframe(state: AppState, value) -> None:
    keyframes = state.document.live.keyframes
    index = None if value is None else int(value)
    if index is not None and 0 <= index < len(keyframes):
        state.playback.keyframe, state.playback.time, state.playback.playing = (
            index,
            keyframes[index].time,
            False,
        )
        show_time(state)
    else:
        state.playback.keyframe = None


@_command("seek", "go to a time (value: seconds)", while_drawing=False)
def _seek(state: AppState, value) -> None:
    state.playback.time = min(max(float(value), 0.0), MAX_TIME)
    show_time(state)


@_command("seek_by", "move the time on or back (value: seconds)", while_drawing=False)
def _seek_by(state: AppState, value) -> None:
    _seek(state, state.playback.time + float(value))


@_command("playback", "play or pause the keyframes", while_drawing=False)
def _playback(state: AppState, value) -> None:
    span = state.document.live.time_span
    if state.playback.playing:
        state.playback.playing = False
        state.say(f"paused at {state.playback.time:.2f} s")
    elif span is None or span[0] == span[1]:
        state.say("add two keyframes at different times to play (the Keyframe button, or I)", error=True)
    else:
        if state.playback.time >= span[1] or state.playback.time < span[0]:
            state.playback.time = span[0]
        state.playback.playing = True
        state.say("playing (Space pauses)")
        show_time(state)


@_command("interpolation", "how the target moves between keyframes", undoable=True, while_drawing=False)
def _interpolation(state: AppState, value) -> None:
    if value in INTERPOLATIONS:
        commit(state, state.document.live.replace(interpolation=value), f"interpolation: {value}")
        show_time(state)


def _drawing_command(state: AppState, name: str) -> bool:
    """Run `name` the way the new-cage mode means it; False if it is not special there."""
    if name == "cancel" and state.selection.drag is None:
        drawing.abandon(state)
    elif name in ("delete", "undo"):
        drawing.remove_last(state)
    elif name == "confirm":
        snapshot = drawing.confirm(state)
        if snapshot is not None:
            commit(state, snapshot, f"new cage, {snapshot.n} points: drag to deform")
            state.selection.edit_mode = "deform"
    elif name in COMMANDS and not COMMANDS[name].while_drawing:
        state.say("finish the new cage first (Enter) or abandon it (Esc)", error=True)
    else:
        return False
    return True


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
