"""GPU drawing of a deformed, textured triangle mesh (Sec. 4.3) with moderngl.

The renderer owns every GL object of a mesh drawing: the programs built from
``shaders/*.glsl``, the source image texture, the vertex and index buffers and the
offscreen framebuffers.  The per-drag update is `WarpRenderer.set_positions`,
which writes the deformed vertices into a buffer in place; programs and vertex
arrays are built only when the mesh itself changes.

For the viewer it also draws what goes on top of and under the mesh: the source
image as a faded backdrop (`draw_backdrop`), one basis function G_i as a heat map
(``content="heat"``, the paper's Fig. 8), the folded-over triangles found on the
GPU (``folds=True``), a lighter preview mesh of the same domain for dense meshes
while a handle moves (`set_preview_mesh`), and overlays of antialiased lines and round handles
(`set_overlay`, `draw_overlay`) for the curves, control polygons and control
points of the paper's Fig. 11.

Coordinates are image pixels, x to the right, y down, origin at the top-left
corner of the image: pixel (column i, row j) covers [i, i+1] x [j, j+1].  A
`View` maps an image point (x, y) to framebuffer pixel (ox + s x, oy + s y),
counted from the framebuffer's top-left corner, exactly like the session file.
"""

from __future__ import annotations

import moderngl
import numpy as np

from app.address_space import GL_CONTEXT_BYTES, PROGRAM_BYTES, render_bytes, require_address_space
from app.console import captured_c_stderr
from app.framing import MAX_OUTPUT_PIXELS
from app.render_passes.backdrop import BackdropPass
from app.render_passes.gl_state import premultiplied_blending, set_view
from app.render_passes.overlay import OverlayPass
from app.render_passes.source_image import SourceImage, checked_image
from app.shaders import load_shader
from app.view import View
from core.mesh import unique_edges

#: Height bands of the paper's Fig. 1: [k, k + 1] / 10 for k = -1..10.
BAND_START = -0.1
BAND_WIDTH = 0.1


def _band_colours() -> np.ndarray:
    """RGB in [0, 1], shape (12, 3): red below 0, blue to yellow in [0, 1], green above 1."""
    blue = np.array([0.13, 0.29, 0.80])
    yellow = np.array([0.99, 0.87, 0.18])
    ramp = blue + np.linspace(0.0, 1.0, 10)[:, None] * (yellow - blue)
    return np.vstack([[0.85, 0.12, 0.10], ramp, [0.18, 0.68, 0.22]])


#: Colours of the height bands, shape (12, 3); band k covers
#: [BAND_START + k BAND_WIDTH, BAND_START + (k + 1) BAND_WIDTH), the first and
#: last also everything below and above.
BAND_COLOURS = _band_colours()

#: Premultiplied RGBA of the overlays.
WIREFRAME_COLOUR = (0.0, 0.0, 0.0, 0.35)
HIGHLIGHT_COLOUR = (0.9 * 0.6, 0.0, 0.6 * 0.6, 0.6)

#: Heat map of one basis function (``content="heat"``): RGB in [0, 1] at the values
#: 0, 1/4, 1/2, 3/4 and 1 (linear in between), and the colour of negative values.
HEAT_STOPS = np.array(
    [
        [0.05, 0.03, 0.25],
        [0.36, 0.09, 0.55],
        [0.80, 0.23, 0.36],
        [0.98, 0.58, 0.16],
        [1.00, 0.97, 0.62],
    ]
)
HEAT_NEGATIVE = np.array([0.10, 0.75, 0.80])

#: The distortion view (``content="distortion"``, `app.viewer.distortion_view`): RGB
#: of a shrunk and a grown area, of the strongest anisotropy and of folded vertices,
#: full colour at |log2| = DISTORTION_RANGE (twice or half the area).
DISTORTION_SHRUNK = np.array([0.16, 0.36, 0.85])
DISTORTION_GROWN = np.array([0.85, 0.18, 0.12])
DISTORTION_SHEARED = np.array([0.45, 0.12, 0.62])
DISTORTION_FOLDED = np.array([0.0, 0.0, 0.0])
DISTORTION_RANGE = 1.0
#: `set_distortion_measure` codes of the shader.
DISTORTION_MEASURES = {"area": 0, "conformal": 1}

#: `WarpRenderer.may_fold` calls a triangle safely unfolded when its deformed area is more than this
#: fraction of its undeformed one: the fold pass's float32 areas are off by ~1e-5 of that at most.
FOLD_MARGIN = 1e-3

