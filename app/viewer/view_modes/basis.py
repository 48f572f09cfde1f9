"""One basis function G_i as a heat map (the paper's Fig. 8): the selected control point's."""

from __future__ import annotations

from app.viewer.view_modes.mode import ViewMode


def field(state, basis, renderer, current):
    """Upload G_i (V,) of the selected control point (the first if none)."""
    index = state.selection.selected if state.selection.selected is not None else 0
    signature = ("basis", basis.key, index)
    if signature != current and index < basis.basis.shape[1]:
        renderer.set_field(basis.basis[:, index].real)
        return signature
    return current


def legend(state, draw, left: float, top: float, span: float) -> None:
    """The heat map's colours: negative values, then 0 to 1."""
    from imgui_bundle import imgui

    from app.render.passes.fields import HEAT_NEGATIVE, HEAT_STOPS
    from app.viewer.view_modes.colours import packed

    index = state.selection.selected if state.selection.selected is not None else 0
    imgui.text(f"basis function G_{index} (Fig. 8)")
    top += 20
    negative = 0.12 * span
    draw.add_rect_filled((left, top), (left + negative, top + 22), packed(HEAT_NEGATIVE))
    stops = len(HEAT_STOPS) - 1
    for k in range(stops):
        x0 = left + negative + (span - negative) * k / stops
        x1 = left + negative + (span - negative) * (k + 1) / stops
        a, b = packed(HEAT_STOPS[k]), packed(HEAT_STOPS[k + 1])
        draw.add_rect_filled_multi_color((x0, top), (x1, top + 22), a, b, b, a)
    for value, x in (("<0", left), ("0", left + negative), ("1", left + span - 6)):
        draw.add_text((x, top + 26), packed((1, 1, 1)), value)
    imgui.dummy((span, 48))
    imgui.text_disabled("isolines every 0.1, white at 0")


MODE = ViewMode(
    "basis",
    "Basis function G_i (Fig. 8)",
    "show the selected point's basis function",
    "heat",
    field=field,
    legend=legend,
)
