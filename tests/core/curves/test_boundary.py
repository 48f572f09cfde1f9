"""core.Boundary: generic sampled curves, Hermite interpolation, validation."""

from __future__ import annotations

import numpy as np
import pytest
from support.shapes import circle  # noqa: F401

import core


def test_hermite_interpolation_between_samples_is_sixth_order():
    errors = []
    for count in (32, 64):
        boundary = circle(count)
        t = np.linspace(0, 2 * np.pi, 1001)
        exact = np.stack([np.cos(t), np.sin(t)], axis=1)
        errors.append(np.abs(boundary.evaluate(t)[0] - exact).max())
    assert errors[0] < 2e-9
    assert errors[0] / errors[1] > 2**5.5


def test_sample_of_a_bspline_keeps_the_exact_curve(blob):
    boundary = blob.sample(10)
    t = np.random.default_rng(0).uniform(0, blob.n, 100)
    np.testing.assert_allclose(boundary.evaluate(t)[0], blob(t), atol=1e-15)
    assert boundary.count == 10 * blob.n
    assert boundary.step == pytest.approx(0.1)
    assert boundary.period == pytest.approx(blob.n)


def test_refined_boundary_samples_the_same_curve(blob):
    boundary = blob.sample(10)
    finer = boundary.refined(4)
    assert finer.count == 4 * boundary.count
    np.testing.assert_allclose(finer.points[::4], boundary.points, atol=1e-15)


def test_second_derivative_at_knots_is_the_mean_of_both_sides(blob):
    boundary = blob.sample(4)
    left = blob.derivative(np.array([1.0 - 1e-12]), 2)
    right = blob.derivative(np.array([1.0 + 1e-12]), 2)
    np.testing.assert_allclose(boundary.second_derivatives[4], 0.5 * (left + right)[0], atol=1e-9)


@pytest.mark.parametrize(
    ("arguments", "message"),
    [
        (([[0, 0], [1, 0]], [[1, 0], [0, 1]], [[0, 0], [0, 0]], 0.1), "at least 3"),
        (([[0, 0], [1, 0], [0, 1]], [[1, 0], [0, 1]], [[0, 0]] * 3, 0.1), "same length"),
        (([[0, 0], [1, 0], [0, 1]], [[1, 0]] * 3, [[0, 0]] * 3, 0.0), "step must be a finite number > 0"),
        (([[0, 0], [1, 0], [2, 0]], [[1, 0]] * 3, [[0, 0]] * 3, 0.1), "collinear"),
        (([[0, 0], [1, 0], [np.inf, 1]], [[1, 0]] * 3, [[0, 0]] * 3, 0.1), "NaN or infinite"),
    ],
)
def test_invalid_boundaries_are_rejected(arguments, message):
    with pytest.raises(ValueError, match=message):
        core.Boundary(*arguments)
