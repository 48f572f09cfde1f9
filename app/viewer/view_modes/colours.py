"""The legends' colours, as imgui's packed 32-bit integers, and their colour bar."""

from __future__ import annotations


def packed(rgb, alpha: float = 1.0) -> int:
    """RGB in [0, 1] (and an alpha) as imgui's ABGR integer."""
    from imgui_bundle import imgui

    return imgui.get_color_u32(imgui.ImVec4(float(rgb[0]), float(rgb[1]), float(rgb[2]), alpha))


#: Height of a legend's colour bar, pixels; its labels stand under it.
BAR_HEIGHT = 22


def colour_bar(draw, corner: tuple[float, float], span: float, pieces, labels) -> None:
    """Draw a legend's colour bar, `span` pixels wide from `corner` (left, top), with labels under it,
    and take its room in the window.

    Parameters
    ----------
    draw : imgui.ImDrawList
    corner : tuple of float
        (left, top) of the bar, window pixels.
    span : float
    pieces : sequence of (x0, x1, rgb0, rgb1)
        From x0 to x1 (pixels from the left) the colour runs from rgb0 to rgb1 (in [0, 1]).
    labels : sequence of (x, str)
        Each text under the bar, x pixels from the left.
    """
    from imgui_bundle import imgui

    left, top = corner
    for x0, x1, first, last in pieces:
        a, b = packed(first), packed(last)
        draw.add_rect_filled_multi_color((left + x0, top), (left + x1, top + BAR_HEIGHT), a, b, b, a)
    for x, text in labels:
        draw.add_text((left + x, top + BAR_HEIGHT + 4), packed((1.0, 1.0, 1.0)), text)
    imgui.dummy((span, 48))
