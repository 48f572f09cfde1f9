"""core.meshes.encroachment: points inside the diametral circles of boundary chords."""

import numpy as np
import pytest

from core.meshes.encroachment import encroached_chords


@pytest.mark.parametrize("spread", [1.0, 1e-3])
def test_encroached_chords_match_a_search_of_all_circles(spread):
    rng = np.random.default_rng(4)
    points = rng.uniform(-1.0, 1.0, (2000, 2))
    centres = rng.uniform(-1.0, 1.0, (300, 2))
    radii = rng.uniform(0.0, 0.08, 300) * spread  # a small spread: tiny circles, many empty cells
    radii[0] = 0.3  # one large circle sets the cells' width
    inside = np.linalg.norm(points[:, None] - centres[None], axis=2) < radii[None] * (1 - 1e-12)
    found = encroached_chords(points, centres, radii)
    expected = np.where(inside.any(axis=1), 299 - np.argmax(inside[:, ::-1], axis=1), -1)
    assert (expected >= 0).sum() > 50
    np.testing.assert_array_equal(found, expected)


def test_a_point_on_a_circle_does_not_encroach():
    centres = np.array([[0.0, 0.0]])
    points = np.array([[0.5, 0.0], [0.0, -0.5], [0.3, 0.3], [0.4, 0.4]])
    assert encroached_chords(points, centres, np.array([0.5])).tolist() == [-1, -1, 0, -1]
    assert encroached_chords(np.zeros((0, 2)), centres, np.array([0.5])).size == 0
