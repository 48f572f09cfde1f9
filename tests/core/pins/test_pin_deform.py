"""core.pin_deform: translations and similarities exactly, a proven bound, fixed points, bad input."""

from __future__ import annotations

import numpy as np
import pytest

import core
from core.injectivity.harmonic_parts import complex_derivatives


def wavy_cage(count: int = 16) -> np.ndarray:
    """A curved cage (count, 2) in pixels: an ellipse with a three-fold wave, 400 wide."""
    angle = np.linspace(0.0, 2.0 * np.pi, count, endpoint=False)
    return np.stack([np.cos(angle) * (1.0 + 0.2 * np.cos(3.0 * angle)), 0.8 * np.sin(angle)], 1) * 200 + 300


CAGE = core.ClosedBSpline(wavy_cage())
PINS = np.array([[300.0, 300.0], [380.0, 320.0], [230.0, 280.0], [300.0, 400.0]])
MOVED = PINS + np.array([[0.0, 0.0], [60.0, -40.0], [-20.0, 0.0], [0.0, 30.0]])


def dense_points(curve: core.ClosedBSpline, count: int, near: int, seed: int) -> np.ndarray:
    """`count` points uniform inside the cage and `near` at 10⁻⁵ to 10⁻² diameters from its boundary."""
    rng = np.random.default_rng(seed)
    low, high = curve.control_points.min(axis=0), curve.control_points.max(axis=0)
    inside = np.zeros((0, 2))
    while inside.shape[0] < count:
        x = rng.uniform(low, high, (2 * count, 2))
        inside = np.concatenate([inside, x[curve.contains(x)]])
    t = rng.uniform(0.0, curve.n, near)
    point, first, _ = curve.evaluate(t)
    normal = np.stack([-first[:, 1], first[:, 0]], axis=1) / np.linalg.norm(first, axis=1)[:, None]
    normal *= 1.0 if curve.area > 0 else -1.0
    depth = curve.diameter * 10.0 ** rng.uniform(-5, -2, near)
    edge = point + depth[:, None] * normal
    return np.concatenate([inside[:count], edge[curve.contains(edge)]])


@pytest.mark.parametrize("bound", [None, 2.0])
def test_one_pin_is_the_translation_that_places_it(bound):
    result = core.pin_deform(CAGE, PINS[:1], PINS[:1] + [12.5, -7.0], max_distortion=bound)
    np.testing.assert_allclose(result.target, CAGE.control_points + [12.5, -7.0], atol=1e-7)
    assert result.pin_error[0] < 1e-7 and result.missed.size == 0


@pytest.mark.parametrize("bound", [None, 1.0, 3.0])
def test_two_pins_are_the_similarity_that_places_both(bound):
    turn = np.array([[0.9, -0.3], [0.3, 0.9]])
    shift = np.array([4.0, -3.0])
    result = core.pin_deform(CAGE, PINS[:2], PINS[:2] @ turn.T + shift, max_distortion=bound)
    np.testing.assert_allclose(result.target, CAGE.control_points @ turn.T + shift, atol=1e-6)
    assert np.all(result.pin_error < 1e-6)


def test_many_pins_land_exactly_without_a_bound():
    result = core.pin_deform(CAGE, PINS, MOVED)
    image = core.deform(core.basis_functions(CAGE, PINS), result.target)
    np.testing.assert_allclose(image, MOVED, atol=1e-8)
    assert np.all(result.pin_error < 1e-8) and result.solves == 0


