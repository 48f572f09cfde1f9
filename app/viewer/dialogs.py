"""The file dialogs of the viewer: the desktop's own (zenity, kdialog, ... through imgui-bundle's
portable file dialogs), polled each frame so that the window keeps drawing meanwhile.  Without a
dialog program the window asks for the path itself (`AppState.status`'s prompts)."""

from __future__ import annotations

import shutil
from pathlib import Path

IMAGE_FILTERS = [
    "Images",
    "*.png *.jpg *.jpeg *.bmp *.tif *.tiff *.webp",
    "Sessions",
    "*.json",
    "All files",
    "*",
]
DIALOG_PROGRAMS = ("zenity", "kdialog", "matedialog", "qarma")


def have_dialogs() -> bool:
    """Whether a program that shows file dialogs is installed."""
    return any(shutil.which(program) for program in DIALOG_PROGRAMS)


class FileDialogs:
    """At most one open dialog and one save dialog, each running until `poll` finds it answered."""

    def __init__(self):
        self.opening = None
        self.saving = None

    @property
    def waiting(self) -> bool:
        """A dialog is shown: the loop polls it."""
        return self.opening is not None or self.saving is not None

    def ask_open(self, directory: Path) -> bool:
        """Show an open dialog in `directory`; False (nothing shown) without a dialog program."""
        if not have_dialogs():
            return False
        from imgui_bundle import portable_file_dialogs as pfd

        self.opening = pfd.open_file("Open an image", str(directory), IMAGE_FILTERS)
        return True

    def ask_save(self, proposed: Path) -> bool:
        """Show a save dialog proposing `proposed`; False (nothing shown) without a dialog program."""
        if not have_dialogs():
            return False
        from imgui_bundle import portable_file_dialogs as pfd

        self.saving = pfd.save_file("Export the warped image", str(proposed), ["PNG images", "*.png"])
        return True

    def poll(self) -> tuple[Path | None, Path | None]:
        """(file chosen to open, file chosen to export to), each None unless a dialog just closed on it."""
        opened = saved = None
        if self.opening is not None and self.opening.ready(0):
            paths = self.opening.result()
            self.opening = None
            opened = Path(paths[0]) if paths else None
        if self.saving is not None and self.saving.ready(0):
            path = self.saving.result()
            self.saving = None
            saved = Path(path) if path else None
        return opened, saved
