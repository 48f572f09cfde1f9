"""The viewer's named commands, in one registry: `COMMANDS` (name, what it does, undoable, allowed
while a new cage is drawn, whether the window runs it, and its function).

The keyboard (`app.viewer.keys`), the panel (`app.viewer.gui`) and scripts give commands by name;
`command` runs those that change the state, and the window (`app.viewer.window.Viewer.command`)
those that need files, dialogs or its loop (``window=True``: their function takes the running
viewer, which provides `WindowActions`).  Nothing here touches GL, so every state command is
testable headless.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

import numpy as np

from app.io.files import InputError, kernel_names
from app.viewer import cage_files, drawing, editing, pin_tool
from app.viewer.changes import change_words
from app.viewer.controller import (
    KEY_ZOOM_STEP,
    cancel_drag,
    commit,
    commit_pins,
    delete,
    fit,
    fit_view,
    map_keyframes,
    show,
    show_time,
    zoom,
)
from app.viewer.file_dialogs import FileRequests
from app.viewer.fold_free import HARMONIC_KERNEL
from app.viewer.frame_grid import half_frame, key_near, on_grid
from app.viewer.state import EDIT_MODES, MEASURES, PARAMETERIZATIONS, SHIFTS, AppState
from app.viewer.view_modes import VIEW_MODE_NAMES
from app.warp.fill import checked_fill
from app.warp.framing import CANVASES, OUTSIDES
from app.warp.keyframes import INTERPOLATIONS, MAX_TIME, Keyframe


class WindowActions(Protocol):
    """What the window's commands ask of the running viewer (`app.viewer.window.Viewer`)."""

    state: AppState
    dialogs: FileRequests

    def save_now(self) -> None: ...

    def export(self, path, typed: str | None = None): ...

    def ask_export_path(self, again: bool) -> None: ...

    def ask_open_path(self, what: str) -> None: ...

    def open_path(self, path) -> None: ...

    def toggle_script(self) -> None: ...

    def start_over(self) -> None: ...


@dataclass(frozen=True)
class Command:
    """One named command of the keyboard, the panel or a script.

    Attributes
    ----------
    name : str
        What `command` is called with (the key table of `app.viewer.keys` and the
        panel's widgets name it).
    run : callable
        ``run(state, value)`` does it; ``run(viewer, value)`` for a `window` command.
    label : str
        What it does, in a few words.
    undoable : bool
        It changes the document as one step of the undo history (through `commit`).
    while_drawing : bool
        It may run while a new cage is drawn; the others are refused then.
    window : bool
        The window runs it (files, dialogs, the script player): `run` takes the viewer.
    moves_view : bool
        It moves the viewport at once: the window lets the view settle before it saves it.
    """

    name: str
    run: Callable[[object, object], None]
    label: str
    undoable: bool = False
    while_drawing: bool = True
    window: bool = False
    moves_view: bool = False


#: Every command of the viewer, by name: `command` runs the state's, the window the others.
COMMANDS: dict[str, Command] = {}


def _command(
    name: str, label: str, undoable: bool = False, while_drawing: bool = True, moves_view: bool = False
):
    """Register the decorated ``run(state, value)`` as the command `name`."""

    def register(run):
        COMMANDS[name] = Command(name, run, label, undoable, while_drawing, moves_view=moves_view)
        return run

    return register


def _edit(name: str, label: str):
    """Register the decorated ``run(state, value)`` as the command `name` that edits the document:
    one step of the undo history, refused while a new cage is drawn."""
    return _command(name, label, undoable=True, while_drawing=False)


def _window_command(name: str, label: str):
    """Register the decorated ``run(viewer, value)`` as the window's command `name`."""

    def register(run):
        COMMANDS[name] = Command(name, run, label, window=True)
        return run

    return register