def test_four_pins_with_k_2_are_proven_and_dense_checked():
    result = core.pin_deform(CAGE, PINS, MOVED, max_distortion=2.0)
    certificate = result.certificate
    assert certificate.injective and certificate.k_max <= 1.0 / 3.0 + 1e-6, str(certificate)
    assert result.within_bound and result.proven_distortion <= 2.0 + 1e-5
    points = dense_points(CAGE, 20_000, 5_000, seed=7)
    assert points.shape[0] >= 24_000
    gradients = core.basis_gradients(CAGE, points)  # (M, n, 2), exact
    jacobian = np.einsum("ni,mnj->mij", result.target, gradients)
    singular = np.linalg.svd(jacobian, compute_uv=False)
    assert np.linalg.det(jacobian).min() > 0
    assert (singular[:, 0] / singular[:, 1]).max() <= 2.0 * (1 + 1e-6)
    # Without a bound the same pins fold the picture: the bound is doing the work.
    free = core.pin_deform(CAGE, PINS, MOVED)
    assert not free.certificate.injective
    # Pins land as close as K = 2 allows: far closer than the best similarity's.
    similar = core.pin_deform(CAGE, PINS, MOVED, max_distortion=1.0)
    assert result.pin_error.max() < 0.1 * similar.pin_error.max()


def test_the_bound_is_met_between_the_samples_on_the_curve_inside_the_boundary():
    """At a hundred times the solver's samples, k stays within the certificate's bound."""
    result = core.pin_deform(CAGE, PINS, MOVED, max_distortion=1.5)
    t = np.linspace(0.0, CAGE.n, 800 * CAGE.n, endpoint=False)
    from core.injectivity.inner_curve import offset_points

    points, deeper = offset_points(CAGE, t, 1e-4 * CAGE.diameter)
    f_z, f_zbar, _ = complex_derivatives(CAGE, result.target, np.concatenate([points, deeper]))
    assert (np.abs(f_zbar) / np.abs(f_z)).max() <= result.certificate.k_max <= 0.2 + 1e-6


def test_a_certified_target_does_not_depend_on_the_drag_before_it():
    """The viewer's release after a drag and `warp --session` in a fresh process give one cage."""
    from core.pins.precompute import _KEPT

    core.pin_deform(CAGE, PINS, MOVED, max_distortion=1.5)
    fresh = core.pin_deform(CAGE, PINS, MOVED, max_distortion=1.5).target
    for step in np.linspace(0.0, 1.0, 6)[1:]:
        core.pin_deform(
            CAGE, PINS, PINS + step * (MOVED - PINS) * [1.3, 0.7], max_distortion=1.5, certify=False
        )
    after_drag = core.pin_deform(CAGE, PINS, MOVED, max_distortion=1.5).target
    _KEPT.clear()
    new_process = core.pin_deform(CAGE, PINS, MOVED, max_distortion=1.5).target
    # The same to the conic solver's tolerance (a drag's history moved it by up to 0.55 px).
    np.testing.assert_allclose(after_drag, fresh, rtol=0, atol=1e-4)
    np.testing.assert_allclose(new_process, fresh, rtol=0, atol=1e-4)


@pytest.mark.parametrize("bound", [None, 2.0])
def test_fixed_control_points_stay(bound):
    held = {3: CAGE.control_points[3] + [5.0, 0.0], 9: CAGE.control_points[9]}
    result = core.pin_deform(CAGE, PINS[:3], MOVED[:3], max_distortion=bound, fixed=held)
    for index, point in held.items():
        np.testing.assert_allclose(result.target[index], point, atol=1e-6)
    by_index = core.pin_deform(CAGE, PINS[:3], MOVED[:3], max_distortion=bound, fixed=[9])
    np.testing.assert_allclose(by_index.target[9], CAGE.control_points[9], atol=1e-6)


def test_more_pins_than_the_cage_can_follow_are_least_squares_and_say_which_miss():
    rng = np.random.default_rng(3)
    pins = dense_points(CAGE, 40, 0, seed=3)
    moved = pins + rng.normal(0.0, 20.0, pins.shape)
    result = core.pin_deform(CAGE, pins, moved)
    assert result.missed.size > 0
    assert np.all(result.pin_error[result.missed] > 1e-5 * CAGE.diameter)
    # Least squares: no cage does better for the pins than this one.
    rows = core.basis_functions(CAGE, pins)
    best, *_ = np.linalg.lstsq(rows, moved, rcond=None)
    best_error = np.linalg.norm(rows @ best - moved)
    assert np.linalg.norm(result.pin_error) <= best_error * (1 + 1e-6)


