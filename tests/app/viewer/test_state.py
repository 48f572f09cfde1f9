"""Snapshots and the undo history of the viewer (app.viewer.state)."""

from pathlib import Path

import numpy as np
import pytest

from app.viewer.state import History, Snapshot


def snapshot(offset=0.0, **changes):
    points = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]]) + offset
    return Snapshot(Path("image.png"), points, points, **changes)


def test_snapshots_are_immutable_and_compare_by_value():
    a = snapshot()
    with pytest.raises(ValueError):
        a.cage[0, 0] = 5.0
    assert a == snapshot() and a != snapshot(1.0) and a != snapshot(kernel="mean-value")
    b = a.replace(target=a.target + 1)
    assert np.array_equal(b.cage, a.cage) and not np.array_equal(b.target, a.target)
    assert a.kernel_params() == {}
    assert snapshot(kernel="power", power=3, shift="none").kernel_params() == {"power": 3.0, "shift": "none"}


def test_snapshot_validation():
    with pytest.raises(ValueError, match="target has 3 control points but cage has 4"):
        Snapshot(Path("x.png"), np.zeros((4, 2)), np.zeros((3, 2)))
    with pytest.raises(ValueError, match="NaN"):
        Snapshot(Path("x.png"), np.full((4, 2), np.nan), np.zeros((4, 2)))
    with pytest.raises(ValueError, match="shift must be one of"):
        snapshot(shift="sideways")


def test_history_undo_redo():
    history = History(snapshot(0))
    assert not history.can_undo and history.undo() is None and history.redo() is None
    assert history.push(snapshot(1)) and history.push(snapshot(2))
    assert not history.push(snapshot(2))  # no change, no step
    assert history.undo() == snapshot(1)
    assert history.undo() == snapshot(0)
    assert history.undo() is None
    assert history.redo() == snapshot(1)
    history.push(snapshot(5))  # a new edit drops the redo steps
    assert not history.can_redo and history.current == snapshot(5)
    assert history.undo() == snapshot(1)


def test_history_limit():
    history = History(snapshot(0), limit=3)
    for offset in range(1, 10):
        history.push(snapshot(offset))
    steps = 0
    while history.undo() is not None:
        steps += 1
    assert steps == 3 and history.current == snapshot(6)
