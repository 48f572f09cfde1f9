"""app.viewer.milestones: the test-mode lines, in the order the window tests read them."""

from pathlib import Path

import numpy as np

from app.viewer.milestones import Milestones
from app.viewer.state import AppState, Document, History, Snapshot
from core.curves import examples


def _state() -> AppState:
    star = examples.starfish(points_per_arm=2) * 100.0 + 240.0
    snapshot = Snapshot(Path("star.png"), star, star)
    return AppState(Document(History(snapshot), snapshot, np.zeros((480, 640, 4), np.uint8), Path("s.json")))


def _frame(milestones: Milestones, state: AppState, drawn: str | None) -> None:
    state.status.frame_ms.append(10.0)
    milestones.frame_done(state, 7, drawn)


def test_a_basis_is_said_drawn_once_after_the_frame_that_shows_it(capsys):
    milestones, state = Milestones(test_mode=True), _state()
    milestones.announce("basis key=a vertices=100 kernel=poisson preview=0")  # before the first frame
    _frame(milestones, state, None)  # the first frame: the cage alone
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == "ready window=7" and "basis key=a vertices=100 kernel=poisson preview=0" in lines
    assert not any(line.startswith("drawn basis") for line in lines)
    _frame(milestones, state, "a")
    assert "drawn basis key=a" in capsys.readouterr().out.splitlines()
    _frame(milestones, state, "a")  # the same basis again: nothing new
    _frame(milestones, state, None)
    assert not any(line.startswith("drawn basis") for line in capsys.readouterr().out.splitlines())
    _frame(milestones, state, "b")
    assert "drawn basis key=b" in capsys.readouterr().out.splitlines()


def test_a_basis_drawn_in_the_first_frame_is_said_after_ready_and_the_basis(capsys):
    milestones, state = Milestones(test_mode=True), _state()
    milestones.announce("basis key=a vertices=100 kernel=poisson preview=0")
    _frame(milestones, state, "a")
    lines = capsys.readouterr().out.splitlines()
    ready, basis = (
        lines.index("ready window=7"),
        lines.index("basis key=a vertices=100 kernel=poisson preview=0"),
    )
    assert ready < basis < lines.index("drawn basis key=a")


def test_outside_test_mode_nothing_is_said(capsys):
    milestones, state = Milestones(test_mode=False), _state()
    _frame(milestones, state, "a")
    assert capsys.readouterr().out == ""