def test_cauchy_green_maps_are_conformal_and_place_the_pins():
    result = core.pin_deform(CAGE, PINS, MOVED, kernel="cauchy-green", max_distortion=1.0)
    points = dense_points(CAGE, 500, 0, seed=5)
    gradients = core.basis_gradients(CAGE, points, "cauchy-green")
    target = result.target[:, 0] + 1j * result.target[:, 1]
    derivative = gradients[:, :, 0] @ target
    assert np.abs(derivative).min() > 0
    assert result.pin_error.max() < 1.0
    assert not result.certificate.injective and "Cauchy-Green" in result.certificate.reason


@pytest.mark.parametrize(
    ("arguments", "message"),
    [
        ({"kernel": "mean-value"}, "pins work with the kernels poisson and cauchy-green, not 'mean-value'"),
        ({"pins": [[0.0, 0.0]], "moved": [[1.0, 1.0]]}, "pin 0 at \\(0, 0\\) is outside the cage"),
        (
            {"pins": [[300.0, 300.0], [300.0, 300.0]], "moved": [[0.0, 0.0], [1.0, 1.0]]},
            "pins 0 and 1 are at one",
        ),
        ({"moved": [[np.nan, 0.0]] * 4}, "moved has 4 point\\(s\\) with NaN or infinite"),
        ({"max_distortion": 0.5}, "max_distortion must be a number >= 1"),
        ({"max_distortion": float("nan")}, "max_distortion must be a number >= 1"),
        ({"fixed": [16]}, "fixed control point 16 is not an index from 0 to 15"),
        ({"moved": MOVED[:3]}, "moved must give one point per pin: 4 pins, 3 moved"),
        ({"pins": np.zeros((0, 2)), "moved": np.zeros((0, 2))}, "pins needs at least 1 points"),
    ],
)
def test_bad_input_is_one_line(arguments, message):
    given = {"pins": PINS, "moved": MOVED, **arguments}
    pins, moved = given.pop("pins"), given.pop("moved")
    with pytest.raises(ValueError, match=message) as raised:
        core.pin_deform(CAGE, pins, moved, **given)
    assert "\n" not in str(raised.value)


@pytest.mark.parametrize("bound", [None, 2.0])
def test_sharp_corners_stay_sharp_and_a_polygon_is_proven(bound):
    square = core.ClosedBSpline(
        np.repeat([[0.0, 0.0], [400.0, 0.0], [400.0, 300.0], [0.0, 300.0]], 2, axis=0)
    )
    pins = np.array([[100.0, 100.0], [300.0, 100.0], [200.0, 250.0]])
    result = core.pin_deform(
        square, pins, pins + [[0.0, 0.0], [30.0, -20.0], [-10.0, 20.0]], max_distortion=bound
    )
    assert np.array_equal(result.target[1::2], result.target[0::2])
    assert result.certificate.injective and np.all(result.pin_error < 1e-3)


def test_a_reflex_corner_is_proven_outside_its_disc_without_endless_tightening():
    shape = np.repeat(
        [[0.0, 0.0], [400.0, 0.0], [400.0, 160.0], [160.0, 160.0], [160.0, 400.0], [0.0, 400.0]], 2, axis=0
    )
    pins = np.array([[80.0, 80.0], [300.0, 80.0], [80.0, 300.0]])
    moved = pins + [[0.0, 0.0], [30.0, -20.0], [-10.0, 20.0]]
    result = core.pin_deform(core.ClosedBSpline(shape), pins, moved, max_distortion=2.0)
    assert result.certificate.away_from_corners and result.certificate.k_max <= 1.0 / 3.0
    assert not result.within_bound and np.all(result.pin_error < 1e-3)
