"""Opening a viewer document (demo, image, cage, session file) and saving it as a session.

The session file is the one of .docs/architecture.md (``image``, ``cage``, ``target``,
``kernel``, ``view``) plus keys of its own that `python -m app warp --session`
also reads, so that it exports exactly what the viewer showed: ``kernel_params``
(the ``power`` kernel's ``power`` and ``shift``), ``parameterization`` (``"natural"``,
the default of older sessions, or ``"arc-length"``: `core.curves.arc_length`) and ``mesh``
(``{"max_edge": h}``, the mesh the viewer used), and the animation that ``animate`` renders:
``keyframes`` (``[{"time": s, "target": {cage}}, ...]``) and ``interpolation``
(`app.warp.keyframes`).  ``viewer`` keeps what only the viewer needs
(mode, what is shown, the power family's settings while another kernel is
chosen, the timeline's time, loop and frame rate ``fps``) and ``history`` the undo
and redo steps (the newest `SAVED_STEPS` of each), so that Ctrl+Z still works after a restart.

Without ``--session`` every image has its own file (`session_path_for`), which
the viewer restores when the same image (or demo) is opened again, whatever the
command; ``--fresh`` starts over and keeps the old file aside.  A file that
cannot be read is kept aside too, and the newest readable backup is restored.
"""

from __future__ import annotations

import os
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from app.io.files import (
    InputError,
    Session,
    cage_curve,
    finite_number,
    kernel_names,
    read_cage,
    read_cage_file,
    read_image,
    read_session,
    reported_as_input,
    session_background,
    session_fold_free,
    session_image,
    session_kernel_params,
    session_keyframes,
    session_max_edge,
    session_output,
    session_parameterization,
    write_session,
)
from app.render.viewport import View
from app.viewer.frame_grid import DEFAULT_FPS, checked_fps, on_grid
from app.viewer.session_files import backups, keep_aside, rotate_backups, session_path_for
from app.viewer.session_lock import SessionLock, lock_session
from app.viewer.state import (
    DEFAULT_POWER,
    DEFAULT_SHIFT,
    EDIT_MODES,
    MEASURES,
    SHIFTS,
    AppState,
    Snapshot,
)
from app.viewer.view_modes import VIEW_MODE_NAMES
from app.warp.fill import session_fill
from app.warp.framing import CANVASES, OUTSIDES
from app.warp.keyframes import DEFAULT_INTERPOLATION, MAX_TIME, Keyframe, keyframes_json
from core import abandoned_temporaries

#: Undo steps (and redo steps) written into the session file.
SAVED_STEPS = 100


@dataclass
class OpenedDocument:
    """What the viewer opens with.

    Attributes
    ----------
    snapshot : Snapshot
        Image, cage, target and kernel.
    image : ndarray of shape (H, W, 4), uint8
    session_path : Path
        Where it autosaves.
    view : View or None
        The session's view (None: fit the image to the window).
    max_edge : float or None
        Mesh edge length given on the command line or by the session.
    preferences : dict
        The session's ``viewer`` object (mode, content, ...).
    undo, redo : list of Snapshot
        The undo history restored with the session (`History` order).
    restored : bool
        Whether `snapshot` is what `session_path` (or its backup) held: the first
        autosave then does not count as a new version.
    start_cage : Path or None
        The cage file a new session of this image starts from ("Start over";
        None: fit the cage to the image).
    notices : list of str
        What the user should hear about the opening (restored, kept aside, ...).
    lock : SessionLock or None
        This process's lock of `session_path` (`app.viewer.session_lock`): held
        as long as the document (or the viewer showing it) keeps it.
    """

    snapshot: Snapshot
    image: np.ndarray
    session_path: Path
    view: View | None = None
    max_edge: float | None = None
    preferences: dict | None = None
    undo: list[Snapshot] = field(default_factory=list)
    redo: list[Snapshot] = field(default_factory=list)
    restored: bool = False
    start_cage: Path | None = None
    notices: list[str] = field(default_factory=list)
    lock: SessionLock | None = None