def command(state: AppState, name: str, value=None) -> bool:
    """Run a named command of the panel or the keyboard (`COMMANDS`); False if there is none.

    A new cage being drawn gives cancel, confirm, delete and undo their drawing meaning
    and refuses the commands that edit the document; the rectangle of a fit on a photo
    takes confirm and cancel.  The window's own commands (open, save, export: ``window=True``)
    are not run here (False): `app.viewer.window.Viewer.command` runs them.
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
    if entry is None or entry.window:
        return False
    entry.run(state, value)
    return True


@_command("undo", "undo the last change of the document (an edit or a setting)")
def _undo(state: AppState, value) -> None:
    _step_history(state, "undo")


@_command("redo", "redo the change undone", while_drawing=False)
def _redo(state: AppState, value) -> None:
    _step_history(state, "redo")


def _step_history(state: AppState, way: str) -> None:
    """Undo (`way` "undo") or redo ("redo") one step; the status line says what it changed."""
    if state.selection.drag is not None:
        cancel_drag(state)
    history = state.document.history
    left = history.current
    snapshot = history.undo() if way == "undo" else history.redo()
    if snapshot is None:
        state.say(f"nothing to {way}")
        return
    show(state, snapshot)
    show_time(state)  # with keyframes, the pose the animation has now at the timeline's time
    if way == "undo":
        state.say(f"undone: {change_words(snapshot, left)}")
    else:
        state.say(f"redone: {change_words(left, snapshot)}")


@_command("cancel", "cancel the drag in progress, close a list or the help")
def _cancel(state: AppState, value) -> None:
    if not cancel_drag(state):
        state.display.show_help = False
        state.status.open_prompt = state.status.export_prompt = None
        state.status.cage_prompt = state.status.target_prompt = None


@_command("new_cage", "draw a new cage by clicking")
def _new_cage(state: AppState, value) -> None:
    drawing.start(state)


@_command("cage_drawing", "a new cage's clicks: points on the curve ('curve') or control points ('control')")
def _cage_drawing(state: AppState, value) -> None:
    drawing.set_style(state, value)


@_command("confirm", "close the new cage; use it")
def _confirm(state: AppState, value) -> None:
    pass  # Enter means something only while a new cage is drawn (`_drawing_command`)


@_edit("reset_target", "reset the target to the source cage")
def _reset_target(state: AppState, value) -> None:
    live = state.document.live
    points = tuple((at, at) for at, _ in live.pins.points)  # the pins where they are on the source
    snapshot = live.replace(target=live.cage, pins=live.pins.replace(points=points, fixed=()))
    commit(state, snapshot, "target reset to the source cage", pose=True)


@_edit("fit", "fit the cage to the subject")
def _fit(state: AppState, value) -> None:
    if value is None and (state.document.image[..., 3] == np.iinfo(state.document.image.dtype).max).all():
        # A photograph: the user shows where the subject is first.
        state.selection.fit_rect = True
        state.say("drag a rectangle around the subject (Enter: the whole picture, Esc: cancel)")
    else:  # an image with a silhouette (alpha), or a number of control points
        fit(state, points=int(value) if value else None)


@_edit("subdivide", "subdivide the cage (same curve, twice the points)")
def _subdivide(state: AppState, value) -> None:
    live = state.document.live
    if live.n < 3:
        state.say("place at least 3 control points first", error=True)
        return
    cage, target = editing.subdivide(live.cage), editing.subdivide(live.target)
    keyframes = map_keyframes(live, editing.subdivide)
    message = f"subdivided: {len(cage)} control points"
    commit(state, live.replace(cage=cage, target=target, keyframes=keyframes), message)
    state.selection.selected = None


@_command(
    "delete", "delete the selected control points (cage mode), the selected pin (pins mode)", undoable=True
)
def _delete(state: AppState, value) -> None:
    delete(state, value)


@_edit("max_distortion", "the pins' bound K on sigma1/sigma2 (None: free)")
def _max_distortion(state: AppState, value) -> None:
    commit_pins(state, pin_tool.bounded(state, value))


@_command("edit_mode", "deform (drag the target), cage (edit the source) or pins", while_drawing=False)
def _edit_mode(state: AppState, value) -> None:
    state.selection.edit_mode = (
        value if value in EDIT_MODES else ("cage" if state.selection.edit_mode == "deform" else "deform")
    )
    state.selection.hovered = None
    state.selection.group = frozenset()
    state.document.session_dirty = True


@_command("view_mode", "what the canvas shows: image, basis, height or distortion")
def _view_mode(state: AppState, value) -> None:
    if value in VIEW_MODE_NAMES:
        state.display.view_mode = value
        state.document.session_dirty = True


@_command("distortion_measure", "the distortion view's measure: area or conformal")
def _distortion_measure(state: AppState, value) -> None:
    if value in MEASURES:
        state.display.distortion_measure = value
        state.document.session_dirty = True


@_edit("kernel", "deform with this kernel")
def _kernel(state: AppState, value) -> None:
    if value not in kernel_names():
        state.say(f"unknown kernel {value!r}", error=True)
    else:
        commit(state, with_kernel(state.document.live, value), f"kernel: {value}")


def with_kernel(live, kernel: str):
    """The snapshot `live` deformed with `kernel`; fold-free is switched off for a kernel whose maps
    are not harmonic (the fold-free map needs ``poisson``, and ``warp`` refuses it otherwise)."""
    return live.replace(kernel=kernel, fold_free=live.fold_free and kernel == HARMONIC_KERNEL)


@_edit("fold_free", "fold-free: the certified map that never folds (poisson only)")
def _fold_free(state: AppState, value) -> None:
    live = state.document.live
    if live.kernel != HARMONIC_KERNEL:
        state.say(f"fold-free needs the {HARMONIC_KERNEL} kernel (its maps are harmonic)", error=True)
        return
    on = not live.fold_free if value is None else bool(value)
    if on != live.fold_free:
        commit(state, live.replace(fold_free=on), f"fold-free {'on' if on else 'off'}")


@_edit("cycle_kernel", "the next (value 'previous': the previous) kernel")
def _cycle_kernel(state: AppState, value) -> None:
    names = kernel_names()
    index = names.index(state.document.live.kernel) if state.document.live.kernel in names else -1
    kernel = names[(index + (-1 if value == "previous" else 1)) % len(names)]
    commit(state, with_kernel(state.document.live, kernel), f"kernel: {kernel}")


@_edit("parameterization", "the boundary's parameter: natural or arc-length")
def _parameterization(state: AppState, value) -> None:
    if value not in PARAMETERIZATIONS:
        state.say(f"unknown parameterization {value!r}", error=True)
    else:
        commit(state, state.document.live.replace(parameterization=value), f"parameterization: {value}")


@_edit("power", "the power kernel's exponent")
def _power(state: AppState, value) -> None:
    if float(value) > 0:
        commit(state, state.document.live.replace(power=float(value)), f"power k: {float(value):g}")


@_edit("shift", "the power kernel's shift")
def _shift(state: AppState, value) -> None:
    if value in SHIFTS:
        commit(state, state.document.live.replace(shift=value), f"shift: {value}")


@_command("outside", "what an export shows outside the warp: transparent or original", undoable=True)
def _outside(state: AppState, value) -> None:
    if value in OUTSIDES:
        commit(state, state.document.live.replace(outside=value), f"outside: {value}")


@_command(
    "background", "what exports show where the warp leaves them transparent: none, or a colour", undoable=True
)
def _background(state: AppState, value) -> None:
    from app.io.images.colours import parse_colour

    if value != "none":
        try:
            parse_colour(str(value))
        except ValueError as error:
            state.say(f"background: {error}", error=True)
            return
    commit(state, state.document.live.replace(background=str(value)), f"background: {value}")


@_command(
    "fill",
    "what fills the original position behind the warp: none, transparent, #rrggbb, inpaint",
    undoable=True,
)
def _fill(state: AppState, value) -> None:
    try:
        fill = checked_fill(value, "fill")
    except InputError as error:
        state.say(str(error), error=True)
        return
    commit(state, state.document.live.replace(fill=fill), f"fill: {fill}")


@_command("canvas", "an export's frame: the source image, or grown to the target", undoable=True)
def _canvas(state: AppState, value) -> None:
    if value in CANVASES:
        commit(state, state.document.live.replace(canvas=value), f"canvas: {value}")


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


@_command("fit_view", "fit the image in the window", moves_view=True)
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


# -- the timeline's commands ------------------------------------------------------------


@_edit("add_keyframe", "a keyframe at the current time (or at time value) from the target shown")
def _add_keyframe(state: AppState, value) -> None:
    live = state.document.live
    keyframes = live.keyframes
    time = state.playback.time if value is None else float(value)
    if not 0.0 <= time <= MAX_TIME:
        state.say(f"a keyframe needs a time within 0..{MAX_TIME:g} s", error=True)
        return
    time = on_grid(time, state.playback.fps)
    kept = tuple(k for k in keyframes if abs(k.time - time) >= half_frame(state.playback.fps))
    replaced = len(kept) < len(keyframes)
    snapshot = live.replace(keyframes=(*kept, Keyframe(time, live.target)))
    count = len(snapshot.keyframes)
    verb = "replaced" if replaced else "added"
    commit(state, snapshot, f"{verb} the keyframe at {time:.2f} s ({count} keyframe{'s' * (count != 1)})")
    state.playback.time = time
    state.playback.keyframe = next(i for i, k in enumerate(snapshot.keyframes) if k.time == time)


@_edit("delete_keyframe", "delete a keyframe (value: its index; the selected one)")
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


@_edit("keyframe_time", "move a keyframe in time (value: index, seconds)")
def _keyframe_time(state: AppState, value) -> None:
    live = state.document.live
    keyframes = live.keyframes
    index, time = int(value[0]), float(value[1])
    if not 0 <= index < len(keyframes):
        return
    if not 0.0 <= time <= MAX_TIME:
        state.say(f"keyframe times lie within 0..{MAX_TIME:g} s", error=True)
        return
    time = on_grid(time, state.playback.fps)
    others = keyframes[:index] + keyframes[index + 1 :]
    if key_near(others, time, state.playback.fps) is not None:
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
    state.playback.time = on_grid(float(value), state.playback.fps)
    show_time(state)


@_command("seek_by", "move the time on or back (value: seconds)", while_drawing=False)
def _seek_by(state: AppState, value) -> None:
    _seek(state, state.playback.time + float(value))


@_command("playback", "play or pause the keyframes", while_drawing=False)
def _playback(state: AppState, value) -> None:
    span = state.document.live.time_span
    if state.playback.playing:
        state.playback.playing = False
        state.playback.time = on_grid(state.playback.time, state.playback.fps)
        show_time(state)
        frame = round(state.playback.time * state.playback.fps)
        state.say(f"paused at {state.playback.time:.2f} s (frame {frame})")
    elif span is None or span[0] == span[1]:
        state.say("add two keyframes at different times to play (the Keyframe button, or I)", error=True)
    else:
        if state.playback.time >= span[1] or state.playback.time < span[0]:
            state.playback.time = span[0]
        state.playback.playing = True
        state.say("playing (Space pauses)")
        show_time(state)


@_edit("interpolation", "how the target moves between keyframes")
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


@_command("quit", "quit")
def _quit(state: AppState, value) -> None:
    state.status.quit = True


# -- the window's commands ----------------------------------------------------------------


@_window_command("save", "save the session now")
def _save(viewer: WindowActions, value) -> None:
    viewer.save_now()


@_window_command("export", "export the warped image or the animation (value 'again': to the last file)")
def _export(viewer: WindowActions, value) -> None:
    viewer.ask_export_path(again=value == "again")


@_window_command("export_path", "export to the path given")
def _export_path(viewer: WindowActions, value) -> None:
    viewer.export(Path(value).expanduser(), value)


@_window_command("open", "open an image")
def _open(viewer: WindowActions, value) -> None:
    viewer.ask_open_path("image")


@_window_command("open_session", "open a session file")
def _open_session(viewer: WindowActions, value) -> None:
    viewer.ask_open_path("session")


@_window_command("open_path", "open the image at the path given")
def _open_path(viewer: WindowActions, value) -> None:
    viewer.open_path(Path(value))


@_window_command("save_cage", "save the source cage to a file (value: its path, .svg or .json; none: ask)")
def _save_cage(viewer: WindowActions, value) -> None:
    _save_cage_file(viewer, "cage", value)


@_window_command("save_target", "save the target cage to a file (value: its path, .svg or .json; none: ask)")
def _save_target(viewer: WindowActions, value) -> None:
    _save_cage_file(viewer, "target", value)


def _save_cage_file(viewer: WindowActions, which: str, path: str | None) -> None:
    """Save the cage or the target to `path`; without one, ask where: a file dialog, or, with no
    dialog program, the typed path and file list in the window (``status.cage_prompt``)."""
    state = viewer.state
    if path:
        cage_files.save_cage(state, which, Path(path).expanduser())
        return
    proposed = cage_files.proposed_path(state, which)
    if not viewer.dialogs.ask_save(f"save_{which}", f"Save the {which}", proposed):
        setattr(state.status, f"{which}_prompt", str(proposed))


@_window_command("play", "play or stop the demo script")
def _play(viewer: WindowActions, value) -> None:
    viewer.toggle_script()


@_window_command("start_over", "start over: the image without a cage")
def _start_over(viewer: WindowActions, value) -> None:
    viewer.start_over()
