"""The warp of an image by a cage: the one pipeline of `warp`, `animate`, the viewer's export and `quality`.

A warp is two steps, as in the paper's Sec. 4.3:

1. `prepare`: mesh the cage's interior and compute the basis functions G (V, n) at
   the mesh vertices, once per cage and kernel (the slow part, cached on disk by
   `core.mesh_basis_functions`);
2. `Deformation.positions` and `render`: the deformed vertices f(v) = sum_i G_i(v) P_i
   for a target (V, n) @ (n, 2), then the source image drawn on the deformed mesh.

Every warped picture is drawn and written by one function, `write_frames` (over `render`):
`warp`'s still, `animate`'s frames and the viewer's still and animation exports, so that the
same target gives the same file; `quality` measures `Deformation.positions` of the same `prepare`.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

import core
from app.io.images import DEFAULT_QUALITY, ImageMetadata
from app.render.viewport import View
from core import deform


@dataclass(frozen=True)
class WarpSettings:
    """How to deform: everything `prepare` needs besides the cage.

    Attributes
    ----------
    kernel : str
        A kernel of `core.mesh_basis_functions` (default: the package default, ``"poisson"``).
    params : dict
        Its keyword parameters (``power``, ``parameterization``, ``samples_per_segment``...).
    max_edge : float, optional
        Longest mesh edge in image pixels; None for the automatic size.
    cache : bool
        Read and write the on-disk basis cache.
    fold_free : bool
        Deform by `core.fold_free_deform` (a certified bijection onto the target; ``poisson`` only)
        instead of G P'.
    """

    kernel: str = core.DEFAULT_KERNEL
    params: dict = field(default_factory=dict)
    max_edge: float | None = None
    cache: bool = True
    fold_free: bool = False


#: Outputs of more pixels than this (one 4096 x 4096 tile) are written strip by strip when PNG;
#: smaller ones are encoded whole, byte for byte as before.
STREAMED_PIXELS = 4096 * 4096


@dataclass(frozen=True)
class OutputFile:
    """Where and how a warp is written.

    Attributes
    ----------
    path : Path
        The file; its extension chooses the format (`app.io.images.output_format`).
    metadata : app.io.images.ImageMetadata, optional
        The input's ICC profile and EXIF block.
    quality : int
        JPEG and WebP quality.
    background : tuple of float, optional
        Straight RGBA in [0, 1] under the warp (``--background``); transparent if None.
    """

    path: Path
    metadata: ImageMetadata | None = None
    quality: int = DEFAULT_QUALITY
    background: tuple[float, float, float, float] | None = None


@dataclass(frozen=True)
class Deformation:
    """A cage's precomputed deformation.

    Attributes
    ----------
    mesh : core.Mesh
        The triangulated interior, V vertices in image pixels.
    basis : ndarray of shape (V, n)
        G at the mesh vertices; complex for the Cauchy-Green kernel.
    kernel : str
        The kernel that computed `basis`.
    curve : core.ClosedBSpline, optional
        The cage (needed by `fold_free` and `certificate`).
    fold_free : bool
        `positions` are those of `core.fold_free_deform`, not G P'.
    """

    mesh: core.Mesh
    basis: np.ndarray
    kernel: str
    curve: core.ClosedBSpline | None = None
    fold_free: bool = False
    _last: dict = field(default_factory=dict, compare=False, repr=False)

    def positions(self, target: np.ndarray) -> np.ndarray:
        """Deformed vertices (V, 2) for the target control points (n, 2): `core.deform`, or the
        certified fold-free map (ValueError where the straight path of cages crosses itself)."""
        if not self.fold_free:
            return deform(self.basis, target)
        return self.fold_free_map(target)[0]

    def certificate(self, target: np.ndarray) -> core.InjectivityCertificate | None:
        """What is proven about the map to `target` (`core.certify_injective`; when `fold_free`, of the
        mesh's fold-free map, or of the continuous map where that map is the plain one and proven);
        None for kernels whose maps are not harmonic."""
        if self.fold_free:
            certificate = self.fold_free_map(target)[1]
            if certificate.extra.get("path") != core.PLAIN_HARMONIC_MAP:
                return certificate
            # The plain map, proven on the mesh: its continuous certificate says more where it proves.
            continuous = core.certify_injective(self.curve, target)
            return continuous if continuous.injective else certificate
        if self.kernel != core.DEFAULT_KERNEL or self.curve is None:
            return None
        return core.certify_injective(self.curve, target)

    def fold_free_map(
        self, target: np.ndarray, progress: Callable[[float], None] | None = None
    ) -> tuple[np.ndarray, core.InjectivityCertificate]:
        """`core.fold_free_deform` of the mesh's vertices onto `target` (n, 2): positions (V, 2) and
        certificate, kept for the last target (`warp` asks for the positions, the report and the
        render); `progress` gets the share of the path proven."""
        key = np.asarray(target, dtype=np.float64).tobytes()
        if key not in self._last:
            self._last.clear()
            boundary = (self.mesh.boundary, self.mesh.boundary_parameters)
            self._last[key] = core.fold_free_deform(
                self.curve,
                target,
                self.mesh.vertices,
                boundary=boundary,
                triangles=self.mesh.triangles,
                progress=progress,
                basis=self.basis,
            )
        return self._last[key]


def prepare(
    curve: core.ClosedBSpline,
    settings: WarpSettings,
    mesh: core.Mesh | None = None,
    progress: Callable[[float], None] | None = None,
    compiling: Callable[[float], None] | None = None,
    meshing: Callable[[float], None] | None = None,
) -> Deformation:
    """Mesh the cage (unless `mesh` is given) and compute its basis functions.

    Parameters
    ----------
    curve : core.ClosedBSpline
        The cage, n control points.
    settings : WarpSettings
        Kernel, parameters, mesh size and caching.
    mesh : core.Mesh, optional
        A mesh of `curve` to use instead of ``core.triangulate(curve, settings.max_edge)``.
    progress, compiling : callable, optional
        Fractions of the basis computation and of a first-run compilation
        (`core.mesh_basis_functions`).
    meshing : callable, optional
        Fractions of the meshing (`core.triangulate`).

    Raises
    ------
    ValueError
        From `core.triangulate` and `core.mesh_basis_functions`, for a cage or settings they refuse.
    """
    if settings.fold_free and settings.kernel != core.DEFAULT_KERNEL:
        raise ValueError(
            f"fold-free warps are harmonic: they need the {core.DEFAULT_KERNEL} kernel, "
            f"got {settings.kernel!r}"
        )
    if mesh is None:
        mesh = core.triangulate(curve, max_edge=settings.max_edge, progress=meshing)
    if progress is not None:
        progress(0.0)  # the basis phase begins (a superseded viewer request stops here)
    basis = core.mesh_basis_functions(
        curve,
        mesh,
        kernel=settings.kernel,
        progress=progress,
        compiling=compiling,
        cache=settings.cache,
        **settings.params,
    )
    return Deformation(mesh, basis, settings.kernel, curve, settings.fold_free)


def render(
    renderer,
    deformation: Deformation,
    target: np.ndarray,
    size: tuple[int, int],
    view: View,
    outside: str,
    background: tuple[float, float, float, float] | None = None,
    in_place: bool = False,
) -> np.ndarray:
    """The image on `renderer` drawn on the mesh deformed to `target`.

    Parameters
    ----------
    renderer : app.render.renderer.WarpRenderer
        Holds the source image and `deformation.mesh` (`set_image`, `set_mesh`).
    deformation : Deformation
    target : ndarray of shape (n, 2)
        Target control points, image pixels.
    size : tuple of int
        (width, height) of the output.
    view : View
        Image pixels to output pixels.
    outside : str
        ``"original"`` draws the source image behind the warp, ``"transparent"`` leaves it clear.
    background : tuple of float, optional
        Straight RGBA in [0, 1] under everything (``--background``); transparent if None.
    in_place : bool
        The warp may be drawn into the renderer's own image, which it then lets go of
        (`app.render.renderer.WarpRenderer.render`).

    Returns
    -------
    ndarray of shape (height, width, 4), uint8, or uint16 for a 16-bit source image
        RGBA with straight alpha.
    """
    renderer.set_positions(deformation.positions(target))
    clear = (0.0, 0.0, 0.0, 0.0) if background is None else background
    return renderer.render(size, view, backdrop=outside == "original", background=clear, in_place=in_place)


@dataclass(frozen=True)
class FrameOutput:
    """What `write_frames` writes: the file, its kind, the framing and what shows outside the warp.

    Attributes
    ----------
    file : OutputFile
        Path, metadata, quality and background.
    kind : str
        ``"image"``: one file in the format of its extension; else a key of
        `app.warp.frame_writers.WRITERS` (``"png"`` frames, ``"mp4"``, ``"gif"``).
    size : tuple of int
        (width, height) of the output.
    view : View
        Image pixels to output pixels.
    outside : str
        ``"original"`` or ``"transparent"`` (`render`).
    fps : float
        Frames per second of an animation.
    consume : bool
        A still may be drawn into the renderer's own image array (`render`'s `in_place`): the caller
        lets go of the image, and the renderer draws nothing more before another ``set_image``.
    """

    file: OutputFile
    kind: str
    size: tuple[int, int]
    view: View
    outside: str
    fps: float = 0.0
    consume: bool = False


def write_frames(renderer, deformation: Deformation, targets, output: FrameOutput) -> Iterator[int]:
    """Draw the warp to each of `targets` and write it: the one way every warped picture is written
    (``warp``, ``animate``, the viewer's still and animation exports).

    Called, it checks that the output fits (the renderer's memory,
    `app.render.renderer.require_render_memory`; the format's caps,
    `app.warp.frame_writers.check_frames`); iterated, it draws a frame at each step and yields
    how many are drawn, so that a window can draw its own frames between them.  Once it has
    yielded ``len(targets)``, the rest needs no GL context: the encoding of a whole still (which
    ``warp`` runs after releasing the context, so that the encoder's memory does not come on top of
    the driver's textures) and the writer's finish.  The output appears when the iteration ends;
    closing the iterator before (or an error) leaves nothing at its path.

    A still (`kind` ``"image"``) PNG larger than `STREAMED_PIXELS` is drawn and compressed strip
    by strip (`WarpRenderer.render_strips`): never whole in memory, compressing overlapping drawing.
    A GIF's palette frames (`FrameWriter.lookahead`) are drawn first.

    Parameters
    ----------
    renderer : app.render.renderer.WarpRenderer
        Holds the source image and `deformation.mesh`.
    deformation : Deformation
    targets : sequence of ndarray of shape (n, 2)
        Target control points of each frame (one for a still), image pixels.
    output : FrameOutput

    Raises
    ------
    MemoryError
        Too little address space to draw the output (when called).
    app.io.files.InputError
        Too many frames for the format (when called); an output that cannot be written, transparent
        pixels for a JPEG, or a target the fold-free map refuses (while iterated; nothing is written).
    """
    from app.render.renderer import require_render_memory
    from app.warp.frame_writers import check_frames

    require_render_memory(renderer.image_size, output.size, context=False)
    if output.kind == "image":
        return _still_steps(renderer, deformation, targets[0], output)
    check_frames(output.kind, len(targets), output.size, output.file.path)
    return _frame_steps(renderer, deformation, targets, output)


def _still_steps(
    renderer, deformation: Deformation, target: np.ndarray, output: FrameOutput
) -> Iterator[int]:
    """`write_frames` of one image file."""
    from app.io.files import reported_as_input, write_image, write_png_strips
    from app.io.images import output_format
    from app.io.images.tiles import crosses, drawn_edges
    from app.render.renderer import STRIP_ROWS

    size, view, file = output.size, output.view, output.file
    with reported_as_input("rendering"):  # a fold-free path may cross itself
        if output_format(file.path) == "PNG" and size[1] > STRIP_ROWS and size[0] * size[1] > STREAMED_PIXELS:
            positions = deformation.positions(target)
            renderer.set_positions(positions)
            edges = None
            backdrop = output.outside == "original"
            if not core.folded_triangles(deformation.mesh, positions).any():  # folds: edges everywhere
                edges = drawn_edges(deformation.mesh, positions, view, renderer.image_size, backdrop)
            strips = renderer.render_strips(
                size,
                view,
                backdrop=backdrop,
                background=(0.0, 0.0, 0.0, 0.0) if file.background is None else file.background,
                antialiased=None if edges is None else lambda box: crosses(edges, box),
            )
            write_png_strips(file.path, size, renderer.pixel_type, strips, file.metadata)
            yield 1
            return
        pixels = render(
            renderer, deformation, target, size, view, output.outside, file.background, output.consume
        )
    yield 1
    write_image(file.path, pixels, file.metadata, file.quality, consume=True)


def _frame_steps(renderer, deformation: Deformation, targets, output: FrameOutput) -> Iterator[int]:
    """`write_frames` of an animation, into the writer of its kind."""
    from app.io.files import InputError, reported_as_input
    from app.warp.frame_writers import WRITERS

    file, size, view = output.file, output.size, output.view

    def drawn(index: int) -> np.ndarray:
        with reported_as_input(f"rendering frame {index}"):  # a fold-free path may cross itself
            return render(renderer, deformation, targets[index], size, view, output.outside, file.background)

    with WRITERS[output.kind](file.path, size, output.fps, file.metadata) as writer:
        for index in writer.lookahead(len(targets)):
            writer.preview(drawn(index))
            yield 0
        for index in range(len(targets)):
            writer.add(drawn(index))
            yield index + 1
        try:
            writer.finish()
        except OSError as error:
            raise InputError(f"{file.path}: cannot write ({error.strerror or error})") from None


__all__ = ["Deformation", "FrameOutput", "OutputFile", "WarpSettings", "prepare", "render", "write_frames"]
