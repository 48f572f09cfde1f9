"""GPU drawing of a deformed, textured triangle mesh (Sec. 4.3) with moderngl.

`WarpRenderer` composes the passes of `app.render.passes`, each owning its programs:
the image pass (the source image warped onto the mesh, the folded and highlighted
triangles, the wireframe, the preview mesh), the field passes (the mesh coloured by a
scalar field: height bands, one basis function G_i as a heat map as in the paper's
Fig. 8, the distortion view), the backdrop pass (the source image faded under the warp)
and the overlay pass (antialiased lines and round handles for the curves, control
polygons and control points of the paper's Fig. 11).  The renderer itself holds the
source image texture, the mesh and preview mesh buffers (`MeshBuffers`) that the image
and field passes draw, and the offscreen framebuffers of `render`.  The per-drag update
is `WarpRenderer.set_positions`, which writes the deformed vertices into a buffer in
place; vertex arrays are built only when the mesh itself changes.

Coordinates are image pixels, x to the right, y down, origin at the top-left
corner of the image: pixel (column i, row j) covers [i, i+1] x [j, j+1].  A
`View` maps an image point (x, y) to framebuffer pixel (ox + s x, oy + s y),
counted from the framebuffer's top-left corner, exactly like the session file.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from functools import partial

import moderngl
import numpy as np

from app.console import captured_c_stderr
from app.io.images.tiles import crosses, encloses
from app.render.address_space import GL_CONTEXT_BYTES, PROGRAM_BYTES, render_bytes, require_address_space
from app.render.compositing import (
    backdrop_rows,
    clear_pixel,
    drawn_box,
    exact_offset,
    mipmap_levels,
    sampled_box,
    straight,
    texel_footprints,
    warp_laid,
    warp_over,
)
from app.render.passes.backdrop import BackdropPass
from app.render.passes.fields import DistortionPass, FieldPass, heat_map_pass, height_bands_pass
from app.render.passes.image import ImagePass
from app.render.passes.mesh_buffers import MeshBuffers, checked_mesh
from app.render.passes.overlay import OverlayPass
from app.render.passes.source_image import SourceImage, checked_image, texture_dtype
from app.render.viewport import View
from app.warp.framing import MAX_OUTPUT_PIXELS

#: Largest side of one offscreen drawing of `WarpRenderer.render`; larger outputs are drawn in tiles.
TILE = 4096
#: Rows of a strip of `WarpRenderer.render_strips` (drawn in tiles of as many columns): a
#: 12000-pixel-wide strip is 25 MB at 8 bits; smaller tiles multisample less of the picture.
STRIP_ROWS = 512
#: Largest `app.render.compositing.texel_footprints` drawn without mipmaps: GL samples level 0 alone
#: up to 1; past it by this much the next level's weight (log2 of it) is under 4e-4.
UNSHRUNK_FOOTPRINT = 1.0 + 2.0**-12
#: Largest side of a tile of the warp drawn over a copied backdrop (`WarpRenderer.render`): one inside
#: its outline is drawn whole, one outside it not at all.
COPIED_TILE = 512
#: Side of the parts of a tile that its outline crosses: those the outline crosses are multisampled,
#: in floats (a multisample resolve costs more than the drawing on a software rasteriser).
EDGE_TILE = 256


class ContextUnavailableError(RuntimeError):
    """No OpenGL context could be created (missing EGL or driver)."""


def create_headless_context() -> moderngl.Context:
    """An OpenGL 3.3 core context without a window, through EGL.

    Raises
    ------
    ContextUnavailableError
        If EGL or a GL 3.3 driver is unavailable; the message says what to install.
    MemoryError
        If an address-space limit leaves less than `app.render.address_space.GL_CONTEXT_BYTES`.
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
    (`context`) or else the renderer's programs (`app.render.address_space`): llvmpipe crashes where
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
        self._image = ImagePass(ctx)
        self._distortion = DistortionPass(ctx)
        self._fields: dict[str, FieldPass] = {
            field.kind: field for field in (height_bands_pass(ctx), heat_map_pass(ctx), self._distortion)
        }
        self._backdrop = BackdropPass(ctx, self._image.textured_program)
        self._overlay = OverlayPass(ctx)
        self._mesh_programs = dict(self._image.mesh_programs)
        for field in self._fields.values():
            self._mesh_programs.update(field.mesh_programs)
        #: Textures, made at the first drawing that samples them: "image" (the whole image), "box"
        #: (the part of it a copied backdrop's warp samples, `_copied_strips`), "backdrop" (what the
        #: backdrop shows instead, `app.warp.fill`).
        self._textures: dict[str, SourceImage] = {}
        #: The straight pixels of the image and of the backdrop image: `render` copies them, and
        #: uploads what it samples.
        self._host: dict[str, np.ndarray] = {}  # "image", "backdrop"
        self._image_size: tuple[int, int] | None = None
        self._mesh: MeshBuffers | None = None
        self._preview: MeshBuffers | None = None
        #: Offscreen framebuffers by (size, samples, dtype), three kinds at most (`_framebuffers`).
        self._target: dict[tuple, list] = {}
        #: Counts the changes of what `draw` and `draw_backdrop` would draw (image, meshes,
        #: positions, fields): a picture drawn at one revision can be reused until the next.
        self.revision = 0

    # -- data ---------------------------------------------------------------

    def set_image(self, image: np.ndarray) -> None:
        """Set the source image; it is uploaded at the first drawing, whole or only the part that
        drawing samples (`render` over a copied backdrop).

        Parameters
        ----------
        image : ndarray of shape (H, W, 4), uint8 or uint16
            RGBA with straight (non-premultiplied) alpha, row 0 at the top.  A 16-bit image
            is drawn, and `render` reads it back, at 16 bits.  The renderer keeps the array (not a
            copy): the caller must not change it while the renderer holds it.
        """
        self.revision += 1
        image = checked_image(self.ctx, image)
        self._release_image()
        self._host["image"] = image
        changed = self._image_size != (image.shape[1], image.shape[0])
        self._image_size = (image.shape[1], image.shape[0])
        if changed:
            for mesh in (self._mesh, self._preview):
                if mesh is not None:
                    mesh.write_uv(self._image_size)
        self._backdrop.set_image_size(self._image_size)

    def set_backdrop_image(self, image: np.ndarray | None) -> None:
        """What `draw_backdrop` shows instead of the source image (the source with the cage's original
        position filled, `app.warp.fill`), or None for the source image itself.

        Parameters
        ----------
        image : ndarray of shape (H, W, 4), uint8, or None
            The size of the source image (`set_image` first; a new source image drops it).
        """
        self.revision += 1
        self._release_texture("backdrop")
        self._host.pop("backdrop", None)
        if image is not None:
            image = checked_image(self.ctx, image)
            if self._image_size is None or self._image_size != (image.shape[1], image.shape[0]):
                raise ValueError("the backdrop image must have the source image's size")
            self._host["backdrop"] = image  # uploaded when first drawn: `render` may only copy it

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
        vertices, triangles = checked_mesh(vertices, triangles)
        self._release_mesh()
        self._mesh = self._build_mesh(vertices, triangles)

    def set_preview_mesh(self, vertices: np.ndarray, triangles: np.ndarray) -> None:
        """Set a lighter mesh of the same domain, drawn instead of the mesh by ``draw(preview=True)``.

        A software rasteriser's frame grows with the triangle count (llvmpipe, 1280x1024:
        ~170 ms for 800k triangles, ~30 ms for 50k), so the viewer draws a dense
        mesh's deformation through a preview mesh of ~20k vertices while a handle moves,
        with positions the dense mesh's P1 interpolant gives there (`core.meshes.mesh_transfer`).

        Parameters
        ----------
        vertices, triangles
            As in `set_mesh`.
        """
        self.revision += 1
        self._require_mesh()
        vertices, triangles = checked_mesh(vertices, triangles)
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
        self._mesh.write_positions(positions)

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
            False when every triangle keeps its orientation with a margin
            (`app.render.passes.fold_possible.FOLD_MARGIN`) far beyond the pass's float32
            rounding, so that the pass would emit nothing.
        """
        self._require_mesh()
        return self._mesh.may_fold(positions)

    def set_distortion_measure(self, measure: str) -> None:
        """How ``content="distortion"`` colours its field: ``"area"`` (log2 det J) or ``"conformal"``."""
        if self._distortion.set_measure(measure):
            self.revision += 1

    def set_field(self, values: np.ndarray) -> None:
        """Write the per-vertex scalar field drawn by ``content="field"``, ``"heat"`` or ``"distortion"``.

        Parameters
        ----------
        values : ndarray of shape (V,)
        """
        self.revision += 1
        self._require_mesh()
        self._mesh.write_values(values)

    def set_highlighted(self, triangles: np.ndarray) -> None:
        """Choose the triangles drawn by ``highlight=True`` (e.g. folded ones).

        Parameters
        ----------
        triangles : ndarray of shape (K,), int or bool of shape (T,)
            Indices into the triangles of `set_mesh`, or a mask over them.
        """
        self.revision += 1
        self._require_mesh()
        self._mesh.write_highlighted(triangles)

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
        view, viewport_size : View, tuple of int
            Where to draw: as for `app.render.passes.gl_state.set_view`.
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

    def _draw(
        self,
        view,
        viewport_size,
        order,
        content,
        wireframe,
        highlight,
        folds,
        preview=False,
        sampling=(True, False, False),
        source=None,
        split=None,
    ) -> None:
        """`draw` with the triangles in ``order``: "screen" (fastest) or "caller" (as given to `set_mesh`);
        `sampling` is ``(mipmaps, snap, coverage)`` and `split` the triangles drawn through the
        mipmaps and those that may show, of `ImagePass.draw_image`, `source` the texture drawn (a
        `SourceImage` of the image; the whole image's if None)."""
        self._require_mesh()
        if preview:
            self._require_preview()
            if content not in ("image", "none") or wireframe or highlight:
                raise ValueError("the preview mesh draws the image and its folds only")
        if content not in ("image", *self._fields, "none"):
            raise ValueError(
                f"content must be 'image', 'field', 'heat', 'distortion' or 'none', got {content!r}"
            )
        if content == "image" and "image" not in self._host:
            raise RuntimeError("draw(content='image') needs set_image first")
        if content in self._fields and not self._mesh.has_field:
            raise RuntimeError(f"draw(content={content!r}) needs set_field first")
        mesh = self._preview if preview else self._mesh
        if content == "image":
            mipmaps, snap, coverage = sampling
            self._image.draw_image(
                source or self._whole(),
                mesh,
                order,
                view,
                viewport_size,
                mipmaps=mipmaps,
                snap=snap,
                coverage=coverage,
                split=split if order == "caller" and not preview else None,
            )
        elif content in self._fields:
            self._fields[content].draw(mesh, order, view, viewport_size)
        self._image.draw_marks(
            mesh, order, view, viewport_size, folds=folds, highlight=highlight, wireframe=wireframe
        )

    def draw_backdrop(self, view: View, viewport_size: tuple[int, int], opacity: float = 1.0) -> None:
        """Draw the whole undeformed source image, faded by `opacity`, into the bound framebuffer.

        Parameters
        ----------
        view, viewport_size : View, tuple of int
            Where to draw: as for `app.render.passes.gl_state.set_view`.
        opacity : float
            In [0, 1]; the image is blended over what is drawn already.
        """
        if "image" not in self._host:
            raise RuntimeError("draw_backdrop needs set_image first")
        if "backdrop" in self._host and "backdrop" not in self._textures:
            self._textures["backdrop"] = SourceImage(self.ctx, self._host["backdrop"])
        self._backdrop.draw(self._textures.get("backdrop") or self._whole(), view, viewport_size, opacity)

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
        view, viewport_size : View, tuple of int
            Where to draw: as for `app.render.passes.gl_state.set_view`.
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
        in_place: bool = False,
    ) -> np.ndarray:
        """Draw offscreen with multisampling and read the result back.

        With `backdrop` at one output pixel per image pixel and a whole-pixel offset, the image's
        pixels are copied, not drawn, and GL draws only the warp, within the box it covers, laid
        over them (`app.render.compositing`): pixels the warp does not touch are the image's, bit
        for bit, straight alpha kept.  The mipmaps are sampled only if a triangle shrinks the image.
        A drawing at one output pixel per image pixel reads a texel itself wherever the texture
        coordinate is its centre up to float32 rounding (an undeformed part comes back exact).

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
        in_place : bool
            Where the output is the image itself under the warp (`backdrop`, the identity view, the
            image's size, a transparent `background`): draw the warp into the array of the image
            (`set_image`'s, or `set_backdrop_image`'s) and return it, rather than a copy of it (0.4 GB
            at 100 megapixels).  The renderer then lets go of the image: `set_image` again to draw
            more.  Elsewhere it is ignored.

        Returns
        -------
        ndarray of shape (height, width, 4), uint8, or uint16 for a 16-bit source image
            RGBA with straight alpha, row 0 at the top.
        """
        width, height = _output_size(size)
        host = self._host.get("backdrop", self._host.get("image"))
        exact = (width, height) == self._image_size and exact_offset(view or View()) == (0, 0)
        drawn_in_place = in_place and backdrop and exact and background[3] == 0 and content == "image"
        drawn_in_place = drawn_in_place and not (wireframe or highlight or folds)
        pixels = host if drawn_in_place else np.empty((height, width, 4), self.pixel_type)
        options = dict(samples=samples, background=background, backdrop=backdrop, in_place=drawn_in_place)
        for _ in self._strips(size, view, None, (content, wireframe, highlight, folds), options, pixels):
            pass
        if drawn_in_place:
            self._release_image()  # what it holds is the output now
        return pixels

    @property
    def image_size(self) -> tuple[int, int] | None:
        """(width, height) of the source image, None before `set_image`."""
        return self._image_size

    @property
    def pixel_type(self) -> np.dtype:
        """The samples `render` returns: uint16 for a 16-bit source image, else uint8."""
        return np.dtype(self._host["image"].dtype if "image" in self._host else np.uint8)

    def render_strips(
        self,
        size: tuple[int, int],
        view: View | None = None,
        *,
        rows: int = STRIP_ROWS,
        samples: int = 4,
        background: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0),
        backdrop: bool = False,
        antialiased: Callable[[tuple[int, int, int, int]], bool] | None = None,
    ) -> Iterator[tuple[int, np.ndarray]]:
        """`render` of the image, a horizontal strip at a time: a large output is never held whole.

        Parameters
        ----------
        size, view, samples, background, backdrop
            As in `render` (``content="image"``, without marks).
        rows : int
            Rows of a strip (the last may have fewer); it is drawn in tiles of `rows` x `rows`.
        antialiased : callable, optional
            Given a tile (left, top, width, height) in output pixels, whether it needs
            multisampling: False where no edge of what is drawn crosses it (every pixel wholly
            inside or outside the warp), which then is drawn without (a multisample resolve
            costs more than the drawing on a software rasteriser; the pixels may differ by a
            unit where two triangles meet).  None: every tile is multisampled, as in `render`.

        Yields
        ------
        top : int
            The strip's first row.
        strip : ndarray of shape (r, width, 4), uint8 or uint16 (`pixel_type`)
            RGBA with straight alpha, a new array each time; the same pixels as `render`'s rows.
        """
        options = dict(samples=samples, background=background, backdrop=backdrop, antialiased=antialiased)
        yield from self._strips(size, view, rows, ("image", False, False, False), options, None)

    def _strips(self, size, view, rows, what, options, into):
        """The strips of `render` (into rows of `into` if given, else new arrays), `rows` high or one
        tile; `what` is ``(content, wireframe, highlight, folds)``, `options` the drawing's."""
        width, height = _output_size(size)
        view = view or View()
        self._require_mesh()
        if what[0] == "image" and "image" not in self._host:
            raise RuntimeError("render(content='image') needs set_image first")
        limit = min(TILE, self.ctx.info["GL_MAX_RENDERBUFFER_SIZE"], *self.ctx.info["GL_MAX_VIEWPORT_DIMS"])
        tile = (min(width, limit, rows or limit), min(height, limit, rows or limit))
        offset = None
        if options["backdrop"] and what == ("image", False, False, False):
            offset = exact_offset(view)
        # Leave the caller's framebuffer bound afterwards (a viewer exporting mid-frame).
        previous = self.ctx.fbo
        if any(previous in objects for objects in self._target.values()):
            previous = None  # ours, perhaps about to be replaced
        dtype = self.pixel_type
        try:
            if offset is None:
                drawing = _Drawing(self, view, tile, what, options, dtype)
                for top in range(0, height, tile[1]):
                    count = min(tile[1], height - top)
                    strip = np.empty((count, width, 4), dtype) if into is None else into[top : top + count]
                    for left in range(0, width, tile[0]):
                        part = strip[:, left : left + tile[0]]
                        drawn = drawing.tile(left, top, options["background"])
                        part[...] = drawn[: len(part), : part.shape[1]]
                    yield top, straight(strip)
            else:
                yield from self._copied_strips((width, height), view, offset, tile, options, into)
        finally:
            if previous is not None:
                previous.use()

    def _copied_strips(self, size, view, offset, tile, options, into):
        """`_strips` of the image over its copied backdrop (`app.render.compositing`): the backdrop's
        pixels copied, the warp drawn alone within its box and laid over them; a tile the warp's
        outline crosses is multisampled, in floats, one inside it drawn once in the image's type.  A
        translucent image's warp is drawn finer (`SourceImage.drawn_dtype`) and its coverage drawn
        too, and both laid over the backdrop (`warp_laid`): its own alpha is not a coverage."""
        width, height = size
        dtype = self.pixel_type
        clear = clear_pixel(options["background"], dtype)
        positions = self._ordered_positions()
        box = drawn_box(positions, offset, size)
        host = self._host.get("backdrop", self._host["image"])
        image = ((host.shape[1], host.shape[0]), partial(_host_rows, host))
        small = (min(tile[0], COPIED_TILE), min(tile[1], COPIED_TILE))
        edge = (min(small[0], EDGE_TILE), min(small[1], EDGE_TILE))
        what = ("image", False, False, False)
        footprints = self._footprints(view)
        footprint = float(footprints.max())
        source = self._sampled_source(footprint)
        mipmaps = footprint > UNSHRUNK_FOOTPRINT  # every level of the whole image's texture
        if mipmaps and source is self._textures.get("box"):
            mipmaps = mipmap_levels(footprint)  # only those the drawing samples
        # Edges blended in 16 bits for an 8-bit image (a unit of 65535 is far below its rounding),
        # in floats for a 16-bit one.
        edge_type = np.uint16 if dtype == np.uint8 else np.float32
        translucent = not source.opaque
        edged = _Drawing(self, view, edge, what, options, edge_type, mipmaps, source)
        plain_type, plain_options = source.drawn_dtype, dict(options, samples=0)
        plain = {}
        for size in (small, edge):
            plain[size] = _Drawing(self, view, size, what, plain_options, plain_type, mipmaps, source)
        for drawing in (edged, *plain.values()):
            drawing.backdrop = False  # copied, not drawn
        edged.antialiased = lambda box: True
        for drawing in plain.values():
            drawing.antialiased = lambda box: False
        outline = None  # folds put edges anywhere
        if not self._mesh.may_fold(positions):
            outline = positions[self._mesh.boundary_edges] * view.scale + np.asarray(offset, np.float32)
            # No triangles overlap: those that shrink nothing are drawn without the mipmaps, and
            # each tile draws those that may show in it.
            corners = positions[self._mesh.triangle_indices] * view.scale + np.asarray(offset, np.float32)
            extents = np.concatenate([corners.min(axis=1), corners.max(axis=1)], axis=1)  # (T, 4)
            for drawing in (edged, *plain.values()):
                drawing.triangles = (footprints > UNSHRUNK_FOOTPRINT, extents)
        for top in range(0, height, tile[1]):
            count = min(tile[1], height - top)
            strip = np.empty((count, width, 4), dtype) if into is None else into[top : top + count]
            if not options.get("in_place"):  # else the rows are the image's own
                backdrop_rows(image, offset, strip, top, clear)
            first, last = (max(top, box[1]), min(top + count, box[3])) if box else (0, 0)
            for row in range(first, last, small[1]):
                for left in range(box[0], box[2], small[0]):
                    whole = (left, row, min(left + small[0], box[2]), min(row + small[1], last))
                    for (x, y, right, bottom), smooth in _drawn_parts(outline, whole, edge):
                        part = strip[y - top : bottom - top, x:right]
                        sub = right - x <= edge[0] and bottom - y <= edge[1]
                        drawing = edged if smooth else plain[edge if sub else small]
                        drawn = drawing.tile(x, y, (0.0, 0.0, 0.0, 0.0))[: len(part), : part.shape[1]]
                        if translucent:
                            drawn = drawn.copy()  # the coverage's drawing reuses its array
                            coverage = drawing.tile(x, y, (0.0, 0.0, 0.0, 0.0), coverage=True)
                            warp_laid(part, drawn, coverage[: len(part), : part.shape[1], 3], clear)
                        else:
                            warp_over(part, drawn)
            yield top, strip

    def _ordered_positions(self) -> np.ndarray:
        """The deformed vertices (V, 2) as the GPU holds them (in `vertex_order`), float32."""
        self._require_mesh()
        return np.frombuffer(self._mesh.positions.read(), np.float32).reshape(-1, 2)

    def _footprints(self, view: View) -> np.ndarray:
        """`app.render.compositing.texel_footprints` of the mesh's triangles (T,), in the caller's
        order, through `view`."""
        mesh = self._mesh
        vertices = mesh.vertices[mesh.order]
        return texel_footprints(vertices, self._ordered_positions(), mesh.triangle_indices, view.scale)

    def _needs_mipmaps(self, view: View, backdrop: bool) -> bool:
        """Whether a drawing through `view` (and of the whole image, with `backdrop`) shrinks the image
        anywhere, so that GL samples its mipmaps: where one output pixel steps over more than one
        image pixel (`_footprints`)."""
        if self._mesh is None or "image" not in self._host:
            return True  # nothing to draw: `_draw` says what is missing
        footprint = float(self._footprints(view).max())
        if backdrop:
            footprint = max(footprint, 1.0 / view.scale)
        return footprint > UNSHRUNK_FOOTPRINT

    def _whole(self) -> SourceImage:
        """The texture of the whole image, uploaded now if it is not yet."""
        if "image" not in self._textures:
            self._textures["image"] = SourceImage(self.ctx, self._host["image"])
        return self._textures["image"]

    def _sampled_source(self, footprint: float) -> SourceImage:
        """A texture holding what a drawing of the mesh samples where one output pixel steps over
        at most `footprint` image pixels (`app.render.compositing.sampled_box`): the box around the
        undeformed mesh (whether or not the whole image is uploaded: a drawing's pixels do not
        depend on what was drawn before), or the whole image where the box is not smaller."""
        box = sampled_box(self._mesh.vertices, self._image_size, footprint)
        if box is None or box == (0, 0, *self._image_size):
            return self._whole()
        if "box" not in self._textures or self._textures["box"].box != box:
            self._release_texture("box")
            self._textures["box"] = SourceImage(self.ctx, self._host["image"], box)
        return self._textures["box"]

    # -- lifetime -----------------------------------------------------------

    def release(self) -> None:
        """Free every GL object of the renderer; it cannot draw afterwards."""
        self._release_mesh()
        self._release_image()
        self._release_target()
        self._overlay.release()
        self._image.release()
        for field in self._fields.values():
            field.release()

    def __enter__(self) -> WarpRenderer:
        return self

    def __exit__(self, *exc_info) -> None:
        self.release()

    # -- internals ----------------------------------------------------------

    def _framebuffers(self, size: tuple[int, int], samples: int, dtype: np.dtype):
        """Multisampled and resolve framebuffers of `size` and samples of `dtype` (8 or 16 bits),
        kept for the next render of that kind."""
        kind = (size, samples, np.dtype(dtype))
        if kind in self._target:
            self._target[kind] = self._target.pop(kind)  # the last used last: kept the longest
        else:
            # Three kinds are kept, the last used (a copied backdrop's warp draws its edges
            # multisampled in floats, the rest in the image's type in two sizes; a drawing's own are
            # never the ones dropped): a 4K 4x multisample target alone is ~130 MB.
            if len(self._target) >= 3:
                self._release_target(next(iter(self._target)))
            gl_type = texture_dtype(dtype)
            colour = self.ctx.renderbuffer(size, 4, samples=samples, dtype=gl_type)
            resolved_colour = self.ctx.renderbuffer(size, 4, dtype=gl_type)
            multisample = self.ctx.framebuffer(color_attachments=[colour])
            resolved = self.ctx.framebuffer(color_attachments=[resolved_colour])
            self._target[kind] = [multisample, resolved, colour, resolved_colour]
        objects = self._target[kind]
        return objects[0], objects[1]

    def _build_mesh(self, vertices: np.ndarray, triangles: np.ndarray) -> MeshBuffers:
        """Buffers and vertex arrays of one mesh for the image and field passes, positions undeformed."""
        return MeshBuffers(
            self.ctx,
            vertices,
            triangles,
            self._image_size or (1, 1),
            self._mesh_programs,
            self._image.solid_program,
        )

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
        for kind in list(self._textures):
            self._release_texture(kind)
        self._host = {}

    def _release_texture(self, kind: str) -> None:
        """Free the texture `kind` (a key of ``_textures``), if there is one."""
        texture = self._textures.pop(kind, None)
        if texture is not None:
            texture.release()

    def _release_target(self, kind=None) -> None:
        """Free the framebuffers of `kind` (a key of ``_target``), or of every kind."""
        for key in [kind] if kind is not None else list(self._target):
            objects = self._target.pop(key)
            if self.ctx.fbo in objects:
                # GL falls back to the default framebuffer when the bound one is deleted.
                self.ctx.fbo = self.ctx.screen
            for item in objects:
                item.release()


