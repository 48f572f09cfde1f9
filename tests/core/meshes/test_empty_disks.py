"""core.meshes.empty_disks: the largest empty disks tangent to a sampled curve (local feature size)."""

import numpy as np
import pytest

from core.meshes.empty_disks import empty_disk_radii


def polar_curve(count, depth):
    """Samples (count, 2) of r = 1 + depth cos(5 angle), with unit normals pointing inward."""
    angle = 2 * np.pi * np.arange(count) / count
    radius = 1.0 + depth * np.cos(5 * angle)
    points = np.stack([radius * np.cos(angle), radius * np.sin(angle)], axis=1)
    tangent = np.roll(points, -1, axis=0) - np.roll(points, 1, axis=0)
    tangent /= np.linalg.norm(tangent, axis=1)[:, None]
    return points, np.stack([-tangent[:, 1], tangent[:, 0]], axis=1)


def test_inside_a_circle_the_disk_is_the_circle_and_outside_it_is_the_largest():
    points, inward = polar_curve(400, 0.0)
    none = np.full(400, -1)
    np.testing.assert_allclose(empty_disk_radii(points, inward, none, 3.0), 1.0, rtol=1e-9)
    np.testing.assert_array_equal(empty_disk_radii(points, -inward, none, 3.0), 3.0)
    np.testing.assert_array_equal(empty_disk_radii(points, inward, none, 0.5), 0.5)


@pytest.mark.parametrize("side", [1.0, -1.0])
def test_disks_are_empty_and_touch_a_sample_unless_largest(side):
    points, inward = polar_curve(600, 0.4)
    largest = 1.5
    radii = empty_disk_radii(points, side * inward, np.full(600, -1), largest)
    centres = points + side * radii[:, None] * inward
    distance = np.linalg.norm(centres[:, None] - points[None], axis=2)
    np.fill_diagonal(distance, np.inf)
    assert (distance.min(axis=1) >= radii * (1 - 1e-8)).all()
    touching = distance.min(axis=1) <= radii * (1 + 1e-8)
    assert (touching | (radii == largest)).all()
    assert radii.min() < 0.5 * largest  # the curve's arms do limit disks


def test_samples_of_one_wedge_do_not_limit_each_other():
    # Two straight spans meeting at a right angle: inside the wedge, disks would be limited by
    # the other span; with one wedge index they are not.
    span = np.linspace(0.05, 1.0, 20)
    points = np.concatenate([np.stack([span, 0 * span], axis=1), np.stack([0 * span, span], axis=1)])
    normals = np.concatenate([np.tile([0.0, 1.0], (20, 1)), np.tile([1.0, 0.0], (20, 1))])
    limited = empty_disk_radii(points, normals, np.full(40, -1), 2.0)
    free = empty_disk_radii(points, normals, np.zeros(40, dtype=np.int64), 2.0)
    np.testing.assert_allclose(limited, np.concatenate([span, span]), rtol=1e-12)  # to the other span
    np.testing.assert_array_equal(free, 2.0)
