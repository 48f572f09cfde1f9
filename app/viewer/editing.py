"""Pure geometry of the viewer's edits: picking handles, inserting, deleting, subdividing, zooming.

No GL and no window here, so that every rule is unit-tested without a display.
Points are ndarrays of shape (n, 2) in image pixels (x right, y down, origin at
the image's top-left corner); window positions are window pixels from the
window's top-left corner; a `View` maps the first to the second.

The cage is a closed uniform quadratic B-spline (Sec. 4.1): array row j is the
paper's P_{j+1}, span j (t in [j, j + 1)) runs from the midpoint of rows j - 1
and j to the midpoint of rows j and j + 1 and bulges towards row j.
"""

from __future__ import annotations

import math
from functools import cache

import numpy as np

from app.render.viewport import View
from core import basis_weights

#: Window pixels within which a click grabs a handle.
PICK_RADIUS = 10.0
#: The viewer aims at this many mesh vertices: a precompute of a second or two, and drag frames
#: within 16.7 ms on a 2-core software rasteriser (llvmpipe) at 1280 x 1024; --max-edge for more.
TARGET_VERTICES = 6_000
#: Overlay samples per B-spline span.
SAMPLES_PER_SPAN = 16


def to_window(view: View, points: np.ndarray) -> np.ndarray:
    """Image points (m, 2) -> window pixels (m, 2)."""
    return np.asarray(view.offset, dtype=np.float64) + view.scale * np.asarray(points, dtype=np.float64)


def to_image(view: View, pixels) -> np.ndarray:
    """Window pixels (..., 2) -> image points (..., 2)."""
    return (np.asarray(pixels, dtype=np.float64) - np.asarray(view.offset, dtype=np.float64)) / view.scale


def nearest_handle(handles: np.ndarray, cursor, radius: float = PICK_RADIUS) -> int | None:
    """Index of the handle nearest to `cursor` if it lies within `radius`, else None.

    Parameters
    ----------
    handles : ndarray of shape (n, 2)
        Handle positions, window pixels.
    cursor : array_like of shape (2,)
        Window pixels.
    radius : float
        Pick radius, window pixels.

    Notes
    -----
    Among handles at the same distance (a doubled corner point) the last one wins,
    the one drawn on top.
    """
    handles = np.asarray(handles, dtype=np.float64).reshape(-1, 2)
    if len(handles) == 0:
        return None
    distances = np.hypot(*(handles - np.asarray(cursor, dtype=np.float64)).T)
    index = len(distances) - 1 - int(np.argmin(distances[::-1]))
    return index if distances[index] <= radius else None


@cache
def curve_matrix(count: int, samples_per_span: int = SAMPLES_PER_SPAN) -> np.ndarray:
    """Folded B-spline basis at ``samples_per_span`` parameters per span, shape (m, n), read-only.

    ``curve_matrix(n) @ control_points`` samples the closed curve, even a
    self-intersecting one (no validation: the overlay must draw what the user made).
    """
    t = np.arange(count * samples_per_span) / samples_per_span
    index, weights = basis_weights(t, count)
    matrix = np.zeros((len(t), count))
    np.add.at(matrix, (np.repeat(np.arange(len(t)), 3), index.ravel()), weights.ravel())
    matrix.setflags(write=False)
    return matrix


def curve_points(control_points: np.ndarray, samples_per_span: int = SAMPLES_PER_SPAN) -> np.ndarray:
    """Samples of the closed quadratic B-spline of `control_points` (n >= 3), shape (n * samples, 2)."""
    control_points = np.asarray(control_points, dtype=np.float64)
    return curve_matrix(len(control_points), samples_per_span) @ control_points


def insertion_span(control_points: np.ndarray, position) -> tuple[int, int]:
    """The control polygon edge (a, a + 1 mod n) where a point clicked at `position` belongs.

    With n >= 3 it is the edge whose part of the curve passes nearest to the
    click: the curve touches edge (j, j + 1) at its midpoint and runs there from
    the middle of span j to the middle of span j + 1.  With fewer points it is the
    closing edge (append at the end).
    """
    control_points = np.asarray(control_points, dtype=np.float64).reshape(-1, 2)
    count = len(control_points)
    if count < 3:
        return max(count - 1, 0), 0
    samples = curve_points(control_points)
    nearest = int(np.argmin(np.hypot(*(samples - np.asarray(position, dtype=np.float64)).T)))
    t = nearest / SAMPLES_PER_SPAN
    span = int(t) % count
    first = span if t - int(t) >= 0.5 else (span - 1) % count
    return first, (first + 1) % count


