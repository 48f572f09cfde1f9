"""The target edge length h of `core.triangulate` (step 1 of `core.meshes.triangulation`): at most
``max_edge``, smaller where the curve turns or another part of it is near (the radius of the
largest empty disk tangent to the curve), graded away from the curve at rate `GRADATION`.
"""

from __future__ import annotations

import math

import numpy as np

from core.curves.bspline import ClosedBSpline
from core.meshes.empty_disks import empty_disk_radii
from core.meshes.mesh import cross
from core.meshes.point_grid import nearest_distances, nearest_neighbours, within_reach

# Largest angle (radians) between the curve tangents at the two ends of a boundary edge.
TURNING_ANGLE = 0.3


# Boundary spacing <= this times the local feature size (radius of the largest empty
# tangent disk, inside or outside): about three edges across the narrowest neck.
NECK_FRACTION = 0.7


# |grad h|: how fast the target edge length may grow with the distance to the curve.
GRADATION = 0.3


# Corners with a smaller interior angle (radians) are sharp: the mesh is graded toward them.
WIDE_CORNER = math.pi / 3


# The dense curve samples that measure h are at most h / this apart...
SAMPLES_PER_EDGE = 4.0


# ...unless that takes more than this many samples or resampling rounds.
MAX_SAMPLES = 4_000_000


MAX_RESAMPLING = 12


# The sizing field never asks for edges below max_edge / this (conforming may still split
# further where the curve nearly touches itself).
SMALLEST_FRACTION = 1000.0


# Five-point Gauss-Legendre rule on [-1, 1] for the spans' lengths.
_GAUSS_NODES, _GAUSS_WEIGHTS = np.polynomial.legendre.leggauss(5)