#: Largest side of one offscreen drawing of `WarpRenderer.render`; larger outputs are drawn in tiles.
TILE = 4096


class ContextUnavailableError(RuntimeError):
    """No OpenGL context could be created (missing EGL or driver)."""


def create_headless_context() -> moderngl.Context:
    """An OpenGL 3.3 core context without a window, through EGL.

    Raises
    ------
    ContextUnavailableError
        If EGL or a GL 3.3 driver is unavailable; the message says what to install.
    MemoryError
        If an address-space limit leaves less than `app.address_space.GL_CONTEXT_BYTES`.
    """
    require_address_space(GL_CONTEXT_BYTES, "an OpenGL context")
    # EGL and Mesa print their warnings (a driver they did not find, ...) on stderr themselves.
    with captured_c_stderr():
        try:
            return moderngl.create_context(standalone=True, backend="egl", require=330)
        except Exception as error:  # moderngl/glcontext raise plain Exception subclasses
            raise ContextUnavailableError(
                f"cannot create a headless OpenGL 3.3 context through EGL ({error}); on Debian/Ubuntu "
                "install libegl1, libegl-mesa0 and libgl1-mesa-dri"
            ) from None


def require_render_memory(image_size: tuple[int, int], output_size: tuple[int, int], context: bool) -> None:
    """`MemoryError` in one line if an address-space limit leaves too little to draw an image
    (width, height) into an output (width, height), and to create the GL context first
    (`context`) or else the renderer's programs (`app.address_space`): llvmpipe crashes where
    numpy would report the lack of memory."""
    needed = render_bytes(image_size, output_size, TILE) + (GL_CONTEXT_BYTES if context else PROGRAM_BYTES)
    what = "an OpenGL context and " if context else "OpenGL "
    what += f"drawing the {image_size[0]}x{image_size[1]} image into {output_size[0]}x{output_size[1]} pixels"
    require_address_space(needed, what)


