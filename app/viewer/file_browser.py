"""The viewer's own file list, where no desktop file dialog can open.

`app.viewer.file_dialogs` opens the desktop's dialog through zenity, kdialog, matedialog or
qarma; a machine without any of them (a server, a minimal install) gets the typed-path field of
`app.viewer.gui` with this list under it: the folders and the files that can be opened in the
folder of the path typed so far.  A click on a folder goes into it, a click on a file puts its
path in the field, a double click opens it.  imgui-bundle's ImFileDialog is not used: it needs
the texture callbacks of imgui-bundle's own runner (hello_imgui), which a glfw loop of our own
with the Python renderer does not provide.  Nothing here draws (no imgui), so it is tested
without a window.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

#: The files the Open field lists: images, sessions and cages.
OPEN_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".webp", ".json", ".svg")
#: The files the Export field lists: what an export writes (an image or an animation).
EXPORT_SUFFIXES = (".png", ".tif", ".tiff", ".jpg", ".jpeg", ".webp", ".gif", ".mp4")
#: Most entries listed: a folder of more (a camera's dump) shows the first ones and says so.
MAX_ENTRIES = 2000


@dataclass(frozen=True)
class Entry:
    """One line of the list: a folder (its name ends in the separator) or a file."""

    name: str
    path: Path
    folder: bool


@dataclass(frozen=True)
class Listing:
    """The folder of a typed path and what it holds.

    Attributes
    ----------
    folder : Path
    entries : tuple of Entry
        ``..`` (unless at the root), the subfolders, then the files with one of the suffixes
        asked for, each group by name; hidden ones (a leading dot) left out.
    note : str
        Why the list is short or empty ("cannot read it: ...", "the first 2000 of 5000"), or "".
    """

    folder: Path
    entries: tuple[Entry, ...]
    note: str = ""


def folder_of(typed: str) -> Path:
    """The folder a typed path points into: itself if it names a folder (or ends in a separator),
    else its parent; the nearest folder that exists, the home folder for an empty field."""
    path = Path(os.path.expanduser(typed.strip() or "~"))
    folder = path if typed.endswith(os.sep) or path.is_dir() else path.parent
    while not folder.is_dir() and folder != folder.parent:
        folder = folder.parent
    return folder.resolve()


def listing(typed: str, suffixes: tuple[str, ...]) -> Listing:
    """What the list under the field shows for the path `typed` so far.

    Parameters
    ----------
    typed : str
        The field's text.
    suffixes : tuple of str
        The file name extensions listed (lower case, with the dot).

    Returns
    -------
    Listing
    """
    folder = folder_of(typed)
    parent = () if folder == folder.parent else (Entry("..", folder.parent, True),)
    try:
        with os.scandir(folder) as scanned:
            found = [entry for entry in scanned if not entry.name.startswith(".")]
    except OSError as error:
        return Listing(folder, parent, f"cannot read it: {error.strerror or error}")
    folders, files = [], []
    for entry in found:
        try:
            is_folder = entry.is_dir()
        except OSError:
            continue
        if is_folder:
            folders.append(Entry(entry.name + os.sep, Path(entry.path), True))
        elif Path(entry.name).suffix.lower() in suffixes:
            files.append(Entry(entry.name, Path(entry.path), False))
    entries = sorted(folders, key=lambda e: e.name.lower()) + sorted(files, key=lambda e: e.name.lower())
    note = f"the first {MAX_ENTRIES} of {len(entries)}" if len(entries) > MAX_ENTRIES else ""
    return Listing(folder, parent + tuple(entries[:MAX_ENTRIES]), note)


def chosen(entry: Entry) -> str:
    """The field's text once `entry` is clicked: a folder's path with a separator (the list then
    shows its content), or a file's path."""
    return str(entry.path.resolve()) + os.sep if entry.folder else str(entry.path)


_last: list = []  # [(key, listing)]: the folder listed for the last frame, read again when it changes


def current_listing(typed: str, suffixes: tuple[str, ...]) -> Listing:
    """`listing`, read again only when the folder or its modification time changed: the field is
    drawn every frame, and a folder of thousands of files takes milliseconds to read."""
    folder = folder_of(typed)
    try:
        stamp = folder.stat().st_mtime_ns
    except OSError:
        stamp = None
    key = (folder, suffixes, stamp)
    if not _last or _last[0][0] != key:
        _last[:] = [(key, listing(str(folder) + os.sep, suffixes))]
    return _last[0][1]