def open_document(
    image: Path | None = None,
    cage: Path | None = None,
    session: Path | None = None,
    max_edge: float | None = None,
    demo_name: str | None = None,
    fresh: bool = False,
) -> OpenedDocument:
    """The document of ``python -m app view [IMAGE] [--cage] [--session] [--fresh]`` (or of a demo).

    - ``--session`` that exists: restore that file (IMAGE, ``--cage`` or ``--fresh``
      with it are refused);
    - otherwise the document is IMAGE, or the bundled demo (`demo_name`, the
      default demo by default) when there is none; its session file is
      ``--session`` or `session_path_for` the image.  If that file exists it is
      restored with its undo history (``--cage`` is then only what "Start over"
      goes back to); with `fresh` it is kept aside and the document starts anew:
      from ``--cage``, or a cage fitted to the image's subject, or an ellipse.

    The session file is locked first (`lock_session`), so that a second viewer
    of the same session cannot overwrite this one's autosaves.

    Raises
    ------
    InputError
        Unreadable files, or IMAGE / ``--cage`` / ``--fresh`` with an existing ``--session``.
    SessionBusy
        The session is open in a viewer of another process.
    """
    if session is not None and session.exists():
        given = [name for name, value in (("IMAGE", image), ("--cage", cage), ("--fresh", fresh)) if value]
        if given:
            try:
                read_session(session)
                state = "exists"
            except InputError as error:  # say so: opening it alone is no fix then
                state = f"exists but cannot be read ({str(error).removeprefix(f'{session}: ')})"
            raise InputError(
                f"{session} {state}: open it alone with --session, or start {' and '.join(given)} "
                "in a new session file"
            )
        lock = lock_session(session)
        finished = finish_interrupted_save(session)
        document = restore(session, max_edge)
        document.notices[:0] = finished
        document.lock = lock
        return document
    if image is None:
        from app.viewer.demos import DEFAULT_DEMO, demo_files

        files = demo_files(demo_name or DEFAULT_DEMO)
        image, cage = files.image, cage or files.cage
    path = session or session_path_for(image)
    lock = lock_session(path)
    notices: list[str] = finish_interrupted_save(path)
    if session is None and not fresh:
        document = recover(path, Path(image), max_edge, notices)
        if document is not None:
            document.start_cage = cage
            document.lock = lock
            return document
    elif fresh and path.exists():
        aside = keep_aside(path, "replaced")
        notices.append(f"started afresh; the previous session is kept as {aside}")
    pixels = read_image(image)
    outside = "transparent"
    if cage is not None:
        control_points, remark = read_cage_file(cage)  # an SVG path fitted: said on the status line
        notices += [remark] if remark else []
        cage_curve(control_points, str(cage))
    else:
        control_points, note = fit_or_ellipse(pixels)
        notices.append(note)
        if (pixels[..., 3] == 255).all():
            # A photograph: its subject is cut out of a picture the user wants to keep whole.
            outside = "original"
    snapshot = Snapshot(Path(os.path.realpath(image)), control_points, control_points, outside=outside)
    return OpenedDocument(
        snapshot,
        pixels,
        path,
        max_edge=max_edge,
        preferences={},
        start_cage=cage,
        notices=notices,
        lock=lock,
    )


def finish_interrupted_save(path: Path) -> list[str]:
    """Complete an autosave of `path` that a killed viewer wrote whole but did not rename.

    An autosave writes a temporary file, flushes it and renames it over `path`
    (`core.storage.atomic_write`); ``kill -9`` between the write and the rename left the
    newest state in the temporary, which the next write would delete.  The newest
    such temporary that is a readable session and newer than `path` becomes `path`
    (the old `path` becomes backup 1); a partly written one is left to be removed.
    Call it with the session locked, so that no running viewer is writing one.

    Returns
    -------
    list of str
        The notice for the status line, or nothing when there was nothing to finish.
    """
    newest = path.stat().st_mtime_ns if path.exists() else -1
    for temporary in abandoned_temporaries(path):
        try:
            if temporary.stat().st_mtime_ns <= newest or not temporary.is_file():
                continue
            read_session(temporary)
        except (InputError, OSError):
            continue
        try:
            rotate_backups(path)
            os.replace(temporary, path)
        except OSError as error:
            return [f"cannot finish the last autosave, interrupted in {temporary} ({error})"]
        return [f"finished the last autosave, which the viewer was killed while writing ({path.name})"]
    return []


