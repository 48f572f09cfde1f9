"""Keyframes and their interpolation in time (app.warp.keyframes)."""

import numpy as np
import pytest

from app.warp.keyframes import Keyframe, frame_times, interpolate, keyframes_json, sorted_keyframes

RNG = np.random.default_rng(11)
POSES = [RNG.uniform(0, 500, size=(7, 2)) for _ in range(4)]
TIMES = [0.0, 0.8, 2.0, 2.5]
KEYFRAMES = tuple(Keyframe(t, pose) for t, pose in zip(TIMES, POSES, strict=True))


@pytest.mark.parametrize("method", ["catmull-rom", "linear"])
def test_interpolation_passes_through_every_keyframe_and_holds_outside(method):
    for keyframe in KEYFRAMES:
        np.testing.assert_array_equal(interpolate(KEYFRAMES, keyframe.time, method), keyframe.target)
    np.testing.assert_array_equal(interpolate(KEYFRAMES, -1.0, method), POSES[0])
    np.testing.assert_array_equal(interpolate(KEYFRAMES, 9.0, method), POSES[-1])


def test_linear_is_the_straight_line_at_constant_speed():
    np.testing.assert_allclose(interpolate(KEYFRAMES, 0.2, "linear"), 0.75 * POSES[0] + 0.25 * POSES[1])


def test_catmull_rom_is_c1_in_time_with_the_catmull_rom_tangent():
    # The velocity at an inner keyframe, from both sides, is (P2 - P0) / (t2 - t0).
    step = 1e-6
    before = (interpolate(KEYFRAMES, 0.8, "catmull-rom") - interpolate(KEYFRAMES, 0.8 - step)) / step
    after = (interpolate(KEYFRAMES, 0.8 + step) - interpolate(KEYFRAMES, 0.8)) / step
    expected = (POSES[2] - POSES[0]) / (2.0 - 0.0)
    np.testing.assert_allclose(before, expected, rtol=1e-4, atol=1e-3)
    np.testing.assert_allclose(after, expected, rtol=1e-4, atol=1e-3)
    # At the ends it starts and stops: zero velocity.
    start = (interpolate(KEYFRAMES, step) - POSES[0]) / step
    np.testing.assert_allclose(start, 0.0, atol=1e-2)


def test_two_keyframes_move_monotonically_along_the_straight_line():
    a, b = POSES[0], POSES[1]
    pair = (Keyframe(0.0, a), Keyframe(1.0, b))
    for method in ("catmull-rom", "linear"):
        samples = np.array([interpolate(pair, t, method) for t in np.linspace(0, 1, 21)])
        fraction = ((samples - a) * (b - a)).sum(axis=2) / ((b - a) ** 2).sum(axis=1)
        assert np.all(np.diff(fraction, axis=0) > 0)
        np.testing.assert_allclose(samples, a + fraction[..., None] * (b - a), atol=1e-9)


def test_frame_times_include_both_ends():
    pair = (Keyframe(0.0, POSES[0]), Keyframe(1.0, POSES[1]))
    np.testing.assert_allclose(frame_times(pair, 10), np.arange(11) / 10)
    odd = frame_times((Keyframe(0.5, POSES[0]), Keyframe(0.75, POSES[1])), 10)
    np.testing.assert_allclose(odd, [0.5, 0.6, 0.7, 0.75])  # the last one is the last keyframe
    assert frame_times(pair[:1], 30).tolist() == [0.0]
    with pytest.raises(ValueError, match="fps must be"):
        frame_times(pair, 0)
    with pytest.raises(ValueError, match="at most 100000"):
        frame_times((Keyframe(0, POSES[0]), Keyframe(86400, POSES[1])), 60)


def test_keyframes_are_checked():
    with pytest.raises(ValueError, match="two keyframes at 1 s"):
        sorted_keyframes([Keyframe(1.0, POSES[0]), Keyframe(1.0, POSES[1])])
    with pytest.raises(ValueError, match="has 7 control points, the cage has 8"):
        sorted_keyframes(KEYFRAMES, 8)
    with pytest.raises(ValueError, match="time must be within"):
        Keyframe(float("nan"), POSES[0])
    with pytest.raises(ValueError, match="NaN or infinite"):
        Keyframe(0.0, np.full((3, 2), np.inf))
    assert [k.time for k in sorted_keyframes(KEYFRAMES[::-1])] == TIMES
    assert keyframes_json(KEYFRAMES[:1]) == [{"time": 0.0, "target": {"control_points": POSES[0].tolist()}}]
