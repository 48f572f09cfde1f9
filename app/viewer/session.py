"""Opening a viewer document (demo, image, cage, session file) and saving it as a session.

The session file is the one of DESIGN.md (``image``, ``cage``, ``target``,
``kernel``, ``view``) plus three keys of its own that `python -m app warp
--session` also reads, so that it exports exactly what the viewer showed:
``kernel_params`` (the ``power`` kernel's ``power`` and ``shift``) and ``mesh``
(``{"max_edge": h}``, the mesh the viewer used).  ``viewer`` keeps what only the
viewer needs (mode, what is shown, the power family's settings while another
kernel is chosen).  Without ``--session`` the viewer saves to
``$XDG_STATE_HOME/transfinite-warp/sessions/NAME.json``
(``~/.local/state/...``; ``$TRANSFINITE_STATE_DIR`` overrides the directory).
"""

from __future__ import annotations

import os
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from app.files import (
    InputError,
    Session,
    cage_curve,
    read_cage,
    read_image,
    read_session,
    reported_as_input,
    session_kernel_params,
    session_max_edge,
    write_session,
)
from app.render import View
from app.viewer.state import CONTENTS, DEFAULT_POWER, DEFAULT_SHIFT, MODES, SHIFTS, AppState, Snapshot

STATE_VARIABLE = "TRANSFINITE_STATE_DIR"


@dataclass
class Document:
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
    """

    snapshot: Snapshot
    image: np.ndarray
    session_path: Path
    view: View | None = None
    max_edge: float | None = None
    preferences: dict | None = None


def state_directory() -> Path:
    """Where sessions without ``--session`` go."""
    configured = os.environ.get(STATE_VARIABLE)
    if configured:
        return Path(configured).expanduser()
    base = os.environ.get("XDG_STATE_HOME") or Path.home() / ".local" / "state"
    return Path(base) / "transfinite-warp"


def default_session_path(name: str) -> Path:
    """The autosave file of a document called `name` (the image's stem or the demo's name)."""
    safe = "".join(c if c.isalnum() or c in "-_." else "_" for c in name) or "session"
    return state_directory() / "sessions" / f"{safe}.json"


def open_document(
    image: Path | None = None,
    cage: Path | None = None,
    session: Path | None = None,
    max_edge: float | None = None,
    demo_name: str | None = None,
) -> Document:
    """The document of ``python -m app view [IMAGE] [--cage] [--session]`` (or of a demo).

    - ``--session`` alone: restore that file (image, cage, target, kernel, view);
    - IMAGE (with or without ``--cage``): a new document; without a cage the cage is
      fitted to the image's silhouette, or an ellipse if there is none;
    - neither: the bundled demo (`demo_name`, the default demo by default).

    Raises
    ------
    InputError
        Unreadable files, or IMAGE / ``--cage`` given with an existing ``--session``.
    """
    if session is not None and session.exists():
        given = [name for name, value in (("IMAGE", image), ("--cage", cage)) if value is not None]
        if given:
            raise InputError(
                f"{session} exists: open it alone with --session, or start {' and '.join(given)} "
                "in a new session file"
            )
        return restore(session, max_edge)
    if image is None:
        from app.viewer.demos import DEFAULT_DEMO, demo_files

        files = demo_files(demo_name or DEFAULT_DEMO)
        image, cage = files.image, files.cage
        name = files.name
    else:
        name = image.stem
    pixels = read_image(image)
    if cage is not None:
        control_points = read_cage(cage)
        cage_curve(control_points, str(cage))
    else:
        control_points, _ = fit_or_ellipse(pixels)
    snapshot = Snapshot(Path(image).resolve(), control_points, control_points)
    return Document(snapshot, pixels, session or default_session_path(name), None, max_edge, {})


def restore(path: Path, max_edge: float | None = None) -> Document:
    """Open a session file: everything, including the view."""
    session = read_session(path)
    pixels = read_image(session.image)
    cage_curve(session.cage, f"{path}: cage")
    params = session_kernel_params(session, path)
    preferences = session.extra.get("viewer") if isinstance(session.extra.get("viewer"), dict) else {}
    power = params.get("power", preferences.get("power", DEFAULT_POWER))
    shift = params.get("shift", preferences.get("shift", DEFAULT_SHIFT))
    if not isinstance(power, (int, float)) or not power > 0:
        power = DEFAULT_POWER
    if shift not in SHIFTS:
        shift = DEFAULT_SHIFT
    snapshot = Snapshot(
        Path(session.image).resolve(), session.cage, session.target, session.kernel, power, shift
    )
    return Document(
        snapshot,
        pixels,
        path,
        View(session.scale, session.offset),
        max_edge if max_edge is not None else session_max_edge(session, path),
        preferences,
    )


def fit_or_ellipse(image: np.ndarray, points: int = 16) -> tuple[np.ndarray, str]:
    """A cage fitted to the image's silhouette (app.fit), or an ellipse if that fails; and a note."""
    from app.fit import fit_cage
    from app.viewer.editing import ellipse_cage

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            with reported_as_input("fit"):
                control_points = fit_cage(image, points)
        except InputError as error:
            height, width = image.shape[:2]
            return ellipse_cage(width, height), f"no silhouette to fit ({error}); started with an ellipse"
    note = str(caught[-1].message) if caught else f"fitted {len(control_points)} control points"
    return np.round(control_points, 3), note


def apply_preferences(state: AppState, preferences: dict | None) -> None:
    """Take the session's ``viewer`` settings that make sense."""
    preferences = preferences or {}
    if preferences.get("mode") in MODES:
        state.mode = preferences["mode"]
    if preferences.get("content") in CONTENTS:
        state.content = preferences["content"]
    for name in ("show_folds", "show_wireframe", "show_overlay"):
        if isinstance(preferences.get(name), bool):
            setattr(state, name, preferences[name])
    selected = preferences.get("selected")
    if isinstance(selected, int) and 0 <= selected < state.live.n:
        state.selected = selected


def session_of(state: AppState, max_edge: float | None) -> Session:
    """The session file's content for the committed state (not a drag in progress)."""
    snapshot = state.history.current
    extra = {
        "viewer": {
            "mode": state.mode,
            "content": state.content,
            "show_folds": state.show_folds,
            "show_wireframe": state.show_wireframe,
            "show_overlay": state.show_overlay,
            "selected": state.selected,
            "power": snapshot.power,
            "shift": snapshot.shift,
        }
    }
    if snapshot.kernel_params():
        extra["kernel_params"] = snapshot.kernel_params()
    if max_edge is not None:
        extra["mesh"] = {"max_edge": float(max_edge)}
    return Session(
        snapshot.image,
        np.array(snapshot.cage),
        np.array(snapshot.target),
        snapshot.kernel,
        float(state.view.scale),
        (float(state.view.offset[0]), float(state.view.offset[1])),
        extra,
    )


def save(state: AppState, max_edge: float | None) -> None:
    """Write the session file atomically (`InputError` if it cannot be written)."""
    path = state.session_path
    path.parent.mkdir(parents=True, exist_ok=True)
    write_session(path, session_of(state, max_edge))
