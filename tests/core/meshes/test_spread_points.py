"""core.meshes.spread_points: the greedy well-spread subset of the circumcentres of a round."""

import numpy as np

from core.meshes.spread_points import spread_points


def greedy(candidates, radii):
    """The same subset by a plain loop over all pairs."""
    blocked = np.zeros(len(candidates), dtype=bool)
    taken = []
    for i, point in enumerate(candidates):
        if not blocked[i]:
            taken.append(i)
            blocked |= np.linalg.norm(candidates - point, axis=1) <= 0.5 * radii[i]
    return candidates[taken]


def test_spread_points_match_the_greedy_loop():
    rng = np.random.default_rng(8)
    candidates = rng.uniform(0.0, 1.0, (800, 2))
    radii = rng.uniform(0.001, 0.1, 800)
    radii[3] = 0.4  # one wide reach sets the cells' width
    taken = spread_points(candidates, radii)
    np.testing.assert_array_equal(taken, greedy(candidates, radii))
    assert 50 < taken.shape[0] < 700
    assert spread_points(np.zeros((0, 2)), np.zeros(0)).shape == (0, 2)
