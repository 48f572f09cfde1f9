"""The field passes: a mesh coloured by its per-vertex field (`MeshBuffers.values`), in the
height bands of the paper's Fig. 1, as the heat map of one basis function G_i (Fig. 8), or
as the distortion view (`app.viewer.distortion_view`)."""

from __future__ import annotations

import moderngl
import numpy as np

from app.render.passes.gl_state import premultiplied_blending, set_view
from app.render.passes.mesh_buffers import MeshBuffers
from app.render.shaders import load_shader
from app.render.viewport import View

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
#: `DistortionPass.set_measure` codes of the shader.
DISTORTION_MEASURES = {"area": 0, "conformal": 1}


class FieldPass:
    """Colours a mesh by its field through one fragment shader of ``shaders/``.

    Parameters
    ----------
    ctx : moderngl.Context
        The context of the program, freed in `release`.
    kind : str
        The name of the mesh's vertex arrays of this pass, the ``content`` that draws it.
    fragment_shader : str
        File name of the fragment shader; it colours ``v_value``.

    Attributes
    ----------
    kind : str
    program : moderngl.Program
    mesh_programs : dict
        ``{kind: (program, "in_value")}``, for `MeshBuffers`.
    """

    def __init__(self, ctx: moderngl.Context, kind: str, fragment_shader: str):
        self._ctx = ctx
        self.kind = kind
        self.program = ctx.program(
            vertex_shader=load_shader("mesh.vert.glsl"), fragment_shader=load_shader(fragment_shader)
        )
        self.mesh_programs = {kind: (self.program, "in_value")}

    def draw(self, mesh: MeshBuffers, order: str, view: View, viewport_size: tuple[int, int]) -> None:
        """Draw `mesh` coloured by its field into the bound framebuffer.

        Parameters
        ----------
        mesh : MeshBuffers
            With its field written (`MeshBuffers.write_values`).
        order : {"screen", "caller"}
            The triangle order (`MeshBuffers.vaos`).
        view, viewport_size : View, tuple of int
            Where to draw: as for `app.render.passes.gl_state.set_view`.
        """
        set_view((self.program,), view, viewport_size)
        premultiplied_blending(self._ctx)
        self._render(mesh.vaos[order][self.kind])

    def release(self) -> None:
        self.program.release()

    def _render(self, vao: moderngl.VertexArray) -> None:
        vao.render()


def height_bands_pass(ctx: moderngl.Context) -> FieldPass:
    """``content="field"``: the field in the bands of `BAND_COLOURS`."""
    result = FieldPass(ctx, "field", "field.frag.glsl")
    result.program["u_bands"].write(BAND_COLOURS.astype("f4").tobytes())
    result.program["u_band_start"].value = BAND_START
    result.program["u_band_width"].value = BAND_WIDTH
    return result


def heat_map_pass(ctx: moderngl.Context) -> FieldPass:
    """``content="heat"``: the field through `HEAT_STOPS`, negative values in `HEAT_NEGATIVE`."""
    result = FieldPass(ctx, "heat", "heat.frag.glsl")
    result.program["u_stops"].write(HEAT_STOPS.astype("f4").tobytes())
    result.program["u_negative"].value = tuple(HEAT_NEGATIVE)
    return result


class DistortionPass(FieldPass):
    """``content="distortion"``: the field as a distortion measure, folded vertices drawn again on top.

    Parameters
    ----------
    ctx : moderngl.Context
        The context of the program, freed in `release`.
    """

    def __init__(self, ctx: moderngl.Context):
        super().__init__(ctx, "distortion", "distortion.frag.glsl")
        for name, colour in (
            ("u_shrunk", DISTORTION_SHRUNK),
            ("u_grown", DISTORTION_GROWN),
            ("u_sheared", DISTORTION_SHEARED),
            ("u_folded", DISTORTION_FOLDED),
        ):
            self.program[name].value = tuple(colour)
        self.program["u_range"].value = DISTORTION_RANGE
        self.program["u_measure"].value = 0
        self.program["u_folds_only"].value = False

    def set_measure(self, measure: str) -> bool:
        """Colour the field as ``"area"`` (log2 det J) or ``"conformal"``; True if that is a change."""
        code = DISTORTION_MEASURES[measure]
        if self.program["u_measure"].value == code:
            return False
        self.program["u_measure"].value = code
        return True

    def _render(self, vao: moderngl.VertexArray) -> None:
        vao.render()
        # Folded vertices again on top: where the mesh overlaps itself they would be hidden.
        self.program["u_folds_only"].value = True
        vao.render()
        self.program["u_folds_only"].value = False
