"""Where the files shipped with the program are: the GLSL shaders and the demo assets.

The repository keeps them in its top-level folders ``shaders/`` and ``assets/``.
A built wheel installs them as package data of `app`, in ``app/data/shaders`` and
``app/data/assets`` (``[tool.setuptools]`` in ``pyproject.toml`` maps them there),
and `bundled_directory` finds them through `importlib.resources`.  In the source
tree and in an editable install there is no ``app/data``: the top-level folders
themselves are used.
"""

from __future__ import annotations

from importlib.resources import files
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from importlib.resources.abc import Traversable

#: The bundled folders, by their name at the top of the repository.
FOLDERS = ("shaders", "assets")


def bundled_directory(folder: str) -> Traversable:
    """The installed ``app/data/<folder>``, or the repository's ``<folder>`` when not installed.

    Parameters
    ----------
    folder : str
        One of `FOLDERS`.

    Returns
    -------
    importlib.resources.abc.Traversable
        A `pathlib.Path` for a package on the file system (a wheel installed by pip,
        the source tree); read files through it with ``read_text``/``read_bytes``.
    """
    if folder not in FOLDERS:
        raise ValueError(f"unknown bundled folder {folder!r}; choose one of {', '.join(FOLDERS)}")
    installed = files("app") / "data" / folder
    if installed.is_dir():
        return installed
    return Path(__file__).resolve().parents[2] / folder  # app/io/bundled.py in the source tree
