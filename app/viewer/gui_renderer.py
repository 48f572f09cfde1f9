"""Drawing imgui's widgets: imgui_bundle's glfw renderer, its flat-coloured fill without a texture fetch.

imgui draws everything with one program, ``Frag_Color * texture(atlas, uv)``; a
flat-coloured triangle (a window background, a frame, a button) has all its
texture coordinates on the font atlas's white texel.  Under a software rasteriser
(Mesa llvmpipe) the bilinear fetch is most of imgui's cost: the viewer's panel and
status line are ~320,000 pixels of flat fill and ~20,000 of text, and their fragment
shading took about as much CPU time as the warped 6,000-vertex mesh's (perf, a drag).
`GuiRenderer` draws each command's long runs of flat triangles with a program that
skips the fetch, and everything else with imgui's own, in imgui's order, so the
pixels are the same: at the white texel's centre the fetch returns exactly (1, 1, 1, 1).

Its `render` repeats the GL state handling of imgui_bundle 1.93's
``ProgrammablePipelineRenderer.render``; tests/test_viewer_gui_renderer.py compares
the pixels with the installed renderer's.
"""

from __future__ import annotations

import ctypes

import numpy as np
import OpenGL.GL as gl
from imgui_bundle import imgui
from imgui_bundle.python_backends.glfw_backend import GlfwRenderer
from imgui_bundle.python_backends.opengl_base_backend import get_common_gl_state, restore_common_gl_state

from app.shaders import load_shader

#: A run of flat triangles gets its own draw call from this many pixels of area on: a draw call
#: costs tens of microseconds of Python and GL, the fetch ~10 ns a pixel (llvmpipe, 2 busy cores).
MIN_SOLID_PIXELS = 4096.0


#: imgui's vertex as numpy sees it: position (x, y) and the texture coordinates' 8 bytes.
_VERTEX_LAYOUT = np.dtype(
    {
        "names": ["position", "uv"],
        "formats": [("<f4", 2), "<u8"],
        "offsets": [imgui.VERTEX_BUFFER_POS_OFFSET, imgui.VERTEX_BUFFER_UV_OFFSET],
        "itemsize": imgui.VERTEX_SIZE,
    }
)


def solid_runs(flat: np.ndarray, areas: np.ndarray, min_pixels: float = MIN_SOLID_PIXELS) -> list[tuple]:
    """Split consecutive triangles into runs drawn in order, flat runs marked where they pay.

    Parameters
    ----------
    flat : ndarray of shape (T,), bool
        Whether each triangle is flat-coloured (all its texture coordinates on the white texel).
    areas : ndarray of shape (T,)
        Each triangle's area in pixels.
    min_pixels : float
        A run of flat triangles smaller than this is drawn with its textured neighbours.

    Returns
    -------
    list of (first, count, solid)
        Runs of triangles ``first .. first + count - 1`` covering ``0 .. T - 1`` in order,
        consecutive runs never both textured; ``solid`` runs hold flat triangles only.
    """
    flat = np.asarray(flat, dtype=bool)
    count = len(flat)
    if count == 0:
        return []
    starts = np.flatnonzero(np.r_[True, flat[1:] != flat[:-1]])
    ends = np.r_[starts[1:], count]
    sums = np.add.reduceat(np.asarray(areas, dtype=np.float64), starts)
    solid = flat[starts] & (sums >= min_pixels)
    runs: list[tuple] = []
    done = 0
    for start, end in zip(starts[solid].tolist(), ends[solid].tolist(), strict=True):
        if start > done:
            runs.append((done, start - done, False))
        runs.append((start, end - start, True))
        done = end
    if done < count:
        runs.append((done, count - done, False))
    return runs


def flat_triangles(vertices: np.ndarray, indices: np.ndarray, white: tuple[float, float]) -> tuple:
    """Which triangles of an imgui draw list are flat-coloured, and their areas.

    Parameters
    ----------
    vertices : ndarray of shape (V * VERTEX_SIZE,), uint8
        imgui's vertices (`imgui.VERTEX_SIZE` bytes each): position and texture
        coordinates (2 float32 each, at `imgui.VERTEX_BUFFER_POS_OFFSET` and
        `imgui.VERTEX_BUFFER_UV_OFFSET`) and a colour.
    indices : ndarray of shape (3 T,), uint16 or uint32
    white : tuple of float
        The font atlas's white texel, texture coordinates (u, v).

    Returns
    -------
    flat : ndarray of shape (T,), bool
    areas : ndarray of shape (T,), float32, pixels
    """
    records = np.frombuffer(vertices, dtype=_VERTEX_LAYOUT)
    # Both texture coordinates at once: the 8 bytes of (u, v) compared as one integer.
    on_white = records["uv"] == np.array(white, dtype="<f4").view("<u8")[0]
    a, b, c = np.asarray(indices, dtype=np.intp).reshape(-1, 3).T
    flat = on_white.take(a) & on_white.take(b) & on_white.take(c)
    x, y = np.ascontiguousarray(records["position"].T)
    xa, ya = x.take(a), y.take(a)
    areas = 0.5 * np.abs((x.take(b) - xa) * (y.take(c) - ya) - (x.take(c) - xa) * (y.take(b) - ya))
    return flat, areas


