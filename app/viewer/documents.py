"""Opening a viewer document (demo, image, cage, session file) and saving it as a session.

The session file is `app.io.session.Session`, read and written there: what `python -m app warp
--session` and ``animate`` read too, so that they export exactly what the viewer showed (the
kernel and its parameters, the mesh, the output choices, the keyframes), and the viewer's own
settings and undo history (the newest `SAVED_STEPS` steps each way), so that Ctrl+Z still works
after a restart.  Here a document becomes a `Session` (`session_of`) and a `Session` a document
(`restore`).

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
    cage_curve,
    finite_number,
    read_cage,
    read_cage_file,
    read_image,
    reported_as_input,
)
from app.io.session import (
    Animation,
    History,
    HistoryStep,
    KernelChoice,
    OutputChoice,
    Pin,
    Session,
    ViewerSettings,
    existing_image,
    read_session,
    write_session,
)
from app.render.viewport import View
from app.viewer import state as model
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
from app.warp.keyframes import MAX_TIME
from core import abandoned_temporaries

#: Undo steps (and redo steps) written into the session file.
SAVED_STEPS = 100


@dataclass(frozen=True)
class Preferences:
    """What a document's session says of the viewer (mode, content, ...) and of its exports."""

    viewer: ViewerSettings = field(default_factory=ViewerSettings)
    output: OutputChoice = field(default_factory=OutputChoice)


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
    preferences : Preferences
        The session's viewer settings and output choices.
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
    preferences: Preferences | None = None
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
    preferences = Preferences()
    if cage is not None:
        control_points, remark = read_cage_file(cage)  # an SVG path fitted: said on the status line
        notices += [remark] if remark else []
        cage_curve(control_points, str(cage))
    else:
        control_points, note = fit_or_ellipse(pixels)
        notices.append(note)
        if (pixels[..., 3] == 255).all():
            # A photograph: its subject is cut out of a picture the user wants to keep whole.
            preferences = Preferences(output=OutputChoice(outside="original"))
    snapshot = Snapshot(Path(os.path.realpath(image)), control_points, control_points)
    return OpenedDocument(
        snapshot,
        pixels,
        path,
        max_edge=max_edge,
        preferences=preferences,
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
    pixels = read_image(existing_image(session, path))
    cage_curve(session.cage, f"{path}: cage")
    image = Path(os.path.realpath(session.image))
    chosen, animation = session.kernel, session.animation
    power, shift = power_family(chosen.params, session.viewer)
    snapshot = Snapshot(
        image,
        session.cage,
        session.target,
        chosen.name,
        power,
        shift,
        animation.keyframes,
        animation.interpolation,
        chosen.parameterization,
        session.fold_free and chosen.name == "poisson",
        pins=model.Pins(
            tuple((pin.at, pin.to) for pin in session.pins), session.max_distortion, _fixed(session)
        ),
    )
    notices: list[str] = []
    try:
        undo, redo = history_of(session.history, image, session.output)
    except ValueError as error:
        undo, redo = [], []
        notices.append(f"{path}: the undo history cannot be read ({error}); starting without it")
    return OpenedDocument(
        snapshot,
        pixels,
        path,
        session.view,
        max_edge if max_edge is not None else session.max_edge,
        Preferences(session.viewer, session.output),
        undo,
        redo,
        restored=True,
        notices=notices,
    )


def _fixed(session: Session) -> tuple[int, ...]:
    """The session's ``fixed`` control points (`app.warp.pins.session_pins`'s), the valid ones."""
    fixed = session.extra.get("fixed", [])
    valid = isinstance(fixed, list) and all(isinstance(i, int) and not isinstance(i, bool) for i in fixed)
    return tuple(i for i in fixed if 0 <= i < len(session.cage)) if valid else ()


def power_family(params: dict, viewer: ViewerSettings) -> tuple[float, str]:
    """The ``power`` kernel's (power, shift) of a session: its kernel parameters when it is the
    kernel, else what the viewer kept of them, else the viewer's defaults."""
    power = finite_number(params.get("power", viewer.power))
    shift = params.get("shift", viewer.shift)
    return (power if power is not None and power > 0 else DEFAULT_POWER), (
        shift if shift in SHIFTS else DEFAULT_SHIFT
    )


def _step(snapshot: Snapshot) -> HistoryStep:
    return HistoryStep(
        snapshot.cage,
        snapshot.target,
        snapshot.kernel,
        snapshot.power,
        snapshot.shift,
        snapshot.keyframes,
        snapshot.interpolation,
        snapshot.parameterization,
        snapshot.fold_free,
        OutputChoice(snapshot.outside, snapshot.canvas, snapshot.fill, snapshot.background),
        tuple(Pin(at, to) for at, to in snapshot.pins.points),
        snapshot.pins.bound,
        snapshot.pins.fixed,
    )


def saved_history(state: AppState) -> History:
    """The session's `History`: the newest `SAVED_STEPS` undo and redo steps of the session's image
    (``undo`` oldest first, ``redo`` with the next step last: `History` order)."""
    image = state.document.history.current.image

    def nearest(steps: tuple[Snapshot, ...]) -> tuple[HistoryStep, ...]:
        """The last `SAVED_STEPS` steps (the nearest to the current state) back to another image."""
        kept = []
        for snapshot in reversed(steps):
            if snapshot.image != image or len(kept) == SAVED_STEPS:
                break
            kept.append(_step(snapshot))
        return tuple(kept[::-1])

    return History(nearest(state.document.history.undo_steps), nearest(state.document.history.redo_steps))


def history_of(
    history: History, image: Path, output: OutputChoice | None = None
) -> tuple[list[Snapshot], list[Snapshot]]:
    """Undo and redo steps of a session's `History`, as snapshots of `image`, each with its own
    output choices (a step of an older session, which holds none, with the session's `output`).

    Raises
    ------
    ValueError
        The history could not be read (`History.problem`), or a step is no snapshot (a step's
        cage that is not simple is not checked here: undoing to it shows it as it was).
    """
    if history.problem:
        raise ValueError(history.problem)

    def snapshots(name: str, steps: tuple[HistoryStep, ...]) -> list[Snapshot]:
        result = []
        for index, step in enumerate(steps):
            try:
                result.append(
                    Snapshot(
                        image,
                        step.cage,
                        step.target,
                        step.kernel,
                        step.power,
                        step.shift,
                        step.keyframes,
                        step.interpolation,
                        step.parameterization,
                        step.fold_free,
                        pins=model.Pins(
                            tuple((pin.at, pin.to) for pin in step.pins), step.max_distortion, step.fixed
                        ),
                    ).replace(**vars(step.output or output or OutputChoice()))
                )
            except ValueError as error:
                raise ValueError(f"{name}[{index}]: {error}") from None
        return result

    return snapshots("undo", history.undo), snapshots("redo", history.redo)


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
    return current.replace(cage=points, target=points, keyframes=(), pins=model.Pins()), note


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


def apply_preferences(state: AppState, preferences: Preferences | None) -> None:
    """Take the session's viewer settings that make sense (a word the viewer does not know, as
    from another version, is passed over) and its output choices (checked when it was read)."""
    viewer = (preferences or Preferences()).viewer
    output = (preferences or Preferences()).output
    if viewer.mode in EDIT_MODES:
        state.selection.edit_mode = viewer.mode
    if viewer.content in VIEW_MODE_NAMES:
        state.display.view_mode = viewer.content
    if viewer.distortion in MEASURES:
        state.display.distortion_measure = viewer.distortion
    for name in ("show_folds", "show_wireframe", "show_overlay"):
        if getattr(viewer, name) is not None:
            setattr(state.display, name, getattr(viewer, name))
    _take_output(state, output)
    if viewer.loop is not None:
        state.playback.loop = viewer.loop
    state.playback.fps = checked_fps(viewer.fps) or DEFAULT_FPS
    if viewer.time is not None and 0 <= viewer.time <= MAX_TIME:
        state.playback.time = on_grid(viewer.time, state.playback.fps)
    if viewer.selected is not None and 0 <= viewer.selected < state.document.live.n:
        state.selection.selected = viewer.selected


def _take_output(state: AppState, output: OutputChoice) -> None:
    """The session's output choices as the document's current snapshot's (the undo history's steps
    hold their own: `history_of`)."""
    document, history = state.document, state.document.history
    saved = document.saved is not None and document.saved == history.current
    document.history = model.History(
        history.current.replace(**vars(output)),
        history.limit,
        list(history.undo_steps),
        list(history.redo_steps),
    )
    document.live = document.history.current
    if saved:
        document.saved = document.live


def session_of(state: AppState, max_edge: float | None) -> Session:
    """The session file's content for the committed state (not a drag in progress)."""
    snapshot = state.document.history.current
    document, display = state.document, state.display
    return Session(
        snapshot.image,
        np.array(snapshot.cage),
        np.array(snapshot.target),
        KernelChoice(snapshot.kernel, snapshot.kernel_params(), snapshot.parameterization),
        View(
            float(display.viewport.scale),
            (float(display.viewport.offset[0]), float(display.viewport.offset[1])),
        ),
        max_edge=None if max_edge is None else float(max_edge),
        fold_free=snapshot.fold_free,
        pins=tuple(Pin(at, to) for at, to in snapshot.pins.points),
        max_distortion=snapshot.pins.bound,
        output=OutputChoice(document.outside, document.canvas, document.fill, document.background),
        animation=Animation(snapshot.keyframes, snapshot.interpolation),
        viewer=ViewerSettings(
            mode=state.selection.edit_mode,
            content=display.view_mode,
            distortion=display.distortion_measure,
            show_folds=display.show_folds,
            show_wireframe=display.show_wireframe,
            show_overlay=display.show_overlay,
            selected=state.selection.selected,
            power=snapshot.power,
            shift=snapshot.shift,
            time=state.playback.time,
            loop=state.playback.loop,
            fps=state.playback.fps,
        ),
        history=saved_history(state),
        extra={"fixed": list(snapshot.pins.fixed)} if snapshot.pins.fixed else {},
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
