"""Cages as SVG paths: the closed uniform quadratic B-spline (Sec. 4.1) as a chain of quadratic Béziers.

A closed uniform quadratic B-spline with control points P_0 ... P_(n-1) is, span by span, the
quadratic Bézier from the midpoint m_(j-1) = (P_(j-1) + P_j) / 2 over the control point P_j to
m_j: the SVG path ``M m_(n-1) Q P_0 m_0 T m_1 T m_2 ... T m_(n-1) Z``, where each ``T`` reflects
the previous control point about the current point, which gives the next control point.  A sharp
corner, a doubled point P_i = P_(i+1), is the end of the span into it and the start of the span
out of it; the span out of a corner starts a new ``Q`` (the chain breaks there).  Such a path
reads back to its control points exactly (`svg_cage`); any other closed path (cubic Béziers, arcs,
lines, from Inkscape or Illustrator) is fitted by `app.fit.curve.fit_closed_bspline` to within
`FIT_TOLERANCE` pixels, its corners kept as doubled points.

Coordinates are the SVG's user units as image pixels (x right, y down); every transform of the
path and its groups applies, the viewport's (``width``, ``height``, ``viewBox``) does not.
The file is parsed by svgelements.
"""

from __future__ import annotations

import io
import math
from dataclasses import dataclass

import numpy as np

#: Largest distance of a chain's joints from its control points' midpoints, relative to its size, for
#: the chain to be read as the B-spline of its control points: rounding, as an editor that writes 8
#: significant digits (Inkscape's default) leaves it, but no visible bend.
CHAIN_TOLERANCE = 1e-6

#: Largest distance, in pixels, between an SVG path and the cage fitted to it.
FIT_TOLERANCE = 0.5

#: A joint of two segments whose tangents turn by more than this (degrees) is a sharp corner.
CORNER_ANGLE = 5.0

#: Spacing, in pixels, of the samples of the path and of the fitted curve that measure the fit
#: (wider on a path longer than `MAX_SAMPLES` of them); the error said is the samples' largest
#: distance plus half of it, a bound of the distance between the curves.
SAMPLE_SPACING = 0.1

#: Most samples of a path fitted; its length at most `MAX_PATH_LENGTH` pixels, so that they stay
#: at most 0.2 px apart.
MAX_SAMPLES = 250_000
MAX_PATH_LENGTH = 50_000.0

#: Most points of the path the least-squares fit uses (the error is measured on all samples).
FIT_POINTS = 4_000

#: Most control points of a fitted cage; a path that needs more is refused.
MAX_FITTED_POINTS = 2000

#: Growth of the number of spans from one fitting attempt to the next.
SPAN_GROWTH = 1.4


@dataclass(frozen=True)
class SvgCage:
    """The cage read from an SVG file.

    Attributes
    ----------
    control_points : ndarray of shape (n, 2)
        Image pixels, x right, y down; a sharp corner is a point repeated twice in a row.
    fit_error : float or None
        None when the path was an exact quadratic B-spline chain; otherwise the largest
        distance, in pixels, between the path and the fitted curve.
    """

    control_points: np.ndarray
    fit_error: float | None


def svg_cage(data: bytes) -> SvgCage:
    """The cage of the first closed path of an SVG document.

    Parameters
    ----------
    data : bytes
        The SVG file's contents.

    Returns
    -------
    SvgCage

    Raises
    ------
    ValueError
        Not SVG, no closed path, or a path that cannot be fitted; one line, in the
        project's words (callers add the file name).
    """
    segments = _first_closed_path(data)
    chain = _exact_chain(segments)
    if chain is not None:
        return SvgCage(chain, None)
    return _fitted(segments)


def svg_text(control_points: np.ndarray, width: float, height: float) -> str:
    """An SVG document of `width` by `height` pixels holding the cage as an exact Q/T chain.

    Parameters
    ----------
    control_points : ndarray of shape (n, 2)
        Image pixels; a point repeated twice in a row is a sharp corner.
    width, height : float
        The image's size in pixels: the document's size and viewBox.

    Returns
    -------
    str
        The document; `svg_cage` reads back `control_points` to rounding of the midpoints.
    """
    points = np.asarray(control_points, dtype=np.float64)
    count = len(points)
    midpoints = 0.5 * (points + np.roll(points, -1, axis=0))  # m_j, end of span j
    commands = [f"M {_pair(midpoints[-1])}"]
    for j in range(count):
        starts_chain = j == 0 or np.array_equal(points[j - 1], points[j])
        if starts_chain:
            commands.append(f"Q {_pair(points[j])} {_pair(midpoints[j])}")
        else:
            commands.append(f"T {_pair(midpoints[j])}")
    commands.append("Z")
    size = f'width="{_number(width)}" height="{_number(height)}"'
    return (
        '<?xml version="1.0" encoding="UTF-8"?>\n'
        f'<svg xmlns="http://www.w3.org/2000/svg" {size} viewBox="0 0 {_number(width)} {_number(height)}">\n'
        "  <!-- a transfinite-warp cage: a closed uniform quadratic B-spline, its control points "
        "the Q and T control points -->\n"
        f'  <path fill="none" stroke="#ff00ff" stroke-width="1" d="{" ".join(commands)}"/>\n'
        "</svg>\n"
    )