def _white_texel(io) -> tuple[int, tuple[float, float]] | None:
    """(font atlas texture id, white texel uv) if a fetch there returns exactly white, else None.

    That holds when the texel is opaque white and the coordinates are its centre, where a
    bilinear fetch gives the other texels zero weight.
    """
    texture, white = io.fonts.tex_data, io.fonts.tex_uv_white_pixel
    if (
        texture is None
        or texture.status != imgui.ImTextureStatus.ok
        or texture.tex_id == 0
        or texture.format != imgui.ImTextureFormat.rgba32
    ):
        return None
    x, y = white.x * texture.width - 0.5, white.y * texture.height - 0.5
    if x != int(x) or y != int(y) or not (0 <= x < texture.width and 0 <= y < texture.height):
        return None
    pixels = np.asarray(texture.get_pixels_array()).reshape(texture.height, texture.width, 4)
    if not (pixels[int(y), int(x)] == 255).all():
        return None
    return int(texture.tex_id), (white.x, white.y)


class GuiRenderer(GlfwRenderer):
    """imgui_bundle's `GlfwRenderer`, drawing long runs of flat triangles without the texture fetch.

    Input handling, textures and GL state are the base class's; only `render` differs.
    """

    def _create_device_objects(self) -> None:
        super()._create_device_objects()
        program = gl.glCreateProgram()
        for kind, name in (
            (gl.GL_VERTEX_SHADER, "gui_solid.vert.glsl"),
            (gl.GL_FRAGMENT_SHADER, "gui_solid.frag.glsl"),
        ):
            shader = gl.glCreateShader(kind)
            gl.glShaderSource(shader, load_shader(name))
            gl.glCompileShader(shader)
            if not gl.glGetShaderiv(shader, gl.GL_COMPILE_STATUS):
                raise RuntimeError(f"{name}: {gl.glGetShaderInfoLog(shader).decode(errors='replace')}")
            gl.glAttachShader(program, shader)
            gl.glDeleteShader(shader)
        # The base class's vertex array is read at its own program's locations.
        gl.glBindAttribLocation(program, self._attrib_location_position, "Position")
        gl.glBindAttribLocation(program, self._attrib_location_color, "Color")
        gl.glLinkProgram(program)
        if not gl.glGetProgramiv(program, gl.GL_LINK_STATUS):
            raise RuntimeError(f"gui_solid: {gl.glGetProgramInfoLog(program).decode(errors='replace')}")
        self._solid_handle = program
        self._solid_proj_mtx = gl.glGetUniformLocation(program, "ProjMtx")

    def _invalidate_device_objects(self) -> None:
        gl.glDeleteProgram(self._solid_handle)
        self._solid_handle = 0
        super()._invalidate_device_objects()

    def render(self, draw_data: imgui.ImDrawData) -> None:
        """Draw `draw_data` into the bound framebuffer: the base class's `render`, command by
        command in the same order and state, flat runs (`solid_runs`) with the fetch-free program."""
        io = self.io
        display_width, display_height = io.display_size
        fb_width = int(display_width * io.display_framebuffer_scale[0])
        fb_height = int(display_height * io.display_framebuffer_scale[1])
        self._update_textures()
        if fb_width == 0 or fb_height == 0:
            return
        draw_data.scale_clip_rects(io.display_framebuffer_scale)
        white = _white_texel(io)

        common_state = get_common_gl_state()
        last_program = gl.glGetIntegerv(gl.GL_CURRENT_PROGRAM)
        last_active_texture = gl.glGetIntegerv(gl.GL_ACTIVE_TEXTURE)
        last_array_buffer = gl.glGetIntegerv(gl.GL_ARRAY_BUFFER_BINDING)
        last_element_array_buffer = gl.glGetIntegerv(gl.GL_ELEMENT_ARRAY_BUFFER_BINDING)
        last_vertex_array = gl.glGetIntegerv(gl.GL_VERTEX_ARRAY_BINDING)

        gl.glEnable(gl.GL_BLEND)
        gl.glBlendEquation(gl.GL_FUNC_ADD)
        gl.glBlendFunc(gl.GL_SRC_ALPHA, gl.GL_ONE_MINUS_SRC_ALPHA)
        gl.glDisable(gl.GL_CULL_FACE)
        gl.glDisable(gl.GL_DEPTH_TEST)
        gl.glEnable(gl.GL_SCISSOR_TEST)
        gl.glActiveTexture(gl.GL_TEXTURE0)
        gl.glPolygonMode(gl.GL_FRONT_AND_BACK, gl.GL_FILL)
        gl.glViewport(0, 0, int(fb_width), int(fb_height))
        # imgui's orthographic projection, column-major.
        projection = (ctypes.c_float * 16)(
            2.0 / display_width, 0.0, 0.0, 0.0,
            0.0, 2.0 / -display_height, 0.0, 0.0,
            0.0, 0.0, -1.0, 0.0,
            -1.0, 1.0, 0.0, 1.0,
        )  # fmt: skip
        gl.glUseProgram(self._solid_handle)
        gl.glUniformMatrix4fv(self._solid_proj_mtx, 1, gl.GL_FALSE, projection)
        gl.glUseProgram(self._shader_handle)
        gl.glUniform1i(self._attrib_location_tex, 0)
        gl.glUniformMatrix4fv(self._attrib_proj_mtx, 1, gl.GL_FALSE, projection)
        gl.glBindVertexArray(self._vao_handle)
        index_type = gl.GL_UNSIGNED_SHORT if imgui.INDEX_SIZE == 2 else gl.GL_UNSIGNED_INT
        index_dtype = np.uint16 if imgui.INDEX_SIZE == 2 else np.uint32

        for commands in draw_data.cmd_lists:
            vertex_bytes = commands.vtx_buffer.size() * imgui.VERTEX_SIZE
            index_count = commands.idx_buffer.size()
            gl.glBindBuffer(gl.GL_ARRAY_BUFFER, self._vbo_handle)
            gl.glBufferData(
                gl.GL_ARRAY_BUFFER,
                vertex_bytes,
                ctypes.c_void_p(commands.vtx_buffer.data_address()),
                gl.GL_STREAM_DRAW,
            )
            gl.glBindBuffer(gl.GL_ELEMENT_ARRAY_BUFFER, self._elements_handle)
            gl.glBufferData(
                gl.GL_ELEMENT_ARRAY_BUFFER,
                index_count * imgui.INDEX_SIZE,
                ctypes.c_void_p(commands.idx_buffer.data_address()),
                gl.GL_STREAM_DRAW,
            )
            flat = areas = None
            if white is not None and index_count:
                vertices = (ctypes.c_uint8 * vertex_bytes).from_address(commands.vtx_buffer.data_address())
                indices = np.frombuffer(
                    (ctypes.c_uint8 * (index_count * imgui.INDEX_SIZE)).from_address(
                        commands.idx_buffer.data_address()
                    ),
                    dtype=index_dtype,
                )
                flat, areas = flat_triangles(vertices, indices, white[1])
            current = self._shader_handle
            for command in commands.cmd_buffer:
                texture = command.tex_ref.get_tex_id()
                gl.glBindTexture(gl.GL_TEXTURE_2D, texture)
                x, y, z, w = command.clip_rect
                gl.glScissor(int(x), int(fb_height - w), int(z - x), int(w - y))
                first, count = command.idx_offset // 3, command.elem_count // 3
                if flat is None or texture != white[0]:
                    runs = [(0, count, False)]
                else:
                    runs = solid_runs(flat[first : first + count], areas[first : first + count])
                for start, length, solid in runs:
                    program = self._solid_handle if solid else self._shader_handle
                    if program != current:
                        gl.glUseProgram(program)
                        current = program
                    gl.glDrawElements(
                        gl.GL_TRIANGLES,
                        3 * length,
                        index_type,
                        ctypes.c_void_p((command.idx_offset + 3 * start) * imgui.INDEX_SIZE),
                    )
            if current != self._shader_handle:
                gl.glUseProgram(self._shader_handle)

        restore_common_gl_state(common_state)
        gl.glUseProgram(last_program)
        gl.glActiveTexture(last_active_texture)
        gl.glBindVertexArray(last_vertex_array)
        gl.glBindBuffer(gl.GL_ARRAY_BUFFER, last_array_buffer)
        gl.glBindBuffer(gl.GL_ELEMENT_ARRAY_BUFFER, last_element_array_buffer)
