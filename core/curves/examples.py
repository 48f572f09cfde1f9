"""Example cages used by the tests, the benchmark and the demos (coordinates in a unit-ish frame),
and example boundary data for them.

Each function returns control points, ndarray of shape (n, 2), counter-clockwise in
a y-up frame unless said otherwise.
"""

from __future__ import annotations

import numpy as np


def starfish(arms: int = 5, inner: float = 0.35, outer: float = 1.0, points_per_arm: int = 2) -> np.ndarray:
    """A star with `arms` limbs: alternating tip and armpit control points."""
    count = arms * points_per_arm
    angles = np.pi / 2 + 2 * np.pi * np.arange(count) / count
    radii = np.where(np.arange(count) % points_per_arm == 0, outer, inner)
    return np.stack([radii * np.cos(angles), radii * np.sin(angles)], axis=1)


def blob() -> np.ndarray:
    """A non-convex 12-point domain in [0, 1]^2, like the paper's Fig. 1."""
    return np.array(
        [
            [0.10, 0.15],
            [0.40, 0.05],
            [0.65, 0.20],
            [0.95, 0.05],
            [1.00, 0.45],
            [0.80, 0.55],
            [0.95, 0.95],
            [0.55, 0.90],
            [0.45, 0.55],
            [0.30, 0.95],
            [0.00, 0.80],
            [0.15, 0.50],
        ]
    )


def ellipse(count: int = 8, a: float = 1.0, b: float = 0.7) -> np.ndarray:
    """A convex cage on an ellipse."""
    angles = 2 * np.pi * np.arange(count) / count
    return np.stack([a * np.cos(angles), b * np.sin(angles)], axis=1)


def lobed_circle(count: int, lobes: int = 5, depth: float = 0.15) -> np.ndarray:
    """`count` control points on a circle of radius 1 + `depth` sin(`lobes` θ), (count, 2): a large
    smooth cage (the bench's and the tests' 200-point one)."""
    angles = 2 * np.pi * np.arange(count) / count
    radii = 1.0 + depth * np.sin(lobes * angles)
    return np.stack([radii * np.cos(angles), radii * np.sin(angles)], axis=1)


def dumbbell() -> np.ndarray:
    """Two lobes joined by a narrow neck (width about 0.1)."""
    return np.array(
        [
            [-1.0, -0.5],
            [-0.3, -0.5],
            [-0.15, -0.05],
            [0.15, -0.05],
            [0.3, -0.5],
            [1.0, -0.5],
            [1.0, 0.5],
            [0.3, 0.5],
            [0.15, 0.05],
            [-0.15, 0.05],
            [-0.3, 0.5],
            [-1.0, 0.5],
        ]
    )


def crowded(dense: int = 6, sparse: int = 6, arc: float = 0.5) -> np.ndarray:
    """Control points on the unit circle, `dense` of them crowded into an arc of `arc` radians
    around angle 0 and `sparse` spread over the rest: very uneven spacing, like the domain of
    the paper's Fig. 12, where the boundary's parameterisation shows."""
    crowd = np.linspace(-arc / 2, arc / 2, dense)
    rest = np.linspace(arc / 2, 2 * np.pi - arc / 2, sparse + 2)[1:-1]
    angles = np.concatenate([crowd, rest])
    return np.stack([np.cos(angles), np.sin(angles)], axis=1)


def wave_heights(count: int) -> np.ndarray:
    """Heights F_i in [0, 1] at `count` control points, two waves around the curve like the data
    of the paper's Fig. 1, shape (count,): the default data of ``compare`` and of the viewer's
    height view."""
    return 0.5 + 0.5 * np.sin(2.0 * np.pi * 2.0 * np.arange(count) / count + 0.3)