class WarpRenderer:
    """Draws one triangle mesh: the source image warped onto it, or a coloured scalar field.

    Typical use::

        renderer = WarpRenderer(ctx)
        renderer.set_image(rgba)                       # (H, W, 4) uint8
        renderer.set_mesh(mesh.vertices, mesh.triangles)
        renderer.set_positions(G @ target_points)      # every drag: in place
        pixels = renderer.render((W, H))               # or renderer.draw(view, size) on screen
        renderer.release()

    Parameters
    ----------
    ctx : moderngl.Context
        An OpenGL >= 3.3 context; the renderer creates its objects in it and frees
        them in `release`.
    """

    def __init__(self, ctx: moderngl.Context):
        self.ctx = ctx
        vertex = load_shader("mesh.vert.glsl")
        self._image_program = ctx.program(
            vertex_shader=vertex, fragment_shader=load_shader("image.frag.glsl")
        )
        self._field_program = ctx.program(
            vertex_shader=vertex, fragment_shader=load_shader("field.frag.glsl")
        )
        self._solid_program = ctx.program(
            vertex_shader=vertex, fragment_shader=load_shader("solid.frag.glsl")
        )
        self._heat_program = ctx.program(vertex_shader=vertex, fragment_shader=load_shader("heat.frag.glsl"))
        self._distortion_program = ctx.program(
            vertex_shader=vertex, fragment_shader=load_shader("distortion.frag.glsl")
        )
        self._folds_program = ctx.program(
            vertex_shader=vertex,
            geometry_shader=load_shader("folds.geom.glsl"),
            fragment_shader=load_shader("solid.frag.glsl"),
        )
        self._programs = [
            self._image_program,
            self._field_program,
            self._solid_program,
            self._heat_program,
            self._distortion_program,
            self._folds_program,
        ]
        self._field_program["u_bands"].write(BAND_COLOURS.astype("f4").tobytes())
        self._field_program["u_band_start"].value = BAND_START
        self._field_program["u_band_width"].value = BAND_WIDTH
        self._heat_program["u_stops"].write(HEAT_STOPS.astype("f4").tobytes())
        self._heat_program["u_negative"].value = tuple(HEAT_NEGATIVE)
        for name, colour in (
            ("u_shrunk", DISTORTION_SHRUNK),
            ("u_grown", DISTORTION_GROWN),
            ("u_sheared", DISTORTION_SHEARED),
            ("u_folded", DISTORTION_FOLDED),
        ):
            self._distortion_program[name].value = tuple(colour)
        self._distortion_program["u_range"].value = DISTORTION_RANGE
        self._distortion_program["u_measure"].value = 0
        self._distortion_program["u_folds_only"].value = False
        self._image_program["u_opacity"].value = 1.0
        self._backdrop = BackdropPass(ctx, self._image_program)
        self._overlay = OverlayPass(ctx)
        self._source: SourceImage | None = None
        self._image_size: tuple[int, int] | None = None
        self._mesh: _MeshObjects | None = None
        self._preview: _MeshObjects | None = None
        self._highlight_count = 0
        self._field_ready = False
        self._target: tuple[tuple[int, int], int, list] | None = None
        #: Counts the changes of what `draw` and `draw_backdrop` would draw (image, meshes,
        #: positions, fields): a picture drawn at one revision can be reused until the next.
        self.revision = 0

    # -- data ---------------------------------------------------------------

    def set_image(self, image: np.ndarray) -> None:
        """Upload the source image.

        Parameters
        ----------
        image : ndarray of shape (H, W, 4), uint8
            RGBA with straight (non-premultiplied) alpha, row 0 at the top.
        """
        self.revision += 1
        image = checked_image(self.ctx, image)
        self._release_image()
        self._source = SourceImage(self.ctx, image)
        changed = self._image_size != self._source.size
        self._image_size = self._source.size
        if changed:
            for mesh in (self._mesh, self._preview):
                if mesh is not None:
                    mesh.uv.write(self._source_uv(mesh).tobytes())
        self._backdrop.set_image_size(self._image_size)

    def set_mesh(self, vertices: np.ndarray, triangles: np.ndarray) -> None:
        """Set the undeformed mesh; positions start undeformed, the field at 0.

        This (re)builds buffers and vertex arrays, and drops the preview mesh: call it
        when the mesh changes, not per drag.

        Parameters
        ----------
        vertices : ndarray of shape (V, 2)
            Undeformed vertices in image pixels; texture coordinates are vertices / (W, H).
        triangles : ndarray of shape (T, 3)
            Vertex indices; triangles sharing an edge share its two vertices, which
            is what keeps the rendering free of cracks.
        """
        self.revision += 1
        vertices, triangles = _checked_mesh(vertices, triangles)
        self._release_mesh()
        self._mesh = self._build_mesh(vertices, triangles)
        self._highlight_count = 0
        self._field_ready = False

    def set_preview_mesh(self, vertices: np.ndarray, triangles: np.ndarray) -> None:
        """Set a lighter mesh of the same domain, drawn instead of the mesh by ``draw(preview=True)``.

        A software rasteriser's frame grows with the triangle count (llvmpipe, 1280x1024:
        ~170 ms for 800k triangles, ~30 ms for 50k), so the viewer draws a dense
        mesh's deformation through a preview mesh of ~20k vertices while a handle moves,
        with positions the dense mesh's P1 interpolant gives there (`core.mesh_transfer`).

        Parameters
        ----------
        vertices, triangles
            As in `set_mesh`.
        """
        self.revision += 1
        self._require_mesh()
        vertices, triangles = _checked_mesh(vertices, triangles)
        self._release_preview()
        self._preview = self._build_mesh(vertices, triangles)

    @property
    def has_preview(self) -> bool:
        """Whether a preview mesh is set (`set_preview_mesh`) for the current mesh."""
        return self._preview is not None

    def set_positions(self, positions: np.ndarray) -> None:
        """Write deformed vertex positions in place (the per-drag update).

        Parameters
        ----------
        positions : ndarray of shape (V, 2)
            Deformed vertices in image pixels, in the order of `set_mesh`.
        """
        self.revision += 1
        self._require_mesh()
        mesh = self._mesh
        positions = np.asarray(positions)
        if positions.shape != mesh.vertices.shape:
            raise ValueError(f"positions must have shape {mesh.vertices.shape}, got {positions.shape}")
        mesh.positions.write(np.asarray(positions, dtype="f4")[mesh.order].tobytes())

    @property
    def vertex_order(self) -> np.ndarray:
        """ndarray of shape (V,): the vertex of `set_mesh` that each GPU buffer row holds."""
        self._require_mesh()
        return self._mesh.order

    @property
    def preview_vertex_order(self) -> np.ndarray:
        """ndarray of shape (V',): the vertex of `set_preview_mesh` that each GPU buffer row holds."""
        self._require_preview()
        return self._preview.order

    def set_ordered_positions(self, positions: np.ndarray) -> None:
        """`set_positions` for positions already in `vertex_order`: no gather, one buffer write.

        Parameters
        ----------
        positions : ndarray of shape (V, 2), float32, C-contiguous
            ``deformed[vertex_order]``, image pixels.
        """
        self.revision += 1
        self._require_mesh()
        self._mesh.write_ordered_positions(positions)

    def set_preview_positions(self, positions: np.ndarray) -> None:
        """Deformed preview vertices, in `preview_vertex_order`: float32 of shape (V', 2)."""
        self.revision += 1
        self._require_preview()
        self._preview.write_ordered_positions(positions)

    def may_fold(self, positions: np.ndarray) -> bool:
        """Whether ``draw(folds=True)`` could mark a triangle at these positions; if not, it may skip
        that pass (a geometry shader over every triangle, run on the CPU by a software rasteriser)
        and draw the same pixels.

        Parameters
        ----------
        positions : ndarray of shape (V, 2), float32
            The positions last written, in `vertex_order` (`set_ordered_positions`).

        Returns
        -------
        bool
            False when every triangle keeps its orientation with a margin (`FOLD_MARGIN`) far
            beyond the pass's float32 rounding, so that the pass would emit nothing.
        """
        self._require_mesh()
        mesh = self._mesh
        if mesh.fold_test is None:
            source = _signed_areas(mesh.vertices[mesh.order], mesh.triangle_indices)
            corners = tuple(
                np.ascontiguousarray(mesh.triangle_indices[:, k], dtype=np.intp) for k in range(3)
            )
            # Undeformed triangles may turn either way: a fold flips the sign, a collapse nears zero.
            mesh.fold_test = (
                *corners,
                np.sign(source).astype(np.float32),
                (2.0 * FOLD_MARGIN * np.abs(source)).astype(np.float32),
            )
        a, b, c, orientation, threshold = mesh.fold_test
        x, y = np.ascontiguousarray(np.asarray(positions, dtype=np.float32).T)
        xa, ya = x.take(a), y.take(a)
        # Twice the deformed signed areas in float32, like the pass: both err far below FOLD_MARGIN.
        twice = (x.take(b) - xa) * (y.take(c) - ya) - (x.take(c) - xa) * (y.take(b) - ya)
        return not bool(np.all(twice * orientation > threshold))

    def set_distortion_measure(self, measure: str) -> None:
        """How ``content="distortion"`` colours its field: ``"area"`` (log2 det J) or ``"conformal"``."""
        code = DISTORTION_MEASURES[measure]
        if self._distortion_program["u_measure"].value != code:
            self.revision += 1
            self._distortion_program["u_measure"].value = code

    def set_field(self, values: np.ndarray) -> None:
        """Write the per-vertex scalar field drawn by ``content="field"``, ``"heat"`` or ``"distortion"``.

        Parameters
        ----------
        values : ndarray of shape (V,)
        """
        self.revision += 1
        self._require_mesh()
        mesh = self._mesh
        values = np.asarray(values)
        if values.shape != (mesh.vertices.shape[0],):
            raise ValueError(f"values must have shape ({mesh.vertices.shape[0]},), got {values.shape}")
        mesh.values.write(np.asarray(values, dtype="f4")[mesh.order].tobytes())
        self._field_ready = True

    def set_highlighted(self, triangles: np.ndarray) -> None:
        """Choose the triangles drawn by ``highlight=True`` (e.g. folded ones).

        Parameters
        ----------
        triangles : ndarray of shape (K,), int or bool of shape (T,)
            Indices into the triangles of `set_mesh`, or a mask over them.
        """
        self.revision += 1
        self._require_mesh()
        triangles = np.asarray(triangles)
        indices = self._mesh.triangle_indices
        count = len(indices)
        if triangles.dtype == bool:
            if triangles.shape != (count,):
                raise ValueError(f"a triangle mask must have shape ({count},), got {triangles.shape}")
            triangles = np.flatnonzero(triangles)
        elif triangles.size == 0:
            triangles = np.zeros(0, dtype=np.int64)
        elif (
            not np.issubdtype(triangles.dtype, np.integer) or triangles.min() < 0 or triangles.max() >= count
        ):
            raise ValueError(f"triangles must be a mask or indices in 0..{count - 1}")
        selected = indices[triangles].reshape(-1, 3)
        if len(selected):
            self._mesh.highlighted.write(selected.tobytes())
        self._highlight_count = len(selected)

    # -- drawing ------------------------------------------------------------

    def draw(
        self,
        view: View,
        viewport_size: tuple[int, int],
        *,
        content: str = "image",
        wireframe: bool = False,
        highlight: bool = False,
        folds: bool = False,
        preview: bool = False,
    ) -> None:
        """Draw into the bound framebuffer with premultiplied-alpha blending.

        Parameters
        ----------
        view : View
            Image-to-framebuffer transform.
        viewport_size : tuple of int
            (width, height) of the viewport in framebuffer pixels.
        content : {"image", "field", "heat", "distortion", "none"}
            The warped image, the scalar field in height bands (Fig. 1), the scalar
            field as a heat map (Fig. 8), the field as the distortion view
            (`app.viewer.distortion_view`), or only overlays.
        wireframe : bool
            Draw the mesh edges on top.
        highlight : bool
            Fill the triangles chosen by `set_highlighted` on top.
        folds : bool
            Fill the triangles that the current positions fold over (found on the
            GPU, like `core.folded_triangles`) on top.
        preview : bool
            Draw the preview mesh (`set_preview_mesh`) instead: ``content`` "image" or
            "none", and folds, only.
        """
        self._draw(view, viewport_size, "screen", content, wireframe, highlight, folds, preview)

    def _draw(self, view, viewport_size, order, content, wireframe, highlight, folds, preview=False) -> None:
        """`draw` with the triangles in ``order``: "screen" (fastest) or "caller" (as given to `set_mesh`)."""
        self._require_mesh()
        if preview:
            self._require_preview()
            if content not in ("image", "none") or wireframe or highlight:
                raise ValueError("the preview mesh draws the image and its folds only")
        if content not in ("image", "field", "heat", "distortion", "none"):
            raise ValueError(
                f"content must be 'image', 'field', 'heat', 'distortion' or 'none', got {content!r}"
            )
        if content == "image" and self._source is None:
            raise RuntimeError("draw(content='image') needs set_image first")
        if content in ("field", "heat", "distortion") and not self._field_ready:
            raise RuntimeError(f"draw(content={content!r}) needs set_field first")
        set_view(
            (
                self._image_program,
                self._field_program,
                self._solid_program,
                self._heat_program,
                self._distortion_program,
                self._folds_program,
            ),
            view,
            viewport_size,
        )
        premultiplied_blending(self.ctx)
        mesh = self._preview if preview else self._mesh
        vaos = mesh.vaos[order]
        if content == "image":
            self._source.bind(self._image_program)
            self._image_program["u_opacity"].value = 1.0
            vaos["image"].render()
            self._source.unbind()
        elif content == "field":
            vaos["field"].render()
        elif content == "heat":
            vaos["heat"].render()
        elif content == "distortion":
            vaos["distortion"].render()
            # Folded vertices again on top: where the mesh overlaps itself they would be hidden.
            self._distortion_program["u_folds_only"].value = True
            vaos["distortion"].render()
            self._distortion_program["u_folds_only"].value = False
        if folds:
            self._folds_program["u_colour"].value = HIGHLIGHT_COLOUR
            vaos["folds"].render()
        if highlight and self._highlight_count:
            self._solid_program["u_colour"].value = HIGHLIGHT_COLOUR
            mesh.highlight_vao.render(vertices=3 * self._highlight_count)
        if wireframe:
            self._solid_program["u_colour"].value = WIREFRAME_COLOUR
            self._edge_vao(mesh).render()

    def draw_backdrop(self, view: View, viewport_size: tuple[int, int], opacity: float = 1.0) -> None:
        """Draw the whole undeformed source image, faded by `opacity`, into the bound framebuffer.

        Parameters
        ----------
        view : View
            Image-to-framebuffer transform.
        viewport_size : tuple of int
            (width, height) of the viewport in framebuffer pixels.
        opacity : float
            In [0, 1]; the image is blended over what is drawn already.
        """
        if self._source is None:
            raise RuntimeError("draw_backdrop needs set_image first")
        self._backdrop.draw(self._source, view, viewport_size, opacity)

    def set_overlay(self, segments: np.ndarray, points: np.ndarray) -> None:
        """Set the overlay lines and handles drawn by `draw_overlay` (rewritten in place).

        Parameters
        ----------
        segments : ndarray of shape (S, 2, 7)
            Line segments, each endpoint ``[x, y, r, g, b, a, width]``: image pixels,
            straight-alpha colour in [0, 1], width in framebuffer pixels.
        points : ndarray of shape (K, 7)
            Round handles ``[x, y, r, g, b, a, diameter]``, drawn after (over) the lines
            in order, the last on top.
        """
        self._overlay.set(segments, points)

    def draw_overlay(self, view: View, viewport_size: tuple[int, int]) -> None:
        """Draw the lines and handles of `set_overlay` into the bound framebuffer.

        Parameters
        ----------
        view : View
            Image-to-framebuffer transform.
        viewport_size : tuple of int
            (width, height) of the viewport in framebuffer pixels.
        """
        self._overlay.draw(view, viewport_size)

    def render(
        self,
        size: tuple[int, int],
        view: View | None = None,
        *,
        samples: int = 4,
        background: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0),
        content: str = "image",
        wireframe: bool = False,
        highlight: bool = False,
        folds: bool = False,
        backdrop: bool = False,
    ) -> np.ndarray:
        """Draw offscreen with multisampling and read the result back.

        An output larger than `TILE` pixels on a side is drawn in tiles of at most
        `TILE` x `TILE`, each through the view shifted by the tile's corner: GL
        drivers cap a framebuffer's size (llvmpipe: 2 GiB of multisampled pixels,
        about 11,585 x 11,585 at 4 samples) below their maximum renderbuffer side.

        Parameters
        ----------
        size : tuple of int
            (width, height) of the output in pixels.
        view : View, optional
            Image-to-output transform; the identity by default.
        samples : int
            Multisample count, lowered to what the driver supports.
        background : tuple of float
            Straight RGBA in [0, 1] outside the drawn mesh; transparent by default.
        content, wireframe, highlight, folds
            As in `draw`.
        backdrop : bool
            Draw the whole undeformed image first (`draw_backdrop`) and the warp
            over it: the rest of the picture kept (``--outside original``).

        Returns
        -------
        ndarray of shape (height, width, 4), uint8
            RGBA with straight alpha, row 0 at the top.
        """
        width, height = int(size[0]), int(size[1])
        if not (1 <= width and 1 <= height and width * height <= MAX_OUTPUT_PIXELS):
            raise ValueError(
                f"output size {width}x{height} is not 1 to {MAX_OUTPUT_PIXELS / 1e6:.0f} megapixels"
            )
        view = view or View()
        limit = min(TILE, self.ctx.info["GL_MAX_RENDERBUFFER_SIZE"], *self.ctx.info["GL_MAX_VIEWPORT_DIMS"])
        tile = (min(width, limit), min(height, limit))
        # Leave the caller's framebuffer bound afterwards (a viewer exporting mid-frame).
        previous = self.ctx.fbo
        if self._target is not None and previous in self._target[2]:
            previous = None  # ours, perhaps about to be replaced
        multisample, resolved = self._framebuffers(tile, max(0, min(int(samples), self.ctx.max_samples)))
        pixels = np.empty((height, width, 4), np.uint8)
        red, green, blue, alpha = background
        for top in range(0, height, tile[1]):
            for left in range(0, width, tile[0]):
                multisample.use()
                multisample.clear(red * alpha, green * alpha, blue * alpha, alpha)
                shifted = View(view.scale, (view.offset[0] - left, view.offset[1] - top))
                if backdrop:
                    self.draw_backdrop(shifted, tile)
                self._draw(shifted, tile, "caller", content, wireframe, highlight, folds)
                self.ctx.copy_framebuffer(resolved, multisample)
                data = resolved.read(components=4, alignment=1)
                # GL rows run bottom-up.
                drawn = np.frombuffer(data, dtype=np.uint8).reshape(tile[1], tile[0], 4)[::-1]
                part = pixels[top : top + tile[1], left : left + tile[0]]
                part[...] = drawn[: part.shape[0], : part.shape[1]]
        if previous is not None:
            previous.use()
        return _unpremultiply(pixels)

    # -- lifetime -----------------------------------------------------------

    def release(self) -> None:
        """Free every GL object of the renderer; it cannot draw afterwards."""
        self._release_mesh()
        self._release_image()
        self._release_target()
        self._overlay.release()
        for program in self._programs:
            program.release()
        self._programs = []

    def __enter__(self) -> WarpRenderer:
        return self

    def __exit__(self, *exc_info) -> None:
        self.release()

    # -- internals ----------------------------------------------------------

    def _framebuffers(self, size: tuple[int, int], samples: int):
        """Multisampled and resolve framebuffers of `size`, kept for the next render of that size."""
        if self._target is None or self._target[:2] != (size, samples):
            # Only one size is kept: a 4K 4x multisample target alone is ~130 MB.
            self._release_target()
            colour = self.ctx.renderbuffer(size, 4, samples=samples)
            resolved_colour = self.ctx.renderbuffer(size, 4)
            multisample = self.ctx.framebuffer(color_attachments=[colour])
            resolved = self.ctx.framebuffer(color_attachments=[resolved_colour])
            self._target = (size, samples, [multisample, resolved, colour, resolved_colour])
        objects = self._target[2]
        return objects[0], objects[1]

    def _build_mesh(self, vertices: np.ndarray, triangles: np.ndarray) -> _MeshObjects:
        """Buffers and vertex arrays of one mesh, positions undeformed."""
        ctx = self.ctx
        count = vertices.shape[0]
        # Vertices renumbered, and triangles drawn on screen, in the order of a space-filling
        # curve: a software rasteriser shades vertices in chunks of the index buffer, and on a
        # dense mesh in the mesher's order it re-shades most of them (llvmpipe, 800k triangles:
        # the textured pass 1.4-2.6x and the fold pass 1.8-3.9x slower, depending on the load).
        # `render` keeps the caller's triangle order, so that where folded triangles overlap
        # the exported picture does not depend on the renderer.
        order = np.argsort(_morton_codes(vertices), kind="stable")
        renumber = np.empty(count, dtype=np.int64)
        renumber[order] = np.arange(count)
        indices = renumber[triangles].astype("u4")
        screen = np.argsort(_morton_codes(vertices[triangles].mean(axis=1)), kind="stable")
        mesh = _MeshObjects(vertices, order, indices)
        mesh.positions = ctx.buffer(vertices[order].astype("f4").tobytes(), dynamic=True)
        mesh.uv = ctx.buffer(self._source_uv(mesh).tobytes())
        mesh.values = ctx.buffer(reserve=4 * count, dynamic=True)
        mesh.highlighted = ctx.buffer(reserve=indices.nbytes, dynamic=True)
        mesh.objects = [mesh.positions, mesh.uv, mesh.values, mesh.highlighted]
        programs = {
            "image": (self._image_program, "in_uv"),
            "field": (self._field_program, "in_value"),
            "heat": (self._heat_program, "in_value"),
            "distortion": (self._distortion_program, "in_value"),
            "folds": (self._folds_program, "in_uv"),
        }
        for name, triangle_order in (("screen", screen), ("caller", None)):
            ordered = indices if triangle_order is None else indices[triangle_order]
            index_buffer = ctx.buffer(np.ascontiguousarray(ordered).tobytes())
            mesh.vaos[name] = vaos = {}
            for kind, (program, attribute) in programs.items():
                second = (mesh.uv, "2f", "in_uv") if attribute == "in_uv" else (mesh.values, "1f", "in_value")
                vaos[kind] = ctx.vertex_array(
                    program, [(mesh.positions, "2f", "in_position"), second], index_buffer=index_buffer
                )
            mesh.objects += [*vaos.values(), index_buffer]
        position = [(mesh.positions, "2f", "in_position")]
        mesh.highlight_vao = ctx.vertex_array(self._solid_program, position, index_buffer=mesh.highlighted)
        mesh.objects.append(mesh.highlight_vao)
        return mesh

    def _edge_vao(self, mesh: _MeshObjects) -> moderngl.VertexArray:
        """The wireframe's vertex array, built on first use (0.5 s for a 400k-vertex mesh)."""
        if mesh.edge_vao is None:
            edges = self.ctx.buffer(unique_edges(mesh.triangle_indices).astype("u4").tobytes())
            mesh.edge_vao = self.ctx.vertex_array(
                self._solid_program,
                [(mesh.positions, "2f", "in_position")],
                index_buffer=edges,
                mode=moderngl.LINES,
            )
            mesh.objects += [mesh.edge_vao, edges]
        return mesh.edge_vao

    def _source_uv(self, mesh: _MeshObjects) -> np.ndarray:
        size = self._image_size or (1, 1)
        return (mesh.vertices[mesh.order] / np.array(size, dtype=np.float64)).astype("f4")

    def _require_mesh(self) -> None:
        if self._mesh is None:
            raise RuntimeError("the renderer has no mesh yet: call set_mesh first")

    def _require_preview(self) -> None:
        if self._preview is None:
            raise RuntimeError("the renderer has no preview mesh: call set_preview_mesh first")

    def _release_mesh(self) -> None:
        self._release_preview()
        if self._mesh is not None:
            self._mesh.release()
        self._mesh = None

    def _release_preview(self) -> None:
        if self._preview is not None:
            self._preview.release()
        self._preview = None

    def _release_image(self) -> None:
        self._backdrop.release()
        if self._source is not None:
            self._source.release()
        self._source = None

    def _release_target(self) -> None:
        if self._target is not None:
            if self.ctx.fbo in self._target[2]:
                # GL falls back to the default framebuffer when the bound one is deleted.
                self.ctx.fbo = self.ctx.screen
            for item in self._target[2]:
                item.release()
        self._target = None


