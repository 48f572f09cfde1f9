"""Example domains as control points, and deterministic points inside a curve."""

from __future__ import annotations

import numpy as np

import core
from app.studies.quality_suite import built_in_shapes
from core.boundary_integrals.poisson import closest_point


def interior_points(curve: core.ClosedBSpline, count: int, seed: int, margin: float = 0.0) -> np.ndarray:
    """`count` uniformly random points inside `curve`, shape (count, 2), fixed seed.

    With margin > 0, only points farther than margin * diameter from the curve.
    """
    from core.curves.closest_point import distance_to_curve

    rng = np.random.default_rng(seed)
    low = curve.control_points.min(axis=0)
    high = curve.control_points.max(axis=0)
    found = []
    while sum(len(f) for f in found) < count:
        x = rng.uniform(low, high, size=(4 * count, 2))
        x = x[curve.contains(x)]
        if margin > 0:
            x = x[distance_to_curve(curve.piecewise_polynomial(), x) > margin * curve.diameter]
        found.append(x)
    return np.concatenate(found)[:count]


def pixel_blob(n: int = 10) -> np.ndarray:
    """A smooth cage about 360 px across in image coordinates (x right, y down), shape (n, 2)."""
    angle = 2 * np.pi * np.arange(n) / n
    radius = 150 * (1 + 0.2 * np.cos(3 * angle))
    return np.stack([300 + radius * np.cos(angle), 300 - radius * np.sin(angle)], axis=1)


def near_cusp(gap: float, turn_degrees: float, k: int = 3) -> np.ndarray:
    """`pixel_blob` with a point inserted `gap` px after point k, towards the cage's tangent
    at k turned by `turn_degrees`: a near-cusp.  From about 150 degrees the cage turns back
    over the two points and the curve crosses itself in a loop around their knot."""
    points = pixel_blob()
    tangent = points[k + 1] - points[k - 1]
    turn = np.radians(turn_degrees)
    rotation = np.array([[np.cos(turn), -np.sin(turn)], [np.sin(turn), np.cos(turn)]])
    direction = rotation @ tangent / np.linalg.norm(tangent)
    return np.insert(points, k + 1, points[k] + gap * direction, axis=0)


def wavy_star(n: int = 15, arms: int = 5, depth: float = 0.5) -> np.ndarray:
    """Control points (n, 2) on r = 1 + depth cos(arms angle): a non-convex star."""
    angle = 2 * np.pi * np.arange(n) / n
    radius = 1.0 + depth * np.cos(arms * angle)
    return np.stack([radius * np.cos(angle), radius * np.sin(angle)], axis=1)


def l_polygon() -> np.ndarray:
    """An L-shaped polygon, every corner doubled (sharp corners), shape (12, 2)."""
    polygon = [[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2]]
    return np.repeat(np.array(polygon, dtype=float), 2, axis=0)


def inward_offsets(curve: core.ClosedBSpline, s: np.ndarray, distance: float) -> np.ndarray:
    """Points at `distance` from p(s) along the inward normal, shape (len(s), 2)."""
    points, tangents, _ = curve.evaluate(s)
    normal = np.stack([-tangents[:, 1], tangents[:, 0]], axis=1)
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    return points + distance * (normal if curve.is_counterclockwise else -normal)


def circle(count: int, radius: float = 1.0) -> core.Boundary:
    """The exact circle p(t) = r (cos t, sin t), t_k = 2 pi k / count."""
    t = 2 * np.pi * np.arange(count) / count
    points = radius * np.stack([np.cos(t), np.sin(t)], axis=1)
    tangents = radius * np.stack([-np.sin(t), np.cos(t)], axis=1)
    return core.Boundary(points, tangents, -points, 2 * np.pi / count)


SHAPES = built_in_shapes()


def near_boundary_points(curve: core.ClosedBSpline, count: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Points at 1e-6 .. 1e-1 diameters from the curve along the inward normal, half of them next to
    knots (corners included), and their distances; shape (K, 2), (K,)."""
    rng = np.random.default_rng(seed)
    t = np.concatenate(
        [
            rng.uniform(0, curve.n, count),
            np.round(rng.uniform(0, curve.n, count)) + rng.normal(0, 1e-3, count),
        ]
    )
    point, tangent, _ = curve.evaluate(t)
    speed = np.linalg.norm(tangent, axis=1)
    keep = speed > 1e-9 * curve.diameter
    normal = np.stack([-tangent[keep, 1], tangent[keep, 0]], axis=1) / speed[keep, None]
    normal *= 1.0 if curve.is_counterclockwise else -1.0
    distance = curve.diameter * 10 ** rng.uniform(-6, -1, keep.sum())
    x = point[keep] + distance[:, None] * normal
    inside = curve.contains(x)
    x, distance = x[inside], distance[inside]
    _, exact = closest_point(curve, x)
    far_enough = exact >= 1e-6 * curve.diameter
    return x[far_enough], exact[far_enough]


def random_polygon_cage(seed: int) -> core.ClosedBSpline:
    """A star-shaped random polygon of 4-8 vertices, about 60 % of them sharp corners (doubled)."""
    rng = np.random.default_rng(seed)
    count = rng.integers(4, 9)
    angle = np.sort(rng.uniform(0, 2 * np.pi, count))
    corners = 300.0 * rng.uniform(0.5, 1.0, count)[:, None] * np.stack([np.cos(angle), np.sin(angle)], 1)
    doubled = rng.random(count) < 0.6
    return core.ClosedBSpline(np.repeat(corners, np.where(doubled, 2, 1), axis=0))
