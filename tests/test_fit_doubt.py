"""The signs of a doubtful subject in `app.fit_doubt`, on drawn pictures."""

import numpy as np

from app.fit_doubt import colour_separation, salient_overflow


def bar_picture():
    """(rgb (200, 300, 3) uint8, bar (200, 300) bool): a light upright bar on a dark blue sky."""
    rgb = np.empty((200, 300, 3), np.uint8)
    rgb[:] = (30, 45, 90)
    bar = np.zeros((200, 300), bool)
    bar[30:170, 140:160] = True
    rgb[bar] = (200, 190, 160)
    return rgb, bar


def grown(mask, pixels):
    rows, columns = np.nonzero(mask)
    out = np.zeros_like(mask)
    out[
        max(rows.min() - pixels, 0) : rows.max() + 1 + pixels,
        max(columns.min() - pixels, 0) : columns.max() + 1 + pixels,
    ] = True
    return out


def test_a_cage_around_the_whole_salient_region_does_not_overflow():
    rgb, bar = bar_picture()
    everywhere = np.ones(bar.shape, bool)
    assert salient_overflow(rgb, grown(bar, 8), everywhere) == 0.0
    # A cage that meets nothing salient has nothing running out of it.
    corner = np.zeros(bar.shape, bool)
    corner[5:25, 5:45] = True
    assert salient_overflow(rgb, corner, everywhere) == 0.0


def test_a_cage_across_the_salient_region_overflows_by_what_it_leaves_out():
    rgb, bar = bar_picture()
    everywhere = np.ones(bar.shape, bool)
    lower = bar.copy()
    lower[:100] = False  # the cage holds the lower half of the bar
    overflow = salient_overflow(rgb, grown(lower, 8), everywhere)
    assert 0.5 < overflow < 1.5
    lowest = bar.copy()
    lowest[:135] = False  # a quarter of it: about three times as much left out
    assert salient_overflow(rgb, grown(lowest, 8), everywhere) > 2 * overflow
    # What lies outside the rectangle where the subject may be does not count.
    allowed = np.zeros(bar.shape, bool)
    allowed[100:] = True
    assert salient_overflow(rgb, grown(lower, 8), allowed) == 0.0


def test_colour_separation_is_one_for_distinct_colours_and_a_half_for_the_same():
    rgb, bar = bar_picture()
    bgr = np.ascontiguousarray(rgb[..., ::-1])
    ring = grown(bar, 20) & ~grown(bar, 5)
    assert colour_separation(bgr, bar, ring) == 1.0
    plain = np.full_like(bgr, 90)
    assert colour_separation(plain, bar, ring) <= 0.5
    assert colour_separation(bgr, bar, np.zeros_like(bar)) == 0.5  # no background to learn from
