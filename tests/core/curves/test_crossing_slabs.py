"""core.curves.crossing_slabs: the slab-indexed point-in-polygon test equals the test over every edge."""

from __future__ import annotations

import numpy as np
import pytest

import core
from core.curves import examples
from core.curves.crossing_slabs import crossing_slabs, inside_polygon


def _crossing_number(polygon: np.ndarray, points: np.ndarray) -> np.ndarray:
    """The crossing-number test over every edge (i - 1, i), vectorised: (M,) bools."""
    xi, yi = polygon[:, 0], polygon[:, 1]
    xj, yj = np.roll(xi, 1), np.roll(yi, 1)
    x, y = points[:, :1], points[:, 1:]
    with np.errstate(divide="ignore", invalid="ignore"):
        straddles = (yi > y) != (yj > y)
        crossing = x < xi + (y - yi) / (yj - yi) * (xj - xi)
    return ((straddles & crossing).sum(axis=1) % 2) == 1


@pytest.mark.parametrize("name", ["blob", "starfish", "dumbbell", "crowded"])
def test_the_slab_test_agrees_with_the_test_over_every_edge(name):
    polygon = core.ClosedBSpline(getattr(examples, name)() * 100.0).sample(40).points
    rng = np.random.default_rng(3)
    points = rng.uniform(polygon.min(axis=0) - 5.0, polygon.max(axis=0) + 5.0, size=(20_000, 2))
    # Heights exactly at vertices and at the extremes, where a slab boundary may fall.
    points[:2_000, 1] = polygon[rng.integers(0, len(polygon), 2_000), 1]
    points[2_000:2_100, 1] = polygon[:, 1].min()
    points[2_100:2_200, 1] = polygon[:, 1].max()
    slabs = crossing_slabs(polygon[:, 1])
    sample_x, sample_y = np.ascontiguousarray(polygon[:, 0]), np.ascontiguousarray(polygon[:, 1])
    got = np.array([inside_polygon(sample_x, sample_y, slabs, x, y) for x, y in points])
    expected = _crossing_number(polygon, points)
    assert 0.2 < expected.mean() < 0.9  # both answers are tested
    np.testing.assert_array_equal(got, expected)


def test_every_edge_that_can_cross_a_height_is_listed_in_its_slab():
    polygon = core.ClosedBSpline(examples.starfish() * 100.0).sample(100).points
    offsets, edges, low, inverse_height = crossing_slabs(polygon[:, 1])
    slabs = offsets.size - 1
    assert slabs == len(polygon) // 4 and edges.size < 4 * len(polygon)  # an index, not every edge
    yi, yj = polygon[:, 1], np.roll(polygon[:, 1], 1)
    for y in np.random.default_rng(4).uniform(yi.min(), yi.max(), 500):
        k = min(int(np.floor((y - low) * inverse_height)), slabs - 1)
        listed = set(edges[offsets[k] : offsets[k + 1]].tolist())
        assert set(np.flatnonzero((yi > y) != (yj > y)).tolist()) <= listed


def test_a_flat_polygon_has_one_slab():
    polygon = np.array([[0.0, 1.0], [1.0, 1.0], [2.0, 1.0]])
    offsets, edges, _, inverse_height = crossing_slabs(polygon[:, 1])
    assert inverse_height == 0.0 and offsets.tolist() == [0, 3] and sorted(edges.tolist()) == [0, 1, 2]
    assert not inside_polygon(
        polygon[:, 0].copy(), polygon[:, 1].copy(), (offsets, edges, 1.0, 0.0), 0.5, 1.0
    )
