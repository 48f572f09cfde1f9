"""app.viewer.commands: every change of the document, a setting of the panel as much as an edit,
is one undo step, and the status line says what Ctrl+Z and Ctrl+Shift+Z did."""

from pathlib import Path

import numpy as np
import pytest

from app.viewer import commands
from app.viewer.state import AppState, Document, History, Snapshot

SQUARE = np.array([[0.0, 0.0], [100.0, 0.0], [100.0, 100.0], [0.0, 100.0]])


@pytest.fixture
def state():
    snapshot = Snapshot(Path("a.png"), SQUARE, SQUARE)
    return AppState(Document(History(snapshot), snapshot, np.zeros((120, 120, 4), np.uint8), Path("s.json")))


@pytest.mark.parametrize(
    "name, value, words",
    [
        ("outside", "original", "outside → original"),
        ("fill", "inpaint", "fill → inpaint"),
        ("canvas", "grow", "canvas → grow"),
        ("background", "#00ff00", "background → #00ff00"),
        ("kernel", "mean-value", "kernel → mean-value"),
        ("parameterization", "arc-length", "parameterization → arc-length"),
        ("interpolation", "linear", "interpolation → linear"),
        ("fold_free", True, "fold-free on"),
    ],
)
def test_each_setting_is_one_undo_step_that_speaks(state, name, value, words):
    before = state.document.live
    commands.command(state, name, value)
    assert state.document.history.can_undo and state.document.session_dirty
    commands.command(state, "undo")
    assert state.document.live == before and state.status_message() == f"undone: {words}"
    commands.command(state, "redo")
    assert state.document.live != before and state.status_message() == f"redone: {words}"


def test_power_and_shift_are_undo_steps_too(state):
    commands.command(state, "kernel", "power")
    commands.command(state, "power", 2.5)
    commands.command(state, "shift", "none")
    commands.command(state, "undo")
    assert state.status_message() == "undone: shift → none"
    commands.command(state, "undo")
    assert state.status_message() == "undone: power k → 2.5" and state.document.live.kernel == "power"


def test_a_drag_fold_free_and_a_fill_come_back_in_turn(state):
    """The issue's sequence: a drag, B, a fill change; Ctrl+Z three times undoes all three."""
    target = SQUARE.copy()
    target[2] += [20.0, 10.0]
    commands.commit(state, state.document.live.replace(target=target), "moved 1 control point")
    commands.command(state, "fold_free")
    commands.command(state, "fill", "inpaint")
    said = []
    for _ in range(3):
        commands.command(state, "undo")
        said.append(state.status_message())
    assert said == ["undone: fill → inpaint", "undone: fold-free on", "undone: moved 1 target point"]
    assert state.document.live == Snapshot(Path("a.png"), SQUARE, SQUARE)
    commands.command(state, "undo")
    assert state.status_message() == "nothing to undo"


def test_a_bad_setting_changes_nothing(state):
    commands.command(state, "fill", "chartreuse")
    commands.command(state, "background", "mauve")
    assert state.status.message_is_error and not state.document.history.can_undo


class NoDialogs:
    """A viewer's dialogs where no dialog program is installed."""

    def ask_save(self, command, title, proposed) -> bool:
        return False


class StandInViewer:
    """What the window's Save cage and Save target commands ask of the viewer."""

    def __init__(self, state):
        self.state, self.dialogs = state, NoDialogs()


@pytest.mark.parametrize("which", ["cage", "target"])
def test_save_without_a_dialog_program_asks_in_the_window_then_writes(tmp_path, which):
    snapshot = Snapshot(Path("a.png"), SQUARE, SQUARE + 1.5)
    state = AppState(
        Document(History(snapshot), snapshot, np.zeros((120, 160, 4), np.uint8), tmp_path / "s.json")
    )
    viewer = StandInViewer(state)
    commands.COMMANDS[f"save_{which}"].run(viewer, None)
    assert getattr(state.status, f"{which}_prompt") == str(tmp_path / f"s.{which}.svg")
    assert not (tmp_path / f"s.{which}.svg").exists()  # nothing written before the user says where
    commands.command(state, "cancel")
    assert getattr(state.status, f"{which}_prompt") is None
    commands.COMMANDS[f"save_{which}"].run(viewer, str(tmp_path / "mine.svg"))
    assert state.status_message() == f"saved the {which} to {tmp_path / 'mine.svg'}"
    assert 'width="160" height="120"' in (tmp_path / "mine.svg").read_text()