def recover(path: Path, image: Path, max_edge: float | None, notices: list[str]) -> OpenedDocument | None:
    """Restore the session of `image` from `path` or, if that cannot be read, its newest readable backup.

    An unreadable `path` (bad JSON, bad keys, a cage that is not simple, another
    image's session) is kept aside, never overwritten.  Appends what happened to
    `notices`; returns None when there is nothing to restore.
    """
    for candidate in [path, *backups(path)] if path.exists() else backups(path):
        try:
            document = restore(candidate, max_edge)
            if document.snapshot.image != Path(os.path.realpath(image)):
                raise InputError(f"{candidate}: is the session of {document.snapshot.image}, not of {image}")
        except InputError as error:
            if candidate == path:
                aside = keep_aside(path, "unreadable")
                notices.append(f"cannot restore the session ({error}); kept it as {aside}")
            continue
        document.session_path = path
        steps = len(document.undo)
        source = "the session" if candidate == path else f"its backup {candidate.name}"
        document.notices[:0] = notices
        document.notices.append(
            f"restored {image.name} from {source} ({steps} undo step{'s' * (steps != 1)}); "
            "--fresh starts over"
        )
        return document
    return None


def restore(path: Path, max_edge: float | None = None) -> OpenedDocument:
    """Open a session file: everything, including the view and the undo history."""
    session = read_session(path)
    pixels = read_image(session_image(session, path))
    cage_curve(session.cage, f"{path}: cage")
    params = session_kernel_params(session, path)
    preferences = session.extra.get("viewer") if isinstance(session.extra.get("viewer"), dict) else {}
    outside, canvas = session_output(session, path)
    settings = {"outside": outside, "canvas": canvas, "fill": session_fill(session.extra, path)}
    if session_background(session, path) is not None:  # checked: a bad colour is one line
        settings["background"] = session.extra["background"]
    power = params.get("power", preferences.get("power", DEFAULT_POWER))
    shift = params.get("shift", preferences.get("shift", DEFAULT_SHIFT))
    power = finite_number(power)
    if power is None or not power > 0:
        power = DEFAULT_POWER
    if shift not in SHIFTS:
        shift = DEFAULT_SHIFT
    image = Path(os.path.realpath(session.image))
    keyframes, interpolation = session_keyframes(session, path)
    snapshot = Snapshot(
        image,
        session.cage,
        session.target,
        session.kernel,
        power,
        shift,
        keyframes,
        interpolation,
        session_parameterization(session, path),
        session_fold_free(session, path) and session.kernel == "poisson",
        **settings,
    )
    notices: list[str] = []
    try:
        undo, redo = history_of(session.extra.get("history"), image, settings)
    except (TypeError, ValueError, KeyError, OverflowError) as error:
        undo, redo = [], []
        notices.append(f"{path}: the undo history cannot be read ({error}); starting without it")
    return OpenedDocument(
        snapshot,
        pixels,
        path,
        View(session.scale, session.offset),
        max_edge if max_edge is not None else session_max_edge(session, path),
        preferences,
        undo,
        redo,
        restored=True,
        notices=notices,
    )


def _step(snapshot: Snapshot) -> dict:
    return {
        "cage": snapshot.cage.tolist(),
        "target": snapshot.target.tolist(),
        "kernel": snapshot.kernel,
        "power": snapshot.power,
        "shift": snapshot.shift,
        "keyframes": keyframes_json(snapshot.keyframes),
        "interpolation": snapshot.interpolation,
        "parameterization": snapshot.parameterization,
        "fold_free": snapshot.fold_free,
        **dict(zip(SETTINGS, snapshot.settings(), strict=True)),
    }


def history_json(state: AppState) -> dict:
    """The ``history`` object of the session file: the newest `SAVED_STEPS` undo and redo steps.

    Steps are ``{"cage": [[x, y], ...], "target": [[x, y], ...], "kernel", "power",
    "shift", "keyframes", "interpolation", "parameterization"}`` of the session's image (the keyframes as in
    the session file); ``undo`` is oldest first, ``redo`` has the
    next step last (`History` order).
    """
    image = state.document.history.current.image

    def nearest(steps: tuple[Snapshot, ...]) -> list[dict]:
        """The last `SAVED_STEPS` steps (the nearest to the current state) back to another image."""
        kept = []
        for snapshot in reversed(steps):
            if snapshot.image != image or len(kept) == SAVED_STEPS:
                break
            kept.append(_step(snapshot))
        return kept[::-1]

    return {
        "undo": nearest(state.document.history.undo_steps),
        "redo": nearest(state.document.history.redo_steps),
    }


