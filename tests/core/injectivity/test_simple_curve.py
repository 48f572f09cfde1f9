"""core.injectivity.simple_curve: the proof that a closed quadratic B-spline does not cross itself."""

from __future__ import annotations

import numpy as np
import pytest

import core
from app.studies.quality_suite import built_in_shapes, polygon, standard_suite
from core.curves import examples
from core.injectivity.simple_curve import bezier_spans, first_crossing

SIMPLE = {
    "blob": examples.blob(),
    "starfish": examples.starfish(),
    "dumbbell": examples.dumbbell(),
    "triangle": np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]),
    "square polygon": polygon([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]),
    **built_in_shapes(),
}


@pytest.mark.parametrize("name", sorted(SIMPLE))
def test_simple_curves_are_proven_simple(name):
    assert first_crossing(SIMPLE[name]) is None


def test_bezier_spans_are_the_curve():
    points = examples.blob()
    curve = core.ClosedBSpline(points)
    spans = bezier_spans(points)
    u = np.linspace(0.0, 1.0, 7)
    for j in range(curve.n):
        arc = ((1 - u) ** 2)[:, None] * spans[j, 0] + (2 * u * (1 - u))[:, None] * spans[j, 1]
        arc += (u**2)[:, None] * spans[j, 2]
        np.testing.assert_allclose(arc, curve(j + u), atol=1e-14)


def test_a_figure_eight_is_not_simple():
    bow_tie = np.array([[0.0, 0.0], [2.0, 1.0], [2.0, 0.0], [0.0, 1.0]])
    assert first_crossing(bow_tie) is not None


def test_a_polygon_that_touches_itself_is_not_simple():
    # The notch's tip touches the opposite side exactly.
    touching = polygon([[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [1.0, 0.0], [0.0, 1.0]])
    assert first_crossing(touching) is not None


def test_a_cusp_is_not_simple():
    # The two sides of the sharp corner at (1, 0) leave it the same way.
    cusp = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 0.0], [0.0, 0.0001], [0.0, 1.0]])
    assert first_crossing(cusp) is not None


def test_a_retraced_span_is_not_simple():
    retraced = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 0.0], [0.0, 1.0]])
    assert first_crossing(retraced) is not None


def test_agrees_with_the_cage_check_on_the_quality_suite():
    """Every simple target of the suite is proven simple, every one the cage check rejects is not."""
    for domain in standard_suite():
        for deformation in domain.deformations:
            try:
                core.ClosedBSpline(deformation.target)
                valid = True
            except ValueError:
                valid = False
            assert (first_crossing(deformation.target) is None) == valid, (domain.name, deformation.label)


def test_a_tiny_loop_at_a_knot_is_found():
    """Two almost equal control points where the cage turns back over them: a loop far smaller
    than a pixel at the knot between them."""
    points = np.array([[2.0, 2.0], [1.0, 0.1], [0.0, 0.0], [1e-3, 0.0], [1.0, 0.2], [2.0, -2.0], [3.0, 0.0]])
    assert core.curves.bspline.knot_loops(points).shape[0] == 1
    assert first_crossing(points) is not None
