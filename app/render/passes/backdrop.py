"""The backdrop pass: the whole undeformed source image, faded, under the warp (the viewer's
backdrop, ``--outside original``)."""

from __future__ import annotations

import moderngl
import numpy as np

from app.render.passes.gl_state import premultiplied_blending, set_view
from app.render.passes.source_image import SourceImage
from app.render.viewport import View


class BackdropPass:
    """Draws the image as two triangles through a textured program it borrows.

    Parameters
    ----------
    ctx : moderngl.Context
    program : moderngl.Program
        `ImagePass.textured_program`: the same shader, so one program fewer to compile and
        hold; its owner releases it.
    """

    def __init__(self, ctx: moderngl.Context, program: moderngl.Program):
        self._ctx = ctx
        self._program = program
        self._vao: moderngl.VertexArray | None = None
        self._objects: list = []

    def set_image_size(self, size: tuple[int, int]) -> None:
        """Cover an image of (W, H) pixels: texture coordinates 0 to 1 over its corners."""
        self.release()
        width, height = size
        corners = np.array([[0, 0], [width, 0], [0, height], [width, height]], dtype="f4")
        uv = np.array([[0, 0], [1, 0], [0, 1], [1, 1]], dtype="f4")
        quad = self._ctx.buffer(np.hstack([corners, uv]).tobytes())
        self._vao = self._ctx.vertex_array(
            self._program, [(quad, "2f 2f", "in_position", "in_uv")], mode=moderngl.TRIANGLE_STRIP
        )
        self._objects = [self._vao, quad]

    def draw(self, source: SourceImage, view: View, viewport_size: tuple[int, int], opacity: float) -> None:
        """Blend `source` at `opacity` over the bound framebuffer.

        Parameters
        ----------
        source : SourceImage
            The image of the last `set_image_size`.
        view, viewport_size : View, tuple of int
            Where to draw: as for `app.render.passes.gl_state.set_view`.
        opacity : float
            Clamped to [0, 1].
        """
        set_view((self._program,), view, viewport_size)
        premultiplied_blending(self._ctx)
        source.bind(self._program)
        self._program["u_opacity"].value = float(min(max(opacity, 0.0), 1.0))
        self._vao.render()
        source.unbind()
        self._program["u_opacity"].value = 1.0

    def release(self) -> None:
        """Free the quad; `set_image_size` makes a new one."""
        for item in self._objects:
            item.release()
        self._objects = []
        self._vao = None