#: The export's settings that each history step holds (`Snapshot.settings`).
SETTINGS = ("outside", "canvas", "fill", "background")


def history_of(value, image: Path, settings: dict | None = None) -> tuple[list[Snapshot], list[Snapshot]]:
    """Undo and redo steps of a ``history`` object (`history_json`); ([], []) when absent.

    A step without the export's settings (older sessions) takes `settings`, the session's.

    Raises
    ------
    TypeError, KeyError, ValueError
        The object is malformed (a step's cage is not simple is not checked here:
        undoing to it shows it as it was).
    """
    if value is None:
        return [], []
    if not isinstance(value, dict):
        raise TypeError(f"expected an object, got {type(value).__name__}")

    def snapshots(name: str) -> list[Snapshot]:
        steps = value.get(name, [])
        if not isinstance(steps, list):
            raise TypeError(f"{name} must be a list")
        result = []
        for index, step in enumerate(steps):
            kernel = step["kernel"]
            if kernel not in kernel_names():
                raise ValueError(f"{name}[{index}] has unknown kernel {kernel!r}")
            cage, target = np.asarray(step["cage"], float), np.asarray(step["target"], float)
            if cage.ndim != 2 or cage.shape[1:] != (2,) or len(cage) < 3:
                raise ValueError(f"{name}[{index}] cage must be 3 or more [x, y] pairs")
            keyframes = [
                Keyframe(float(item["time"]), np.asarray(item["target"]["control_points"], float))
                for item in step.get("keyframes", [])  # absent in the steps of older sessions
            ]
            interpolation = step.get("interpolation", DEFAULT_INTERPOLATION)
            power, shift = float(step["power"]), step["shift"]
            parameterization = step.get("parameterization", "natural")  # absent in older sessions
            fold_free = step.get("fold_free", False) is True and kernel == "poisson"
            kept = {name: step[name] for name in SETTINGS if _valid_setting(name, step.get(name))}
            result.append(
                Snapshot(
                    image,
                    cage,
                    target,
                    kernel,
                    power,
                    shift,
                    keyframes,
                    interpolation,
                    parameterization,
                    fold_free,
                    **{**(settings or {}), **kept},
                )
            )
        return result

    return snapshots("undo"), snapshots("redo")


def _valid_setting(name: str, value) -> bool:
    """Whether `value` is a valid export setting `name` of a history step (one of `SETTINGS`)."""
    from app.io.images.colours import parse_colour
    from app.warp.fill import checked_fill

    if not isinstance(value, str):
        return False
    if name in ("outside", "canvas"):
        return value in (OUTSIDES if name == "outside" else CANVASES)
    try:
        checked_fill(value, name) if name == "fill" else value == "none" or parse_colour(value)
    except ValueError:
        return False
    return True


def start_snapshot(current: Snapshot, image: np.ndarray, cage: Path | None) -> tuple[Snapshot, str]:
    """A new start of the document `current` and a note saying what it is.

    The cage (and target) of the file `cage`, or a cage fitted to `image`
    (`fit_or_ellipse`) when there is none; image and kernel stay.
    """
    if cage is None:
        points, note = fit_or_ellipse(image)
    else:
        points = read_cage(cage)
        cage_curve(points, str(cage))
        note = f"the cage of {cage.name}"
    return current.replace(cage=points, target=points, keyframes=()), note


def begin_with(document: OpenedDocument, snapshot: Snapshot, message: str) -> None:
    """Make `snapshot` the document's state as one undoable step (what it held stays a Ctrl+Z away)."""
    if snapshot == document.snapshot:
        return
    document.undo.append(document.snapshot)
    document.redo.clear()
    document.snapshot = snapshot
    document.restored = False
    document.notices.append(message)


