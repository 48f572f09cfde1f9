"""The one loader for the GLSL sources in ``shaders/``.

Every GL program of the application is built from files loaded here by name, so
that shader code lives in ``.glsl`` files (syntax highlighting, one place to edit)
and each file is read once per process.  Where the folder is, in the source tree
or in an installed package, is `app.io.bundled`'s business.
"""

from __future__ import annotations

from functools import cache

from app.io.bundled import bundled_directory


@cache
def load_shader(name: str) -> str:
    """Return the source text of ``shaders/<name>``.

    Parameters
    ----------
    name : str
        File name relative to the ``shaders`` directory, e.g. ``"mesh.vert.glsl"``.

    Raises
    ------
    FileNotFoundError
        If there is no such file; the message lists the shaders that exist.
    """
    directory = bundled_directory("shaders")
    try:
        return (directory / name).read_text(encoding="utf-8")
    except FileNotFoundError:
        shaders = directory.iterdir() if directory.is_dir() else ()
        available = ", ".join(sorted(p.name for p in shaders if p.name.endswith(".glsl"))) or "none"
        raise FileNotFoundError(
            f"shader {name!r} not found in {directory} (available: {available})"
        ) from None
