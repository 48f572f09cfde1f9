"""The viewer's own settings, kept between runs: ``viewer-settings.json`` in the state directory.

Not part of any session: the window's size and position, and how a new cage is drawn.
A missing, unreadable or damaged file means the defaults (a note on stderr is not
worth a user's attention for window sizes); the file is written atomically, so a
viewer killed while writing leaves the last good one.
"""

from __future__ import annotations

import math
from pathlib import Path

from app.io.files import InputError, read_json, write_json
from core import state_directory

FILE_NAME = "viewer-settings.json"


def settings_path() -> Path:
    """Where the settings live (``$TRANSFINITE_STATE_DIR`` or ``~/.local/state/transfinite-warp``)."""
    return state_directory() / FILE_NAME


def read_settings(path: Path | None = None) -> dict:
    """The settings saved by the last viewer, ``{}`` if there are none or they cannot be read."""
    path = settings_path() if path is None else path
    try:
        value = read_json(path)
    except (InputError, OSError):
        return {}
    return value if isinstance(value, dict) else {}


def write_settings(changes: dict, path: Path | None = None) -> None:
    """Merge `changes` into the saved settings and write them atomically (OSError if it cannot)."""
    path = settings_path() if path is None else path
    path.parent.mkdir(parents=True, exist_ok=True)
    write_json(path, {**read_settings(path), **changes})


def window_rectangle(settings: dict) -> tuple[int, int, int, int] | None:
    """The saved window (x, y, width, height), screen pixels, or None if there is none or it is damaged."""
    value = settings.get("window")
    if not isinstance(value, dict):
        return None
    numbers = [value.get(name) for name in ("x", "y", "width", "height")]
    if not all(isinstance(number, (int, float)) and math.isfinite(number) for number in numbers):
        return None
    x, y, width, height = (int(round(number)) for number in numbers)
    return (x, y, width, height) if width > 0 and height > 0 else None
