"""Asking for a file: the desktop's own dialog where one can open, a path typed in the window otherwise.

Open image (Ctrl+O), Open session (Ctrl+Shift+O) and Export (Ctrl+E) ask through a
`DialogBackend`: `NativeDialogs` is imgui-bundle's portable-file-dialogs, which on Linux
runs zenity, kdialog, matedialog or qarma (none installed, or no display for them: no
dialog), and the native dialogs on Windows and macOS.  Where no dialog can open, the
typed-path field of `app.viewer.gui` asks instead (``AppState.status.open_prompt`` and
``export_prompt``).  A dialog runs beside the window's loop: `FileRequests.poll` is
called every frame and hands back what was chosen as the window's commands.
"""

from __future__ import annotations

import os
import shutil
import sys
from pathlib import Path
from typing import Protocol

from app.viewer.state import AppState

#: The programs portable-file-dialogs runs on Linux and the BSDs.
DIALOG_PROGRAMS = ("zenity", "kdialog", "matedialog", "qarma")
IMAGE_FILTERS = [
    "Images",
    "*.png *.jpg *.jpeg *.bmp *.tif *.tiff *.webp",
    "Sessions and cages",
    "*.json *.svg",
    "All files",
    "*",
]
SESSION_FILTERS = ["Sessions", "*.json", "All files", "*"]
EXPORT_FILTERS = ["PNG image", "*.png", "Animation", "*.gif *.mp4", "All files", "*"]
CAGE_FILTERS = ["SVG path", "*.svg", "Cage JSON", "*.json", "All files", "*"]


class PendingDialog(Protocol):
    """A dialog on screen: ``ready()`` once the user chose or cancelled, then ``result()``, the path
    chosen (str), or "" or an empty list when cancelled (a list of paths for an open dialog)."""

    def ready(self, timeout: int = ...) -> bool: ...

    def result(self): ...


class DialogBackend(Protocol):
    """What opens dialogs: `NativeDialogs`, or a stand-in in tests."""

    def available(self) -> bool: ...

    def open_file(self, title: str, directory: str, filters: list[str]) -> PendingDialog: ...

    def save_file(self, title: str, path: str, filters: list[str]) -> PendingDialog: ...


class NativeDialogs:
    """imgui-bundle's portable-file-dialogs."""

    def available(self) -> bool:
        """Whether a dialog can open: always on Windows and macOS, with a dialog program and a
        display elsewhere."""
        if sys.platform in ("win32", "darwin"):
            return True
        has_display = bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))
        return has_display and any(shutil.which(program) for program in DIALOG_PROGRAMS)

    def open_file(self, title: str, directory: str, filters: list[str]) -> PendingDialog:
        from imgui_bundle import portable_file_dialogs as pfd

        return pfd.open_file(title, directory, filters)

    def save_file(self, title: str, path: str, filters: list[str]) -> PendingDialog:
        from imgui_bundle import portable_file_dialogs as pfd

        return pfd.save_file(title, path, filters)


class FileRequests:
    """The file dialogs of one viewer: at most one open at a time.

    Parameters
    ----------
    backend : DialogBackend, optional
        `NativeDialogs` by default.
    """

    def __init__(self, backend: DialogBackend | None = None):
        self.backend = backend if backend is not None else NativeDialogs()
        self._pending: tuple[str, PendingDialog] | None = None  # (command for the answer, dialog)

    @property
    def waiting(self) -> bool:
        """Whether a dialog is on screen (the loop then wakes often to see its answer)."""
        return self._pending is not None

    def ask_open(self, state: AppState, what: str, folder: Path) -> None:
        """Ask for an image (`what` "image") or a session ("session") to open, starting in `folder`."""
        title, filters = {
            "image": ("Open an image", IMAGE_FILTERS),
            "session": ("Open a session", SESSION_FILTERS),
        }[what]
        if self._pending is not None:
            return
        if not self.backend.available():
            state.status.open_prompt = str(folder) + os.sep
            return
        self._pending = ("open_path", self.backend.open_file(title, str(folder), filters))

    def ask_export(self, state: AppState, proposed: Path | str) -> None:
        """Ask where to export, proposing `proposed`."""
        if self._pending is not None:
            return
        if not self.backend.available():
            state.status.export_prompt = str(proposed)
            return
        self._pending = ("export_path", self.backend.save_file("Export", str(proposed), EXPORT_FILTERS))

    def ask_save(self, command: str, title: str, proposed: Path) -> bool:
        """Ask where to save a cage, proposing `proposed`; the answer comes back from `poll` as
        ``(command, path)``.  False when no dialog can open (nothing asked)."""
        if self._pending is not None:
            return True
        if not self.backend.available():
            return False
        self._pending = (command, self.backend.save_file(title, str(proposed), CAGE_FILTERS))
        return True

    def poll(self) -> list[tuple[str, str]]:
        """The window's commands for a dialog answered since the last call: ``[("open_path", path)]``
        or ``[("export_path", path)]``; none while it is open or when it was cancelled."""
        if self._pending is None or not self._pending[1].ready(0):
            return []
        command, dialog = self._pending
        self._pending = None
        answer = dialog.result()
        path = answer[0] if isinstance(answer, (list, tuple)) and answer else answer
        return [(command, path)] if isinstance(path, str) and path else []
