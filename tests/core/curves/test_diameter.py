"""Tests of core.curves.diameter: the exact diameter of a point set in O(N log N)."""

import tracemalloc

import numpy as np
import pytest

from core.curves.diameter import point_set_diameter


def brute_force(points):
    difference = points[:, None, :] - points[None, :, :]
    return float(np.sqrt((difference**2).sum(-1).max()))


def point_sets(seed):
    rng = np.random.default_rng(seed)
    for trial in range(200):
        count = int(rng.integers(2, 150))
        angles = np.sort(rng.uniform(0.0, 2 * np.pi, count))
        yield {
            0: rng.normal(size=(count, 2)),
            # every point on the hull, far from the origin (rounding in the angles matters)
            1: np.c_[np.cos(angles), 0.3 * np.sin(angles)] * 1e3 + 5e5,
            # many ties: points of a small integer grid
            2: rng.integers(0, 5, size=(count, 2)).astype(np.float64),
            # collinear: no hull, the fallback
            3: np.outer(rng.uniform(size=count), [1.0, 2.0]) - 7.0,
        }[trial % 4]


def test_matches_brute_force_exactly_on_small_sets():
    for points in point_sets(seed=5):
        assert point_set_diameter(points) == brute_force(points)


@pytest.mark.parametrize("points", [np.zeros((0, 2)), np.ones((1, 2)), np.ones((4, 2))])
def test_fewer_than_two_distinct_points(points):
    assert point_set_diameter(points) == 0.0


def test_memory_is_linear_for_points_all_on_the_hull():
    # 320,000 points on an ellipse, all hull vertices: pairwise differences would take 1.6 TB.
    angles = np.linspace(0.0, 2 * np.pi, 320_000, endpoint=False)
    points = np.c_[3.0 * np.cos(angles), np.sin(angles)]
    tracemalloc.start()
    try:
        diameter = point_set_diameter(points)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert diameter == 6.0  # the points at angles 0 and pi, exactly
    assert peak < 40 * points.nbytes  # 200 MB: linear in N with a generous constant


def test_the_plain_hull_and_qhulls_give_the_same_diameter(monkeypatch):
    import core.curves.diameter as diameter

    for points in point_sets(seed=8):
        plain = point_set_diameter(points)
        monkeypatch.setattr(diameter, "PLAIN_HULL_POINTS", 0)  # Qhull for every set
        assert point_set_diameter(points) == plain
        monkeypatch.undo()


def test_a_cages_diameter_imports_no_scipy_spatial():
    import subprocess
    import sys

    code = (
        "import sys, numpy as np; from core.curves.diameter import point_set_diameter; "
        "point_set_diameter(np.random.default_rng(1).normal(size=(5000, 2))); "
        "print('scipy.spatial' in sys.modules)"
    )
    from support.paths import ROOT

    result = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "False"
