"""The image pass: a mesh textured with the source image (Sec. 4.3), and the marks drawn on a
mesh: the triangles it folds over (found on the GPU), chosen triangles, its edges."""

from __future__ import annotations

import moderngl
import numpy as np

from app.render.passes.gl_state import premultiplied_blending, set_view
from app.render.passes.mesh_buffers import MeshBuffers
from app.render.passes.source_image import SourceImage
from app.render.shaders import load_shader
from app.render.viewport import View

#: Premultiplied RGBA of the marks.
WIREFRAME_COLOUR = (0.0, 0.0, 0.0, 0.35)
HIGHLIGHT_COLOUR = (0.9 * 0.6, 0.0, 0.6 * 0.6, 0.6)


class ImagePass:
    """The programs of the textured mesh (``image.frag.glsl``, also the backdrop's), of one solid
    colour (``solid.frag.glsl``) and of the folded triangles (``folds.geom.glsl``).

    Parameters
    ----------
    ctx : moderngl.Context
        The context of the programs, freed in `release`.

    Attributes
    ----------
    textured_program : moderngl.Program
        Draws the source image at ``u_opacity`` (1 unless a draw fades it).
    solid_program : moderngl.Program
        Draws in one colour from the positions alone: highlighted triangles and edges.
    mesh_programs : dict
        ``{kind: (program, attribute)}`` of the vertex arrays of a `MeshBuffers` that this
        pass draws: "image" and "folds".
    """

    def __init__(self, ctx: moderngl.Context):
        self._ctx = ctx
        vertex = load_shader("mesh.vert.glsl")
        self.textured_program = ctx.program(
            vertex_shader=vertex, fragment_shader=load_shader("image.frag.glsl")
        )
        self.solid_program = ctx.program(vertex_shader=vertex, fragment_shader=load_shader("solid.frag.glsl"))
        self._folds_program = ctx.program(
            vertex_shader=vertex,
            geometry_shader=load_shader("folds.geom.glsl"),
            fragment_shader=load_shader("solid.frag.glsl"),
        )
        self._programs = [self.textured_program, self.solid_program, self._folds_program]
        self.textured_program["u_opacity"].value = 1.0
        self.textured_program["u_snap"].value = False
        self.textured_program["u_coverage"].value = False
        self.mesh_programs = {
            "image": (self.textured_program, "in_uv"),
            "folds": (self._folds_program, "in_uv"),
        }

    def draw_image(
        self,
        source: SourceImage,
        mesh: MeshBuffers,
        order: str,
        view: View,
        viewport_size: tuple[int, int],
        *,
        mipmaps: bool = True,
        snap: bool = False,
        coverage: bool = False,
        split: tuple[np.ndarray, np.ndarray] | None = None,
    ) -> None:
        """Draw `mesh` textured with `source` into the bound framebuffer.

        Parameters
        ----------
        source : SourceImage
        mesh : MeshBuffers
        order : {"screen", "caller"}
            The triangle order (`MeshBuffers.vaos`).
        view, viewport_size : View, tuple of int
            Where to draw: as for `app.render.passes.gl_state.set_view`.
        mipmaps : bool
            Sample through the mipmaps (`SourceImage.bind`); False where no triangle shrinks the image.
        snap : bool
            Read a texel itself where the texture coordinate is its centre up to float32 rounding
            (``image.frag.glsl``): for drawings at one pixel per image pixel.
        coverage : bool
            Draw, instead of the image, how much of each pixel it covers in every channel (the alpha
            an opaque image would have: ``image.frag.glsl``).
        split : tuple of two ndarray of shape (T,), bool, optional
            (shrinking, shown), for the caller's triangles where none overlap: those that shrink the
            image, drawn through the mipmaps if `mipmaps` (the others sample level 0 alone there
            too, and are drawn bilinearly, the cheaper filter), and those that may show in the
            viewport (the others are left out: a software rasteriser sets up every triangle it is
            given).  The pixels of one drawing of the mesh (`MeshBuffers.chosen_first`), within a
            unit where llvmpipe's trilinear filter at no shrinking is not quite its bilinear one
            (26 of 58 million pixels of a 100-megapixel warp).
        """
        set_view((self.textured_program,), view, viewport_size)
        premultiplied_blending(self._ctx)
        self.textured_program["u_opacity"].value = 1.0
        self.textured_program["u_snap"].value = snap
        self.textured_program["u_coverage"].value = coverage
        if split is None:
            source.bind(self.textured_program, mipmaps)
            mesh.vaos[order]["image"].render()
        else:
            shrinking, shown = split
            vao, count, total = mesh.chosen_first(shrinking, shown)
            for first, last, filtered in ((0, count, mipmaps), (count, total, False)):
                if last > first:
                    source.bind(self.textured_program, filtered)
                    vao.render(vertices=3 * (last - first), first=3 * first)
                    source.unbind()
        self.textured_program["u_snap"].value = False
        self.textured_program["u_coverage"].value = False
        source.unbind()

    def draw_marks(
        self,
        mesh: MeshBuffers,
        order: str,
        view: View,
        viewport_size: tuple[int, int],
        *,
        folds: bool,
        highlight: bool,
        wireframe: bool,
    ) -> None:
        """Draw the chosen marks on `mesh` into the bound framebuffer, in this order, each over the last;
        with none chosen, touch no GL state.

        Parameters
        ----------
        mesh : MeshBuffers
        order : {"screen", "caller"}
            The triangle order of the fold pass.
        view, viewport_size : View, tuple of int
            Where to draw: as for `app.render.passes.gl_state.set_view`.
        folds : bool
            Fill the triangles that the current positions fold over.
        highlight : bool
            Fill the triangles of `MeshBuffers.write_highlighted`.
        wireframe : bool
            Draw the edges.
        """
        if not (folds or highlight or wireframe):
            return
        set_view((self.solid_program, self._folds_program), view, viewport_size)
        premultiplied_blending(self._ctx)
        if folds:
            self._folds_program["u_colour"].value = HIGHLIGHT_COLOUR
            mesh.vaos[order]["folds"].render()
        if highlight and mesh.highlight_count:
            self.solid_program["u_colour"].value = HIGHLIGHT_COLOUR
            mesh.highlight_vao.render(vertices=3 * mesh.highlight_count)
        if wireframe:
            self.solid_program["u_colour"].value = WIREFRAME_COLOUR
            mesh.edge_vao().render()

    def release(self) -> None:
        for program in self._programs:
            program.release()
        self._programs = []
