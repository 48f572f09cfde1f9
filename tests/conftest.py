"""Shared fixtures: example domains and deterministic interior points."""

from __future__ import annotations

import numpy as np
import pytest

import core
from core import examples


def interior_points(curve: core.ClosedBSpline, count: int, seed: int, margin: float = 0.0) -> np.ndarray:
    """`count` uniformly random points inside `curve`, shape (count, 2), fixed seed.

    With margin > 0, only points farther than margin * diameter from the curve.
    """
    from core.closest_point import distance_to_curve

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


@pytest.fixture(scope="session")
def blob() -> core.ClosedBSpline:
    """The non-convex 12-point domain (like the paper's Fig. 1)."""
    return core.ClosedBSpline(examples.blob())


@pytest.fixture(scope="session")
def starfish() -> core.ClosedBSpline:
    """A five-armed star: non-convex, with limbs."""
    return core.ClosedBSpline(examples.starfish())


@pytest.fixture(scope="session")
def ellipse() -> core.ClosedBSpline:
    """A convex domain."""
    return core.ClosedBSpline(examples.ellipse())
