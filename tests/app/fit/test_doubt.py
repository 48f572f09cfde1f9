"""The sign of a doubtful subject in `app.fit.doubt`, on a drawn picture."""

import numpy as np

from app.fit.doubt import colour_separation


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


def test_colour_separation_is_one_for_distinct_colours_and_a_half_for_the_same():
    rgb, bar = bar_picture()
    bgr = np.ascontiguousarray(rgb[..., ::-1])
    ring = grown(bar, 20) & ~grown(bar, 5)
    assert colour_separation(bgr, bar, ring) == 1.0
    plain = np.full_like(bgr, 90)
    assert colour_separation(plain, bar, ring) <= 0.5
    assert colour_separation(bgr, bar, np.zeros_like(bar)) == 0.5  # no background to learn from
