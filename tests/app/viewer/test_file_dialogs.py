"""app.viewer.file_dialogs: a dialog where one can open, the typed-path field otherwise."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from app.viewer.file_dialogs import CAGE_FILTERS, EXPORT_FILTERS, SESSION_FILTERS, FileRequests, NativeDialogs
from app.viewer.state import AppState, History, Snapshot

SQUARE = np.array([[0.0, 0.0], [100.0, 0.0], [100.0, 100.0], [0.0, 100.0]])


class StandInDialog:
    """A dialog that the user answers with `answer` after `frames` looks at it."""

    def __init__(self, answer, frames: int = 2):
        self.answer, self.frames = answer, frames

    def ready(self, timeout: int = 0) -> bool:
        self.frames -= 1
        return self.frames < 0

    def result(self):
        return self.answer


class StandInBackend:
    """A dialog backend that records what was asked and answers `answer`."""

    def __init__(self, available: bool, answer):
        self.is_available, self.answer, self.asked = available, answer, []

    def available(self) -> bool:
        return self.is_available

    def open_file(self, title, directory, filters):
        self.asked.append(("open", title, directory, filters))
        return StandInDialog([self.answer] if self.answer else [])

    def save_file(self, title, path, filters):
        self.asked.append(("save", title, path, filters))
        return StandInDialog(self.answer)


@pytest.fixture
def state():
    snapshot = Snapshot(Path("/pictures/square.png"), SQUARE, SQUARE)
    return AppState.opened(History(snapshot), np.zeros((120, 120, 4), np.uint8), Path("/state/s/square.json"))


def answered(requests: FileRequests) -> list:
    """Poll as the window does once a frame until the dialog is answered (or 10 frames)."""
    for _ in range(10):
        commands = requests.poll()
        if commands or not requests.waiting:
            return commands
    raise AssertionError("the dialog never answered")


@pytest.mark.parametrize(("what", "folder"), [("image", "/pictures"), ("session", "/state/s")])
def test_open_uses_the_dialog_when_one_exists(state, what, folder):
    backend = StandInBackend(True, "/pictures/other.png")
    requests = FileRequests(backend)
    requests.ask_open(state, what, Path(folder))
    assert requests.waiting and requests.poll() == []  # not answered yet: the loop goes on
    assert answered(requests) == [("open_path", "/pictures/other.png")]
    assert state.status.open_prompt is None and not requests.waiting
    ((kind, title, directory, filters),) = backend.asked
    assert kind == "open" and directory == folder and title.lower().endswith(what)
    assert (filters == SESSION_FILTERS) == (what == "session")


def test_export_uses_the_dialog_when_one_exists(state):
    backend = StandInBackend(True, "/out/warped.gif")
    requests = FileRequests(backend)
    requests.ask_export(state, Path("/pictures/square-warped.png"))
    requests.ask_export(state, Path("/elsewhere.png"))  # one dialog at a time: ignored
    assert answered(requests) == [("export_path", "/out/warped.gif")]
    assert backend.asked == [("save", "Export", "/pictures/square-warped.png", EXPORT_FILTERS)]
    assert state.status.export_prompt is None


def test_a_cancelled_dialog_does_nothing(state):
    requests = FileRequests(StandInBackend(True, ""))
    requests.ask_open(state, "image", Path("/pictures"))
    assert answered(requests) == []
    requests.ask_export(state, "/pictures/x.png")
    assert answered(requests) == []


def test_without_a_dialog_the_path_is_typed_in_the_window(state):
    backend = StandInBackend(False, "/never.png")
    requests = FileRequests(backend)
    requests.ask_open(state, "image", Path("/pictures"))
    assert state.status.open_prompt == "/pictures" + os.sep and not requests.waiting
    requests.ask_export(state, Path("/pictures/square-warped.png"))
    assert state.status.export_prompt == "/pictures/square-warped.png"
    assert requests.poll() == [] and backend.asked == []


def test_native_dialogs_need_a_dialog_program_and_a_display(tmp_path, monkeypatch):
    monkeypatch.setattr("app.viewer.file_dialogs.sys.platform", "linux")  # Windows and macOS always have one
    monkeypatch.setenv("PATH", str(tmp_path))
    monkeypatch.setenv("DISPLAY", ":0")
    assert not NativeDialogs().available()
    program = tmp_path / "zenity"
    program.write_text("#!/bin/sh\n")
    program.chmod(0o755)
    assert NativeDialogs().available()
    monkeypatch.delenv("DISPLAY")
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    assert not NativeDialogs().available()


def test_saving_a_cage_asks_a_dialog_and_answers_with_the_save_command():
    backend = StandInBackend(available=True, answer="/tmp/mine.svg")
    requests = FileRequests(backend)
    assert requests.ask_save("save_target", "Save the target", Path("/state/s/square.target.svg"))
    assert backend.asked == [("save", "Save the target", "/state/s/square.target.svg", CAGE_FILTERS)]
    assert answered(requests) == [("save_target", "/tmp/mine.svg")]


def test_saving_a_cage_without_a_dialog_program_asks_nothing():
    backend = StandInBackend(available=False, answer="/tmp/mine.svg")
    assert not FileRequests(backend).ask_save("save_cage", "Save the cage", Path("/x.cage.svg"))
    assert backend.asked == []
