"""Keyframed animation of the target cage: keyframes, their interpolation in time, frame times.

A keyframe is a time in seconds and a whole target cage (n control points, the
source cage's count).  Between keyframes every target control point follows a
curve in time of its own:

- ``"catmull-rom"`` (the default): a cubic Hermite curve through the keyframes
  whose velocity at an inner keyframe k is the Catmull-Rom tangent for uneven
  times, m_k = (P_{k+1} - P_{k-1}) / (t_{k+1} - t_{k-1}), and zero at the first
  and the last keyframe (the motion starts and stops smoothly); it is C1 in time;
- ``"linear"``: straight lines at constant speed, C0 in time.

Because the basis functions G are computed once for the source cage, a frame at
any time costs one product ``G @ interpolate(...)`` (V x n by n x 2).  Nothing
here knows about files, windows or GL.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

INTERPOLATIONS = ("catmull-rom", "linear")
DEFAULT_INTERPOLATION = "catmull-rom"
#: Two keyframes closer in time than this (seconds) are the same keyframe.
TIME_RESOLUTION = 1e-6
#: Longest animation (seconds), and most frames an export writes.
MAX_TIME = 24 * 3600.0
MAX_FRAMES = 100_000
#: Frame rates of an export: a GIF frame lasts at most 655.35 s (a 16-bit count of 1/100 s).
MIN_FPS = 0.01
MAX_FPS = 1000.0


@dataclass(frozen=True, eq=False)
class Keyframe:
    """One keyframe, never modified in place.

    Attributes
    ----------
    time : float
        Seconds, in [0, `MAX_TIME`].
    target : ndarray of shape (n, 2), float64, read-only
        Target control points, image pixels (x right, y down, origin top-left).
    """

    time: float
    target: np.ndarray

    def __post_init__(self):
        time = float(self.time)
        if not 0.0 <= time <= MAX_TIME:  # also refuses NaN
            raise ValueError(f"keyframe time must be within 0..{MAX_TIME:g} seconds, got {self.time!r}")
        target = np.array(self.target, dtype=np.float64).reshape(-1, 2)
        if not np.isfinite(target).all():
            raise ValueError("keyframe target contains NaN or infinite values")
        target.setflags(write=False)
        object.__setattr__(self, "time", time)
        object.__setattr__(self, "target", target)

    def __eq__(self, other) -> bool:
        if not isinstance(other, Keyframe):
            return NotImplemented
        return self.time == other.time and np.array_equal(self.target, other.target)

    __hash__ = None


def sorted_keyframes(keyframes, count: int | None = None) -> tuple[Keyframe, ...]:
    """The keyframes sorted by time, checked: distinct times, and (with `count`) n = `count` points each.

    Raises
    ------
    ValueError
        Two keyframes at the same time (within `TIME_RESOLUTION`), or a target
        of another number of control points.
    """
    result = tuple(sorted(keyframes, key=lambda keyframe: keyframe.time))
    for index, keyframe in enumerate(result):
        if count is not None and len(keyframe.target) != count:
            raise ValueError(
                f"the keyframe at {keyframe.time:g} s has {len(keyframe.target)} control points, "
                f"the cage has {count}"
            )
        if index and keyframe.time - result[index - 1].time < TIME_RESOLUTION:
            raise ValueError(f"two keyframes at {keyframe.time:g} s")
    return result


def interpolate(
    keyframes: tuple[Keyframe, ...], time: float, method: str = DEFAULT_INTERPOLATION
) -> np.ndarray:
    """The target control points at `time`, ndarray of shape (n, 2).

    Parameters
    ----------
    keyframes : tuple of Keyframe
        At least one, sorted by time (`sorted_keyframes`).
    time : float
        Seconds; before the first keyframe it is the first's target, after the
        last the last's.
    method : {"catmull-rom", "linear"}
    """
    if method not in INTERPOLATIONS:
        raise ValueError(f"interpolation must be one of {', '.join(INTERPOLATIONS)}, got {method!r}")
    if not keyframes:
        raise ValueError("no keyframes to interpolate")
    times = np.array([keyframe.time for keyframe in keyframes])
    if time <= times[0]:
        return np.array(keyframes[0].target)
    if time >= times[-1]:
        return np.array(keyframes[-1].target)
    k = int(np.searchsorted(times, time, side="right")) - 1  # times[k] <= time < times[k + 1]
    start, end = keyframes[k].target, keyframes[k + 1].target
    span = times[k + 1] - times[k]
    s = (time - times[k]) / span
    if method == "linear":
        return (1.0 - s) * start + s * end
    tangent_start = _tangent(keyframes, times, k) * span  # d/ds = span * d/dt
    tangent_end = _tangent(keyframes, times, k + 1) * span
    s2, s3 = s * s, s * s * s
    return (
        (2 * s3 - 3 * s2 + 1) * start
        + (s3 - 2 * s2 + s) * tangent_start
        + (-2 * s3 + 3 * s2) * end
        + (s3 - s2) * tangent_end
    )


def _tangent(keyframes: tuple[Keyframe, ...], times: np.ndarray, k: int) -> np.ndarray:
    """Velocity (n, 2), pixels per second, at keyframe k: Catmull-Rom inside, zero at the ends."""
    if k == 0 or k == len(keyframes) - 1:
        return np.zeros_like(keyframes[k].target)
    return (keyframes[k + 1].target - keyframes[k - 1].target) / (times[k + 1] - times[k - 1])


def frame_times(keyframes: tuple[Keyframe, ...], fps: float) -> np.ndarray:
    """Times of the frames of an export, ndarray of shape (F,), seconds.

    Frame k is at t_first + k / fps, from the first keyframe to the last, both
    included: when the length is not a whole number of frames, the last frame is
    the last keyframe, a shorter step after the one before.

    Raises
    ------
    ValueError
        No keyframes, `fps` not a finite number > 0, or more than `MAX_FRAMES` frames.
    """
    if not keyframes:
        raise ValueError("no keyframes")
    if not (math.isfinite(fps) and fps > 0):
        raise ValueError(f"fps must be a finite number > 0, got {fps!r}")
    first, last = keyframes[0].time, keyframes[-1].time
    steps = math.ceil((last - first) * fps - 1e-9)
    if steps + 1 > MAX_FRAMES:
        raise ValueError(
            f"{steps + 1} frames ({last - first:g} s at {fps:g} fps); at most {MAX_FRAMES} can be written"
        )
    times = first + np.arange(steps + 1) / fps
    times[-1] = last
    return times


def keyframes_json(keyframes: tuple[Keyframe, ...]) -> list[dict]:
    """The session file's ``keyframes`` list: ``[{"time": s, "target": {"control_points": [...]}}]``."""
    return [
        {"time": keyframe.time, "target": {"control_points": keyframe.target.tolist()}}
        for keyframe in keyframes
    ]
