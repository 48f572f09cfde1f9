"""A height interpolant in bands (the paper's Fig. 1): G @ heights of a wave around the cage."""

from __future__ import annotations

from app.viewer.view_modes.mode import ViewMode


def field(state, basis, renderer, current):
    """Upload G @ h (V,) for the wave heights h of `core.curves.examples.wave_heights`."""
    from core import wave_heights

    signature = ("height", basis.key)
    if signature != current:
        renderer.set_field((basis.basis @ wave_heights(basis.basis.shape[1])).real)
    return signature


def legend(state, draw, left: float, top: float, span: float) -> None:
    """The bands' colours, [k, k+1]/10."""
    from imgui_bundle import imgui

    from app.render.passes.fields import BAND_COLOURS, BAND_START, BAND_WIDTH
    from app.viewer.view_modes.colours import colour_bar

    imgui.text("height, bands [k, k+1]/10 (Fig. 1)")
    count = len(BAND_COLOURS)
    pieces = [(span * k / count, span * (k + 1) / count, rgb, rgb) for k, rgb in enumerate(BAND_COLOURS)]
    labels = [(span * k / count - 6, f"{BAND_START + k * BAND_WIDTH:.1f}") for k in (1, 6, 11)]
    colour_bar(draw, (left, top + 20), span, pieces, labels)
    imgui.text_disabled("red < 0, green > 1")


MODE = ViewMode(
    "height",
    "Height interpolant (Fig. 1)",
    "show a height interpolant in bands (Fig. 1)",
    "field",
    field=field,
    legend=legend,
)
