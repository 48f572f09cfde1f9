"""Drawing imgui's widgets through moderngl: imgui_bundle's renderer, its flat-coloured fill
without a texture fetch.

imgui draws everything with one program, ``Frag_Color * texture(atlas, uv)``; a
flat-coloured triangle (a window background, a frame, a button) has all its
texture coordinates on the font atlas's white texel.  Under a software rasteriser
(Mesa llvmpipe) the bilinear fetch is most of imgui's cost: the viewer's panel and
status line are ~320,000 pixels of flat fill and ~20,000 of text, and their fragment
shading took about as much CPU time as the warped 6,000-vertex mesh's (perf, a drag).
`GuiRenderer` draws each command's long runs of flat triangles with a program that
skips the fetch, and everything else with imgui's own, in imgui's order, so the
pixels are the same: at the white texel's centre the fetch returns exactly (1, 1, 1, 1).

It draws through moderngl rather than imgui_bundle's PyOpenGL calls: those cost
~3 ms of Python a frame (state queried and restored, every call checked for errors),
a fifth of a 60 Hz frame.  tests/app/viewer/test_gui_renderer.py compares the pixels
with imgui_bundle 1.93's ``ProgrammablePipelineRenderer.render``.
"""

from __future__ import annotations

import ctypes

import glfw
import moderngl
import numpy as np
from imgui_bundle import imgui
from imgui_bundle.python_backends import compute_fb_scale
from imgui_bundle.python_backends.glfw_backend import GlfwRenderer

from app.render.shaders import load_shader

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
    """imgui_bundle's `GlfwRenderer`, drawing through moderngl, long runs of flat triangles without
    the texture fetch.

    Input handling and the font atlas's texture are the base class's; `render` is this class's.
    The base class's own GL objects are kept, so that its `render` can still draw a frame for
    comparison (tests/app/viewer/test_gui_renderer.py).

    Parameters
    ----------
    window : glfw window
        Its context is current, and `ctx` is a moderngl context on it.
    ctx : moderngl.Context
    """

    def __init__(self, window, ctx: moderngl.Context):
        self._ctx = ctx
        super().__init__(window)
        self._focused = bool(glfw.get_window_attrib(window, glfw.FOCUSED))
        glfw.set_window_focus_callback(window, self._focus_callback)

    def _focus_callback(self, window, focused: int) -> None:
        self._focused = bool(focused)

    def mouse_callback(self, window, x: float, y: float) -> None:
        """The base class's: the pointer for imgui while the window has the focus, else none; from
        the event's own position and the focus its callback keeps (the base class asked the X
        server for both on every pointer motion, two round trips an event)."""
        if self._focused:
            self.io.add_mouse_pos_event(x, y)
        else:
            self.io.add_mouse_pos_event(-1, -1)

    def _create_device_objects(self) -> None:
        super()._create_device_objects()
        ctx = self._ctx
        self._textured = ctx.program(
            vertex_shader=load_shader("gui.vert.glsl"), fragment_shader=load_shader("gui.frag.glsl")
        )
        self._textured["Texture"].value = 0
        self._solid = ctx.program(
            vertex_shader=load_shader("gui_solid.vert.glsl"),
            fragment_shader=load_shader("gui_solid.frag.glsl"),
        )
        self._buffers: list = []  # vertices, indices and their two vertex arrays, grown on demand
        self._textures: dict[int, moderngl.Texture] = {}  # imgui's GL texture names, wrapped
        self._display: tuple | None = None  # the display size ProjMtx was written for

    def _invalidate_device_objects(self) -> None:
        for item in (*self._buffers, self._textured, self._solid):
            item.release()
        self._buffers = []
        super()._invalidate_device_objects()

    def process_inputs(self, window_size: tuple[int, int], framebuffer_size: tuple[int, int]) -> None:
        """The base class's `process_inputs` with the sizes given (kept by the caller's glfw size
        callbacks) instead of asked of the window system every frame."""
        io = self.io
        io.display_size = imgui.ImVec2(*window_size)
        io.display_framebuffer_scale = imgui.ImVec2(*compute_fb_scale(window_size, framebuffer_size))
        now = glfw.get_time()
        io.delta_time = now - self._gui_time if self._gui_time else 1.0 / 60.0
        if io.delta_time <= 0.0:
            io.delta_time = 1.0 / 1000.0
        self._gui_time = now

    def render(self, draw_data: imgui.ImDrawData) -> None:
        """Draw `draw_data` into the bound framebuffer as imgui_bundle's renderer does (the same
        programs, blending and scissors, command by command in order), flat runs (`solid_runs`)
        with the fetch-free program; all lists' vertices are uploaded in one write.

        Leaves blending on (``SRC_ALPHA, ONE_MINUS_SRC_ALPHA``), depth test and culling off, and
        the scissor test off; whoever draws next sets the state it needs.
        """
        io = self.io
        display_width, display_height = io.display_size
        fb_width = int(display_width * io.display_framebuffer_scale[0])
        fb_height = int(display_height * io.display_framebuffer_scale[1])
        self._update_textures()
        if fb_width == 0 or fb_height == 0 or draw_data.total_idx_count == 0:
            return
        draw_data.scale_clip_rects(io.display_framebuffer_scale)
        lists = draw_data.cmd_lists
        vertices, indices, list_starts = _concatenated(lists)
        white = _white_texel(io)
        flat = areas = None
        if white is not None:
            flat, areas = flat_triangles(vertices, indices, white[1])
        textured, solid = self._upload(vertices, indices)
        self._set_projection(display_width, display_height)

        ctx = self._ctx
        ctx.enable_only(moderngl.BLEND)
        ctx.blend_equation = moderngl.FUNC_ADD
        ctx.blend_func = moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA
        ctx.viewport = (0, 0, fb_width, fb_height)
        for commands, list_start in zip(lists, list_starts, strict=True):
            for command in commands.cmd_buffer:
                x, y, z, w = command.clip_rect
                if z <= x or w <= y:
                    continue
                texture = command.tex_ref.get_tex_id()
                self._texture(texture).use(location=0)
                ctx.scissor = (int(x), int(fb_height - w), int(z - x), int(w - y))
                first, count = list_start + command.idx_offset // 3, command.elem_count // 3
                if flat is None or texture != white[0]:
                    runs = [(0, count, False)]
                else:
                    runs = solid_runs(flat[first : first + count], areas[first : first + count])
                for start, length, fill in runs:
                    (solid if fill else textured).render(
                        moderngl.TRIANGLES, vertices=3 * length, first=3 * (first + start)
                    )
        ctx.scissor = None

    def _upload(self, vertices: np.ndarray, indices: np.ndarray) -> tuple:
        """Write the frame's vertices and indices, growing the buffers by doubling; returns the
        (textured, solid) vertex arrays reading them."""
        if (
            not self._buffers
            or vertices.nbytes > self._buffers[0].size
            or indices.nbytes > self._buffers[1].size
        ):
            for item in self._buffers:
                item.release()
            ctx = self._ctx
            vbo = ctx.buffer(reserve=max(2 * vertices.nbytes, 1 << 16), dynamic=True)
            ibo = ctx.buffer(reserve=max(2 * indices.nbytes, 1 << 15), dynamic=True)
            layout = f"2f 2f 4f1 {imgui.VERTEX_SIZE - 20}x" if imgui.VERTEX_SIZE > 20 else "2f 2f 4f1"
            textured = ctx.vertex_array(
                self._textured,
                [(vbo, layout, "Position", "UV", "Color")],
                index_buffer=ibo,
                index_element_size=4,
            )
            solid = ctx.vertex_array(
                self._solid,
                [(vbo, layout.replace("2f 2f", "2f 8x", 1), "Position", "Color")],
                index_buffer=ibo,
                index_element_size=4,
            )
            self._buffers = [vbo, ibo, textured, solid]
        vbo, ibo, textured, solid = self._buffers
        # New storage each frame: a software rasteriser may still be reading the last frame's.
        vbo.orphan()
        ibo.orphan()
        vbo.write(vertices)
        ibo.write(indices)
        return textured, solid

    def _set_projection(self, width: float, height: float) -> None:
        """imgui's orthographic projection for a `width` x `height` display, in both programs."""
        if self._display == (width, height):
            return
        projection = np.array(
            [
                [2.0 / width, 0.0, 0.0, 0.0],
                [0.0, 2.0 / -height, 0.0, 0.0],
                [0.0, 0.0, -1.0, 0.0],
                [-1.0, 1.0, 0.0, 1.0],
            ],
            dtype="f4",
        )  # column-major, as GL reads it
        for program in (self._textured, self._solid):
            program["ProjMtx"].write(projection.tobytes())
        self._display = (width, height)

    def _texture(self, name: int) -> moderngl.Texture:
        """imgui's texture `name` (a GL texture the base class made) as a moderngl object."""
        texture = self._textures.get(name)
        if texture is None:
            # Only bound by name: the size and format given here are not used.
            texture = self._textures[name] = self._ctx.external_texture(name, (1, 1), 4, 0, "f1")
        return texture