def fit_or_ellipse(image: np.ndarray, points: int = 16, rect=None) -> tuple[np.ndarray, str]:
    """A cage fitted to the image's subject (app.fit.subject; inside `rect`, (x, y, width, height), if
    given), or an ellipse if that fails; and a note."""
    from app.fit.subject import fit_cage
    from app.viewer.editing import ellipse_cage

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            with reported_as_input("fit"):
                control_points = fit_cage(image, points, rect=rect)
        except InputError as error:
            height, width = image.shape[:2]
            return ellipse_cage(width, height), f"no subject found ({error}); started with an ellipse"
    note = str(caught[-1].message) if caught else f"fitted {len(control_points)} control points"
    return np.round(control_points, 3), note


def apply_preferences(state: AppState, preferences: dict | None) -> None:
    """Take the session's ``viewer`` settings that make sense."""
    preferences = preferences or {}
    if preferences.get("mode") in EDIT_MODES:
        state.selection.edit_mode = preferences["mode"]
    if preferences.get("content") in VIEW_MODE_NAMES:
        state.display.view_mode = preferences["content"]
    if preferences.get("distortion") in MEASURES:
        state.display.distortion_measure = preferences["distortion"]
    for name in ("show_folds", "show_wireframe", "show_overlay"):
        if isinstance(preferences.get(name), bool):
            setattr(state.display, name, preferences[name])
    if isinstance(preferences.get("loop"), bool):
        state.playback.loop = preferences["loop"]
    state.playback.fps = checked_fps(preferences.get("fps")) or DEFAULT_FPS
    time = finite_number(preferences.get("time"))
    if time is not None and 0 <= time <= MAX_TIME:
        state.playback.time = on_grid(time, state.playback.fps)
    selected = preferences.get("selected")
    if isinstance(selected, int) and 0 <= selected < state.document.live.n:
        state.selection.selected = selected


def session_of(state: AppState, max_edge: float | None) -> Session:
    """The session file's content for the committed state (not a drag in progress)."""
    snapshot = state.document.history.current
    extra = {
        "viewer": {
            "mode": state.selection.edit_mode,
            "content": state.display.view_mode,
            "distortion": state.display.distortion_measure,
            "show_folds": state.display.show_folds,
            "show_wireframe": state.display.show_wireframe,
            "show_overlay": state.display.show_overlay,
            "selected": state.selection.selected,
            "power": snapshot.power,
            "shift": snapshot.shift,
            "time": state.playback.time,
            "loop": state.playback.loop,
            "fps": state.playback.fps,
        }
    }
    if snapshot.kernel_params():
        extra["kernel_params"] = snapshot.kernel_params()
    if max_edge is not None:
        extra["mesh"] = {"max_edge": float(max_edge)}
    extra["outside"], extra["canvas"] = state.document.outside, state.document.canvas
    if state.document.background != "none":  # files without the key read as transparent
        extra["background"] = state.document.background
    if (
        state.document.fill != "none"
    ):  # files without the key read as "none" (and stay as older versions wrote them)
        extra["fill"] = state.document.fill
    if snapshot.fold_free:  # read by warp and animate too; absent (false) as older versions wrote
        extra["fold_free"] = True
    extra["keyframes"] = keyframes_json(snapshot.keyframes)
    extra["interpolation"] = snapshot.interpolation
    extra["parameterization"] = snapshot.parameterization
    extra["history"] = history_json(state)
    return Session(
        snapshot.image,
        np.array(snapshot.cage),
        np.array(snapshot.target),
        snapshot.kernel,
        float(state.display.viewport.scale),
        (float(state.display.viewport.offset[0]), float(state.display.viewport.offset[1])),
        extra,
    )


def save(state: AppState, max_edge: float | None, new_version: bool = True) -> None:
    """Write the session file atomically (`InputError` if it cannot be written).

    With `new_version` (the document changed since the file was written) the
    file's previous version becomes backup 1 first (`rotate_backups`).
    """
    path = state.document.session_path
    path.parent.mkdir(parents=True, exist_ok=True)
    if new_version:
        try:
            rotate_backups(path)
        except OSError as error:
            raise InputError(f"{path}: cannot keep a backup ({error.strerror or error})") from None
    write_session(path, session_of(state, max_edge))
