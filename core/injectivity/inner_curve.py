"""The closed curve Γ just inside a cage's boundary on which the certificate samples the map.

Γ runs counter-clockwise (the source is made counter-clockwise first) and is made of pieces:

- offset pieces: c(t) + δ(t) ν(t) for t between the sharp corners (ν the inward unit normal),
  at a depth δ(t) = δ / (1 + 4 δ κ⁺(t)) that stays below a quarter of the radius of curvature
  where the boundary bends around the domain (κ⁺ > 0), so that the offset does not fold; each
  offset point has a companion `DEEPER` times deeper, which measures how the derivatives vary
  across the strip between Γ and the boundary (`core.injectivity.certificate`);
- corner arcs: at a sharp corner P (a doubled control point) the circle |z - P| = ρ inside the
  domain's angle α, from the side the curve arrives on to the side it leaves on, down to
  `SIDE_GAP` of the diameter from the two straight sides.  ρ is `CORNER_FRACTION` of the shorter
  straight side (both spans at a doubled point are straight: the span leaving P is
  P + u² (P_next - P) / 2), at most `CORNER_CAP` of the diameter and at most half the distance
  from P to the rest of the curve (a lower bound of it from samples), so the sector |z - P| < ρ
  lies in the domain and both its sides are straight.

Consecutive pieces are joined by straight connectors (a few δ long).  Γ is the closed polygon
through all samples in order.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from core.curves.bspline import ClosedBSpline

#: Depth δ of Γ below the boundary, as a fraction of the diameter, and the smaller ones tried
#: where Γ at that depth leaves the domain (a thinner part).
DEPTH = 1e-3
DEPTHS = (DEPTH, 1e-4, 1e-5)
#: The companion samples are this many times deeper.
DEEPER = 4.0
#: Corner arcs' radius: this fraction of the shorter straight side ...
CORNER_FRACTION = 0.5
#: ... and at most this fraction of the diameter.
CORNER_CAP = 0.05
#: Points per span at which the distance from a corner to the rest of the curve is bounded, and
#: how many times more where that bound is not conclusive.
CLEARANCE_SAMPLES = 64
CLEARANCE_REFINE = 64
#: Corner arcs stop this fraction of the diameter away from the straight sides.
SIDE_GAP = 1e-5


@dataclass(frozen=True)
class Corner:
    """A sharp corner of the source: its knot, point P, radius ρ, the angle θ of the side it
    leaves on, the domain's angle α there, and the parameter range [t - before, t + after]
    that the arc replaces.  Points, angles in the counter-clockwise source's frame."""

    knot: float
    point: np.ndarray
    radius: float
    leave_angle: float
    angle: float
    before: float
    after: float


@dataclass(frozen=True)
class Piece:
    """One piece of Γ: an offset piece (corner None) over t in [start, stop], or the arc of
    `corner` over angles from `start` down to `stop` (both in the domain's angle there)."""

    start: float
    stop: float
    corner: Corner | None


def corners(curve: ClosedBSpline) -> list[Corner]:
    """The sharp corners of a counter-clockwise `curve`, in the order of their knots."""
    points = curve.control_points
    n = curve.n
    result = []
    for (knot, *directions), angle in zip(curve.corners(), curve.corner_angles(), strict=True):
        j = int(round(knot)) % n  # paper P_j = P_{j+1}: array rows j - 1 and j
        point = points[j]
        side_after = 0.5 * np.linalg.norm(points[(j + 1) % n] - point)
        side_before = 0.5 * np.linalg.norm(point - points[(j - 2) % n])
        clearance = _clearance(curve, point, (j + np.arange(1, n - 1)) % n)
        radius = min(CORNER_FRACTION * min(side_after, side_before), CORNER_CAP * curve.diameter)
        radius = min(radius, 0.5 * clearance)
        leave = math.atan2(directions[3], directions[2])
        result.append(
            Corner(
                knot=float(knot),
                point=point.copy(),
                radius=radius,
                leave_angle=leave,
                angle=float(angle),
                before=math.sqrt(radius / side_before),
                after=math.sqrt(radius / side_after),
            )
        )
    return result


def _clearance(curve: ClosedBSpline, point: np.ndarray, spans: np.ndarray) -> float:
    """A lower bound (>= 0) of the distance from `point` (2,) to the curve's spans t in [i, i + 1] for
    i in `spans` (S,): per span, the distance to samples u/m less half the arc between samples, at most
    the span's largest speed (|p'| is convex on a span, largest at an end) over 2m; the spans whose
    bound is below the nearest sample's distance are sampled again `CLEARANCE_REFINE` times finer."""
    _, first, _ = curve.evaluate(np.arange(curve.n + 1, dtype=np.float64))
    speeds = np.linalg.norm(first, axis=1)
    largest = np.maximum(speeds[:-1], speeds[1:])
    bounds = np.full(spans.size, np.inf)
    chosen, count = np.arange(spans.size), CLEARANCE_SAMPLES
    for _ in range(2):
        t = (spans[chosen][:, None] + np.arange(count) / count).ravel()
        distances = np.linalg.norm(curve(t) - point, axis=1).reshape(chosen.size, count)
        bounds[chosen] = distances.min(axis=1) - largest[spans[chosen]] / (2.0 * count)
        chosen, count = chosen[bounds[chosen] < distances.min()], count * CLEARANCE_REFINE
    return max(float(bounds.min(initial=np.inf)), 0.0)


def pieces(curve: ClosedBSpline, found: list[Corner]) -> list[Piece]:
    """Γ's pieces in counter-clockwise order: offset pieces between corner arcs (one offset piece
    over [0, n] if there is no corner)."""
    if not found:
        return [Piece(0.0, float(curve.n), None)]
    result = []
    for k, corner in enumerate(found):
        gap = math.asin(min(1.0, SIDE_GAP * curve.diameter / corner.radius))
        result.append(Piece(corner.angle - gap, gap, corner))
        following = found[(k + 1) % len(found)]
        stop = following.knot - following.before
        if stop <= corner.knot + corner.after:
            stop += curve.n
        result.append(Piece(corner.knot + corner.after, stop, None))
    return result


def offset_points(curve: ClosedBSpline, t: np.ndarray, depth: float) -> tuple[np.ndarray, np.ndarray]:
    """Points of Γ at parameters t (m,) of a counter-clockwise curve and their deeper companions,
    two ndarrays (m, 2); `depth` is δ in the curve's units."""
    point, first, second = curve.evaluate(t)
    speed = np.linalg.norm(first, axis=1)
    normal = np.stack([-first[:, 1], first[:, 0]], axis=1) / speed[:, None]
    curvature = (first[:, 0] * second[:, 1] - first[:, 1] * second[:, 0]) / speed**3
    local = depth / (1.0 + 4.0 * depth * np.abs(curvature))
    return point + local[:, None] * normal, point + (DEEPER * local)[:, None] * normal


def arc_points(corner: Corner, angles: np.ndarray) -> np.ndarray:
    """Points (m, 2) of a corner's arc at angles (m,) measured from the side it leaves on."""
    direction = corner.leave_angle + angles
    return corner.point + corner.radius * np.stack([np.cos(direction), np.sin(direction)], axis=1)


__all__ = ["Corner", "Piece", "arc_points", "corners", "offset_points", "pieces"]