class _MeshObjects:
    """The GL objects of one mesh: buffers in `order` (a Z-order of the vertices) and vertex arrays.

    Attributes
    ----------
    vertices : ndarray of shape (V, 2)
        Undeformed, in the caller's order.
    order : ndarray of shape (V,)
        The caller's vertex held by each buffer row.
    triangle_indices : ndarray of shape (T, 3), uint32
        The caller's triangles, in buffer rows.
    vaos : dict
        ``vaos[order][kind]``: order "screen" (Z-ordered triangles) or "caller", kind
        "image", "field", "heat", "distortion" or "folds".
    """

    def __init__(self, vertices: np.ndarray, order: np.ndarray, triangle_indices: np.ndarray):
        self.vertices, self.order, self.triangle_indices = vertices, order, triangle_indices
        # `WarpRenderer.may_fold`'s corners a, b, c (T,), orientation (T,) and threshold (T,).
        self.fold_test: tuple | None = None
        self.vaos: dict = {}
        self.edge_vao: moderngl.VertexArray | None = None
        self.objects: list = []

    def write_ordered_positions(self, positions: np.ndarray) -> None:
        """Write float32 positions (V, 2), already in `order`, into the position buffer."""
        if positions.shape != self.vertices.shape or positions.dtype != np.float32:
            raise ValueError(f"positions must be float32 of shape {self.vertices.shape}")
        self.positions.write(np.ascontiguousarray(positions))

    def release(self) -> None:
        for item in self.objects:
            item.release()
        self.objects = []