def _number(value: float) -> str:
    """The shortest text that reads back as `value` (an integer without its ``.0``)."""
    value = float(value) + 0.0  # no "-0"
    return str(int(value)) if value.is_integer() and abs(value) < 1e15 else repr(value)


def _pair(point: np.ndarray) -> str:
    return f"{_number(point[0])},{_number(point[1])}"


def _first_closed_path(data: bytes) -> list:
    """The drawing segments (no Move, no empty Close) of the document's first closed path."""
    import svgelements

    try:
        document = svgelements.SVG.parse(io.BytesIO(data))
    except Exception as error:  # svgelements raises what its XML parser raises
        raise ValueError(f"not an SVG document ({type(error).__name__})") from None
    # User units are the image's pixels: undo the viewport's scaling, keep every transform inside.
    viewport = ~svgelements.Matrix(document.viewbox_transform)
    for element in document.elements():
        if not isinstance(element, svgelements.Shape) or isinstance(element, svgelements.SVG):
            continue
        path = svgelements.Path(element) * viewport
        path.reify()
        for subpath in path.as_subpaths():
            segments = list(subpath)
            drawn = [s for s in segments if not isinstance(s, svgelements.Move)]
            closed = bool(drawn) and (
                isinstance(drawn[-1], svgelements.Close) or drawn[-1].end == drawn[0].start
            )
            drawn = [s for s in drawn if not (isinstance(s, svgelements.Close) and s.start == s.end)]
            if closed and len(drawn) >= 2:
                return drawn
    raise ValueError("no closed path in the SVG (a cage is a closed path: end it with Z)")


def _exact_chain(segments: list) -> np.ndarray | None:
    """The control points of a chain of quadratic Béziers joined at their control points' midpoints,
    or None when the path is anything else."""
    import svgelements

    if not all(isinstance(s, svgelements.QuadraticBezier) for s in segments):
        return None
    controls = np.array([[s.control.x, s.control.y] for s in segments], dtype=np.float64)
    ends = np.array([[s.end.x, s.end.y] for s in segments], dtype=np.float64)
    extent = max(1.0, float(np.abs(controls).max()))
    joints = 0.5 * (controls + np.roll(controls, -1, axis=0))
    if np.abs(joints - ends).max() > CHAIN_TOLERANCE * extent:
        return None
    return controls


def _fitted(segments: list) -> SvgCage:
    """A closed B-spline fitted to the path within `FIT_TOLERANCE`, corners as doubled points."""
    lengths = [float(segment.length(error=1e-6)) for segment in segments]
    total = sum(lengths)
    if not math.isfinite(total):
        raise ValueError("the path's coordinates are not all finite numbers")
    if total > MAX_PATH_LENGTH:
        raise ValueError(
            f"the path is {total:,.0f} px long; a path of at most {MAX_PATH_LENGTH:,.0f} px can be fitted"
        )
    spacing = max(SAMPLE_SPACING, total / MAX_SAMPLES)
    pieces, cornered = _pieces(segments, lengths, spacing)
    from scipy.spatial import cKDTree

    path_samples = np.concatenate([piece[:-1] for piece in pieces])
    path_tree = cKDTree(path_samples)
    lengths = np.array([np.linalg.norm(np.diff(piece, axis=0), axis=1).sum() for piece in pieces])
    minimum = 2 if cornered else 3  # two spans between corners make a straight side
    budget = max(4.0, 4.0 * len(pieces))
    error = math.inf
    while True:
        spans = np.maximum(minimum, np.ceil(budget * lengths / lengths.sum())).astype(int)
        count = int(spans.sum())
        if count > MAX_FITTED_POINTS:
            raise ValueError(
                f"the path cannot be fitted within {FIT_TOLERANCE:g} px by {MAX_FITTED_POINTS} control "
                f"points (off by {error:.2f} px)"
            )
        control_points = _fit(pieces, spans, cornered)
        error = _distance(path_samples, path_tree, control_points, spacing)
        if error <= FIT_TOLERANCE:
            return SvgCage(control_points, error)
        budget = count * SPAN_GROWTH


