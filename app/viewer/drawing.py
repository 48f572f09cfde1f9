"""Drawing a new cage by clicking, with GIMP's habits (the "new cage" mode).

Each click places the next control point; clicking the first point or pressing
Enter closes the curve; Enter on a closed curve makes it the cage (one undoable
step) and switches to deforming.  Backspace removes the last point (or reopens a
closed curve), Esc abandons the new cage.  A double click on the last point, or
Ctrl+click, makes a sharp corner: the point doubled.  A curve that crosses
itself is refused when it is closed, with the reason.

The points live in ``state.document.live`` while they are placed, outside the undo
history, so nothing is saved until the cage is made.
"""

from __future__ import annotations

import numpy as np

from app.viewer import editing
from app.viewer.state import AppState, Drawing, Snapshot

#: Two clicks this close in time (seconds) and space (window pixels) are a double click.
DOUBLE_CLICK_SECONDS = 0.4
DOUBLE_CLICK_PIXELS = 6.0
HINT = "click to place points; click the first point or press Enter to close; Backspace, Esc"


def start(state: AppState) -> None:
    """Begin a new cage: no points yet, the current document kept to return to."""
    before = (
        state.selection.drawing.before
        if state.selection.drawing is not None
        else state.document.history.current
    )
    state.selection.drawing = Drawing(before)
    state.selection.drag = None
    empty = np.zeros((0, 2))
    state.document.live = before.replace(cage=empty, target=empty, keyframes=())
    state.selection.edit_mode = "cage"
    state.selection.selected = state.selection.hovered = None
    state.selection.group = frozenset()
    state.say(f"new cage: {HINT}")


def press(state: AppState, x: float, y: float, corner: bool, now: float) -> None:
    """A left click at window point (x, y) at time `now`; `corner`: Ctrl held."""
    drawing, points = state.selection.drawing, state.document.live.cage
    if drawing.closed:
        state.say("the new cage is closed: Enter makes it the cage, Backspace reopens it, Esc abandons it")
        return
    window = editing.to_window(state.display.viewport, points)
    if len(points) >= 3 and editing.nearest_handle(window[:1], (x, y)) == 0:
        close(state)
        return
    last = drawing.last_click
    if (
        last is not None
        and now - last[0] <= DOUBLE_CLICK_SECONDS
        and np.hypot(x - last[1], y - last[2]) <= DOUBLE_CLICK_PIXELS
    ):
        drawing.last_click = None
        if len(points) >= 2 and np.array_equal(points[-1], points[-2]):
            return  # already a corner
        _set(state, np.vstack([points, points[-1:]]))
        state.say(f"point {len(points) - 1} is a sharp corner")
        return
    position = editing.to_image(state.display.viewport, (x, y))
    _set(state, np.vstack([points, [position, position] if corner else [position]]))
    drawing.last_click = (now, float(x), float(y))
    state.say(f"{len(state.document.live.cage)} points: {HINT}")


def close(state: AppState) -> bool:
    """Close the curve if it makes a valid cage; False (and the reason in the status line) if not."""
    points = state.document.live.cage
    if len(np.unique(points, axis=0)) < 3:
        state.say("place at least 3 points before closing the cage", error=True)
        return False
    problem = editing.cage_problem(points)
    if problem:
        state.say(f"cannot close the cage: {problem} (Backspace removes the last point)", error=True)
        return False
    state.selection.drawing.closed = True
    state.selection.drawing.last_click = None
    state.say(f"closed, {len(points)} points: Enter makes it the cage, Backspace reopens it, Esc abandons it")
    return True


def confirm(state: AppState) -> Snapshot | None:
    """Enter: close an open curve; on a closed one, end the mode and return the document with the
    new cage (the caller commits it as one undoable edit).  None while the curve stays open."""
    if not state.selection.drawing.closed:
        close(state)
        return None
    points = state.document.live.cage
    state.document.live = state.selection.drawing.before
    state.selection.drawing = None
    return state.document.live.replace(cage=points, target=points, keyframes=())


def remove_last(state: AppState) -> None:
    """Backspace: reopen a closed curve, or remove the last point placed."""
    drawing, points = state.selection.drawing, state.document.live.cage
    drawing.last_click = None
    if drawing.closed:
        drawing.closed = False
        state.say(f"reopened: {HINT}")
    elif len(points):
        _set(state, points[:-1])
        state.say(f"{len(points) - 1} points: {HINT}")
    else:
        state.say("no point to remove (Esc abandons the new cage)")


def abandon(state: AppState) -> None:
    """Esc: back to the document as it was before the new cage."""
    state.document.live = state.selection.drawing.before
    state.selection.drawing = None
    state.say("new cage abandoned")


def _set(state: AppState, points: np.ndarray) -> None:
    state.document.live = state.document.live.replace(cage=points, target=points, keyframes=())