def insert_point(cage: np.ndarray, target: np.ndarray, position) -> tuple[np.ndarray, np.ndarray, int]:
    """Insert a source control point at `position` on the nearest span, and its target.

    The target gets the new point displaced like its two neighbours on average,
    so inserting into a deformed cage does not tear the target curve.

    Returns
    -------
    cage, target : ndarray of shape (n + 1, 2)
    index : int
        Row of the new point.
    """
    cage = np.asarray(cage, dtype=np.float64).reshape(-1, 2)
    target = np.asarray(target, dtype=np.float64).reshape(-1, 2)
    position = np.asarray(position, dtype=np.float64).reshape(2)
    if len(cage) < 3:
        offset = np.zeros(2) if len(cage) == 0 else (target - cage).mean(axis=0)
        return np.vstack([cage, position]), np.vstack([target, position + offset]), len(cage)
    first, second = insertion_span(cage, position)
    displacement = 0.5 * ((target[first] - cage[first]) + (target[second] - cage[second]))
    index = first + 1
    return (
        np.insert(cage, index, position, axis=0),
        np.insert(target, index, position + displacement, axis=0),
        index,
    )


def delete_point(cage: np.ndarray, target: np.ndarray, index: int) -> tuple[np.ndarray, np.ndarray]:
    """Remove control point `index` from the cage and the target.

    Raises
    ------
    ValueError
        If the cage would keep fewer than 3 points, or `index` is out of range.
    """
    cage = np.asarray(cage, dtype=np.float64).reshape(-1, 2)
    if not 0 <= index < len(cage):
        raise ValueError(f"no control point {index}; the cage has {len(cage)}")
    if len(cage) <= 3:
        raise ValueError("a cage needs at least 3 control points")
    return np.delete(cage, index, axis=0), np.delete(np.asarray(target, dtype=np.float64), index, axis=0)


def move_points(points: np.ndarray, indices, shift) -> np.ndarray:
    """A copy of `points` (n, 2) with the rows `indices` moved by `shift` (2,)."""
    points = np.array(points, dtype=np.float64).reshape(-1, 2)
    points[list(indices)] += np.asarray(shift, dtype=np.float64)
    return points


def subdivide(points: np.ndarray) -> np.ndarray:
    """The same closed quadratic B-spline with 2n control points: q(2t) = p(t).

    Chaikin's corner cutting, the rule of `core.ClosedBSpline.subdivide`, without
    its validation so that it applies to a target curve that crosses itself.
    """
    points = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    following = np.roll(points, -1, axis=0)
    refined = np.empty((2 * len(points), 2))
    refined[0::2] = 0.75 * points + 0.25 * following
    refined[1::2] = 0.25 * points + 0.75 * following
    return np.roll(refined, 1, axis=0)


def cage_problem(cage: np.ndarray) -> str | None:
    """Why `cage` is no valid domain (fewer than 3 points, self-intersection, ...), or None."""
    import core

    cage = np.asarray(cage, dtype=np.float64).reshape(-1, 2)
    if len(cage) < 3:
        return f"place {3 - len(cage)} more control point{'s' * (len(cage) < 2)} (click on the image)"
    try:
        core.ClosedBSpline(cage)
    except ValueError as error:
        return str(error)
    return None


def default_max_edge(cage: np.ndarray, target_vertices: int = TARGET_VERTICES) -> float:
    """Mesh edge length that gives about `target_vertices` vertices inside `cage`, 3 significant digits.

    A triangle mesh of edge h has about 2 A / (sqrt(3) h^2) vertices on an area A.
    Never coarser than `core.triangulate`'s own default (diameter / 50).
    """
    import core

    curve = core.ClosedBSpline(cage)
    edge = math.sqrt(2.0 * abs(curve.area) / (math.sqrt(3.0) * target_vertices))
    edge = min(edge, curve.diameter / 50.0)
    digits = 2 - math.floor(math.log10(edge))
    return round(edge, digits)


def zoom_about(view: View, cursor, factor: float, limits: tuple[float, float] = (0.02, 64.0)) -> View:
    """Scale the view by `factor` keeping the image point under `cursor` (window pixels) in place."""
    scale = min(max(view.scale * factor, limits[0]), limits[1])
    factor = scale / view.scale
    cursor = np.asarray(cursor, dtype=np.float64)
    offset = cursor - (cursor - np.asarray(view.offset, dtype=np.float64)) * factor
    return View(scale, (float(offset[0]), float(offset[1])))


def pan(view: View, delta) -> View:
    """Move the view by `delta` window pixels."""
    return View(view.scale, (view.offset[0] + float(delta[0]), view.offset[1] + float(delta[1])))


def ellipse_cage(width: int, height: int, count: int = 12) -> np.ndarray:
    """A cage of `count` points on the ellipse inscribed in the middle 70% of a width x height image."""
    angles = 2 * np.pi * np.arange(count) / count
    centre = np.array([width, height]) / 2
    return centre + np.stack([0.35 * width * np.cos(angles), 0.35 * height * np.sin(angles)], axis=1)
