"""The overlay pass: antialiased lines and round handles drawn on top of everything, for the
curves, control polygons and control points of the paper's Fig. 11."""

from __future__ import annotations

import moderngl
import numpy as np

from app.render.passes.gl_state import premultiplied_blending, set_view
from app.render.shaders import load_shader
from app.render.viewport import View

#: Floats per overlay vertex: x, y (image pixels), r, g, b, a (straight alpha),
#: size (line width or handle diameter, framebuffer pixels).
OVERLAY_FLOATS = 7


class OverlayPass:
    """The line and handle programs and the one buffer of both, grown by doubling.

    Parameters
    ----------
    ctx : moderngl.Context
        The context of the programs and the buffer, freed in `release`.
    """

    def __init__(self, ctx: moderngl.Context):
        self._ctx = ctx
        self._line_program = ctx.program(
            vertex_shader=load_shader("overlay_line.vert.glsl"),
            geometry_shader=load_shader("overlay_line.geom.glsl"),
            fragment_shader=load_shader("overlay_line.frag.glsl"),
        )
        self._point_program = ctx.program(
            vertex_shader=load_shader("overlay_point.vert.glsl"),
            fragment_shader=load_shader("overlay_point.frag.glsl"),
        )
        self._programs = [self._line_program, self._point_program]
        self._objects: list = []
        self._capacity = 0
        self._counts = (0, 0)

    def set(self, segments: np.ndarray, points: np.ndarray) -> None:
        """Set the lines and handles that `draw` draws (rewritten in place); their layout is
        `app.render.renderer.WarpRenderer.set_overlay`'s."""
        segments = np.asarray(segments, dtype="f4").reshape(-1, OVERLAY_FLOATS)
        points = np.asarray(points, dtype="f4").reshape(-1, OVERLAY_FLOATS)
        if len(segments) % 2:
            raise ValueError("segments must have shape (S, 2, 7)")
        data = np.concatenate([segments, points])
        if not np.isfinite(data).all():
            raise ValueError("overlay data contain NaN or infinite values")
        if len(data) > self._capacity:
            # Grows by doubling, so that vertex arrays are rebuilt only a few times
            # in a session (when the control points multiply), never per drag.
            self._release_buffer()
            capacity = max(1024, 2 * len(data))
            buffer = self._ctx.buffer(reserve=capacity * OVERLAY_FLOATS * 4, dynamic=True)
            layout = (buffer, "2f 4f 1f", "in_position", "in_colour", "in_size")
            self._line_vao = self._ctx.vertex_array(self._line_program, [layout], mode=moderngl.LINES)
            self._point_vao = self._ctx.vertex_array(self._point_program, [layout], mode=moderngl.POINTS)
            self._buffer = buffer
            self._objects = [self._line_vao, self._point_vao, buffer]
            self._capacity = capacity
        if len(data):
            self._buffer.write(np.ascontiguousarray(data))
        self._counts = (len(segments), len(points))

    def draw(self, view: View, viewport_size: tuple[int, int]) -> None:
        """Draw the lines and handles of `set` into the bound framebuffer
        (`app.render.renderer.WarpRenderer.draw_overlay`)."""
        line_vertices, point_count = self._counts
        if not (line_vertices or point_count):
            return
        set_view((self._line_program, self._point_program), view, viewport_size)
        premultiplied_blending(self._ctx)
        if line_vertices:
            self._line_vao.render(vertices=line_vertices)
        if point_count:
            self._ctx.enable(moderngl.PROGRAM_POINT_SIZE)
            self._point_vao.render(vertices=point_count, first=line_vertices)
            self._ctx.disable(moderngl.PROGRAM_POINT_SIZE)

    def release(self) -> None:
        self._release_buffer()
        for program in self._programs:
            program.release()
        self._programs = []

    def _release_buffer(self) -> None:
        for item in self._objects:
            item.release()
        self._objects = []
        self._capacity = 0
        self._counts = (0, 0)