def _turn(incoming: np.ndarray, outgoing: np.ndarray) -> float:
    """The angle, in degrees, between two directions."""
    cross = incoming[0] * outgoing[1] - incoming[1] * outgoing[0]
    return abs(math.degrees(math.atan2(cross, float(np.dot(incoming, outgoing)))))


def _pieces(segments: list, lengths: list[float], spacing: float) -> tuple[list[np.ndarray], bool]:
    """Dense samples of the path (its segments' `lengths`, `spacing` apart) between its sharp
    corners, and whether it has corners.

    Each piece, an array (K, 2), runs from one corner to the next; a path without corners is
    one piece, its first sample repeated at its end."""
    samples = []
    for segment, length in zip(segments, lengths, strict=True):
        if length == 0.0:
            continue
        count = max(8, math.ceil(length / spacing))
        samples.append(np.asarray(segment.npoint(np.linspace(0.0, 1.0, count + 1)), dtype=np.float64))
    corners = [
        k
        for k in range(len(samples))
        if _turn(samples[k - 1][-1] - samples[k - 1][-2], samples[k][1] - samples[k][0]) > CORNER_ANGLE
    ]
    if not corners:
        return [np.concatenate([s[:-1] for s in samples] + [samples[0][:1]])], False
    pieces = []
    for first, last in zip(corners, corners[1:] + [corners[0] + len(samples)], strict=True):
        run = [samples[k % len(samples)] for k in range(first, last)]
        pieces.append(np.concatenate([s[:-1] for s in run] + [run[-1][-1:]]))
    return pieces, True


def _fit(pieces: list[np.ndarray], spans: np.ndarray, cornered: bool) -> np.ndarray:
    """Control points (n, 2) of the B-spline fitted to `pieces`, piece k over spans[k] spans; with
    corners, piece k runs from the corner at parameter o_k + 1 to the next (o_k: the spans before)."""
    from app.fit.curve import fit_closed_bspline

    count = int(spans.sum())
    # The fit needs far fewer points than the error's measure: FIT_POINTS, or 20 a span, ends kept.
    step = max(1, math.ceil(sum(len(piece) for piece in pieces) / max(FIT_POINTS, 20 * count)))
    pieces = [np.concatenate([piece[:-1:step], piece[-1:]]) for piece in pieces]
    if not cornered:
        return fit_closed_bspline(pieces[0][:-1], count)
    starts = np.concatenate([[0], np.cumsum(spans)[:-1]])
    data, parameters = [], []
    for piece, start, span in zip(pieces, starts, spans, strict=True):
        steps = np.linalg.norm(np.diff(piece, axis=0), axis=1)
        along = np.concatenate([[0.0], np.cumsum(steps)]) / steps.sum()
        data.append(piece[:-1])
        parameters.append(np.mod(start + 1 + span * along[:-1], count))
    return fit_closed_bspline(
        np.concatenate(data),
        count,
        corners=tuple(int(s) for s in starts),
        parameters=np.concatenate(parameters),
    )


def _distance(path_samples: np.ndarray, path_tree, control_points: np.ndarray, spacing: float) -> float:
    """A bound of the largest distance from the path to the curve and from the curve to the path (pixels).

    Both are sampled about `spacing` apart (`path_tree`: the path samples' k-d tree): the largest
    distance between the samples, plus half the spacing, as no point is farther than that from a
    sample of its curve."""
    from scipy.spatial import cKDTree

    from core import basis_weights

    count = len(control_points)
    polygon = np.linalg.norm(np.diff(control_points, axis=0, append=control_points[:1]), axis=1).sum()
    samples = min(max(8 * count, math.ceil(polygon / spacing)), 2 * MAX_SAMPLES)  # a wild fit: capped
    t = np.linspace(0.0, count, samples, endpoint=False)
    index, weights = basis_weights(t, count)
    curve = np.einsum("kj,kjd->kd", weights, control_points[index])
    to_curve = cKDTree(curve).query(path_samples)[0].max()
    to_path = path_tree.query(curve)[0].max()
    return float(max(to_curve, to_path)) + 0.5 * spacing
