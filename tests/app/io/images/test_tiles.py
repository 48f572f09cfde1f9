"""The tiles of a large drawing: which of them the outline of the warp crosses, and which lie inside it."""

import numpy as np

from app.io.images.tiles import crosses, encloses


def outline(*corners_lists) -> np.ndarray:
    """Segments (E, 2, 2) of closed polygons given by their corners, shuffled (seed 2)."""
    segments = [
        np.stack([corners, np.roll(corners, -1, axis=0)], axis=1)
        for corners in (np.asarray(c, float) for c in corners_lists)
    ]
    joined = np.concatenate(segments)
    return joined[np.random.default_rng(2).permutation(len(joined))]


def test_encloses_counts_the_outline_crossed_towards_the_right_in_any_order_with_holes():
    ring = outline([[10, 10], [90, 12], [95, 80], [12, 88]], [[40, 40], [40, 60], [60, 60], [60, 40]])
    assert encloses(ring, (20.5, 20.5)) and encloses(ring, (80.5, 70.5))
    assert not encloses(ring, (50.5, 50.5))  # in the hole
    assert not encloses(ring, (5.5, 50.5)) and not encloses(ring, (99.5, 50.5))
    assert not encloses(ring, (50.5, 95.5)) and not encloses(ring, (50.5, 2.5))
    assert encloses(ring, (50.0, 30.0))  # level with no corner, right of the left side


def test_crosses_is_any_segment_within_the_margin_of_the_tile():
    square = outline([[10, 10], [90, 10], [90, 90], [10, 90]])
    assert crosses(square, (0, 0, 20, 20)) and crosses(square, (85, 40, 20, 20))
    assert not crosses(square, (30, 30, 40, 40))  # inside, away from every side
    assert crosses(square, (30, 30, 40, 40), margin=25.0)
    assert not crosses(square, (100, 100, 10, 10))
