"""The one loader for the GLSL sources in ``shaders/``.

Every GL program of the application is built from files loaded here by name, so
that shader code lives in ``.glsl`` files (syntax highlighting, one place to edit)
and each file is read from disk once per process.
"""

from __future__ import annotations

from functools import cache
from pathlib import Path

SHADER_DIRECTORY = Path(__file__).resolve().parent.parent / "shaders"


@cache
def load_shader(name: str) -> str:
    """Return the source text of ``shaders/<name>``.

    Parameters
    ----------
    name : str
        File name relative to the ``shaders`` directory, e.g. ``"warp.vert.glsl"``.

    Raises
    ------
    FileNotFoundError
        If there is no such file; the message lists the shaders that exist.
    """
    path = SHADER_DIRECTORY / name
    try:
        return path.read_text(encoding="utf-8")
    except FileNotFoundError:
        available = ", ".join(sorted(p.name for p in SHADER_DIRECTORY.glob("*.glsl"))) or "none"
        raise FileNotFoundError(
            f"shader {name!r} not found in {SHADER_DIRECTORY} (available: {available})"
        ) from None
