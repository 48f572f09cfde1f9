"""What one step of the undo history changed, in a few words: the status line of Ctrl+Z and
Ctrl+Shift+Z says it ("undone: fill → inpaint", "redone: moved 3 control points")."""

from __future__ import annotations

import numpy as np

from app.viewer.state import Snapshot

#: The settings of a snapshot named by the words of the panel, each said as "name → value".
NAMED_SETTINGS = (
    ("kernel", "kernel"),
    ("power", "power k"),
    ("shift", "shift"),
    ("parameterization", "parameterization"),
    ("interpolation", "interpolation"),
    ("outside", "outside"),
    ("canvas", "canvas"),
    ("fill", "fill"),
    ("background", "background"),
)


def change_words(before: Snapshot, after: Snapshot) -> str:
    """What turned `before` into `after`, e.g. "fill → inpaint" or "moved 2 control points".

    Parameters
    ----------
    before, after : Snapshot
        Two neighbouring states of the history.

    Returns
    -------
    str
        The changes, joined by "; " ("an edit" when nothing tells them apart).
    """
    words = []
    if before.image != after.image:
        words.append(f"image → {after.image.name}")
    for field, name in NAMED_SETTINGS:
        value = getattr(after, field)
        if getattr(before, field) != value:
            words.append(f"{name} → {value:g}" if isinstance(value, float) else f"{name} → {value}")
    if before.fold_free != after.fold_free:
        words.append(f"fold-free {'on' if after.fold_free else 'off'}")
    if before.pins.bound != after.pins.bound:
        words.append(f"K → {'∞' if after.pins.bound is None else f'{after.pins.bound:g}'}")
    words += _pin_words(before, after)
    words += _points_words(before, after)
    if before.keyframes != after.keyframes:
        words.append(_keyframe_words(before, after))
    return "; ".join(words) or "an edit"


def _points_words(before: Snapshot, after: Snapshot) -> list[str]:
    """The cage and the target's changes: a new cage, points added or removed, points moved."""
    if before.n != after.n:
        return [f"cage of {before.n} → {after.n} control points"]
    words = []
    for points, name in ((after.cage, "cage"), (after.target, "target")):
        moved = int(np.any(points != getattr(before, name), axis=1).sum())
        if moved:
            words.append(f"moved {moved} {name} point{'s' * (moved != 1)}")
    return words


def _pin_words(before: Snapshot, after: Snapshot) -> list[str]:
    """Pins added, removed or moved."""
    old, new = before.pins.points, after.pins.points
    if len(old) != len(new):
        return [f"pins {len(old)} → {len(new)}"]
    moved = sum(a != b for a, b in zip(old, new, strict=True))
    return [f"moved {moved} pin{'s' * (moved != 1)}"] if moved else []


def _keyframe_words(before: Snapshot, after: Snapshot) -> str:
    """A keyframe added, deleted, moved in time or re-posed."""
    old = {k.time for k in before.keyframes}
    new = {k.time for k in after.keyframes}
    if len(new) > len(old):
        return f"keyframe added at {min(new - old):.2f} s"
    if len(new) < len(old):
        return f"keyframe deleted at {min(old - new):.2f} s"
    if old != new:
        return f"keyframe moved from {min(old - new):.2f} s to {min(new - old):.2f} s"
    return "keyframes changed"