def _drawn_parts(outline: np.ndarray | None, tile: tuple[int, int, int, int], edge: tuple[int, int]):
    """The parts of the output `tile` (left, top, right, bottom) where a drawing of the warp shows, each
    as (part, smooth), part a box like `tile` and smooth whether it is multisampled: the whole tile,
    not smooth, if the warp's `outline` (E, 2, 2: segments, output pixels) keeps away from it and
    it lies inside; nothing if it lies outside (nothing is drawn there); else its parts of `edge`
    (width, height) that the outline crosses (smooth) or that lie inside (not).  `outline` None
    (folds put edges anywhere): every part of `edge`, smooth."""
    left, top, right, bottom = tile
    if outline is not None and not crosses(outline, (left, top, right - left, bottom - top)):
        if encloses(outline, ((left + right) / 2, (top + bottom) / 2)):
            yield tile, False
        return
    for y in range(top, bottom, edge[1]):
        for x in range(left, right, edge[0]):
            part = (x, y, min(x + edge[0], right), min(y + edge[1], bottom))
            if outline is None or crosses(outline, (x, y, part[2] - x, part[3] - y)):
                yield part, True
            elif encloses(outline, ((x + part[2]) / 2, (y + part[3]) / 2)):
                yield part, False


def _host_rows(host: np.ndarray, top: int, bottom: int, left: int, right: int, out=None) -> np.ndarray:
    """Rows `top` to `bottom`, columns `left` to `right` of `host` (H, W, 4): a view, or copied into `out`."""
    if out is None:
        return host[top:bottom, left:right]
    out[...] = host[top:bottom, left:right]
    return out


