"""Input checks shared by every public function of `core`.

One helper per kind of argument, each raising `ValueError` with a message that
names the argument and says what to change, so that the CLI and the viewer can
show it to a person as one line.
"""

from __future__ import annotations

import numpy as np

#: Most boundary samples N = samples_per_segment * n of one curve: N floats per array of
#: the solver's quadrature, and N operations per point.  A 10,000-point cage at the
#: default 100 per span fits.
MAX_BOUNDARY_SAMPLES = 1 << 20
#: Most control points of a curve: 2 boundary samples per span, the fewest, fill `MAX_BOUNDARY_SAMPLES`.
MAX_CONTROL_POINTS = MAX_BOUNDARY_SAMPLES // 2


def as_points(value, name: str, *, min_count: int = 0) -> np.ndarray:
    """Return `value` as a C-contiguous float64 array of shape (M, 2).

    Raises `ValueError` naming `name` if the value is not a list of (x, y) pairs,
    holds non-finite numbers, or has fewer than `min_count` rows.
    """
    try:
        array = np.array(value, dtype=np.float64)
    except (TypeError, ValueError, OverflowError) as error:
        raise ValueError(f"{name} must be a list of (x, y) number pairs ({error})") from None
    if array.ndim == 1 and array.shape[0] == 2 and min_count <= 1:
        array = array.reshape(1, 2)
    if array.ndim != 2 or array.shape[1] != 2:
        raise ValueError(f"{name} must have shape (M, 2), got shape {array.shape}")
    if array.shape[0] < min_count:
        raise ValueError(f"{name} needs at least {min_count} points, got {array.shape[0]}")
    bad = ~np.isfinite(array).all(axis=1)
    if bad.any():
        first = int(np.flatnonzero(bad)[0])
        raise ValueError(
            f"{name} has {int(bad.sum())} point(s) with NaN or infinite coordinates (first at index {first})"
        )
    return np.ascontiguousarray(array)


def as_parameters(value, name: str = "t") -> np.ndarray:
    """Return `value` as a finite float64 array of shape (m,)."""
    try:
        array = np.atleast_1d(np.asarray(value, dtype=np.float64))
    except (TypeError, ValueError) as error:
        raise ValueError(f"{name} must be numbers ({error})") from None
    if array.ndim != 1:
        raise ValueError(f"{name} must be a 1-D array of parameters, got shape {array.shape}")
    if not np.isfinite(array).all():
        raise ValueError(f"{name} has NaN or infinite values")
    return array


def positive_int(value, name: str, *, minimum: int = 1) -> int:
    """Return `value` as an int >= `minimum`, or raise `ValueError` naming `name`."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise ValueError(f"{name} must be an integer, got {value!r}")
    if value < minimum:
        raise ValueError(f"{name} must be at least {minimum}, got {value}")
    return int(value)


def checked_samples_per_segment(value, control_points: int) -> int:
    """Return `value` as an int in [2, MAX_BOUNDARY_SAMPLES // control_points], or raise `ValueError`."""
    per = positive_int(value, "samples_per_segment", minimum=2)
    most = MAX_BOUNDARY_SAMPLES // control_points
    if control_points > MAX_CONTROL_POINTS:
        raise ValueError(too_many_control_points(control_points))
    if per > most:
        raise ValueError(
            f"samples_per_segment={per} gives {per * control_points:,} boundary samples for "
            f"{control_points} control points, more than the {MAX_BOUNDARY_SAMPLES:,} allowed; "
            f"use 2 <= samples_per_segment <= {most}"
        )
    return per


def too_many_control_points(count: int) -> str:
    """The message for a curve of `count` > `MAX_CONTROL_POINTS` control points."""
    return (
        f"{count:,} control points need at least {2 * count:,} boundary samples, more than the "
        f"{MAX_BOUNDARY_SAMPLES:,} allowed; use at most {MAX_CONTROL_POINTS:,} control points"
    )


def positive_float(value, name: str) -> float:
    """Return `value` as a finite float > 0, or raise `ValueError` naming `name`."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number, got {value!r}") from None
    except OverflowError:  # an integer beyond float's range
        number = float("inf")
    if not np.isfinite(number) or number <= 0:
        raise ValueError(f"{name} must be a finite number > 0, got {_shown(value)}")
    return number


def _shown(value, limit: int = 60) -> str:
    """`repr` of `value`, shortened to a readable piece of a line."""
    text = repr(value)
    return text if len(text) <= limit else f"{text[: limit - 3]}..."