class Sizing:
    """Target edge length h at dense curve samples and, graded, anywhere in the plane."""

    def __init__(self, curve: ClosedBSpline, max_edge: float):
        self.max_edge = max_edge
        self.period = curve.n
        self.t = _dense_parameters(curve, max_edge)
        # Disks between samples farther apart than the feature are missed: sample more
        # densely where h is small until every sample step is below h / SAMPLES_PER_EDGE.
        self._measure(curve)
        for _ in range(MAX_RESAMPLING):  # each round ends measured, the last one too
            target = np.minimum(self.h, np.roll(self.h, -1)) / SAMPLES_PER_EDGE
            extra = np.ceil(np.diff(self.arc) / target).astype(np.int64) - 1
            if extra.max() <= 0 or self.t.size + extra.sum() > MAX_SAMPLES:
                break
            following = np.append(self.t[1:], self.period)
            inserted = [
                self.t[i] + (following[i] - self.t[i]) * np.arange(1, count + 1) / (count + 1)
                for i, count in zip(np.flatnonzero(extra > 0), extra[extra > 0], strict=True)
            ]
            self.t = np.sort(np.concatenate([self.t, *inserted]))
            self._measure(curve)
        fine = self.h < max_edge
        self.fine_points = self.points[fine]  # (F, 2), where h < max_edge
        self._fine_h = self.h[fine]
        # Farther than this from every fine sample, h is max_edge.
        self.reach = (max_edge - self._fine_h.min(initial=max_edge)) / GRADATION
        if fine.any():  # (2, 2): outside this box no fine sample is within reach
            self._fine_box = np.stack([self.fine_points.min(axis=0), self.fine_points.max(axis=0)])
            self._fine_box += [[-self.reach], [self.reach]]

    def _measure(self, curve: ClosedBSpline) -> None:
        """Samples, arc lengths and graded target lengths h at the parameters self.t."""
        self.points, first, second = curve.evaluate(self.t)
        speed = np.linalg.norm(first, axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            tangents = first / speed[:, None]
            curvature = np.abs(cross(first, second)) / speed**3
        stopped = speed <= 1e-12 * curve.diameter  # the knot of a sharp corner
        curvature[stopped] = 0.0
        chords = np.roll(self.points, -1, axis=0) - np.roll(self.points, 1, axis=0)
        tangents[stopped] = chords[stopped] / np.linalg.norm(chords[stopped], axis=1)[:, None]
        orientation = 1.0 if curve.is_counterclockwise else -1.0
        inward = orientation * np.stack([-tangents[:, 1], tangents[:, 0]], axis=1)
        steps = np.linalg.norm(np.roll(self.points, -1, axis=0) - self.points, axis=1)
        self.arc = np.concatenate([[0.0], np.cumsum(steps)])  # (S + 1,), closes the loop
        outside_wedge, inside_wedge = _corner_wedges(curve, self.t)
        largest = 1.01 * self.max_edge / NECK_FRACTION  # larger disks do not limit h
        radius = np.minimum(
            empty_disk_radii(self.points, inward, inside_wedge, largest),
            empty_disk_radii(self.points, -inward, outside_wedge, largest),
        )
        with np.errstate(divide="ignore"):
            h = np.minimum(TURNING_ANGLE / curvature, NECK_FRACTION * radius)
        self.h = self._graded(np.clip(h, self.max_edge / SMALLEST_FRACTION, self.max_edge))

    def _graded(self, h: np.ndarray) -> np.ndarray:
        """Smallest h with h_i <= h_j + GRADATION |p_i - p_j| between nearby samples.

        Only samples within (max_edge - min h) / GRADATION of a sample with h below
        max_edge can be lowered, so only those are visited.
        """
        fine = h < self.max_edge
        if not fine.any():
            return h
        reach = (self.max_edge - h.min()) / GRADATION
        near = np.flatnonzero(within_reach(self.points[fine], self.points, reach))
        k = min(32, h.shape[0])
        distance, index = nearest_neighbours(self.points, self.points[near], k)
        for _ in range(h.shape[0]):  # each pass carries the bound at least one sample on
            graded = np.minimum(h[near], (h[index] + GRADATION * distance).min(axis=1))
            if np.array_equal(graded, h[near]):
                break
            h = h.copy()
            h[near] = graded
        return h

    def __call__(self, x: np.ndarray) -> np.ndarray:
        """Target edge length at points x (M, 2), ndarray of shape (M,)."""
        result = np.full(x.shape[0], self.max_edge)
        if self.fine_points.shape[0] == 0 or x.shape[0] == 0:
            return result
        near = np.flatnonzero(((x >= self._fine_box[0]) & (x <= self._fine_box[1])).all(axis=1))
        k = min(8, self._fine_h.size)
        distance, index = nearest_neighbours(self.fine_points, x[near], k, self.reach)
        index = np.minimum(index, self._fine_h.size - 1)  # misses: index == size, distance inf
        result[near] = np.minimum(result[near], (self._fine_h[index] + GRADATION * distance).min(axis=1))
        return result

    def distance_to_curve(self, x: np.ndarray, reach: float) -> np.ndarray:
        """Distance to the nearest dense curve sample (within half a sample spacing of exact),
        or inf beyond `reach`, at points x (M, 2): ndarray of shape (M,)."""
        return nearest_distances(self.points, x, reach)

    def arc_length(self, t: np.ndarray) -> np.ndarray:
        """Arc length from t = 0 along the dense polyline, for t in [0, 2 n)."""
        wrapped = np.concatenate([self.t, [self.period]])
        turns = np.floor(t / self.period)
        return np.interp(t - turns * self.period, wrapped, self.arc) + turns * self.arc[-1]

    def parameter(self, s: np.ndarray) -> np.ndarray:
        """Inverse of `arc_length`, parameters in [0, n) for arc lengths s (any real)."""
        total = self.arc[-1]
        turns = np.floor(s / total)
        wrapped = np.concatenate([self.t, [self.period]])
        return np.mod(np.interp(s - turns * total, self.arc, wrapped), self.period)

    def boundary_parameters(self, corner_parameters: np.ndarray) -> np.ndarray:
        """Parameters of the first boundary vertices, sorted in [0, n).

        Between consecutive corners (or around the whole curve if it has none) the
        vertices split the integral of ds / h(s) into equal parts of at most 1.
        """
        density = 1.0 / self.h
        steps = np.diff(self.arc)
        integral = np.concatenate(
            [[0.0], np.cumsum(0.5 * steps * (density + np.roll(density, -1)))]
        )  # (S + 1,)
        wrapped = np.concatenate([self.t, [self.period]])
        starts = np.sort(corner_parameters) if corner_parameters.size else np.zeros(1)
        stops = np.append(starts[1:], starts[0] + self.period)
        minimum_edges = 1 if corner_parameters.size else 3

        def cumulative(t):
            turns = np.floor(t / self.period)
            return np.interp(t - turns * self.period, wrapped, integral) + turns * integral[-1]

        parameters = []
        for start, stop in zip(starts, stops, strict=True):
            low, high = cumulative(start), cumulative(stop)
            edges = max(minimum_edges, math.ceil(high - low - 1e-9))
            targets = low + (high - low) * np.arange(edges) / edges
            turns = np.floor(targets / integral[-1])
            local = np.interp(targets - turns * integral[-1], integral, wrapped) + turns * self.period
            local[0] = start  # a corner exactly at its knot
            parameters.append(np.mod(local, self.period))
        result = np.unique(np.concatenate(parameters))
        return result[result < self.period]


def _dense_parameters(curve: ClosedBSpline, max_edge: float) -> np.ndarray:
    """Parameters of the first dense samples: every knot, at least 32 per span, ~max_edge / 8 apart."""
    nodes, weights = _GAUSS_NODES, _GAUSS_WEIGHTS
    u = 0.5 * (nodes + 1.0)
    spans = np.arange(curve.n)
    first = curve.derivative((spans[:, None] + u[None, :]).ravel()).reshape(curve.n, 5, 2)
    lengths = 0.5 * (np.linalg.norm(first, axis=2) * weights).sum(axis=1)
    counts = np.clip(np.ceil(8.0 * lengths / max_edge).astype(np.int64), 32, 1 << 16)
    return np.concatenate([j + np.arange(c) / c for j, c in zip(spans, counts, strict=True)])


def _corner_wedges(curve: ClosedBSpline, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Index of the sharp corner whose two straight spans hold each sample, or -1.

    The two spans next to a doubled control point are straight segments meeting
    at the corner, so samples on them need not limit each other's feature size.
    Returns the wedges for the disks outside the domain (every corner) and for
    the disks inside (only corners of interior angle at least `WIDE_CORNER`:
    inside a sharper corner the sides do limit each other, which grades the
    mesh toward the tip so that its triangles keep good angles).
    """
    outside = np.full(t.shape[0], -1, dtype=np.int64)
    inside = outside.copy()
    angles = curve.corner_angles()
    for index, corner in enumerate(curve.corners()[:, 0]):
        in_wedge = np.mod(t - corner + 1.0, curve.n) < 2.0
        outside[in_wedge] = index
        if angles[index] >= WIDE_CORNER:
            inside[in_wedge] = index
    return outside, inside
