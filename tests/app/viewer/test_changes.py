"""app.viewer.changes: what one history step changed, in the words the status line uses."""

from pathlib import Path

import numpy as np

from app.viewer.changes import change_words
from app.viewer.state import Snapshot
from app.warp.keyframes import Keyframe

SQUARE = np.array([[0.0, 0.0], [100.0, 0.0], [100.0, 100.0], [0.0, 100.0]])
BEFORE = Snapshot(Path("a.png"), SQUARE, SQUARE)


def test_each_setting_is_named_with_its_new_value():
    assert change_words(BEFORE, BEFORE.replace(fill="inpaint")) == "fill → inpaint"
    assert change_words(BEFORE, BEFORE.replace(kernel="power", power=2.5)) == "kernel → power; power k → 2.5"
    assert change_words(BEFORE, BEFORE.replace(outside="original", canvas="grow")) == (
        "outside → original; canvas → grow"
    )
    assert change_words(BEFORE, BEFORE.replace(fold_free=True)) == "fold-free on"
    assert change_words(BEFORE.replace(fold_free=True), BEFORE) == "fold-free off"
    assert change_words(BEFORE, BEFORE.replace(background="#ff0000")) == "background → #ff0000"
    assert change_words(BEFORE, BEFORE.replace(interpolation="linear")) == "interpolation → linear"


def test_points_and_keyframes_are_counted():
    target = SQUARE.copy()
    target[1:3] += 5.0
    assert change_words(BEFORE, BEFORE.replace(target=target)) == "moved 2 target points"
    assert change_words(BEFORE, BEFORE.replace(cage=target, target=target)) == (
        "moved 2 cage points; moved 2 target points"
    )
    five = np.vstack([SQUARE, [[50.0, 120.0]]])
    assert change_words(BEFORE, BEFORE.replace(cage=five, target=five)) == "cage of 4 → 5 control points"
    keyed = BEFORE.replace(keyframes=(Keyframe(0.5, SQUARE),))
    assert change_words(BEFORE, keyed) == "keyframe added at 0.50 s"
    assert change_words(keyed, BEFORE) == "keyframe deleted at 0.50 s"
    moved = BEFORE.replace(keyframes=(Keyframe(1.0, SQUARE),))
    assert change_words(keyed, moved) == "keyframe moved from 0.50 s to 1.00 s"
    assert change_words(BEFORE, BEFORE) == "an edit"