def _concatenated(lists) -> tuple[np.ndarray, np.ndarray, list[int]]:
    """All draw lists' vertices and indices in one pair of arrays.

    Returns
    -------
    vertices : ndarray of shape (V * VERTEX_SIZE,), uint8
    indices : ndarray of shape (3 T,), uint32
        Each list's indices shifted by the vertices of the lists before it.
    list_starts : list of int
        The first triangle of each list in `indices`.
    """
    vertex_parts, index_parts, list_starts = [], [], []
    vertex_count = triangle_count = 0
    index_dtype = np.uint16 if imgui.INDEX_SIZE == 2 else np.uint32
    for commands in lists:
        count = commands.vtx_buffer.size()
        index_count = commands.idx_buffer.size()
        vertex_parts.append(_bytes_at(commands.vtx_buffer.data_address(), count * imgui.VERTEX_SIZE))
        indices = np.frombuffer(
            _bytes_at(commands.idx_buffer.data_address(), index_count * imgui.INDEX_SIZE), dtype=index_dtype
        )
        index_parts.append(indices.astype(np.uint32) + np.uint32(vertex_count))
        list_starts.append(triangle_count)
        vertex_count += count
        triangle_count += index_count // 3
    return np.concatenate(vertex_parts), np.concatenate(index_parts), list_starts


def _bytes_at(address: int, size: int) -> np.ndarray:
    """A read-only uint8 view of `size` bytes of imgui's memory at `address` (valid this frame)."""
    if size == 0:
        return np.zeros(0, np.uint8)
    return np.frombuffer((ctypes.c_uint8 * size).from_address(address), dtype=np.uint8)
