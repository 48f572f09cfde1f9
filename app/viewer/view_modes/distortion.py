"""How much the deformation stretches, shears or folds, per vertex (`app.viewer.distortion_view`)."""

from __future__ import annotations

from app.viewer.view_modes.mode import ViewMode


def field(state, basis, renderer, current):
    """Upload log2 det J or log2 sigma1/sigma2 (V,) for the target shown; sets
    ``state.display.distortion``."""
    from app.viewer.distortion_view import vertex_distortion

    target = state.document.live.target
    signature = ("distortion", basis.key, state.display.distortion_measure, target.tobytes())
    if signature != current:
        values, state.display.distortion = vertex_distortion(
            basis.mesh.vertices,
            basis.mesh.triangles,
            basis.basis,
            basis.gradients,
            target,
            state.display.distortion_measure,
        )
        renderer.set_field(values)
    renderer.set_distortion_measure(state.display.distortion_measure)
    return signature


def legend(state, draw, left: float, top: float, span: float) -> None:
    """The colour bar of the measure and the worst values of the deformation shown."""
    from imgui_bundle import imgui

    from app.render.passes.fields import (
        DISTORTION_FOLDED,
        DISTORTION_GROWN,
        DISTORTION_RANGE,
        DISTORTION_SHEARED,
        DISTORTION_SHRUNK,
    )
    from app.viewer.view_modes.colours import BAR_HEIGHT, colour_bar, packed

    white = (1.0, 1.0, 1.0)
    area = state.display.distortion_measure == "area"
    imgui.text("area change det J" if area else "anisotropy sigma1/sigma2")
    top += 20
    folded = 0.16 * span
    stops = (DISTORTION_SHRUNK, white, DISTORTION_GROWN) if area else (white, DISTORTION_SHEARED)
    width = (span - folded) / (len(stops) - 1)
    pieces = [(0.0, folded, DISTORTION_FOLDED, DISTORTION_FOLDED)]
    pieces += [
        (folded + width * k, folded + width * (k + 1), stops[k], stops[k + 1]) for k in range(len(stops) - 1)
    ]
    full = 2.0**DISTORTION_RANGE
    labels = ((0.0, "fold"), (folded + 4, f"1/{full:g}"), (folded + width - 3, "1"), (span - 8, f"{full:g}"))
    if not area:
        labels = ((0.0, "fold"), (folded + 4, "1"), (span - 8, f"{full:g}"))
    colour_bar(draw, (left, top), span, pieces, labels)
    draw.add_rect((left, top), (left + folded, top + BAR_HEIGHT), packed(white))  # over the fold's colour
    summary = state.display.distortion
    if summary is not None:
        worst = f"min det {summary.min_det:.3g}" if area else f"max {summary.max_ratio:.3g}"
        imgui.text_disabled(f"{worst}, {summary.folded} folded")
        if imgui.is_item_hovered():
            imgui.set_tooltip(
                f"{summary.exact:,} of {summary.vertices:,} vertices exact (from the gradients of the "
                "basis functions); the others from their triangles (FEM harmonic, boundary, or "
                "gradients still being computed)"
            )


MODE = ViewMode(
    "distortion",
    "Distortion (Jacobian)",
    "show the distortion: area change or anisotropy of the Jacobian, folded vertices black",
    "distortion",
    gradients=True,
    field=field,
    legend=legend,
    legend_height=116.0,
)
