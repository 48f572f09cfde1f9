"""The viewer's cage files: Open a cage (JSON or SVG) as the document's new cage, Save the cage or
the target to a file (`app.io.files.write_cage`: ``.svg`` writes the exact chain of quadratic
Béziers over the image's size, any other name JSON)."""

from __future__ import annotations

from pathlib import Path

from app.io.files import CAGE_SUFFIXES, InputError, read_cage_file, write_cage
from app.viewer import editing
from app.viewer.controller import commit
from app.viewer.state import AppState, Pins

#: What Save writes, by the command's value: the source cage or the target.
SAVED = ("cage", "target")


def open_cage(state: AppState, path: Path) -> None:
    """Make the cage file at `path` the document's cage and target, one undo step.

    Raises
    ------
    InputError
        The file is not a cage, or its cage is not a simple closed curve.
    """
    cage, remark = read_cage_file(path)
    problem = editing.cage_problem(cage)
    if problem:
        raise InputError(f"{path}: {problem}")
    live = state.document.live
    commit(state, live.replace(cage=cage, target=cage, keyframes=(), pins=Pins()), f"cage from {path}")
    if remark is not None:
        state.say(remark)


def proposed_path(state: AppState, which: str) -> Path:
    """Where Save proposes to write the cage (`which` "cage") or the target ("target"): an SVG
    beside the session file, named after it."""
    session = Path(state.document.session_path)
    return session.with_name(f"{session.stem}.{which}.svg")


def save_cage(state: AppState, which: str, path: Path | str) -> None:
    """Write the live cage (`which` "cage") or target ("target") to `path`; the status says where,
    or what went wrong."""
    path = Path(path)
    if path.suffix.lower() not in CAGE_SUFFIXES:
        state.say(f"{path}: a cage file's name ends in {' or '.join(CAGE_SUFFIXES)}", error=True)
        return
    live = state.document.live
    height, width = state.document.image.shape[:2]
    try:
        write_cage(path, live.cage if which == "cage" else live.target, image_size=(width, height))
    except InputError as error:
        state.say(str(error), error=True)
        return
    state.say(f"saved the {which} to {path}")
