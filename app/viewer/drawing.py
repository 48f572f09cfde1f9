"""Drawing a new cage by clicking, with GIMP's habits (the "new cage" mode).

Each click places the next point; clicking the first point or pressing Enter
closes the curve; Enter on a closed curve makes it the cage (one undoable step)
and switches to deforming.  Backspace removes the last point (or reopens a closed
curve), Esc abandons the new cage.  A double click on the last point, or
Ctrl+click, makes a sharp corner: a doubled control point.  A curve that crosses
itself is refused when it is closed, with the reason.

The clicks are points on the curve (``state.selection.cage_drawing == "curve"``, the
default: the control points are those of the closed B-spline through them,
`core.curves.interpolating_spline`), or the control points themselves (``"control"``).
The control points live in ``state.document.live`` while they are placed, outside the undo
history, so nothing is saved until the cage is made.
"""

from __future__ import annotations

import numpy as np

from app.viewer import editing
from app.viewer.state import AppState, Drawing, Pins, Snapshot
from core import interpolating_control_points

#: What a click places: a point on the curve, or a control point (the panel's choice).
STYLES = ("curve", "control")

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
    state.document.live = before.replace(cage=empty, target=empty, keyframes=(), pins=Pins())
    state.selection.edit_mode = "cage"
    state.selection.selected = state.selection.hovered = None
    state.selection.group = frozenset()
    state.say(f"new cage: {HINT}")


def press(state: AppState, x: float, y: float, corner: bool, now: float) -> None:
    """A left click at window point (x, y) at time `now`; `corner`: Ctrl held."""
    drawing = state.selection.drawing
    if drawing.closed:
        state.say("the new cage is closed: Enter makes it the cage, Backspace reopens it, Esc abandons it")
        return
    window = editing.to_window(state.display.viewport, clicked_points(state))
    if len(drawing.clicks) >= 3 and editing.nearest_handle(window[:1], (x, y)) == 0:
        close(state)
        return
    last = drawing.last_click
    if (
        last is not None
        and now - last[0] <= DOUBLE_CLICK_SECONDS
        and np.hypot(x - last[1], y - last[2]) <= DOUBLE_CLICK_PIXELS
    ):
        drawing.last_click = None
        if drawing.corners[-1]:
            return  # already a corner
        drawing.corners[-1] = True
        _update(state)
        state.say(f"point {len(drawing.clicks) - 1} is a sharp corner")
        return
    position = editing.to_image(state.display.viewport, (x, y))
    drawing.clicks.append((float(position[0]), float(position[1])))
    drawing.corners.append(bool(corner))
    _update(state)
    drawing.last_click = (now, float(x), float(y))
    state.say(f"{len(drawing.clicks)} points: {HINT}")


def close(state: AppState) -> bool:
    """Close the curve if it makes a valid cage; False (and the reason in the status line) if not."""
    points = state.document.live.cage
    if len(np.unique(clicked_points(state), axis=0)) < 3:
        state.say("place at least 3 points before closing the cage", error=True)
        return False
    problem = editing.cage_problem(points)
    if problem:
        state.say(f"cannot close the cage: {problem} (Backspace removes the last point)", error=True)
        return False
    state.selection.drawing.closed = True
    state.selection.drawing.last_click = None
    count = len(state.selection.drawing.clicks)
    state.say(f"closed, {count} points: Enter makes it the cage, Backspace reopens it, Esc abandons it")
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
    return state.document.live.replace(cage=points, target=points, keyframes=(), pins=Pins())


def remove_last(state: AppState) -> None:
    """Backspace: reopen a closed curve, or remove the last point placed."""
    drawing = state.selection.drawing
    drawing.last_click = None
    if drawing.closed:
        drawing.closed = False
        state.say(f"reopened: {HINT}")
    elif drawing.clicks:
        del drawing.clicks[-1], drawing.corners[-1]
        _update(state)
        state.say(f"{len(drawing.clicks)} points: {HINT}")
    else:
        state.say("no point to remove (Esc abandons the new cage)")


def abandon(state: AppState) -> None:
    """Esc: back to the document as it was before the new cage."""
    state.document.live = state.selection.drawing.before
    state.selection.drawing = None
    state.say("new cage abandoned")


def set_style(state: AppState, style: str) -> None:
    """The panel's choice: clicks are points on the curve ("curve") or control points ("control");
    a cage being drawn follows at once."""
    if style not in STYLES:
        state.say(f"unknown way of drawing a cage {style!r}", error=True)
        return
    state.selection.cage_drawing = style
    if state.selection.drawing is not None:
        _update(state)


def control_points(clicks, corners, style: str) -> np.ndarray:
    """The control points (n, 2), image pixels, of the clicks (m, 2) with their `corners` (m,):
    those of the curve through them (``style="curve"``), or the clicks with each corner doubled."""
    clicks = np.asarray(clicks, dtype=np.float64).reshape(-1, 2)
    corners = np.asarray(corners, dtype=bool).reshape(-1)
    if not len(clicks):
        return np.zeros((0, 2))
    if style == "curve":
        return interpolating_control_points(clicks, corners)
    return np.repeat(clicks, np.where(corners, 2, 1), axis=0)


def clicked_points(state: AppState) -> np.ndarray:
    """The points clicked so far (m, 2), image pixels: the handles shown while a cage is drawn."""
    return np.asarray(state.selection.drawing.clicks, dtype=np.float64).reshape(-1, 2)


def _update(state: AppState) -> None:
    drawing = state.selection.drawing
    points = control_points(drawing.clicks, drawing.corners, state.selection.cage_drawing)
    state.document.live = state.document.live.replace(cage=points, target=points, keyframes=(), pins=Pins())
