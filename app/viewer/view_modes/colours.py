"""Colours of the legends as imgui's packed 32-bit integers."""

from __future__ import annotations


def packed(rgb, alpha: float = 1.0) -> int:
    """RGB in [0, 1] (and an alpha) as imgui's ABGR integer."""
    from imgui_bundle import imgui

    return imgui.get_color_u32(imgui.ImVec4(float(rgb[0]), float(rgb[1]), float(rgb[2]), alpha))
