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
    from app.viewer.view_modes.colours import colour_bar

    index = state.selection.selected if state.selection.selected is not None else 0
    imgui.text(f"basis function G_{index} (Fig. 8)")
    negative = 0.12 * span
    stops = len(HEAT_STOPS) - 1
    width = (span - negative) / stops
    pieces = [(0.0, negative, HEAT_NEGATIVE, HEAT_NEGATIVE)]
    pieces += [
        (negative + width * k, negative + width * (k + 1), HEAT_STOPS[k], HEAT_STOPS[k + 1])
        for k in range(stops)
    ]
    colour_bar(draw, (left, top + 20), span, pieces, ((0.0, "<0"), (negative, "0"), (span - 6, "1")))
    imgui.text_disabled("isolines every 0.1, white at 0")


MODE = ViewMode(
    "basis",
    "Basis function G_i (Fig. 8)",
    "show the selected point's basis function",
    "heat",
    field=field,
    legend=legend,
)