def _output_size(size: tuple[int, int]) -> tuple[int, int]:
    """(width, height) as ints, or ValueError if it is not 1 to `MAX_OUTPUT_PIXELS` pixels."""
    width, height = int(size[0]), int(size[1])
    if not (1 <= width and 1 <= height and width * height <= MAX_OUTPUT_PIXELS):
        raise ValueError(f"output size {width}x{height} is not 1 to {MAX_OUTPUT_PIXELS / 1e6:.0f} megapixels")
    return width, height


class _Drawing:
    """One offscreen drawing of `WarpRenderer._strips`, a tile at a time: its view, what it draws and
    how, and the framebuffers (of samples of `dtype`) it draws into and reads back from; `mipmaps`
    the image's mipmaps it samples (True: every level, a number: that many, built now; None:
    those it needs), `source` the texture it draws (a `SourceImage`; the whole image's if None)."""

    def __init__(self, renderer: WarpRenderer, view, tile, what, options, dtype, mipmaps=None, source=None):
        self.renderer, self.view, self.size, self.what, self.source = renderer, view, tile, what, source
        self.backdrop = options["backdrop"]
        self.antialiased = options.get("antialiased") or (lambda box: True)
        samples = max(0, min(int(options["samples"]), renderer.ctx.max_samples))
        self.multisample, self.resolved = renderer._framebuffers(tile, samples, np.dtype(dtype))
        self.pixels = np.empty((tile[1], tile[0], 4), dtype)
        if mipmaps is None:  # whether the drawing samples them (`WarpRenderer._needs_mipmaps`)
            mipmaps = what[0] == "image" and renderer._needs_mipmaps(view, self.backdrop)
        if mipmaps and "image" in renderer._host:
            # Before the output's pages: the driver's temporaries go first.  `mipmaps` True: every
            # level; a number: the levels the drawing samples.
            (source or renderer._whole()).build_mipmaps(None if mipmaps is True else mipmaps)
        self.sampling = (bool(mipmaps), bool(view.scale == 1))
        #: (shrinking (T,), extents (T, 4): each triangle's box in output pixels), when no
        #: triangles overlap: the drawing splits the mesh (`ImagePass.draw_image`); None: it does not.
        self.triangles = None

    def tile(self, left: int, top: int, background, coverage: bool = False) -> np.ndarray:
        """The tile whose top-left output pixel is (`left`, `top`) drawn over `background` (straight
        RGBA in [0, 1]), read back premultiplied, row 0 at the top: a view of a reused array; with
        `coverage`, the image's coverage of each pixel instead (`ImagePass.draw_image`)."""
        red, green, blue, alpha = background
        smooth = self.antialiased((left, top, self.size[0], self.size[1]))
        target = self.multisample if smooth else self.resolved
        target.use()
        target.clear(red * alpha, green * alpha, blue * alpha, alpha)
        shifted = View(self.view.scale, (self.view.offset[0] - left, self.view.offset[1] - top))
        if self.backdrop:
            self.renderer.draw_backdrop(shifted, self.size)
        sampling = (*self.sampling, coverage)
        split = None
        if self.triangles is not None:
            shrinking, extents = self.triangles
            right, bottom = left + self.size[0], top + self.size[1]
            shown = (extents[:, 2] >= left - 1) & (extents[:, 0] <= right + 1)
            shown &= (extents[:, 3] >= top - 1) & (extents[:, 1] <= bottom + 1)
            split = (shrinking, shown)
        what = dict(sampling=sampling, source=self.source, split=split)
        self.renderer._draw(shifted, self.size, "caller", *self.what, **what)
        if smooth:
            self.renderer.ctx.copy_framebuffer(self.resolved, self.multisample)
        self.resolved.read_into(
            self.pixels, components=4, alignment=1, dtype=texture_dtype(self.pixels.dtype)
        )
        return self.pixels[::-1]  # GL rows run bottom-up
