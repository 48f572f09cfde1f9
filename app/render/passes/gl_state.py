"""The GL state every pass draws with: a view's uniforms and premultiplied-alpha blending."""

from __future__ import annotations

from collections.abc import Iterable

import moderngl

from app.render.viewport import View


def set_view(programs: Iterable[moderngl.Program], view: View, viewport_size: tuple[int, int]) -> None:
    """Write the uniforms of `view` into each program that has them.

    Parameters
    ----------
    programs : iterable of moderngl.Program
        Programs with any of ``u_scale``, ``u_offset`` and ``u_viewport``.
    view : View
        Image-to-framebuffer transform.
    viewport_size : tuple of int
        (width, height) of the viewport in framebuffer pixels.
    """
    values = {
        "u_scale": float(view.scale),
        "u_offset": (float(view.offset[0]), float(view.offset[1])),
        "u_viewport": (float(viewport_size[0]), float(viewport_size[1])),
    }
    for program in programs:
        for name, value in values.items():
            member = program.get(name, None)
            if member is not None:
                member.value = value


def premultiplied_blending(ctx: moderngl.Context) -> None:
    """Blend premultiplied colours over the framebuffer, without depth test or face culling."""
    ctx.disable(moderngl.DEPTH_TEST | moderngl.CULL_FACE)
    ctx.enable(moderngl.BLEND)
    ctx.blend_func = moderngl.ONE, moderngl.ONE_MINUS_SRC_ALPHA