def _signed_areas(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Signed areas (T,) float64 of `triangles` (T, 3) over `points` (V, 2), image pixels (y down)."""
    corners = points[triangles].astype(np.float64)  # (T, 3, 2)
    edges = corners[:, 1:] - corners[:, :1]
    return 0.5 * (edges[:, 0, 0] * edges[:, 1, 1] - edges[:, 1, 0] * edges[:, 0, 1])


def _checked_mesh(vertices, triangles) -> tuple[np.ndarray, np.ndarray]:
    """(vertices (V, 2) float64, triangles (T, 3)), or ValueError saying what is wrong."""
    vertices = np.asarray(vertices, dtype=np.float64)
    triangles = np.asarray(triangles)
    if vertices.ndim != 2 or vertices.shape[1] != 2 or vertices.shape[0] < 3:
        raise ValueError(f"vertices must have shape (V, 2) with V >= 3, got {vertices.shape}")
    if not np.isfinite(vertices).all():
        raise ValueError("vertices contain NaN or infinite values")
    if triangles.ndim != 2 or triangles.shape[1] != 3 or triangles.shape[0] < 1:
        raise ValueError(f"triangles must have shape (T, 3) with T >= 1, got {triangles.shape}")
    if (
        not np.issubdtype(triangles.dtype, np.integer)
        or triangles.min() < 0
        or triangles.max() >= len(vertices)
    ):
        raise ValueError(f"triangles must be integer indices into the {len(vertices)} vertices")
    return vertices, triangles


def _unpremultiply(pixels: np.ndarray) -> np.ndarray:
    """RGBA uint8 (H, W, 4), premultiplied -> straight alpha, in place; only partly covered pixels change."""
    result = pixels
    alpha = result[..., 3]
    partial = (alpha > 0) & (alpha < 255)
    if partial.any():
        a = alpha[partial].astype(np.float32)[:, None]
        result[partial, :3] = np.clip(result[partial, :3] * (255.0 / a) + 0.5, 0, 255).astype(np.uint8)
    return result


def _morton_codes(points: np.ndarray) -> np.ndarray:
    """Position of each point along a Z-order curve on a 1024 x 1024 grid over their bounding box.

    Parameters
    ----------
    points : ndarray of shape (K, 2)

    Returns
    -------
    ndarray of shape (K,), uint32
        Interleaved bits of the cell column (even bits) and row (odd bits).
    """
    low = points.min(axis=0)
    extent = np.maximum(points.max(axis=0) - low, 1e-300)
    cells = np.minimum((points - low) / extent * 1024, 1023).astype(np.uint32)
    spread = []
    for bits in cells.T:  # 10 bits apart into the even positions of 20
        bits = (bits | (bits << 8)) & 0x00FF00FF
        bits = (bits | (bits << 4)) & 0x0F0F0F0F
        bits = (bits | (bits << 2)) & 0x33333333
        bits = (bits | (bits << 1)) & 0x55555555
        spread.append(bits)
    return spread[0] | (spread[1] << 1)
